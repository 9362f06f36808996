"""BPM elastic calibration (SPEC 2.3): the bulk and shear moduli of a bonded network, measured
by deforming it at a constant rate, and their affine (Born) estimates.

One run deforms the solid in the phases of the moduli protocol (driver/moduli_protocol.py:
compression, then simple shear in each plane, then all again at half the rate), each from the
same undeformed state: positions and box read back from an exact dump of the start, velocities
zero. Stresses are LAMMPS's pressure tensor (virial plus kinetic): P = tr(p) / d, shear stress
tau_ij = -p_ij.
"""

from __future__ import annotations

import numpy as np

from driver.bpm.input_blocks import SYSTEM_FRESH, SYSTEM_RESUME, comm_cutoff, common_values, pair_coeff_lines, styles
from driver.bpm.solid import build_system, packing_and_network
from driver.moduli_protocol import SHEAR_PLANES, Phase, phases, record_every, resume_phase, write_phase_files
from driver.runner import ProgressSpec
from driver.schedule import chunk_steps, segments, write_session
from driver.templates import render
from runfiles.atomic import atomic_write_json
from runfiles.records import MODULI_RECORD

#: Bond stiffness of SPEC 2.2 Eq. 2 at r = r0: C1 = 36 2^(2/3) u / a^2, the same on both
#: branches (the repulsive branch's second derivative at r0 is 6 K / r0^2 = C1).
BOND_STIFFNESS = 36.0 * 2.0 ** (2.0 / 3.0)


