"""BCM calibration on a periodic block of cells (SPEC 3: "BCM effective moduli measured by the
calibration scenarios on a block of cells"; cells and interfaces of SPEC 1.1-1.2).

The block: ``block.n_cells`` periodic CVT cells (driver/bcm/block.py) in a cube of side
``L = h n^(1/3)``, h the cell size (default: the particle's, ``h = (V_particle / N_c)^(1/3)``
from the model section, so the block is made of the particle's cells). Every shared face is an
interface of the model section (k_n, k_t, e_n^2, G_c unchanged); cells are eroded by r_m =
rounding h for their contacts, as in the particle. LAMMPS holds one atom per cell, wrapped into
the box ``[0, L)^3`` (periodic in x, y, z, triclinic for the shear tilts), one bond per
interface; the interface polygons are written near cell i and the bond style refers them to
each cell by minimum image.

Time scales. dt = shortest contact period / steps_per_period, as for the particle, with
k_max the stiffest spring (interface or contact). Rates are expressed in sound-crossing times
of the block, ``T = L / c_0`` with ``c_0 = sqrt(k_n / (rho_s h))`` (a chain of cells of mass
rho_s h^3 joined by k_n at spacing h). With dt from k_max and the rate in crossings, scaling
every stiffness by a factor s scales dt and T by 1/sqrt(s) and leaves the number of steps of
every phase unchanged: the dynamics are exactly similar and B, G scale by s to round-off.

moduli (the interfaces made unbreakable, G_c = UNBREAKABLE_GC: the moduli of the intact
block): the phases of the moduli protocol, driver/moduli_protocol.py (isotropic compression at
true strain rate edot, simple shear of the tilts xy, xz, yz at edot, then all again at edot / 2), each from
the undeformed block (the start's restart file read back: positions, orientations, box,
interface reference state), edot = max_strain / (3 crossings T): the fast compression phase
lasts ``block.crossings`` crossing times (its shear phases three times that).

fracture: the interfaces crossing the plane z = L/2 whose centroid lies at x < notch L are
left unbonded (the notch: a periodic array of through-thickness edge cracks, y being the
thickness); the block is pulled along z at engineering strain rate ``pull_rate / T`` with x
and y held (uniaxial strain) until ``pull_strain``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from driver.bcm import styles
from driver.bcm.block import BlockTessellation, cached_periodic_cvt
from driver.bcm.lammps_files import read_cells, resume_cells, write_cell_data, write_interfaces
from driver.bcm.tessellation import Cell, erode
from driver.moduli_protocol import phases, record_every, resume_phase, write_phase_files

SYSTEM_FRESH = f"""units           si
dimension       3
boundary        p p p
atom_style      bpm/sphere
atom_modify     map array
# newton bond off: both ranks holding an interface's cells evaluate it identically.
newton          on off
# bonded cells interact only through their interface (intact or broken), never as a pair.
special_bonds   lj 0 1 1 coul 1 1 1
{read_cells("system.data")}
# simple shear tilts the box
change_box      all triclinic"""
#: The undeformed block, written after `run 0` and read back before every phase.
START_RESTART = "start.restart"


# ------------------------------------------------------------------------- geometry
def particle_cell_size(model) -> float:
    """h = (V_particle / N_c)^(1/3): the mean cell size of the model's particle."""
    from driver.bcm.particle import parent_shape  # noqa: PLC0415

    shape = parent_shape(model.shape, model.diameter, model.diameter_kind)
    return float((shape.volume / model.n_cells) ** (1.0 / 3.0))


def block_of(model, block, seed: int, cache_dir: Path | None = None) -> BlockTessellation:
    """The (cached) periodic block of a config: ``block.n_cells`` cells of size h in a cube,
    Lloyd's tolerances of the model section; refused when LAMMPS cannot bond it."""
    h = block.cell_size if block.cell_size is not None else particle_cell_size(model)
    side = h * block.n_cells ** (1.0 / 3.0)
    tess = cached_periodic_cvt([side] * 3, block.n_cells, seed, tol=model.lloyd_tol, max_iter=model.lloyd_max_iter,
                               cache_dir=cache_dir)
    tess.require_minimum_image()
    return tess


def block_cell(tess: BlockTessellation, i: int) -> Cell:
    """Cell i of the block as a tessellation Cell (absolute coordinates), for erosion."""
    verts, faces = tess.cell_polyhedron(i)
    rows = np.arange(tess.cell_face_ptr[i], tess.cell_face_ptr[i + 1])
    return Cell(vertices=verts, faces=faces, normals=tess.face_normal[rows], offsets=tess.face_offset[rows],
                neighbors=tess.face_neighbor[rows], volume=float(tess.volume[i]), centroid=tess.centroid[i],
                inertia=tess.inertia[i], principal_moments=tess.principal_moments[i],
                principal_axes=tess.principal_axes[i], quaternion=tess.quaternion[i])


