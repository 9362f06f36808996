"""LAMMPS data file (atom_style angle) of a BPM packing and its bond network.

Atoms lines are ``atom-ID molecule-ID atom-type x y z`` (molecule 0, ids 1-based in packing
order); Angles lines are ``id type atom1 atom2 atom3`` with atom2 the vertex, as LAMMPS's
angle styles expect. Coordinates are written with 17 significant digits so that LAMMPS
recomputes exactly the r0 and theta0 of the network.
"""

from __future__ import annotations

import io
import os
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from driver.bpm.network import Network
from driver.bpm.packing import Packing


def write_data(path: str | os.PathLike, packing: Packing, network: Network,
               bond_type: int | np.ndarray = 1, angle_type: int | np.ndarray = 1) -> Path:
    """Write the data file atomically (temporary file in the same folder, then os.replace).

    bond_type / angle_type: one type for all, or one per bond / angle (1-based).
    Returns the path written.
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

    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.chmod(tmp, 0o644)  # mkstemp makes it private; a data file is an ordinary output
        with os.fdopen(fd, "w", newline="\n") as fh:
            fh.write(head.getvalue())
            fh.write("\nAtoms # angle\n\n")
            atoms.to_csv(fh, sep=" ", header=False, index=False, float_format="%.17g")
            if network.n_bonds:
                fh.write("\nBonds\n\n")
                bonds.to_csv(fh, sep=" ", header=False, index=False)
            if network.n_angles:
                fh.write("\nAngles\n\n")
                angles.to_csv(fh, sep=" ", header=False, index=False)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
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