# ------------------------------------------------------------------ affine (Born) estimates
def _min_image(d: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    return d - lengths * np.round(d / lengths)


def _angles_of(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    cross = np.cross(u, v)
    s = np.linalg.norm(cross, axis=-1) if cross.ndim > 1 else np.abs(cross)
    return np.arctan2(s, np.einsum("ij,ij->i", u, v))


def affine_moduli(positions: np.ndarray, lengths: np.ndarray, bonds: np.ndarray, angles: np.ndarray,
                  dimension: int, k_A: float, k_bond: float = BOND_STIFFNESS) -> dict[str, float]:
    """B and G of the network if every bond and angle followed the affine deformation (Born):
    the second derivative of the bonded energy per unit volume along the strain, with the
    stiffnesses at rest, k_bond for a bond's length (SPEC Eq. 2) and k_A for an angle (Eq. 3,
    S = 1). Non-affine relaxation can only lower the true moduli. The non-bonded repulsion is
    left out (bonded neighbours do not repel; other pairs barely touch in the packing).

    Derivatives of bond lengths and angles along each strain by central differences of the
    deformed geometry (exact to ~1e-8 relative). G in 3D is the mean over the three shear
    planes; `G_planes` gives each."""
    d = dimension
    lengths = np.asarray(lengths, dtype=float)[:d]
    pos = np.asarray(positions, dtype=float)[:, :d]
    vol = float(np.prod(lengths))
    bvec = _min_image(pos[bonds[:, 1]] - pos[bonds[:, 0]], lengths)
    u = _min_image(pos[angles[:, 0]] - pos[angles[:, 1]], lengths)
    v = _min_image(pos[angles[:, 2]] - pos[angles[:, 1]], lengths)

    def pad(x: np.ndarray) -> np.ndarray:  # angles from 3-vectors in 2D too
        return np.concatenate([x, np.zeros((len(x), 3 - d))], axis=1) if d == 2 else x

    def energy_density_curvature(F: np.ndarray, h: float = 1e-6) -> float:
        """d^2 (E / V) / d eps^2 at eps = 0 for the deformation gradient I + eps F."""
        derivs = []
        for eps in (h, -h):
            M = np.eye(d) + eps * F
            derivs.append((np.linalg.norm(bvec @ M.T, axis=1), _angles_of(pad(u @ M.T), pad(v @ M.T))))
        dr = (derivs[0][0] - derivs[1][0]) / (2 * h)
        dth = (derivs[0][1] - derivs[1][1]) / (2 * h)
        return float((k_bond * np.sum(dr ** 2) + k_A * np.sum(dth ** 2)) / vol)

    # isotropic compression: eps_v = -tr(strain); each axis strained by -eps_v / d
    bulk = energy_density_curvature(-np.eye(d) / d)
    planes = {}
    for tilt, i, j in SHEAR_PLANES[d]:
        F = np.zeros((d, d))
        F[i, j] = 1.0  # x_i += gamma x_j: the tilt of LAMMPS's triclinic box
        planes[tilt] = energy_density_curvature(F)
    return {"B_affine": bulk, "G_affine": float(np.mean(list(planes.values()))), "G_planes": planes}


# ---------------------------------------------------------------------------- the run
RESET_DUMP = "calibration_start.lammpstrj"  # the undeformed state, exact (%.17g)


def reset_commands(phase: Phase, dimension: int) -> list[str]:
    """Between phases: the undeformed box and positions back (read from the exact dump of the
    start; the step counter goes on), image flags and velocities zero, then the next phase's
    deformation."""
    return ["unfix           deform",
            f"read_dump       {RESET_DUMP} 0 {' '.join('xyz'[:dimension])} box yes replace yes",
            f"reset_timestep  {phase.start}",  # read_dump set it to the dump's step, 0
            "set             group all image 0 0 0",
            "velocity        all set 0.0 0.0 0.0",
            f"include         phase_{phase.index}.lammps"]


def run_moduli(cfg, rd, plugin_path) -> tuple[dict, ProgressSpec]:
    """Build the solid, write the inputs, phases and schedule; returns (system facts, progress)."""
    m, sc = cfg.model, cfg.scenario
    system = build_system(cfg, rd)
    packing, net = packing_and_network(cfg)
    lengths = np.asarray(packing.box[1]) - np.asarray(packing.box[0])
    system.update(affine_moduli(packing.positions, lengths, net.bonds, net.angles, m.dimension, m.k_A))
    plan = phases(m.dimension, sc.strain_rate, sc.max_strain, m.timestep)
    every = record_every(sc.thermo_every, plan)
    write_phase_files(rd.root, plan, m.dimension, m.timestep)
    types = {int(k): v for k, v in system["type_diameters"].items()}
    pair_lines, max_abar = pair_coeff_lines(types, m.gamma)
    common = common_values(cfg, plugin_path, comm_cutoff(m, system["max_r0"], max_abar), every, MODULI_RECORD)
    setup = render("bpm_moduli.in", role="Fresh start from system.data (setup.lammps; in.lammps runs it whole).",
                   system=(SYSTEM_FRESH.format(dimension=m.dimension, boundary="p p p")
                           + "\nchange_box      all triclinic"),
                   styles=styles(m, pair_lines), phase="include         phase_0.lammps",
                   record_target="file thermo.dat",
                   start=(f"run             0\nwrite_dump      all custom {RESET_DUMP} id "
                          f"{' '.join('xyz'[:m.dimension])} modify sort id format float %.17g"), **common)
    resume = render("bpm_moduli.in", role="Start from a checkpoint (resume.lammps: -var checkpoint FILE).",
                    system=SYSTEM_RESUME, styles="# styles and coefficients: from the checkpoint",
                    phase=resume_phase(plan), record_target="append thermo.dat", start="", **common)
    chunk = chunk_steps("bpm", system["n_particles"], cfg.execution.chunk_steps)
    schedule = segments(plan[-1].end, chunk, {p.start: reset_commands(p, m.dimension) for p in plan[1:]})
    system.update(total_steps=plan[-1].end, chunk_steps=schedule["chunk"], record_every=every,
                  phases=[p.__dict__ | {"end": p.end} for p in plan])
    atomic_write_json(rd.root / "system.json", system)
    write_session(rd.root, setup, resume, schedule, cfg.execution.checkpoint_steps())
    return system, progress_spec(cfg, system)


def progress_spec(cfg, system: dict) -> ProgressSpec:
    """The progress fields of a moduli run: the phase and its strain."""
    return ProgressSpec(file="thermo.dat", total_steps=system["total_steps"], label=cfg.name,
                        columns={"phase": MODULI_RECORD.column("phase"), "strain": MODULI_RECORD.column("strain")})
