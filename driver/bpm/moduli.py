"""BPM elastic calibration (SPEC 2.3): the bulk and shear moduli of a bonded network, measured
by deforming it at a constant rate, and their affine (Born) estimates.

One run deforms the solid in phases, each from the same undeformed state (positions and box
read back from an exact dump of the start, velocities zero): isotropic compression at a true
strain rate (B from the pressure against the volumetric strain), then simple shear of the
triclinic box in each shear plane (2D: xy; 3D: xy, xz, yz; G from the shear stress against the
shear strain), then all of it again at half the rate: moduli that depend on the rate are not
elastic (inertia, damping) and are flagged.

Strain of a phase (the `strain` column of the record): compression, the volumetric strain
eps_v = d edot t (each axis at true rate -edot); shear, the engineering shear strain
gamma = edot t (tilt over the perpendicular box length). Stresses are LAMMPS's pressure
tensor (virial plus kinetic): P = tr(p) / d, shear stress tau_ij = -p_ij.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Bond stiffness of SPEC 2.2 Eq. 2 at r = r0: C1 = 36 2^(2/3) u / a^2, the same on both
#: branches (the repulsive branch's second derivative at r0 is 6 K / r0^2 = C1).
BOND_STIFFNESS = 36.0 * 2.0 ** (2.0 / 3.0)
#: Shear planes of each dimension: (tilt, the two axes) -- fix deform's tilt keyword.
SHEAR_PLANES = {2: (("xy", 0, 1),), 3: (("xy", 0, 1), ("xz", 0, 2), ("yz", 1, 2))}


@dataclass(frozen=True)
class Phase:
    """One deformation of the undeformed solid: `load` compression or a shear tilt, at `rate`,
    `steps` long, starting at `start`."""

    index: int
    load: str          # "compression" or the tilt "xy", "xz", "yz"
    rate: float
    start: int
    steps: int

    @property
    def end(self) -> int:
        return self.start + self.steps


def phases(dimension: int, rate: float, max_strain: float, timestep: float) -> list[Phase]:
    """Compression and each shear plane at `rate`, then all of them at rate / 2, each up to
    `max_strain` (volumetric strain for compression, shear strain for shear)."""
    out, start = [], 0
    for r in (rate, rate / 2):
        for load in ("compression", *(t for t, _, _ in SHEAR_PLANES[dimension])):
            per_step = (dimension if load == "compression" else 1.0) * r * timestep
            steps = int(math.ceil(max_strain / per_step))
            out.append(Phase(len(out), load, r, start, steps))
            start += steps
    return out


def deform_args(phase: Phase, dimension: int) -> str:
    """fix deform arguments of a phase: every axis at true rate -edot, or a tilt at
    engineering rate edot (remap x: the atoms follow affinely)."""
    if phase.load == "compression":
        return " ".join(f"{a} trate {-phase.rate:.12g}" for a in "xyz"[:dimension])
    return f"{phase.load} erate {phase.rate:.12g}"


def strain_expression(phase: Phase, dimension: int, timestep: float) -> str:
    """LAMMPS equal-style formula of the phase's strain (see the module docstring)."""
    factor = dimension if phase.load == "compression" else 1
    return f"{factor * phase.rate * timestep:.12g}*(step-{phase.start})"


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
#: Fewest stress records in a phase (the record interval shrinks for fast tests).
MIN_RECORDS = 40


def phase_file(phase: Phase, dimension: int, timestep: float) -> str:
    """phase_K.lammps: the phase number, its strain and its deformation."""
    return (f"# phase {phase.index}: {phase.load} at rate {phase.rate:g}, steps {phase.start}..{phase.end}\n"
            f"variable        phase equal {phase.index}\n"
            f"variable        strain equal {strain_expression(phase, dimension, timestep)}\n"
            f"fix             deform all deform 1 {deform_args(phase, dimension)} remap x\n")


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


def resume_phase(plan: list[Phase]) -> str:
    """resume.lammps's choice of the phase file by the checkpoint's step (a checkpoint at a
    phase's first step already holds the reset state)."""
    # LAMMPS: if "c1" then "cmd1" elif "c2" "cmd2" ... (elif takes no `then`)
    cases = [f'"${{resume_step}} < {p.end}"' + (" then" if k == 0 else "") + f' "include phase_{p.index}.lammps"'
             for k, p in enumerate(plan)]
    return ("variable        resume_step equal step\n"
            "if " + " elif ".join(cases) + "\n")


def run_moduli(cfg, rd, plugin_path) -> tuple[dict, object]:
    """Build the solid, write the inputs, phases and schedule; returns (system facts, progress)."""
    import driver  # noqa: PLC0415
    from driver.bpm.shear import (SYSTEM_FRESH, SYSTEM_RESUME, build_system, packing_and_network,  # noqa: PLC0415
                                  pair_coeff_lines)
    from driver.schedule import chunk_steps, segments, write_session  # noqa: PLC0415
    from driver.templates import render  # noqa: PLC0415
    from runfiles.atomic import atomic_write_json, atomic_write_text  # noqa: PLC0415
    from runfiles.records import MODULI_RECORD  # noqa: PLC0415

    m, sc = cfg.model, cfg.scenario
    system = build_system(cfg, rd)
    packing, net = packing_and_network(cfg)
    lengths = np.asarray(packing.box[1]) - np.asarray(packing.box[0])
    system.update(affine_moduli(packing.positions, lengths, net.bonds, net.angles, m.dimension, m.k_A))
    plan = phases(m.dimension, sc.strain_rate, sc.max_strain, m.timestep)
    # at least MIN_RECORDS records in the shortest phase, whatever the rate
    every = max(1, min(sc.thermo_every, min(p.steps for p in plan) // MIN_RECORDS))
    for p in plan:
        atomic_write_text(rd.root / f"phase_{p.index}.lammps", phase_file(p, m.dimension, m.timestep))
    types = {int(k): v for k, v in system["type_diameters"].items()}
    pair_lines, max_abar = pair_coeff_lines(types, m.gamma)
    comm_cutoff = max(2.0 * m.lambda_c * system["max_r0"], max_abar) + m.skin
    common = dict(
        package_version=driver.__version__, config_name=cfg.name, plugin_path=plugin_path,
        comm_cutoff=f"{comm_cutoff:.6g}", skin=m.skin, timestep=m.timestep, thermo_every=every,
        enforce2d="fix             planar all enforce2d" if m.dimension == 2 else "",
        record_print=MODULI_RECORD.print_text(), record_title=MODULI_RECORD.title())
    styles = (f"pair_style      cr/repulsion\n{pair_lines}\n\n"
              f"bond_style      breakable/cr\nbond_coeff      1 {m.lambda_c} {m.gamma}\n"
              f"angle_style     breakable/cr\nangle_coeff     1 {m.k_A} {m.theta_c_deg} {m.lambda_c}")
    setup = render("bpm_moduli.in", role="Fresh start from system.data (setup.lammps; in.lammps runs it whole).",
                   system=(SYSTEM_FRESH.format(dimension=m.dimension, boundary="p p p")
                           + "\nchange_box      all triclinic"),
                   styles=styles, phase="include         phase_0.lammps", record_target="file thermo.dat",
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


def progress_spec(cfg, system: dict):
    from driver.runner import ProgressSpec  # noqa: PLC0415
    from runfiles.records import MODULI_RECORD  # noqa: PLC0415

    return ProgressSpec(file="thermo.dat", total_steps=system["total_steps"], label=cfg.name,
                        columns={"phase": MODULI_RECORD.column("phase"), "strain": MODULI_RECORD.column("strain")})
