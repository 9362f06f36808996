"""LAMMPS data file (atom_style angle) of a BPM packing and its bond network, and the
reference geometry of its bonds and angles.

Atoms lines are ``atom-ID molecule-ID atom-type x y z`` (molecule 0, ids 1-based in packing
order); Angles lines are ``id type atom1 atom2 atom3`` with atom2 the vertex, as LAMMPS's
angle styles expect. Coordinates are written with 17 significant digits.

Next to the data file, ``<stem>.refs`` holds what ``fix breakable/references`` reads (SPEC 2.2:
r0 of every bond; theta0 and the arm lengths r1_0, r2_0 of every angle), computed here from
the packing with the minimum-image convention, so that every MPI rank uses the same values
whatever periodic image it sees an atom through:

    bond  id1 id2 r0
    angle id1 id2 id3 theta0 r1_0 r2_0      (id2 = vertex, radians; r1_0 = r0 of bond 1-2)
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np
import pandas as pd

from driver.bpm.network import Network
from driver.bpm.packing import Packing
from runfiles.atomic import atomic_save


def write_data(path: str | os.PathLike, packing: Packing, network: Network,
               bond_type: int | np.ndarray = 1, angle_type: int | np.ndarray = 1) -> Path:
    """Write the data file atomically (runfiles/atomic.py).

    bond_type / angle_type: one type for all, or one per bond / angle (1-based).
    Also writes the reference file ``path.with_suffix(".refs")`` (see write_references).
    Returns the path of the data file.
    """
    path = Path(path)
    n = packing.n
    if network.n_atoms != n:
        raise ValueError(f"network has {network.n_atoms} atoms, packing {n}")
    btypes = _per_item(bond_type, network.n_bonds, "bond_type")
    atypes = _per_item(angle_type, network.n_angles, "angle_type")
    n_atom_types = int(packing.types.max())
    n_bond_types = int(btypes.max()) if len(btypes) else 1
    n_angle_types = int(atypes.max()) if len(atypes) else 1
    lo, hi = (np.asarray(b, dtype=np.float64) for b in packing.box)
    if packing.dimension == 2:
        lo, hi = lo.copy(), hi.copy()
        lo[2], hi[2] = -0.5, 0.5  # LAMMPS requires z to straddle 0 in 2D

    head = io.StringIO()
    head.write(f"LAMMPS data file: BPM packing, {packing.dimension}D, {n} atoms "
               f"(driver.bpm.datafile)\n\n")
    head.write(f"{n} atoms\n{network.n_bonds} bonds\n{network.n_angles} angles\n\n")
    head.write(f"{n_atom_types} atom types\n{n_bond_types} bond types\n"
               f"{n_angle_types} angle types\n\n")
    for k, ax in enumerate("xyz"):
        head.write(f"{lo[k]:.17g} {hi[k]:.17g} {ax}lo {ax}hi\n")
    head.write("\nMasses\n\n")
    head.write("".join(f"{t} 1.0\n" for t in range(1, n_atom_types + 1)))

    atoms = pd.DataFrame({
        "id": np.arange(1, n + 1),
        "mol": np.zeros(n, dtype=np.int64),
        "type": np.asarray(packing.types, dtype=np.int64),
        "x": packing.positions[:, 0], "y": packing.positions[:, 1], "z": packing.positions[:, 2],
    })
    bonds = pd.DataFrame({
        "id": np.arange(1, network.n_bonds + 1), "type": btypes,
        "a1": network.bonds[:, 0] + 1, "a2": network.bonds[:, 1] + 1,
    })
    angles = pd.DataFrame({
        "id": np.arange(1, network.n_angles + 1), "type": atypes,
        "a1": network.angles[:, 0] + 1, "a2": network.angles[:, 1] + 1,  # a2 = vertex
        "a3": network.angles[:, 2] + 1,
    })

    def write(tmp: Path) -> None:
        with open(tmp, "w", newline="\n") as fh:
            fh.write(head.getvalue())
            fh.write("\nAtoms # angle\n\n")
            atoms.to_csv(fh, sep=" ", header=False, index=False, float_format="%.17g")
            if network.n_bonds:
                fh.write("\nBonds\n\n")
                bonds.to_csv(fh, sep=" ", header=False, index=False)
            if network.n_angles:
                fh.write("\nAngles\n\n")
                angles.to_csv(fh, sep=" ", header=False, index=False)

    atomic_save(path, write)
    lengths = np.full(3, np.inf)
    lengths[:packing.dimension] = np.asarray(packing.lengths, dtype=np.float64)[:packing.dimension]
    write_references(path.with_suffix(".refs"), packing.positions, network.bonds, network.angles,
                     lengths)
    return path


def references(positions: np.ndarray, bonds: np.ndarray, angles: np.ndarray,
               lengths: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Reference geometry of a bond network (SPEC 2.2), with the minimum-image convention.

    positions: (N, 3); bonds: (Nb, 2) and angles: (Na, 3) 0-based, angle rows (i, vertex, k);
    lengths: periodic box edges (3,), inf (or None) along a non-periodic axis.
    Returns r0 (Nb,) and an (Na, 3) array of theta0 (radians, from atan2 of |u x w| and
    u . w, accurate near 0 and pi), r1_0 = |u|, r2_0 = |w| with u = x_i - x_vertex,
    w = x_k - x_vertex. An arm's length is the r0 of its bond to the last bit (a separation
    and its negative have the same norm), so that an angle's S(l) of Eq. 4 and its bond's
    break test of Eq. 2 use one reference.
    """
    x = np.asarray(positions, dtype=np.float64)
    bonds = np.asarray(bonds, dtype=np.int64).reshape(-1, 2)
    angles = np.asarray(angles, dtype=np.int64).reshape(-1, 3)
    L = np.full(3, np.inf) if lengths is None else np.asarray(lengths, dtype=np.float64)

    def separation(i: np.ndarray, j: np.ndarray) -> np.ndarray:
        d = x[i] - x[j]
        periodic = np.isfinite(L)
        d[:, periodic] -= L[periodic] * np.round(d[:, periodic] / L[periodic])
        return d

    r0 = np.linalg.norm(separation(bonds[:, 0], bonds[:, 1]), axis=1)
    u = separation(angles[:, 0], angles[:, 1])
    w = separation(angles[:, 2], angles[:, 1])
    theta0 = np.arctan2(np.linalg.norm(np.cross(u, w), axis=1), np.einsum("ij,ij->i", u, w))
    return r0, np.stack([theta0, np.linalg.norm(u, axis=1), np.linalg.norm(w, axis=1)], axis=1)