def notch_interfaces(tess: BlockTessellation, fraction: float) -> np.ndarray:
    """Interfaces (bool, m) of the notch: those whose two cells' centroids (the bonded images)
    lie on either side of a plane z = L/2 (mod L) and whose centroid has x (mod L) below
    ``fraction`` Lx."""
    i, j = tess.iface_cells.T
    L = tess.lengths
    z1 = tess.centroid[i, 2]
    z2 = tess.centroid[j, 2] + tess.iface_shift[:, 2] * L[2]
    crosses = np.floor((z1 - 0.5 * L[2]) / L[2]) != np.floor((z2 - 0.5 * L[2]) / L[2])
    return crosses & (np.mod(tess.iface_centroid[:, 0], L[0]) < fraction * L[0])


@dataclass
class BlockFacts:
    """What the inputs and the analysis need of a built block (SI units)."""

    n_cells: int
    n_interfaces: int
    n_notch: int
    side: float
    cell_size: float
    timestep: float
    crossing_time: float
    c0: float
    max_bound_radius: float
    r_m: float
    mass: float


def write_block(tess: BlockTessellation, model, root: Path, unbonded: np.ndarray | None = None,
                steps_per_period: float = 50.0) -> BlockFacts:
    """system.data, interfaces.txt and cells.txt of the block in ``root`` (interfaces flagged
    in ``unbonded`` left out), and its time scales."""
    from driver.bcm.particle import contact_timestep  # noqa: PLC0415
    from runfiles.cells import write_cells  # noqa: PLC0415

    n, h = tess.n_cells, tess.mean_cell_size
    r_m = model.rounding * h
    cores_v, cores_f, bound = [], [], np.empty(n)
    for i in range(n):
        cell = block_cell(tess, i)
        core = erode(cell, r_m) if r_m > 0 else cell
        cores_v.append((core.vertices - tess.centroid[i]) @ tess.principal_axes[i])  # R^T (v - c)
        cores_f.append(core.faces)
        # the whole cell holds its core and its interface polygons (the bond style checks it)
        bound[i] = np.linalg.norm(cell.vertices - tess.centroid[i], axis=1).max()
    bonded = np.ones(tess.n_interfaces, bool) if unbonded is None else ~unbonded
    masses = model.density * tess.volume
    write_cell_data(root / "system.data", tess.wrapped_centroid, tess.quaternion, masses,
                    model.density * tess.principal_moments, 2 * bound, tess.iface_cells[bonded],
                    box=(np.zeros(3), tess.lengths))
    keep = np.flatnonzero(bonded)
    write_interfaces(root / "interfaces.txt", tess.iface_cells[keep], tess.iface_area[keep],
                     tess.iface_normal[keep], [tess.interface_polygon(int(k)) for k in keep])
    write_cells(root / "cells.txt", cores_v, cores_f)
    k_max = max(model.contact.kn, model.contact.kt, model.interface.kn, model.interface.kt)
    if model.interface_stiffness == "per_area":
        areas = tess.iface_area[bonded]
        k_max = max(k_max, max(model.interface.kn, model.interface.kt) * areas.max() / areas.mean())
    dt, _ = contact_timestep(masses, k_max, steps_per_period)
    c0 = math.sqrt(model.interface.kn / (model.density * h))
    side = float(tess.lengths[0])
    return BlockFacts(n_cells=n, n_interfaces=int(bonded.sum()), n_notch=int((~bonded).sum()), side=side,
                      cell_size=h, timestep=dt, crossing_time=side / c0, c0=c0,
                      max_bound_radius=float(bound.max()), r_m=r_m, mass=float(masses.sum()))


# ---------------------------------------------------------------------------- inputs
#: G_c of the moduli test (J/m^2): the elastic constants do not depend on G_c, and with the
#: defaults an interface breaks near 0.05 % strain, ten times below the fit range.
UNBREAKABLE_GC = 1e30


def _styles(model, r_m: float, G_c: float | None = None) -> str:
    """Pair and bond styles of the model section; G_c overrides the interfaces' fracture energy."""
    return ("# Contacts between cells that share no interface (SPEC 1.2), frictional-contact parameters.\n"
            f"{styles.pair_setup(model, r_m)}\n"
            "# Griffith interfaces (SPEC 1.2 Eq. 1-7), one bond per shared face.\n"
            f"{styles.bond_setup(model, G_c)}")


