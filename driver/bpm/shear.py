"""BPM shear fragmentation (SPEC 2.4): build the solid, write the LAMMPS input, run, measure."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import driver
from driver.bpm.datafile import write_data
from driver.bpm.network import delaunay_network
from driver.bpm.packing import cached_packing
from driver.config import RunConfig, steps_for_strain
from driver.plugin_build import cache_base
from runfiles.atomic import atomic_write_json
from driver.rundir import RunDir
from driver.runner import ProgressSpec
from driver.schedule import chunk_steps, segments, write_session
from driver.templates import render
from runfiles.records import BONDS_DUMP, SHEAR_RECORD, atoms_dump

@dataclass
class Snapshot:
    strain: float
    step: int
    atoms: str
    bonds: str


@dataclass
class ShearPlan:
    """What the generated input will do: total steps and the snapshot schedule."""

    total_steps: int
    snapshots: list[Snapshot]


def deform_args(dimension: int, rate: float) -> str:
    """SPEC 2.4: 2D pure shear (x +edot, y -edot); 3D triaxial (x, y +edot/2, z -edot)."""
    if dimension == 2:
        return f"x trate {rate:.12g} y trate {-rate:.12g}"
    return f"x trate {rate / 2:.12g} y trate {rate / 2:.12g} z trate {-rate:.12g}"


def pair_coeff_lines(type_diameters: dict[int, float], gamma: float) -> tuple[str, float]:
    """pair_style cr/repulsion coefficients per type pair (u = 1, abar = sum of radii, the
    damping gamma), every pair written out; and the largest abar (the pair cutoff)."""
    lines, max_abar = [], 0.0
    types = sorted(type_diameters)
    for a, ti in enumerate(types):
        for tj in types[a:]:
            abar = 0.5 * (type_diameters[ti] + type_diameters[tj])
            max_abar = max(max_abar, abar)
            lines.append(f"pair_coeff      {ti} {tj} 1.0 {abar:.12g} {gamma:.12g}")
    return "\n".join(lines), max_abar


def snapshot_commands(snap: Snapshot, dimension: int) -> str:
    # columns named as runfiles/records.py declares them (OVITO maps them by name; 2D without z)
    atoms = atoms_dump(dimension)
    return (f"write_dump      all custom {snap.atoms} {atoms.args()} modify sort id {atoms.modify()}\n"
            f"write_dump      all local {snap.bonds} {BONDS_DUMP.args()} modify {BONDS_DUMP.modify()}\n")


def radius_variable(type_diameters: dict[int, float]) -> str:
    """`variable radius atom ...`: each particle's radius from its type (the dumps' radius)."""
    terms = "+".join(f"{0.5 * d:.12g}*(type=={t})" for t, d in sorted(type_diameters.items()))
    return f'variable        radius atom "{terms}"'



SYSTEM_FRESH = """units           lj
dimension       {dimension}
boundary        {boundary}
atom_style      angle
# newton bond off: every atom holds all its bonds and angles, so each rank decides a break
# identically; special lj 0 keeps bonded pairs out of the repulsion, coul 1 keeps them in
# the neighbour list so a broken bond's repulsion switches on without a rebuild.
newton          on off
special_bonds   lj 0 1 1 coul 1 1 1
read_data       system.data"""
# A checkpoint holds the box, atoms, topology with broken bonds and angles (type 0), the
# styles with their coefficients and the reference lengths and angles (per atom).
SYSTEM_RESUME = "read_restart    ${checkpoint}"


def plan_and_input(cfg: RunConfig, plugin_path: Path, type_diameters: dict[int, float],
                   max_r0: float, n_particles: int) -> tuple[ShearPlan, str, str, dict]:
    """The schedule of this config and its LAMMPS inputs: (plan, setup, resume, schedule)."""
    m, sc = cfg.model, cfg.scenario
    strains = list(sc.measure_strains)
    if not strains or strains[-1] < sc.max_strain:
        strains.append(sc.max_strain)
    snaps = [Snapshot(0.0, 0, "dumps/atoms.0.lammpstrj", "dumps/bonds.0.lammpstrj")]
    for eps in strains:
        step = steps_for_strain(eps, sc.strain_rate, m.timestep)
        if step <= snaps[-1].step:
            continue
        snaps.append(Snapshot(eps, step, f"dumps/atoms.{step}.lammpstrj", f"dumps/bonds.{step}.lammpstrj"))
    total = snaps[-1].step
    periodic = radius_variable(type_diameters)
    if sc.dump_every > 0:
        atoms = atoms_dump(m.dimension)
        periodic += (f"\ndump            atoms all custom {sc.dump_every} dumps/atoms.*.lammpstrj {atoms.args()}\n"
                     f"dump_modify     atoms sort id {atoms.modify()}\n"
                     f"dump            bonds all local {sc.dump_every} dumps/bonds.*.lammpstrj {BONDS_DUMP.args()}\n"
                     f"dump_modify     bonds {BONDS_DUMP.modify()}")
    pair_lines, max_abar = pair_coeff_lines(type_diameters, m.gamma)
    # Ghosts must reach both arms of every angle: two stretched bonds plus the skin.
    comm_cutoff = max(2.0 * m.lambda_c * max_r0, max_abar) + m.skin
    common = dict(
        package_version=driver.__version__, config_name=cfg.name, plugin_path=plugin_path,
        comm_cutoff=f"{comm_cutoff:.6g}", skin=m.skin, timestep=m.timestep,
        enforce2d="fix             planar all enforce2d" if m.dimension == 2 else "",
        deform_args=deform_args(m.dimension, sc.strain_rate), strain_rate=sc.strain_rate,
        thermo_every=sc.thermo_every, periodic_dumps=periodic,
        record_print=SHEAR_RECORD.print_text(), record_title=SHEAR_RECORD.title())
    setup = render(
        "bpm_shear.in", role="Fresh start from system.data (setup.lammps; in.lammps runs it whole).",
        system=SYSTEM_FRESH.format(dimension=m.dimension, boundary="p p p"),
        styles=(f"pair_style      cr/repulsion\n{pair_lines}\n\n"
                f"bond_style      breakable/cr\nbond_coeff      1 {m.lambda_c} {m.gamma}\n"
                f"angle_style     breakable/cr\nangle_coeff     1 {m.k_A} {m.theta_c_deg} {m.lambda_c}"),
        record_target="file thermo.dat", start="run             0\n" + snapshot_commands(snaps[0], m.dimension),
        **common)
    resume = render(
        "bpm_shear.in", role="Start from a checkpoint (resume.lammps: -var checkpoint FILE).",
        system=SYSTEM_RESUME, styles="# pair, bond and angle styles with their coefficients: from the checkpoint",
        record_target="append thermo.dat", start="", **common)
    chunk = chunk_steps("bpm", n_particles, cfg.execution.chunk_steps)
    schedule = segments(total, chunk, {s.step: snapshot_commands(s, m.dimension).splitlines() for s in snaps[1:]})
    return ShearPlan(total_steps=total, snapshots=snaps), setup, resume, schedule


def packing_and_network(cfg: RunConfig):
    """The run's packing (cached) and its Delaunay network (SPEC 2.1)."""
    m = cfg.model
    packing = cached_packing(cache_base() / "packings", m.dimension, m.L, cfg.seed, m.packing_fraction,
                             m.packing or "contact")
    return packing, delaunay_network(packing, m.bond_max_length if m.dimension == 3 else None)


