"""BPM crushing between platens (SPEC 4.1, 3): the BPM impact's particle (driver/bpm/impact.py:
the packing clipped to the parent, bonded, in the random orientation from the seed) at rest on
the plane z = 0, its lowest sphere touching it, and the platen of driver/bpm/platen.py over its
highest sphere coming down at scenario.platen_speed (m/s, converted to a / tau), run until the
platen force has dropped after its peak (the BCM crush's stop rule, driver/bcm/crush.py).

The chunks are `run N pre no` (driver/bpm/platen.py: a set-up sees the platen at rest for one
force evaluation); the platen's position is a function of the step from step 0, so a run
resumed from a checkpoint puts it where it was; its work and the other running integrals are
carried on from the totals saved with the checkpoint. A resumed run's first set-up still sees
the platen at rest for that one evaluation: its force is off by the damping of v_p on the
touching spheres for one half-kick (driver/bpm/platen.py measured 0.35 % just after the split)."""

from __future__ import annotations

import math
from pathlib import Path

from driver.bpm.impact import DIAMETER, SYSTEM_FRESH, _dump_commands, build_system, plane_fix
from driver.bpm.input_blocks import SYSTEM_RESUME, comm_cutoff, common_values, periodic_dumps, styles
from driver.bpm.platen import platen_fix, platen_force, platen_region
from driver.runner import ProgressSpec
from driver.schedule import peak_drop_check, settle, settle_windows, write_session
from driver.templates import render
from runfiles.atomic import atomic_write_json
from runfiles.records import BPM_CRUSH_RECORD

#: the running integrals of lammps_inputs/bpm_crush.in and the samples they start from, saved
#: with each checkpoint and restored as the base a resumed run adds to (`<name>_base`)
INTEGRALS = ("wall_work", "upper_work", "damp_pair", "damp_bond", "wall_pw", "upper_pw", "damp_pair_pw",
             "damp_bond_pw", "platen_work", "platen_pc", "platen_half")


def crush_system(cfg, rd) -> dict:
    """The particle on the plane (its lowest sphere touching it at zero overlap) and the facts of
    the crush: d, the height between the platens at contact (SI; height_a in a), the platen's
    start h0 (over the highest sphere, plus scenario.gap diameters) and its speed in a / tau."""
    sc, p = cfg.scenario, cfg.model.particle
    system = build_system(cfg, rd, gap=0.0)
    un = system["units"]
    height_a = system["centres_z"][1] + 0.5 * DIAMETER  # the lowest sphere's bottom is at z = 0
    system.update(height_a=height_a, height=height_a * un["a"],
                  platen_start=height_a + sc.gap * p.diameter / un["a"],
                  platen_speed=sc.platen_speed, platen_speed_lj=sc.platen_speed * un["tau"] / un["a"])
    return system


def render_inputs(cfg, plugin_path: Path, system: dict) -> tuple[str, str, dict]:
    """(setup.lammps, resume.lammps, schedule) of a BPM crush run."""
    m, sc = cfg.model, cfg.scenario
    un, law, dt = system["units"], system["plane"], system["timestep"]
    tau = un["tau"]
    window, chunk = settle_windows(sc.check_every, sc.check_every)
    v = system["platen_speed_lj"]
    gap0 = system["platen_start"] - system["height_a"]
    t_end = min(sc.max_time / tau, (gap0 + sc.max_strain * system["height_a"]) / v)
    max_windows = max(1, math.ceil(t_end / (window * dt)))
    periodic = "compute         bl all property/local batom1 batom2 btype"
    if sc.dump_every > 0:
        periodic += "\n" + periodic_dumps(3, sc.dump_every)
    platen = "\n".join([*platen_region("upper", system["platen_start"], v, n0=0), platen_fix(law, "upper"),
                        *platen_force(law, "upper")])
    common = common_values(
        cfg, plugin_path, comm_cutoff(m, system["max_r0"], DIAMETER), sc.thermo_every, BPM_CRUSH_RECORD,
        a_m=f"{un['a']:.6g}", m_kg=f"{un['m']:.6g}", u_J=f"{un['u']:.6g}", tau_s=f"{tau:.17g}",
        timestep=f"{dt:.12g}", steps_per_period=f"{sc.steps_per_period:g}", kn=f"{law['kn']:.12g}",
        kt=f"{law['kt']:.12g}", eta_n=f"{law['eta_n']:.12g}", mu=f"{law['mu']:.12g}", plane_fix=plane_fix(law),
        platen=platen, periodic_dumps=periodic, window_steps=window, max_windows=max_windows,
        stop_after_drop=f"{sc.stop_after_drop:g}")
    setup = render(
        "bpm_crush.in", role="Fresh start from system.data (setup.lammps; in.lammps runs it whole).",
        system=SYSTEM_FRESH, styles=styles(m, f"pair_coeff      1 1 1.0 {DIAMETER!r} {m.gamma:.12g}"),
        record_target="file thermo.dat", step0=0,
        start="run             0\n" + _dump_commands("start") + "\nvariable        peak_prev equal 0", **common)
    resume = render(
        "bpm_crush.in", role="Start from a checkpoint (resume.lammps: -var checkpoint FILE).",
        system=SYSTEM_RESUME, styles="# pair, bond and angle styles with their coefficients: from the checkpoint",
        record_target="append thermo.dat", step0="$(step)",
        start="# the stop rule's peak so far (peak_prev): from the checkpoint's record", **common)
    # the BCM crush's stop rule (driver/bcm/crush.py), on the platen's load and the broken bonds
    schedule = settle(
        window, chunk, max_windows,
        **peak_drop_check(sc.stop_after_drop),
        end=_dump_commands("end").splitlines(), pre_no=True)
    return setup, resume, schedule


def run_crush(cfg, rd, plugin_path: Path) -> tuple[dict, ProgressSpec]:
    """Build the particle and write the run's inputs; returns (system facts, progress spec)."""
    system = crush_system(cfg, rd)
    setup, resume, schedule = render_inputs(cfg, plugin_path, system)
    system.update(window_steps=schedule["window"], chunk_steps=schedule["chunk"],
                  max_windows=schedule["max_windows"], max_steps=schedule["window"] * schedule["max_windows"])
    atomic_write_json(rd.root / "system.json", system)
    write_session(rd.root, setup, resume, schedule, cfg.execution.checkpoint_steps(),
                  checkpoint_variables=["peak_prev", *INTEGRALS],
                  restore_as={name: f"{name}_base" for name in INTEGRALS})
    return system, progress_spec(cfg, system)


def progress_spec(cfg, system: dict) -> ProgressSpec:
    """The progress fields of a BPM crush: the time, the platen's load and the bonds broken."""
    return ProgressSpec(file="thermo.dat", total_steps=system["max_steps"], label=cfg.name,
                        columns={name: BPM_CRUSH_RECORD.column(name) for name in ("time", "F_upper", "bonds_broken")})
