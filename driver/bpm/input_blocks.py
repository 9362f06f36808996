"""The blocks of LAMMPS input every BPM scenario's template is filled with (SPEC 2.1-2.2): the
system header of a fresh start and of a resumed one, the cr/repulsion pair coefficients, the
styles block, the communication cut-off, the template values every BPM input takes, and the
dumps (periodic ones, and one written at once). The scenarios (shear.py, moduli.py, mode1.py,
mode2.py, impact.py) add their own deformation, groups and records around them."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import driver
from runfiles.records import BONDS_DUMP, Record, atoms_dump

#: The header of a fresh start of a periodic or free BPM solid (format: dimension, boundary).
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
#: 2D runs keep every particle in the plane.
ENFORCE_2D = "fix             planar all enforce2d"


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


def styles(m, pair_lines: str) -> str:
    """Pair, bond and angle styles with the model section's coefficients, one bond and one angle
    type (SPEC 2.2; the mode-II test adds its unbreakable type 2 itself)."""
    return (f"pair_style      cr/repulsion\n{pair_lines}\n\n"
            f"bond_style      breakable/cr\nbond_coeff      1 {m.lambda_c} {m.gamma}\n"
            f"angle_style     breakable/cr\nangle_coeff     1 {m.k_A} {m.theta_c_deg} {m.lambda_c}")


def comm_cutoff(m, max_r0: float, max_abar: float) -> float:
    """Ghost cut-off: ghosts must reach both arms of every angle (two bonds stretched to their
    break, lambda_c r0 each) and every repulsion partner, plus the skin."""
    return max(2.0 * m.lambda_c * max_r0, max_abar) + m.skin


def common_values(cfg, plugin_path: Path | str, cutoff: float, thermo_every: int, record: Record,
                  **more: Any) -> dict[str, Any]:
    """The template values every BPM input takes (its version line, plugin, neighbour and time
    settings, the record it prints), with `more` of the scenario added (or replacing one, as the
    impact's own time step)."""
    m = cfg.model
    values = dict(package_version=driver.__version__, config_name=cfg.name, plugin_path=plugin_path,
                  comm_cutoff=f"{cutoff:.6g}", skin=m.skin, timestep=m.timestep, thermo_every=thermo_every,
                  enforce2d=ENFORCE_2D if m.dimension == 2 else "", record_print=record.print_text(),
                  record_title=record.title())
    values.update(more)
    return values


def periodic_dumps(dimension: int, every: int) -> str:
    """Atom and bond dumps every `every` steps into dumps/ (columns named as runfiles/records.py
    declares them)."""
    atoms = atoms_dump(dimension)
    return (f"dump            atoms all custom {every} dumps/atoms.*.lammpstrj {atoms.args()}\n"
            f"dump_modify     atoms sort id {atoms.modify()}\n"
            f"dump            bonds all local {every} dumps/bonds.*.lammpstrj {BONDS_DUMP.args()}\n"
            f"dump_modify     bonds {BONDS_DUMP.modify()}")


def write_dumps(atoms_file: str, bonds_file: str, dimension: int) -> str:
    """write_dump of the atoms and the bonds now, into the two files named (the columns of
    runfiles/records.py: OVITO maps them by name; 2D without z)."""
    atoms = atoms_dump(dimension)
    return (f"write_dump      all custom {atoms_file} {atoms.args()} modify sort id {atoms.modify()}\n"
            f"write_dump      all local {bonds_file} {BONDS_DUMP.args()} modify {BONDS_DUMP.modify()}")
