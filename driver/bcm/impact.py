"""BCM impact on a rigid plane (SPEC 1.4): tessellate, glue, place, run to a settled outcome."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

import driver
from analysis.plots import PlotGuard
from analysis.tables import save_table
from driver.bcm import styles
from driver.bcm.cellstats import cell_statistics, plot_cell_stats
from driver.bcm.lammps_files import read_cells, resume_cells, write_particle
from driver.bcm.particle import build_particle, contact_timestep, particle_tessellation
from driver.cache import cache_base
from driver.runner import ProgressSpec
from driver.schedule import chunk_steps, settle, settle_windows, write_session
from driver.templates import render
from runfiles.atomic import atomic_write_json
from runfiles.cells import write_cells
from runfiles.records import CELLS_DUMP, IMPACT_RECORD, INTERFACES_DUMP

if TYPE_CHECKING:  # for readers and checkers only
    from driver.config import RunConfig
    from driver.rundir import RunDir

# the plane has "loaded" the particle once it has given back this fraction of the incoming momentum
LOADED_FRACTION = 0.5


def _interface_values() -> str:
    # the values and column names of the interface dump (fix bcm/interfaces/dump and
    # write_bcm_interfaces, which write it from the bond style without LAMMPS's computes)
    return f"{INTERFACES_DUMP.args()} {INTERFACES_DUMP.names_keyword()}"


def _dump_commands(name: str) -> str:
    # columns named as runfiles/records.py declares them (OVITO maps them by name)
    return (f"write_dump      all custom dumps/cells.{name}.lammpstrj {CELLS_DUMP.args()} modify sort id "
            f"{CELLS_DUMP.modify()}\n"
            f"write_bcm_interfaces all dumps/interfaces.{name}.lammpstrj {_interface_values()}")


def bonded_interfaces(areas: np.ndarray, min_fraction: float) -> np.ndarray:
    """Which shared faces are glued: those of at least `min_fraction` of the median face area
    (model.min_interface_area; 0 glues every face, the published model)."""
    return areas >= min_fraction * float(np.median(areas)) if min_fraction > 0 else np.ones(len(areas), bool)


def timestep_facts(m, areas: np.ndarray, masses: np.ndarray, steps_per_period: float) -> dict:
    """system.json's time step of BCM cells (a particle or a bed): dt from the stiffest contact
    or interface and the lightest cells (particle.py contact_timestep), and its rule."""
    # per_area: the stiffest interface is the largest, k_n S_max / <S>
    k_iface = m.interface.kn * (areas.max() / areas.mean() if m.interface_stiffness == "per_area" else 1.0)
    k_max = max(m.contact.kn, k_iface)
    dt, period = contact_timestep(masses, k_max, steps_per_period)
    return {"timestep": dt, "shortest_period": period,
            "timestep_rule": f"dt = 2 pi sqrt((m_min/2) / k_max) / {steps_per_period:g}, k_max = {k_max:g} N/m"}


def particle_facts(m, tess, particle, bonded: np.ndarray, steps_per_period: float, t_tess: float) -> dict:
    """system.json's facts of a BCM particle (impact and crush): cells, interfaces, A_0, mass,
    the tessellation and the time step (timestep_facts)."""
    areas = tess.iface_area[bonded]
    return {
        "n_cells": tess.n_cells, "n_interfaces": int(bonded.sum()),
        "n_faces_unbonded": int((~bonded).sum()),
        "contact_points": int(np.diff(tess.iface_ptr)[bonded].sum()),
        # A_0: the bonded interfaces only (faces below min_interface_area are never glued)
        "A0": float(areas.sum()), "mean_interface_area": float(areas.mean()),
        "interface_stiffness": m.interface_stiffness,
        "mass": float(particle.masses.sum()),
        "volume": float(tess.volume.sum()), "mean_cell_size": float(tess.mean_cell_size),
        "r_m": float(particle.r_m), "lloyd_iterations": int(tess.n_iter), "lloyd_residual": float(tess.residual),
        "lloyd_converged": bool(tess.converged), "tessellation_key": tess.key,
        "tessellation_seconds": t_tess, **timestep_facts(m, areas, particle.masses, steps_per_period),
        "max_bound_radius": float(particle.bound_radius.max()),
    }


def place_particle(cfg: RunConfig, rd: RunDir, gap: float) -> tuple[dict, object, PlotGuard]:
    """The run's particle, for the impact and the crush alike: the tessellation (cached), its
    cell statistics (table and figure), the rounded cells in the seed's orientation with the
    lowest point `gap` above z = 0, and the data, interfaces and cells files. Returns
    (particle_facts, the placed particle, the plot guard of the cell figure)."""
    m, sc = cfg.model, cfg.scenario
    t0 = time.perf_counter()
    tess = particle_tessellation(m, cfg.seed, cache_base() / "tessellations")
    t_tess = time.perf_counter() - t0
    stats = cell_statistics(tess)
    save_table(stats, rd.results / "cells")
    guard = PlotGuard()  # the cell statistics figure never decides whether the run goes on
    guard.draw("cells", rd.plots / "cells.png", plot_cell_stats, stats, rd.plots / "cells.png")
    rng = np.random.default_rng([cfg.seed, 1])  # orientation stream, apart from the tessellation's
    particle = build_particle(tess, m.density, m.rounding, rng, plane_z=0.0, gap=gap)
    root = rd.root
    bonded = bonded_interfaces(tess.iface_area, m.min_interface_area)
    write_particle(root, tess, particle, bonded, m.diameter)
    # the Voronoi cells themselves, for the analysis: fragment boxes from the cells' own vertices
    write_cells(root / "voronoi_cells.txt", particle.cell_vertices, particle.cell_faces)
    return particle_facts(m, tess, particle, bonded, sc.steps_per_period, t_tess), particle, guard


def periodic_dumps(dump_every: int) -> str:
    """The cell and interface dumps every `dump_every` steps (none when 0), for the impact, the
    crush and the compression alike. The interface dump is the plugin's fix, which holds no
    array over the interfaces (LAMMPS's compute bond/local would hold one all run)."""
    if dump_every <= 0:
        return "# no periodic dumps (scenario.dump_every = 0): cells and interfaces at named moments only"
    return (f"dump            cells all custom {dump_every} dumps/cells.*.lammpstrj {CELLS_DUMP.args()}\n"
            f"dump_modify     cells sort id {CELLS_DUMP.modify()}\n"
            f"fix             ifaces all bcm/interfaces/dump {dump_every} dumps/interfaces.*.lammpstrj "
            f"{_interface_values()}")


def build_system(cfg: RunConfig, rd: RunDir) -> dict:
    """Tessellation (cached) -> rounded cells -> placement -> data, interfaces and cells files."""
    sc = cfg.scenario
    facts, _, guard = place_particle(cfg, rd, gap=sc.gap * cfg.model.diameter)
    return {**facts, "initial_velocity": sc.velocity, "plots_failed": guard.failed}


SYSTEM_FRESH = """units           si
dimension       3
boundary        m m m
atom_style      bpm/sphere
atom_modify     map array
# newton bond off: both ranks holding an interface's cells evaluate it identically.
newton          on off
# bonded cells interact only through their interface (intact or broken), never as a pair.
special_bonds   lj 0 1 1 coul 1 1 1
""" + read_cells("system.data")
# A checkpoint holds the box, atoms (their orientations too), topology, the bond style with its
# interface table and reference state, the pair style with its counters, and the wall's
# counters; the per-atom arrays come back when their fix is defined again with the same id; the
# dumps' orientation compute is defined again.
SYSTEM_RESUME = resume_cells("${checkpoint}")


def render_inputs(cfg: RunConfig, plugin_path: Path, system: dict) -> tuple[str, str, dict]:
    """(setup.lammps, resume.lammps, schedule) of an impact run."""
    m, sc = cfg.model, cfg.scenario
    dt = system["timestep"]
    chunk = chunk_steps("bcm", system["n_cells"], cfg.execution.chunk_steps)
    window, chunk = settle_windows(max(1, math.ceil(sc.settle_window / dt)), chunk)
    max_windows = max(1, math.ceil(sc.max_time / (window * dt)))
    periodic = periodic_dumps(sc.dump_every)
    skin = 0.1 * system["mean_cell_size"]
    # ghosts must hold every bonded partner: two bounding radii plus the skin
    comm_cutoff = 2.0 * system["max_bound_radius"] * 1.05 + skin
    common = dict(
        package_version=driver.__version__, config_name=cfg.name, plugin_path=plugin_path,
        comm_cutoff=f"{comm_cutoff:.9g}", r_m=f"{system['r_m']:.12g}",
        wall_setup=styles.wall_setup(m, system["r_m"]),
        skin=f"{skin:.9g}", steps_per_period=f"{sc.steps_per_period:g}",
        period=f"{system['shortest_period']:.6g}", timestep=f"{dt:.12g}",
        thermo_every=sc.thermo_every, periodic_dumps=periodic, record_print=IMPACT_RECORD.print_text(),
        record_title=IMPACT_RECORD.title(),
        window_steps=window, max_windows=max_windows, ke_tolerance=sc.ke_tolerance)
    setup = render(
        "bcm_impact.in", role="Fresh start from system.data (setup.lammps; in.lammps runs it whole).",
        system=SYSTEM_FRESH,
        pair_setup=styles.pair_setup(m, system["r_m"]),
        bond_setup=styles.bond_setup(m),
        velocity=f"velocity        all set 0.0 0.0 -{sc.velocity} units box",
        record_target="file thermo.dat",
        start=("run             0\n" + _dump_commands("start") +
               "\nvariable        nb_prev equal ${nb}\nvariable        ke_prev equal ${kin}"
               "\nvariable        loaded_prev equal 0\nvariable        reached_prev equal 0"),
        **common)
    resume = render(
        "bcm_impact.in", role="Start from a checkpoint (resume.lammps: -var checkpoint FILE).",
        system=SYSTEM_RESUME, pair_setup="# pair style, coefficients and counters: from the checkpoint",
        bond_setup="# bond style, interface table and reference state: from the checkpoint",
        velocity="# velocities: from the checkpoint", record_target="append thermo.dat",
        start="# the settle rule's last values (nb_prev, ke_prev, loaded_prev, reached_prev): from the checkpoint's "
              "record",
        **common)
    # Stop rule (SPEC 1.4), latched: the plane must first have loaded the particle (given back
    # LOADED_FRACTION of its incoming momentum: the centre of mass has slowed from -v0 to at
    # least -(1 - LOADED_FRACTION) v0; nothing else acts on it), and only then a window with
    # no break, a steady kinetic energy and the plane unloaded ends the run. First contact
    # at the end of a window (the plane barely touched) therefore never stops a run.
    schedule = settle(
        window, chunk, max_windows,
        check=["variable        nb_now equal ${nb}", "variable        ke_now equal ${kin}",
               f"variable        loaded_now equal \"v_loaded_prev || (vcm(all,z) >= "
               f"{-(1.0 - LOADED_FRACTION) * sc.velocity!r})\"",
               "variable        loaded_now equal ${loaded_now}",
               # reached: the plane has touched the particle (a cell on it now, or the momentum changed)
               f"variable        reached_now equal \"v_reached_prev || (f_plane[1] > 0) || (vcm(all,z) > "
               f"{-(1.0 - 1e-6) * sc.velocity!r})\"",
               "variable        reached_now equal ${reached_now}",
               f'variable        settled equal "(v_loaded_now > 0) && (v_nb_now == v_nb_prev) && '
               f'(abs(v_ke_now - v_ke_prev) <= {sc.ke_tolerance}*v_ke_prev) && '
               f'(v_wall_energy <= {sc.ke_tolerance}*v_ke_now)"'],
        settled_variable="settled",
        advance=["variable        nb_prev equal ${nb_now}", "variable        ke_prev equal ${ke_now}",
                 "variable        loaded_prev equal ${loaded_now}", "variable        reached_prev equal ${reached_now}"],
        end=_dump_commands("end").splitlines(),
        never=("reached_now", f"the particle did not reach the plane within max_time = {sc.max_time:g} s (gap "
                          f"{sc.gap * m.diameter:g} m at {sc.velocity:g} m/s needs {sc.gap * m.diameter / sc.velocity:g} s "
                          "of flight): raise scenario.max_time"))
    return setup, resume, schedule


def run_impact(cfg: RunConfig, rd: RunDir, plugin_path: Path) -> tuple[dict, dict]:
    """Build the particle and write the run's inputs; returns (system facts, progress spec)."""
    system = build_system(cfg, rd)
    setup, resume, schedule = render_inputs(cfg, plugin_path, system)
    system.update(window_steps=schedule["window"], chunk_steps=schedule["chunk"],
                  max_windows=schedule["max_windows"], max_steps=schedule["window"] * schedule["max_windows"])
    atomic_write_json(rd.root / "system.json", system)
    write_session(rd.root, setup, resume, schedule, cfg.execution.checkpoint_steps(),
                  checkpoint_variables=["nb_prev", "ke_prev", "loaded_prev", "reached_prev"])
    return system, progress_spec(cfg, system)


def progress_spec(cfg: RunConfig, system: dict) -> ProgressSpec:
    return ProgressSpec(file="thermo.dat", total_steps=system["max_steps"], label=cfg.name,
                        columns={name: IMPACT_RECORD.column(name) for name in ("time", "broken")})