def render_block(cfg, plugin_path: Path, facts: BlockFacts, every: int, phase: str, start: str,
                 system: str, styles: str, record_target: str, role: str) -> str:
    """One rendering of lammps_inputs/bcm_block.in."""
    import driver  # noqa: PLC0415
    from driver.templates import render  # noqa: PLC0415
    from runfiles.records import BCM_BLOCK_RECORD  # noqa: PLC0415

    skin = 0.1 * facts.cell_size
    # ghosts must hold every bonded partner: two bounding radii plus the skin
    comm_cutoff = 2.0 * facts.max_bound_radius * 1.05 + skin
    return render("bcm_block.in", role=role, package_version=driver.__version__, config_name=cfg.name,
                  plugin_path=plugin_path, system=system, comm_cutoff=f"{comm_cutoff:.9g}", styles=styles,
                  skin=f"{skin:.9g}", timestep=f"{facts.timestep:.12g}", thermo_every=every,
                  crossing_time=f"{facts.crossing_time:.6g}", record_print=BCM_BLOCK_RECORD.print_text(),
                  record_title=BCM_BLOCK_RECORD.title(), record_target=record_target, phase=phase, start=start)


def block_section(cfg):
    """The scenario's block section (filled in by the unit's check)."""
    return cfg.scenario.block


def _build(cfg, rd, unbonded_of=None) -> tuple[BlockTessellation, BlockFacts]:
    from driver.cache import cache_base  # noqa: PLC0415

    blk = block_section(cfg)
    tess = block_of(cfg.model, blk, cfg.seed, cache_base() / "blocks")
    unbonded = unbonded_of(tess) if unbonded_of is not None else None
    return tess, write_block(tess, cfg.model, rd.root, unbonded, blk.steps_per_period)


def moduli_rate(max_strain: float, crossings: float, crossing_time: float) -> float:
    """edot such that the volumetric strain 3 edot t reaches max_strain in `crossings` T."""
    return max_strain / (3.0 * crossings * crossing_time)


def run_moduli(cfg, rd, plugin_path: Path) -> tuple[dict, object]:
    """Build the block, write the phases, inputs and schedule of a moduli run."""
    from driver.schedule import chunk_steps, segments, write_session  # noqa: PLC0415
    from runfiles.atomic import atomic_write_json, atomic_write_text  # noqa: PLC0415

    sc, blk = cfg.scenario, block_section(cfg)
    tess, facts = _build(cfg, rd)
    rate = moduli_rate(sc.max_strain, blk.crossings, facts.crossing_time)
    plan = phases(3, rate, sc.max_strain, facts.timestep)
    every = record_every(sc.thermo_every, plan)
    write_phase_files(rd.root, plan, 3, facts.timestep)
    styles = _styles(cfg.model, facts.r_m, UNBREAKABLE_GC)
    common = dict(cfg=cfg, plugin_path=plugin_path, facts=facts, every=every)
    # the start's restart holds no fix deform: each phase defines its own after reading it back
    setup = render_block(**common, system=SYSTEM_FRESH, styles=styles,
                         phase="variable        phase equal -1\nvariable        strain equal 0",
                         start=f"run             0\nwrite_restart   {START_RESTART}\ninclude         phase_0.lammps",
                         record_target="file thermo.dat",
                         role="Fresh start from system.data (setup.lammps; in.lammps runs it whole).")
    resume = render_block(**common, system=resume_cells("${checkpoint}"),
                          styles="# styles, coefficients, interface table and reference state: from the checkpoint",
                          phase=resume_phase(plan), start="", record_target="append thermo.dat",
                          role="Start from a checkpoint (resume.lammps: -var checkpoint FILE).")
    # before each later phase: the undeformed block back (restart of the start), step counter on
    restore = render_block(**common, system=resume_cells(START_RESTART) + "\nreset_timestep  ${phase_start}",
                           styles="# styles, coefficients, interface table and reference state: from the restart",
                           phase="", start="", record_target="append thermo.dat",
                           role="The undeformed block again before a phase (restore.lammps: -var phase_start STEP).")
    atomic_write_text(rd.root / "restore.lammps", restore)
    resets = {p.start: ["clear", f"variable        phase_start equal {p.start}", "include         restore.lammps",
                        f"include         phase_{p.index}.lammps"] for p in plan[1:]}
    chunk = chunk_steps("bcm", facts.n_cells, cfg.execution.chunk_steps)
    schedule = segments(plan[-1].end, chunk, resets)
    system = _facts_dict(tess, facts) | {
        "strain_rate": rate, "crossings": blk.crossings, "G_c_used": UNBREAKABLE_GC, "total_steps": plan[-1].end,
        "chunk_steps": schedule["chunk"], "record_every": every, "phases": [p.__dict__ | {"end": p.end} for p in plan]}
    atomic_write_json(rd.root / "system.json", system)
    write_session(rd.root, setup, resume, schedule, cfg.execution.checkpoint_steps())
    return system, progress_spec(cfg, system)


