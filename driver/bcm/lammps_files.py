"""Files that carry a BCM particle into LAMMPS: the data file, the interface geometry, the cells.

- data file (`atom_style bpm/sphere`, read by the commands of `read_cells`): one atom per cell
  at its centroid, with mass rmass, a bounding diameter (for neighbour lists only), one bond
  per interface, the section `BcmProps` (principal moments, angular momentum) read by
  `fix property/atom d2_bcm_inertia 3 d2_bcm_angmom 3` (plugins/src/bcm_rigid.h) and the
  section `BcmOrientations` (quaternion body -> space), which the plugin's `bcm_orient` puts
  into the atom style's quaternion (LAMMPS's data files have no column for it);
- interfaces file (read by `bond_style bcm/griffith geometry FILE`): per interface
  `tag1 tag2 area nx ny nz npts` and the polygon's vertices in space, reference state;
- cells file (runfiles/cells.py): each cell's rounded core; write_particle writes all three.
All writes are atomic (temporary file, then rename).
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from runfiles.atomic import atomic_write_text
from runfiles.cells import write_cells

#: The cells' per-atom arrays beside the atom style's (plugins/src/bcm_rigid.h); a restart file
#: brings their values back when this fix is defined again after read_restart.
CELL_PROPS = "fix             cellprops all property/atom d2_bcm_inertia 3 d2_bcm_angmom 3 ghost yes"
#: The orientations as a compute's per-atom values, for the cells' dumps (runfiles/records.py,
#: CELLS_DUMP): dump custom has no keyword for atom_style bpm/sphere's quaternion. After the box.
QUAT_COMPUTE = "compute         bcm_quat all property/atom quatw quati quatj quatk"


def resume_cells(restart: str) -> str:
    """LAMMPS commands reading a restart file of cells (after `plugin load`): what it does not
    hold, the per-atom arrays' fix (their values come back) and the dumps' orientation compute."""
    return "\n".join([f"read_restart    {restart}", CELL_PROPS, QUAT_COMPUTE])


def read_cells(data: str) -> str:
    """LAMMPS commands reading the data file `data` of write_cell_data (after `plugin load`, with
    the box settings before them). The orientation lives in atom_style bpm/sphere's quaternion,
    which LAMMPS sends to ghost cells with their positions and velocities
    (plugins/src/bcm_orientation.h)."""
    return f"""{CELL_PROPS}
fix             orient0 all property/atom d2_bcm_quat0 4
read_data       {data} fix cellprops NULL BcmProps fix orient0 NULL BcmOrientations
bcm_orient      d2_bcm_quat0
unfix           orient0
{QUAT_COMPUTE}"""


def _rows(arr: np.ndarray, fmt: str) -> str:
    buf = io.StringIO()
    np.savetxt(buf, arr, fmt=fmt)
    return buf.getvalue()


def write_cell_data(path: Path, centroids: np.ndarray, quats: np.ndarray, masses: np.ndarray,
                    moments: np.ndarray, bound_diameters: np.ndarray, bonds: np.ndarray,
                    margin: float = 0.0, box: tuple[np.ndarray, np.ndarray] | None = None,
                    grain: np.ndarray | None = None) -> Path:
    """LAMMPS data file of the cells (ids 1..n in array order; bonds are 0-based index pairs),
    read by the commands of read_cells().
    The box: `box` = (lo, hi) when given (a periodic block: centroids wrapped into it), else
    the centroids' bounds widened by `margin`. `grain`: each cell's grain id (1-based), written
    as its molecule id (1 for every cell of a single particle)."""
    n = len(centroids)
    if box is not None:
        lo, hi = (np.asarray(b, dtype=float) for b in box)
    else:
        lo = centroids.min(axis=0) - margin
        hi = centroids.max(axis=0) + margin
    # the atom style takes a density: choose it so that rmass is the cell's exact mass
    density = masses / (np.pi / 6.0 * bound_diameters ** 3)
    head = [
        "LAMMPS data file: BCM cells (brittle-driver)", "",
        f"{n} atoms", "1 atom types", f"{len(bonds)} bonds", "1 bond types", "",
        f"{lo[0]:.17g} {hi[0]:.17g} xlo xhi", f"{lo[1]:.17g} {hi[1]:.17g} ylo yhi",
        f"{lo[2]:.17g} {hi[2]:.17g} zlo zhi", "",
        "Atoms # bpm/sphere", "",
    ]
    ids = np.arange(1, n + 1)
    mol = np.ones(n) if grain is None else np.asarray(grain)
    atoms = np.column_stack([ids, mol, np.ones(n), bound_diameters, density, centroids])
    body = _rows(atoms, "%d %d %d %.17g %.17g %.17g %.17g %.17g")
    bond_rows = np.column_stack([np.arange(1, len(bonds) + 1), np.ones(len(bonds)), bonds + 1])
    props = np.column_stack([ids, moments, np.zeros((n, 3))])
    text = ("\n".join(head) + "\n" + body + "\nBonds\n\n" + _rows(bond_rows, "%d %d %d %d")
            + "\nBcmProps\n\n" + _rows(props, "%d" + " %.17g" * 6)
            + "\nBcmOrientations\n\n" + _rows(np.column_stack([ids, quats]), "%d" + " %.17g" * 4))
    return atomic_write_text(path, text)


def write_interfaces(path: Path, pairs: np.ndarray, areas: np.ndarray, normals: np.ndarray,
                     polygons: list[np.ndarray]) -> Path:
    """Interface geometry in the reference state (pairs 0-based, written as 1-based tags with
    tag1 < tag2 and the normal pointing from tag1 to tag2)."""
    lines = ["# tag1 tag2 area nx ny nz npts x1 y1 z1 ... (SI units, reference state)"]
    for (i, j), s, nrm, poly in zip(pairs, areas, normals, polygons):
        if i > j:
            i, j, nrm = j, i, -nrm
        pts = " ".join(f"{v:.17g}" for v in np.asarray(poly).ravel())
        lines.append(f"{i + 1} {j + 1} {s:.17g} {nrm[0]:.17g} {nrm[1]:.17g} {nrm[2]:.17g} {len(poly)} {pts}")
    return atomic_write_text(path, "\n".join(lines) + "\n")


def write_particle(root: Path, tess, particle, bonded: np.ndarray, margin: float) -> None:
    """system.data, interfaces.txt (the `bonded` faces glued) and cells.txt (the rounded cells'
    cores) of a placed particle (driver/bcm/particle.py) in `root`."""
    polygons = [p for p, keep in zip(particle.interface_polygons, bonded) if keep]
    write_cell_data(root / "system.data", particle.centroids, particle.quats, particle.masses, particle.moments,
                    2 * particle.bound_radius, tess.iface_cells[bonded], margin=margin)
    write_interfaces(root / "interfaces.txt", tess.iface_cells[bonded], tess.iface_area[bonded],
                     tess.iface_normal[bonded] @ particle.placement.rotation.T, polygons)
    write_cells(root / "cells.txt", particle.core_vertices, particle.core_faces)
