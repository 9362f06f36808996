"""BCM impact on a rigid plane (SPEC 1.4): tessellate, glue, place, run to a settled outcome."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

import driver
from analysis.tables import save_table
from driver.bcm.cellstats import cell_statistics, plot_cell_stats
from driver.bcm.lammps_files import write_cell_data, write_cells, write_interfaces
from driver.bcm.particle import build_particle, contact_timestep, particle_tessellation
from driver.config import RunConfig
from driver.plugin_build import cache_base
from driver.rundir import RunDir, atomic_write_json, atomic_write_text
from driver.runner import ProgressSpec, run_input
from driver.templates import render

CELL_COLUMNS = ("id mass x y z vx vy vz omegax omegay omegaz "
                "d2_bcm_quat[1] d2_bcm_quat[2] d2_bcm_quat[3] d2_bcm_quat[4]")
INTERFACE_COLUMNS = "c_ifc[1] c_ifc[2] c_ifs[1] c_ifs[2] c_ifs[3] c_ifs[4] c_ifs[5] c_ifs[6]"


def _dump_commands(name: str) -> str:
    return (f"write_dump      all custom dumps/cells.{name}.lammpstrj {CELL_COLUMNS} modify sort id\n"
            f"write_dump      all local dumps/interfaces.{name}.lammpstrj {INTERFACE_COLUMNS}")


def build_system(cfg: RunConfig, rd: RunDir) -> dict:
    """Tessellation (cached) -> rounded cells -> placement -> data, interfaces and cells files."""
    m, sc = cfg.model, cfg.scenario
    t0 = time.perf_counter()
    tess = particle_tessellation(m, cfg.seed, cache_base() / "tessellations")
    t_tess = time.perf_counter() - t0
    stats = cell_statistics(tess)
    save_table(stats, rd.results / "cells")
    plot_cell_stats(stats, rd.plots / "cells.png")
    rng = np.random.default_rng([cfg.seed, 1])  # orientation stream, apart from the tessellation's
    particle = build_particle(tess, m.density, m.rounding, rng, plane_z=0.0, gap=sc.gap * m.diameter)
    root = rd.root
    write_cell_data(root / "system.data", particle.centroids, particle.quats, particle.masses, particle.moments,
                    2 * particle.bound_radius, tess.iface_cells, margin=m.diameter)
    write_interfaces(root / "interfaces.txt", tess.iface_cells, tess.iface_area,
                     tess.iface_normal @ particle.placement.rotation.T, particle.interface_polygons)
    write_cells(root / "cells.txt", particle.core_vertices, particle.core_faces)
    # the Voronoi cells themselves, for the analysis: fragment boxes from the cells' own vertices
    write_cells(root / "voronoi_cells.txt", particle.cell_vertices, particle.cell_faces)
    k_max = max(m.contact.kn, m.interface.kn)
    dt, period = contact_timestep(particle.masses, k_max, sc.steps_per_period)
    return {
        "n_cells": tess.n_cells, "n_interfaces": tess.n_interfaces,
        "contact_points": int(np.diff(tess.iface_ptr).sum()),
        "A0": float(tess.total_interface_area), "mass": float(particle.masses.sum()),
        "volume": float(tess.volume.sum()), "mean_cell_size": float(tess.mean_cell_size),
        "r_m": float(particle.r_m), "lloyd_iterations": int(tess.n_iter), "lloyd_residual": float(tess.residual),
        "lloyd_converged": bool(tess.converged), "tessellation_key": tess.key,
        "tessellation_seconds": t_tess, "timestep": dt, "shortest_period": period,
        "timestep_rule": f"dt = 2 pi sqrt((m_min/2) / k_max) / {sc.steps_per_period:g}, k_max = {k_max:g} N/m",
        "max_bound_radius": float(particle.bound_radius.max()),
        "initial_velocity": sc.velocity,
    }


def plan_and_input(cfg: RunConfig, plugin_path: Path, system: dict) -> tuple[dict, str]:
    m, sc = cfg.model, cfg.scenario
    dt = system["timestep"]
    window = max(1, math.ceil(sc.settle_window / dt))
    max_windows = max(1, math.ceil(sc.max_time / (window * dt)))
    periodic = ""
    if sc.dump_every > 0:
        periodic = (f"compute         ifc all property/local batom1 batom2\n"
                    f"compute         ifs all bond/local b1 b2 b3 b4 b5 b6\n"
                    f"dump            cells all custom {sc.dump_every} dumps/cells.*.lammpstrj {CELL_COLUMNS}\n"
                    f"dump_modify     cells sort id\n"
                    f"dump            ifaces all local {sc.dump_every} dumps/interfaces.*.lammpstrj "
                    f"{INTERFACE_COLUMNS}")
    else:
        periodic = ("compute         ifc all property/local batom1 batom2\n"
                    "compute         ifs all bond/local b1 b2 b3 b4 b5 b6")
    skin = 0.1 * system["mean_cell_size"]
    # ghosts must hold every bonded partner: two bounding radii plus the skin
    comm_cutoff = 2.0 * system["max_bound_radius"] * 1.05 + skin
    text = render(
        "bcm_impact.in", package_version=driver.__version__, config_name=cfg.name, plugin_path=plugin_path,
        comm_cutoff=f"{comm_cutoff:.9g}", r_m=f"{system['r_m']:.12g}",
        kn=m.interface.kn, kt=m.interface.kt, en2=m.interface.en2, G_c=m.interface.G_c,
        kn_c=m.contact.kn, kt_c=m.contact.kt, en2_c=m.contact.en2, mu=m.contact.mu,
        griffith_energy=m.griffith_energy, skin=f"{skin:.9g}", steps_per_period=f"{sc.steps_per_period:g}",
        period=f"{system['shortest_period']:.6g}", timestep=f"{dt:.12g}", velocity=sc.velocity,
        thermo_every=sc.thermo_every, periodic_dumps=periodic, dump_start=_dump_commands("start"),
        window_steps=window, max_windows=max_windows, ke_tolerance=sc.ke_tolerance,
        dump_end=_dump_commands("end"),
    )
    return {"window_steps": window, "max_windows": max_windows, "max_steps": window * max_windows}, text


def run_impact(cfg: RunConfig, rd: RunDir, plugin_path: Path, np_ranks: int, show_progress: bool) -> dict:
    system = build_system(cfg, rd)
    plan, text = plan_and_input(cfg, plugin_path, system)
    system.update(plan)
    atomic_write_json(rd.root / "system.json", system)
    atomic_write_text(rd.root / "in.lammps", text)
    spec = ProgressSpec(file="thermo.dat", total_steps=plan["max_steps"], label=cfg.name,
                        columns={"time": 1, "broken": 5})
    t0 = time.perf_counter()
    run_input(rd.root, np=np_ranks, progress=spec, show_progress=show_progress)
    return {"system": system, "lammps_wall_seconds": time.perf_counter() - t0}