def pull_steps(pull_strain: float, pull_rate: float, crossing_time: float, timestep: float) -> tuple[float, int]:
    """(engineering strain rate, steps) of the fracture pull: pull_rate strain per crossing time."""
    rate = pull_rate / crossing_time
    return rate, int(math.ceil(pull_strain / (rate * timestep)))


def run_fracture(cfg, rd, plugin_path: Path) -> tuple[dict, object]:
    """Build the notched block, write the inputs and schedule of a mode-I pull."""
    from driver.schedule import chunk_steps, segments, write_session  # noqa: PLC0415
    from runfiles.atomic import atomic_write_json  # noqa: PLC0415

    sc, blk = cfg.scenario, block_section(cfg)
    tess, facts = _build(cfg, rd, lambda t: notch_interfaces(t, blk.notch))
    rate, steps = pull_steps(blk.pull_strain, blk.pull_rate, facts.crossing_time, facts.timestep)
    every = max(1, min(sc.thermo_every, steps // 400))
    phase = (f"variable        phase equal 0\n"
             f"variable        strain equal {rate * facts.timestep:.12g}*step\n"
             f"# mode I: z pulled at engineering rate {rate:.6g} 1/s, x and y held (uniaxial strain)\n"
             f"fix             deform all deform 1 z erate {rate:.12g} remap x")
    common = dict(cfg=cfg, plugin_path=plugin_path, facts=facts, every=every, phase=phase)
    setup = render_block(**common, system=SYSTEM_FRESH, styles=_styles(cfg.model, facts.r_m),
                         start="run             0", record_target="file thermo.dat",
                         role="Fresh start from system.data (setup.lammps; in.lammps runs it whole).")
    resume = render_block(**common, system=resume_cells("${checkpoint}"),
                          styles="# styles, coefficients, interface table and reference state: from the checkpoint",
                          start="", record_target="append thermo.dat",
                          role="Start from a checkpoint (resume.lammps: -var checkpoint FILE).")
    chunk = chunk_steps("bcm", facts.n_cells, cfg.execution.chunk_steps)
    schedule = segments(steps, chunk, {})
    notch = notch_interfaces(tess, blk.notch)
    system = _facts_dict(tess, facts) | {
        "strain_rate": rate, "pull_rate": blk.pull_rate, "pull_strain": blk.pull_strain, "notch": blk.notch,
        "notch_area": float(tess.iface_area[notch].sum()), "total_steps": steps, "chunk_steps": schedule["chunk"],
        "record_every": every,
        # the crack plane's projected area, one side (the block's x-y section)
        "crack_plane_area": float(tess.lengths[0] * tess.lengths[1])}
    atomic_write_json(rd.root / "system.json", system)
    write_session(rd.root, setup, resume, schedule, cfg.execution.checkpoint_steps())
    return system, progress_spec(cfg, system)


def _facts_dict(tess: BlockTessellation, facts: BlockFacts) -> dict:
    return facts.__dict__ | {
        "lengths": [float(x) for x in tess.lengths], "A0": float(tess.iface_area.sum()),
        "mean_interface_area": float(tess.iface_area.mean()), "volume": float(tess.volume.sum()),
        "lloyd_iterations": int(tess.n_iter), "lloyd_residual": float(tess.residual),
        "lloyd_converged": bool(tess.converged), "tessellation_key": tess.key,
        "timestep_rule": "dt = 2 pi sqrt((m_min/2) / k_max) / steps_per_period, k_max the stiffest spring",
        "crossing_rule": "T = L / c_0, c_0 = sqrt(k_n / (rho_s h))"}


def progress_spec(cfg, system: dict):
    from driver.runner import ProgressSpec  # noqa: PLC0415
    from runfiles.records import BCM_BLOCK_RECORD  # noqa: PLC0415

    return ProgressSpec(file="thermo.dat", total_steps=system["total_steps"], label=cfg.name,
                        columns={"phase": BCM_BLOCK_RECORD.column("phase"),
                                 "strain": BCM_BLOCK_RECORD.column("strain")})
