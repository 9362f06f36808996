"""The moduli protocol both models' calibration runs follow (BPM: driver/bpm/moduli.py; the BCM
block: driver/bcm/calibrate.py): the solid deformed in phases, each from the same undeformed
state, isotropic compression at a true strain rate (B from the pressure against the volumetric
strain), then simple shear of the triclinic box in each shear plane (2D: xy; 3D: xy, xz, yz; G
from the shear stress against the shear strain), then all of it again at half the rate: moduli
that depend on the rate are not elastic (inertia, damping) and are flagged.

Strain of a phase (the `strain` column of the record): compression, the volumetric strain
eps_v = d edot t (each axis at true rate -edot); shear, the engineering shear strain
gamma = edot t (tilt over the perpendicular box length).

Each phase is a file, phase_K.lammps (its number, its strain and its deformation), included
when the phase starts; how the undeformed state is brought back between phases is the model's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from runfiles.atomic import atomic_write_text

#: Shear planes of each dimension: (tilt, the two axes) -- fix deform's tilt keyword.
SHEAR_PLANES = {2: (("xy", 0, 1),), 3: (("xy", 0, 1), ("xz", 0, 2), ("yz", 1, 2))}
#: Fewest stress records in a phase (the record interval shrinks for fast tests).
MIN_RECORDS = 40


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


def phase_file(phase: Phase, dimension: int, timestep: float) -> str:
    """phase_K.lammps: the phase number, its strain and its deformation."""
    return (f"# phase {phase.index}: {phase.load} at rate {phase.rate:g}, steps {phase.start}..{phase.end}\n"
            f"variable        phase equal {phase.index}\n"
            f"variable        strain equal {strain_expression(phase, dimension, timestep)}\n"
            f"fix             deform all deform 1 {deform_args(phase, dimension)} remap x\n")


def write_phase_files(root: Path, plan: list[Phase], dimension: int, timestep: float) -> None:
    """phase_K.lammps of every phase of `plan` into the run directory `root`."""
    for p in plan:
        atomic_write_text(Path(root) / f"phase_{p.index}.lammps", phase_file(p, dimension, timestep))


def record_every(thermo_every: int, plan: list[Phase]) -> int:
    """Steps between records: the scenario's, or fewer so that the shortest phase has at least
    MIN_RECORDS records, whatever the rate."""
    return max(1, min(thermo_every, min(p.steps for p in plan) // MIN_RECORDS))


def resume_phase(plan: list[Phase]) -> str:
    """resume.lammps's choice of the phase file by the checkpoint's step (a checkpoint at a
    phase's first step already holds the reset state)."""
    # LAMMPS: if "c1" then "cmd1" elif "c2" "cmd2" ... (elif takes no `then`)
    cases = [f'"${{resume_step}} < {p.end}"' + (" then" if k == 0 else "") + f' "include phase_{p.index}.lammps"'
             for k, p in enumerate(plan)]
    return ("variable        resume_step equal step\n"
            "if " + " elif ".join(cases) + "\n")
