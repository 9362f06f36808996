"""BPM shear fragmentation (SPEC 2.4): build the solid, write the LAMMPS input, run, measure."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from driver.bpm.input_blocks import (SYSTEM_FRESH, SYSTEM_RESUME, comm_cutoff, common_values, pair_coeff_lines,
                                     periodic_dumps, styles, write_dumps)
from driver.bpm.solid import build_system
from driver.runner import ProgressSpec
from driver.schedule import chunk_steps, segments, steps_for_strain, write_session
from driver.templates import render
from runfiles.atomic import atomic_write_json
from runfiles.records import SHEAR_RECORD

if TYPE_CHECKING:  # for readers and checkers only
    from driver.config import RunConfig
    from driver.rundir import RunDir


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


def snapshot_commands(snap: Snapshot, dimension: int) -> str:
    """The snapshot's atom and bond dumps, each command ending its line."""
    return write_dumps(snap.atoms, snap.bonds, dimension) + "\n"


def radius_variable(type_diameters: dict[int, float]) -> str:
    """`variable radius atom ...`: each particle's radius from its type (the dumps' radius)."""
    terms = "+".join(f"{0.5 * d:.12g}*(type=={t})" for t, d in sorted(type_diameters.items()))
    return f'variable        radius atom "{terms}"'


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
        periodic += "\n" + periodic_dumps(m.dimension, sc.dump_every)
    pair_lines, max_abar = pair_coeff_lines(type_diameters, m.gamma)
    common = common_values(cfg, plugin_path, comm_cutoff(m, max_r0, max_abar), sc.thermo_every, SHEAR_RECORD,
                           deform_args=deform_args(m.dimension, sc.strain_rate), strain_rate=sc.strain_rate,
                           periodic_dumps=periodic)
    setup = render(
        "bpm_shear.in", role="Fresh start from system.data (setup.lammps; in.lammps runs it whole).",
        system=SYSTEM_FRESH.format(dimension=m.dimension, boundary="p p p"), styles=styles(m, pair_lines),
        record_target="file thermo.dat", start="run             0\n" + snapshot_commands(snaps[0], m.dimension),
        **common)
    resume = render(
        "bpm_shear.in", role="Start from a checkpoint (resume.lammps: -var checkpoint FILE).",
        system=SYSTEM_RESUME, styles="# pair, bond and angle styles with their coefficients: from the checkpoint",
        record_target="append thermo.dat", start="", **common)
    chunk = chunk_steps("bpm", n_particles, cfg.execution.chunk_steps)
    schedule = segments(total, chunk, {s.step: snapshot_commands(s, m.dimension).splitlines() for s in snaps[1:]})
    return ShearPlan(total_steps=total, snapshots=snaps), setup, resume, schedule


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
    """The progress fields of a shear run: the strain and the bonds broken."""
    return ProgressSpec(file="thermo.dat", total_steps=system["total_steps"], label=cfg.name,
                        columns={"strain": SHEAR_RECORD.column("strain"), "broken": SHEAR_RECORD.column("bonds_broken")})
