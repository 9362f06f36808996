"""BCM crushing between platens (SPEC 4.1): the impact's particle (driver/bcm/impact.py: same
tessellation, rounding, random orientation from the seed) between a fixed lower platen at z = 0,
touching its lowest point, and an upper platen over its highest point coming down at
scenario.platen_speed, run until the platen force has dropped after its peak."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

import driver
from analysis.rotations import quat_to_matrix
from driver.bcm import styles
from driver.bcm.impact import SYSTEM_FRESH, SYSTEM_RESUME, _dump_commands, periodic_dumps, place_particle
from driver.runner import ProgressSpec
from driver.schedule import peak_drop_check, settle, settle_windows, write_session
from driver.templates import render
from runfiles.atomic import atomic_write_json
from runfiles.records import CRUSH_RECORD

if TYPE_CHECKING:  # for readers and checkers only
    from driver.config import RunConfig
    from driver.rundir import RunDir


def particle_extent(particle) -> tuple[float, float]:
    """(lowest, highest) z of the rounded particle in the lab: its cores' vertices -/+ r_m."""
    rot = quat_to_matrix(particle.quats)  # (n, 3, 3) body -> lab
    z = np.concatenate([v @ r[2] + c[2] for v, r, c in zip(particle.core_vertices, rot, particle.centroids)])
    return float(z.min() - particle.r_m), float(z.max() + particle.r_m)


def build_system(cfg: RunConfig, rd: RunDir) -> dict:
    """Tessellation (cached) -> rounded cells -> placement on the lower platen -> data,
    interfaces and cells files; the upper platen's start over the highest point."""
    m, sc = cfg.model, cfg.scenario
    # the impact's particle as it lies (the same orientation stream), touching the lower platen
    facts, particle, guard = place_particle(cfg, rd, gap=0.0)
    lowest, highest = particle_extent(particle)
    height = highest - lowest  # d of SPEC 4.1: the height between the platens at first contact
    top0 = highest + sc.gap * m.diameter
    return {**facts, "lowest_z": lowest, "highest_z": highest, "height": height, "platen_start": top0,
            "platen_speed": sc.platen_speed, "plots_failed": guard.failed}


def render_inputs(cfg: RunConfig, plugin_path: Path, system: dict) -> tuple[str, str, dict]:
    """(setup.lammps, resume.lammps, schedule) of a crush run."""
    m, sc = cfg.model, cfg.scenario
    dt = system["timestep"]
    window, chunk = settle_windows(sc.check_every, sc.check_every)
    # the strain limit and max_time, whichever comes first, as a number of checks
    gap0 = system["platen_start"] - system["highest_z"]
    t_end = min(sc.max_time, (gap0 + sc.max_strain * system["height"]) / sc.platen_speed)
    max_windows = max(1, math.ceil(t_end / (window * dt)))
    periodic = periodic_dumps(sc.dump_every)
    skin = 0.1 * system["mean_cell_size"]
    comm_cutoff = 2.0 * system["max_bound_radius"] * 1.05 + skin
    r_m = system["r_m"]
    common = dict(
        package_version=driver.__version__, config_name=cfg.name, plugin_path=plugin_path,
        comm_cutoff=f"{comm_cutoff:.9g}",
        lower_setup=styles.wall_setup(m, r_m, fix_id="lower", face="zlo", coord=0.0),
        upper_setup=styles.wall_setup(m, r_m, fix_id="upper", face="zhi", coord=system["platen_start"],
                                      velocity=-sc.platen_speed),
        platen_speed=f"{sc.platen_speed:g}", top0=repr(system["platen_start"]), A0=repr(system["A0"]),
        skin=f"{skin:.9g}", steps_per_period=f"{sc.steps_per_period:g}",
        period=f"{system['shortest_period']:.6g}", timestep=f"{dt:.12g}",
        thermo_every=sc.thermo_every, periodic_dumps=periodic, record_print=CRUSH_RECORD.print_text(),
        record_title=CRUSH_RECORD.title(), window_steps=window, max_windows=max_windows,
        stop_after_drop=f"{sc.stop_after_drop:g}")
    setup = render(
        "bcm_crush.in", role="Fresh start from system.data (setup.lammps; in.lammps runs it whole).",
        system=SYSTEM_FRESH, pair_setup=styles.pair_setup(m, r_m), bond_setup=styles.bond_setup(m),
        record_target="file thermo.dat",
        start="run             0\n" + _dump_commands("start") + "\nvariable        peak_prev equal 0",
        **common)
    resume = render(
        "bcm_crush.in", role="Start from a checkpoint (resume.lammps: -var checkpoint FILE).",
        system=SYSTEM_RESUME, pair_setup="# pair style, coefficients and counters: from the checkpoint",
        bond_setup="# bond style, interface table and reference state: from the checkpoint",
        record_target="append thermo.dat",
        start="# the stop rule's peak so far (peak_prev): from the checkpoint's record", **common)
    # Stop rule (SPEC 4.1): the peak is the largest force seen at the checks (it can only be
    # below the true peak, so a stop is never early); once an interface has broken (chatter
    # at first touch, before any damage, is no peak) a force below stop_after_drop x peak ends
    # the run. The strain limit and max_time end it through the number of checks.
    schedule = settle(
        window, chunk, max_windows,
        **peak_drop_check(sc.stop_after_drop),
        end=_dump_commands("end").splitlines())
    return setup, resume, schedule


def run_crush(cfg: RunConfig, rd: RunDir, plugin_path: Path) -> tuple[dict, dict]:
    """Build the particle and write the run's inputs; returns (system facts, progress spec)."""
    system = build_system(cfg, rd)
    setup, resume, schedule = render_inputs(cfg, plugin_path, system)
    system.update(window_steps=schedule["window"], chunk_steps=schedule["chunk"],
                  max_windows=schedule["max_windows"], max_steps=schedule["window"] * schedule["max_windows"])
    atomic_write_json(rd.root / "system.json", system)
    write_session(rd.root, setup, resume, schedule, cfg.execution.checkpoint_steps(),
                  checkpoint_variables=["peak_prev"])
    return system, progress_spec(cfg, system)


def progress_spec(cfg: RunConfig, system: dict) -> ProgressSpec:
    return ProgressSpec(file="thermo.dat", total_steps=system["max_steps"], label=cfg.name,
                        columns={name: CRUSH_RECORD.column(name) for name in ("time", "F_upper", "broken")})
