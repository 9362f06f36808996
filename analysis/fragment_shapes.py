"""Fragment shapes (SPEC 1.5): the box a >= b >= c of a set of vertices, and a fragment table.

Definitions (SPEC 1.5), for the vertices P of a fragment's cells, in space:
- a = largest distance between two vertices; its unit direction u.
- b = largest extent perpendicular to a: the largest distance between two vertices after
  projection onto the plane normal to u (= the largest width of P along any direction
  perpendicular to u); its unit direction v (perpendicular to u).
- c = extent of P along w = u x v, the unit normal of the plane of a and b:
  c = max(P . w) - min(P . w).
- elongation b/a, flatness c/b, shape factor S_f = (1/a + 1/b + 1/c) sqrt(a^2 + b^2 + c^2) / sqrt(3)
  (S_f = 3 when a = b = c, larger for elongated or flat shapes).

The extreme distances are attained at convex-hull vertices, so they are searched exactly
among the hull's vertices (Qhull), O(h^2) in chunks: exact and fast up to several thousand
hull points. Vertices must be unwrapped: a fragment straddling a periodic boundary has to be
made whole first.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.spatial import ConvexHull, QhullError

from analysis.rotations import quat_to_matrix

_CHUNK_PAIRS = 4_000_000  # distances evaluated per block in the O(h^2) search


@dataclass(frozen=True)
class BoxShape:
    """a >= b >= c of a vertex set and their unit directions (rows of axes: u, v, w)."""

    a: float
    b: float
    c: float
    axes: np.ndarray  # (3, 3)

    @property
    def elongation(self) -> float:
        return self.b / self.a if self.a > 0 else float("nan")

    @property
    def flatness(self) -> float:
        return self.c / self.b if self.b > 0 else float("nan")

    @property
    def shape_factor(self) -> float:
        return float(shape_factor(self.a, self.b, self.c))


def shape_factor(a, b, c):
    """S_f = (1/a + 1/b + 1/c) sqrt(a^2 + b^2 + c^2) / sqrt(3) (SPEC 1.5); inf if c = 0."""
    a, b, c = (np.asarray(v, dtype=float) for v in (a, b, c))
    with np.errstate(divide="ignore", invalid="ignore"):
        return (1 / a + 1 / b + 1 / c) * np.sqrt(a * a + b * b + c * c) / np.sqrt(3.0)


def box_dimensions(vertices: np.ndarray) -> BoxShape:
    """a, b, c (SPEC 1.5) of a set of points in 3D, shape (n, 3)."""
    p = np.asarray(vertices, dtype=float).reshape(-1, 3)
    if len(p) == 0:
        raise ValueError("no vertices")
    h = _hull_points(p, 3)
    i, j, a = _farthest_pair(h)
    if a == 0.0:
        return BoxShape(0.0, 0.0, 0.0, np.eye(3))
    u = (h[j] - h[i]) / a
    # Orthonormal basis (e1, e2) of the plane normal to u; project into it.
    e1 = np.cross(u, np.eye(3)[np.argmin(np.abs(u))])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    q = h @ np.column_stack([e1, e2])
    q2 = _hull_points(q, 2)
    k, l, b = _farthest_pair(q2)
    if b == 0.0:
        return BoxShape(a, 0.0, 0.0, np.vstack([u, e1, e2]))
    d = (q2[l] - q2[k]) / b
    v = d[0] * e1 + d[1] * e2
    w = np.cross(u, v)
    w /= np.linalg.norm(w)
    s = h @ w
    return BoxShape(float(a), float(b), float(s.max() - s.min()), np.vstack([u, v, w]))


def _hull_points(p: np.ndarray, dim: int) -> np.ndarray:
    """The convex-hull vertices of p (all unique points if the set is degenerate)."""
    p = np.unique(p, axis=0)
    if len(p) <= dim + 1:
        return p
    try:
        return p[ConvexHull(p).vertices]
    except QhullError:
        return p  # flat or collinear: few points in practice, searched exhaustively


def _farthest_pair(p: np.ndarray) -> tuple[int, int, float]:
    """(i, j, distance) of the two points of p farthest apart, exact, in O(n^2) blocks.

    Squared distances by |x|^2 + |y|^2 - 2 x.y (one matrix product per block) on centred
    points; the winning pair's distance is then recomputed directly.
    """
    n = len(p)
    if n < 2:
        return 0, 0, 0.0
    p = p - p.mean(axis=0)
    sq = np.einsum("ij,ij->i", p, p)
    best, bi, bj = -np.inf, 0, 0
    rows = max(1, _CHUNK_PAIRS // n)
    for s in range(0, n, rows):
        d2 = sq[s:s + rows, None] + sq[None, :] - 2.0 * (p[s:s + rows] @ p.T)
        r, c = divmod(int(np.argmax(d2)), n)
        if d2[r, c] > best:
            best, bi, bj = float(d2[r, c]), s + r, c
    return bi, bj, float(np.linalg.norm(p[bj] - p[bi]))


# ---------------------------------------------------------------------------------------
# Fragments

def fragment_table(labels: np.ndarray, masses: np.ndarray, volumes: np.ndarray, cell_vertices) -> pd.DataFrame:
    """One row per fragment: fragment, n_cells, mass, volume, a, b, c, elongation (b/a),
    flatness (c/b), shape_factor (S_f), single_cell.

    labels: (n_cells,) fragment label per cell (0..n_fragments-1, e.g. from
    analysis.grains); masses, volumes: (n_cells,); cell_vertices: the cells' vertices in
    space, either a list of (k_i, 3) arrays or a pair (vertices (V, 3), offsets
    (n_cells + 1,)) where cell i owns vertices[offsets[i]:offsets[i+1]].
    Shapes are computed for every fragment, single cells included; `single_cell` marks the
    rows that SPEC 1.5's shape averages leave out (see shape_averages).
    """
    labels = np.asarray(labels, dtype=np.int64)
    n_cells = len(labels)
    masses, volumes = np.asarray(masses, dtype=float), np.asarray(volumes, dtype=float)
    if masses.shape != (n_cells,) or volumes.shape != (n_cells,):
        raise ValueError("labels, masses and volumes must have one entry per cell")
    verts, offsets = _as_csr(cell_vertices, n_cells)
    n_frag = int(labels.max()) + 1 if n_cells else 0
    # Vertices grouped by fragment in one sort, then one box per fragment.
    vert_frag = np.repeat(labels, np.diff(offsets))
    order = np.argsort(vert_frag, kind="stable")
    bounds = np.concatenate([[0], np.cumsum(np.bincount(vert_frag, minlength=n_frag))])
    grouped = verts[order]
    shapes = []
    for f in range(n_frag):
        pts = grouped[bounds[f]:bounds[f + 1]]
        shapes.append(box_dimensions(pts) if len(pts) else BoxShape(np.nan, np.nan, np.nan, np.full((3, 3), np.nan)))
    a = np.array([s.a for s in shapes])
    b = np.array([s.b for s in shapes])
    c = np.array([s.c for s in shapes])
    count = np.bincount(labels, minlength=n_frag)
    with np.errstate(divide="ignore", invalid="ignore"):
        df = pd.DataFrame({"fragment": np.arange(n_frag), "n_cells": count,
                           "mass": np.bincount(labels, weights=masses, minlength=n_frag),
                           "volume": np.bincount(labels, weights=volumes, minlength=n_frag),
                           "a": a, "b": b, "c": c, "elongation": b / a, "flatness": c / b,
                           "shape_factor": shape_factor(a, b, c), "single_cell": count == 1})
    return df


def shape_averages(table: pd.DataFrame, include_single_cells: bool = False) -> dict[str, float]:
    """Mean and standard deviation of elongation, flatness and S_f over fragments
    (SPEC 1.5: single-cell fragments left out unless include_single_cells)."""
    t = table if include_single_cells else table[~table["single_cell"]]
    out: dict[str, float] = {"n_fragments": int(len(t))}
    for col in ("elongation", "flatness", "shape_factor"):
        vals = t[col].to_numpy(dtype=float)
        out[f"{col}_mean"] = float(np.mean(vals)) if len(vals) else float("nan")
        out[f"{col}_std"] = float(np.std(vals, ddof=1)) if len(vals) > 1 else float("nan")
    return out


def _as_csr(cell_vertices, n_cells: int) -> tuple[np.ndarray, np.ndarray]:
    if (isinstance(cell_vertices, tuple) and len(cell_vertices) == 2
            and np.asarray(cell_vertices[1]).ndim == 1 and np.asarray(cell_vertices[0]).ndim == 2):
        verts = np.asarray(cell_vertices[0], dtype=float)
        offsets = np.asarray(cell_vertices[1], dtype=np.int64)
    else:
        arrays = [np.asarray(v, dtype=float).reshape(-1, 3) for v in cell_vertices]
        offsets = np.concatenate([[0], np.cumsum([len(v) for v in arrays])]).astype(np.int64)
        verts = np.concatenate(arrays) if arrays else np.empty((0, 3))
    if len(offsets) != n_cells + 1 or offsets[0] != 0 or offsets[-1] != len(verts) or np.any(np.diff(offsets) < 0):
        raise ValueError(f"cell vertices do not match {n_cells} cells")
    return verts, offsets


def vertices_in_space(body_vertices: np.ndarray, offsets: np.ndarray, positions: np.ndarray,
                      quaternions: np.ndarray) -> np.ndarray:
    """Space positions x = r_i + R(q_i) x_body of every cell's body-frame vertices.

    body_vertices (V, 3) with cell i owning rows offsets[i]:offsets[i+1]; positions (n, 3);
    quaternions (n, 4) as (w, x, y, z), body-to-space like LAMMPS's atom->quat
    (MathExtra::quat_to_mat); normalised here.
    """
    q = np.asarray(quaternions, dtype=float)
    rot = quat_to_matrix(q / np.linalg.norm(q, axis=1, keepdims=True))  # (n, 3, 3)
    cell = np.repeat(np.arange(len(rot)), np.diff(np.asarray(offsets)))
    return np.asarray(positions, dtype=float)[cell] + np.einsum("vij,vj->vi", rot[cell], body_vertices)
