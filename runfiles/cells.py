"""The BCM cells file: each cell's core polyhedron in its body frame, read by `pair_style
bcm/contact` and `fix bcm/wall` (plugins/src/bcm_cells.cpp) and by the analysis (fragment
shapes, pictures). Written by the driver's builder, read by both."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from runfiles.atomic import atomic_write_text


def _rows(arr: np.ndarray, fmt: str) -> str:
    buf = io.StringIO()
    np.savetxt(buf, arr, fmt=fmt)
    return buf.getvalue()


def write_cells(path: Path, vertices: list[np.ndarray], faces: list[list[np.ndarray]]) -> Path:
    """Cell cores in their body frames for `pair_style bcm/contact` and `fix bcm/wall`
    (format of plugins/src/bcm_cells.cpp): `bcm/cells NCELLS`, then per cell `TAG NV NF`,
    NV lines `x y z`, NF lines `K i0 .. i(K-1)` (0-based, counter-clockwise from outside)."""
    out = [f"bcm/cells {len(vertices)}"]
    for tag, (verts, fcs) in enumerate(zip(vertices, faces), start=1):
        out.append(f"{tag} {len(verts)} {len(fcs)}")
        out.append(_rows(np.asarray(verts), "%.17g %.17g %.17g").rstrip("\n"))
        out.extend(f"{len(f)} " + " ".join(str(int(i)) for i in f) for f in fcs)
    return atomic_write_text(path, "\n".join(out) + "\n")


def read_cells(path: Path) -> tuple[list[np.ndarray], list[list[np.ndarray]]]:
    """Inverse of write_cells: (body-frame vertices per cell, faces per cell), in tag order."""
    tok = Path(path).read_text().split()
    if tok[0] != "bcm/cells":
        raise ValueError(f"{path}: not a cells file (starts with {tok[0]!r})")
    n, pos = int(tok[1]), 2
    verts, faces = [None] * n, [None] * n
    for _ in range(n):
        tag, nv, nf = int(tok[pos]), int(tok[pos + 1]), int(tok[pos + 2])
        pos += 3
        verts[tag - 1] = np.array(tok[pos:pos + 3 * nv], dtype=float).reshape(nv, 3)
        pos += 3 * nv
        fl = []
        for _ in range(nf):
            k = int(tok[pos])
            fl.append(np.array(tok[pos + 1:pos + 1 + k], dtype=int))
            pos += 1 + k
        faces[tag - 1] = fl
    return verts, faces