def write_references(path: str | os.PathLike, positions: np.ndarray, bonds: np.ndarray,
                     angles: np.ndarray, lengths: np.ndarray | None = None) -> Path:
    """Write the file of fix breakable/references (module docstring; atom IDs 1-based,
    17 significant digits), atomically. Arguments as for references()."""
    path = Path(path)
    r0, ang = references(positions, bonds, angles, lengths)
    bonds = np.asarray(bonds, dtype=np.int64).reshape(-1, 2) + 1
    angles = np.asarray(angles, dtype=np.int64).reshape(-1, 3) + 1
    out = io.StringIO()
    out.write("# reference geometry (SPEC 2.2) for fix breakable/references (driver.bpm.datafile)\n"
              "# bond id1 id2 r0 | angle id1 id2(vertex) id3 theta0(rad) r1_0 r2_0\n")
    out.writelines(f"bond {a} {b} {r!r}\n" for (a, b), r in zip(bonds.tolist(), r0.tolist()))
    out.writelines(f"angle {a} {v} {b} {t!r} {r1!r} {r2!r}\n"
                   for (a, v, b), (t, r1, r2) in zip(angles.tolist(), ang.tolist()))
    atomic_save(path, lambda p: Path(p).write_text(out.getvalue()))
    return path


def _per_item(value: int | np.ndarray, count: int, name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=np.int64)
    if arr.ndim == 0:
        arr = np.full(count, int(arr), dtype=np.int64)
    if arr.shape != (count,):
        raise ValueError(f"{name} must be an int or have shape ({count},), got {arr.shape}")
    if count and arr.min() < 1:
        raise ValueError(f"{name} must be >= 1")
    return arr