def build_system(cfg: RunConfig, rd: RunDir) -> dict:
    """Packing -> Delaunay network -> data file; returns the network facts for the summary."""
    t0 = time.perf_counter()
    packing, net = packing_and_network(cfg)
    write_data(rd.root / "system.data", packing, net)
    types = {int(t): float(2 * packing.radii[packing.types == t][0]) for t in np.unique(packing.types)}
    return {
        "n_particles": int(len(packing.radii)),
        "n_bonds": int(len(net.bonds)),
        "n_angles": int(len(net.angles)),
        "bonds_per_particle": float(net.bonds_per_particle),
        "angles_per_particle": float(net.angles_per_particle),
        "max_r0": float(np.max(net.r0)),
        "mean_diameter": float(np.mean(2 * packing.radii)),
        "type_diameters": types,
        "build_seconds": time.perf_counter() - t0,
    }


def run_shear(cfg: RunConfig, rd: RunDir, plugin_path: Path) -> tuple[dict, ProgressSpec]:
    """Build the solid and write the run's inputs and schedule; returns (system facts, progress)."""
    system = build_system(cfg, rd)
    plan, setup, resume, schedule = plan_and_input(
        cfg, plugin_path, {int(k): v for k, v in system["type_diameters"].items()}, system["max_r0"],
        system["n_particles"])
    system.update(total_steps=plan.total_steps, chunk_steps=schedule["chunk"])
    atomic_write_json(rd.root / "system.json", system)
    # the snapshot plan is written before the run, so a run cut short can still be analysed
    atomic_write_json(rd.root / "snapshots.json", [s.__dict__ for s in plan.snapshots])
    write_session(rd.root, setup, resume, schedule, cfg.execution.checkpoint_steps())
    return system, progress_spec(cfg, system)


def progress_spec(cfg: RunConfig, system: dict) -> ProgressSpec:
    return ProgressSpec(file="thermo.dat", total_steps=system["total_steps"], label=cfg.name,
                        columns={"strain": SHEAR_RECORD.column("strain"), "broken": SHEAR_RECORD.column("bonds_broken")})
