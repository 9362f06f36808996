"""Centroidal Voronoi tessellation of a convex parent into BCM cells (SPEC 1.1) and their
face-to-face interfaces (SPEC 1.2).

Clipping. The Voronoi cells of the seeds, clipped to the convex parent, are computed exactly as
the Voronoi diagram of the seeds plus their mirror images across the parent's face planes: the
bisector of a seed and its own image across plane k is plane k, and the image q' of another
seed q never cuts the clipped cell, because a point x inside the parent is nearer to q than
to q' (it lies on q's side of plane k). So inside the parent the diagram is the clipped
diagram, and a seed's cell is cut by every plane it is mirrored across. A seed is mirrored
across the planes whose face polygon is within reach of its cell (1.1 times its extent in the
previous Lloyd step; at first 2 cell sizes); a cell that comes out unbounded or with a vertex
outside the parent has its seed mirrored across every plane and the diagram is recomputed.

Lloyd's method (SPEC 1.1): seeds uniform at random in the parent (``numpy.random.
default_rng(seed)``, rejection from the bounding box), then repeatedly build the clipped cells
and move each seed to its cell's mass centroid, until the RMS seed displacement of a step is
below ``tol`` times the mean cell size ``h = (V_parent / n_cells)^(1/3)`` (default 2e-3: 120
steps and about 8 s on one core for 1728 cells in GP(3,0)). The steps integrate the cells from
a Delaunay tetrahedralisation (``_lloyd_step``: fast, no polygon ordering; exact to ~1e-7 h,
see there); the final cells come from Qhull's Voronoi diagram, exact to round-off.

Final cells are the clipped Voronoi cells of the last seeds (each seed a cell generator; the
cell centroid differs from it by about ``tol h``). Every cell face is either on a parent plane
or on the bisector plane of two seeds; the face polygons are Voronoi ridges, so two
neighbouring cells share the very same vertices (one global vertex array). Qhull merges
cospherical sites into one Voronoi vertex (the mirror images make many: every vertex on a
parent plane or edge), so cells that touch only along an edge or at a vertex have no ridge.
As safety nets, Voronoi vertices closer than ``1e-10 h`` are merged and ridges below
``min_face_area_rel`` (default 1e-10) of the mean face area are dropped as degenerate; neither
happens in practice. Every remaining internal face is an interface: genuine faces can be small
(the smallest of a converged 1728-cell tessellation are ~1e-6 of the mean face area).

Conventions: cell face loops counter-clockwise seen from outside the cell; interface ``k``
joins cells ``i < j``, its normal points from i to j (the bisector normal ``(s_j - s_i) /
|s_j - s_i|``), its polygon is ordered counter-clockwise about that normal (outward for i).
Mass properties are for unit density (multiply by rho_s): formulas in ``shapes``.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import os
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np
from scipy.spatial import Delaunay, Voronoi

from driver.bcm.polyhedra import (ConvexShape, build_shape, chebyshev_center, halfspace_polyhedron,
                               merge_close_points, polyhedron_mass_properties,
                               principal_axes, rotation_to_quaternion, tetra_mass_properties)
from runfiles.atomic import atomic_save

#: Bumped whenever the algorithm changes what a given (shape, n_cells, seed, tol) produces;
#: part of the cache key.
ALGORITHM_VERSION = 1

#: Voronoi vertices closer than this (times the mean cell size h) are one vertex.
VERTEX_MERGE_REL = 1e-10

#: Vertices of a cell farther than this (times h) outside a parent plane mean the cell was
#: not clipped by it: its seed gets mirrored across every plane.
OUTSIDE_REL = 1e-9

#: A seed is mirrored across the face planes whose face polygon is within reach of its cell:
#: at first FIRST_REACH_REL h, then REACH_MARGIN times the cell's extent in the last step.
FIRST_REACH_REL = 2.0
REACH_MARGIN = 1.1


# ------------------------------------------------------------------------------- data types
@dataclass(eq=False)
class Cell:
    """One convex cell (or its eroded core).

    vertices (V, 3); faces: vertex-index loops counter-clockwise seen from outside;
    normals (F, 3) unit outward and offsets (F,) of the face planes (``normals @ x <= offsets``
    inside); neighbors (F,): the cell across each face, or ``-1 - k`` for parent plane k;
    volume, centroid (3,), inertia (3, 3) about the centroid, principal_moments (3,) ascending,
    principal_axes (3, 3) (columns; a proper rotation R, ``x_lab = R x_body``),
    quaternion (w, x, y, z) of R. Mass properties for unit density.
    """

    vertices: np.ndarray
    faces: list[np.ndarray]
    normals: np.ndarray
    offsets: np.ndarray
    neighbors: np.ndarray
    volume: float
    centroid: np.ndarray
    inertia: np.ndarray
    principal_moments: np.ndarray
    principal_axes: np.ndarray
    quaternion: np.ndarray


@dataclass(eq=False)
class Tessellation:
    """A clipped centroidal Voronoi tessellation: flat arrays, ready for ``np.savez``.

    Cells (n = n_cells): ``seeds`` (n, 3) generators; ``volume`` (n,), ``centroid`` (n, 3),
    ``inertia`` (n, 3, 3) about the centroid, ``principal_moments`` (n, 3),
    ``principal_axes`` (n, 3, 3), ``quaternion`` (n, 4) — unit density.

    Cell faces (one row per face per cell; an interface appears twice, once from each side):
    ``face_cell`` (f,), ``face_neighbor`` (f,) (cell id, or ``-1 - k`` on parent plane k),
    ``face_interface`` (f,) (interface id or -1), ``face_normal`` (f, 3) outward,
    ``face_offset`` (f,), ``face_area`` (f,), loops ``face_vertices[face_ptr[a]:face_ptr[a+1]]``
    into ``vertices`` (v, 3), counter-clockwise seen from outside the cell. Faces are grouped
    by cell: cell i owns rows ``cell_face_ptr[i]:cell_face_ptr[i+1]``.

    Interfaces (m): ``iface_cells`` (m, 2) with i < j, ``iface_area`` (m,), ``iface_normal``
    (m, 3) from i to j, ``iface_centroid`` (m, 3), polygons ``iface_vertices[iface_ptr[k]:
    iface_ptr[k+1]]`` counter-clockwise about the normal.

    Lloyd record: ``residuals`` (n_iter,) RMS seed displacement of each step over ``h``;
    ``converged`` when the last is below ``tol``. ``key`` is the cache key.
    """

    shape_params: dict
    n_cells: int
    seed: int
    tol: float
    max_iter: int
    min_face_area_rel: float
    key: str
    n_iter: int
    converged: bool
    residuals: np.ndarray
    seeds: np.ndarray
    vertices: np.ndarray
    volume: np.ndarray
    centroid: np.ndarray
    inertia: np.ndarray
    principal_moments: np.ndarray
    principal_axes: np.ndarray
    quaternion: np.ndarray
    cell_face_ptr: np.ndarray
    face_cell: np.ndarray
    face_neighbor: np.ndarray
    face_interface: np.ndarray
    face_normal: np.ndarray
    face_offset: np.ndarray
    face_area: np.ndarray
    face_ptr: np.ndarray
    face_vertices: np.ndarray
    iface_cells: np.ndarray
    iface_area: np.ndarray
    iface_normal: np.ndarray
    iface_centroid: np.ndarray
    iface_ptr: np.ndarray
    iface_vertices: np.ndarray
    _shape: ConvexShape | None = field(default=None, repr=False)

    # ---- derived quantities
    @property
    def shape(self) -> ConvexShape:
        """The parent shape, rebuilt from ``shape_params``."""
        if self._shape is None:
            self._shape = build_shape(**self.shape_params)
        return self._shape

    @property
    def mean_cell_size(self) -> float:
        """h = (V_parent / n_cells)^(1/3)."""
        return float((self.volume.sum() / self.n_cells) ** (1.0 / 3.0))

    @property
    def residual(self) -> float:
        """Last Lloyd step's RMS seed displacement over h (nan without Lloyd steps)."""
        return float(self.residuals[-1]) if len(self.residuals) else float("nan")

    @property
    def n_interfaces(self) -> int:
        return len(self.iface_area)

    def face_loop(self, face: int) -> np.ndarray:
        return self.face_vertices[self.face_ptr[face]:self.face_ptr[face + 1]]

    def interface_polygon(self, k: int) -> np.ndarray:
        """Vertex coordinates (n, 3) of interface k, counter-clockwise about its normal."""
        return self.vertices[self.iface_vertices[self.iface_ptr[k]:self.iface_ptr[k + 1]]]

    def cell_vertex_ids(self, i: int) -> np.ndarray:
        """Global vertex ids of cell i, sorted."""
        rows = range(self.cell_face_ptr[i], self.cell_face_ptr[i + 1])
        return np.unique(np.concatenate([self.face_loop(a) for a in rows]))

    def cell(self, i: int) -> Cell:
        """Cell i as a polyhedron with local vertex indices."""
        rows = np.arange(self.cell_face_ptr[i], self.cell_face_ptr[i + 1])
        ids = self.cell_vertex_ids(i)
        local = {int(g): k for k, g in enumerate(ids)}
        faces = [np.array([local[int(g)] for g in self.face_loop(a)]) for a in rows]
        return Cell(vertices=self.vertices[ids], faces=faces, normals=self.face_normal[rows],
                    offsets=self.face_offset[rows], neighbors=self.face_neighbor[rows],
                    volume=float(self.volume[i]), centroid=self.centroid[i], inertia=self.inertia[i],
                    principal_moments=self.principal_moments[i], principal_axes=self.principal_axes[i],
                    quaternion=self.quaternion[i])

    def faces_per_cell(self) -> np.ndarray:
        """Number of interfaces of each cell (n,)."""
        return np.bincount(self.iface_cells.ravel(), minlength=self.n_cells)

    # ---- persistence
    _META = ("shape_params", "n_cells", "seed", "tol", "max_iter", "min_face_area_rel", "key",
             "n_iter", "converged")

    def save(self, path: str | os.PathLike) -> Path:
        """Write all arrays and parameters to ``path`` (.npz), atomically."""
        meta = {k: getattr(self, k) for k in self._META}
        arrays = {f.name: getattr(self, f.name) for f in fields(self)
                  if f.name not in self._META and not f.name.startswith("_")}
        return atomic_save(path, lambda tmp: np.savez(tmp, meta=np.array(json.dumps(meta, sort_keys=True)), **arrays))

    @classmethod
    def load(cls, path: str | os.PathLike) -> "Tessellation":
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            arrays = {k: data[k] for k in data.files if k != "meta"}
        return cls(**meta, **arrays)


# ------------------------------------------------------------------------------- cache key
def tessellation_key(shape: ConvexShape, n_cells: int, seed: int, tol: float, max_iter: int,
                     min_face_area_rel: float, seeds: np.ndarray | None = None) -> str:
    """Hash of everything that determines a tessellation (shape parameters, n_cells, seed,
    tolerances, algorithm version; given seeds for ``clipped_voronoi``): 16 hex digits of SHA-256."""
    blob = json.dumps({"shape": shape.params, "n_cells": int(n_cells), "seed": int(seed), "tol": float(tol),
                       "max_iter": int(max_iter), "min_face_area_rel": float(min_face_area_rel),
                       "version": ALGORITHM_VERSION}, sort_keys=True).encode()
    if seeds is not None:
        blob += np.ascontiguousarray(seeds, dtype="<f8").tobytes()
    return hashlib.sha256(blob).hexdigest()[:16]


# ------------------------------------------------------------------ mirror images, reach
def _padded_face_edges(shape: ConvexShape) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Edges of every face, padded to the largest face: start vertex (F, M, 3), edge vector,
    in-plane inward normal (towards the polygon; loops are ccw), and a validity mask (F, M)."""
    m = max(len(f) for f in shape.faces)
    idx = np.array([np.r_[f, np.full(m - len(f), f[-1])] for f in shape.faces])
    nxt = np.array([np.r_[np.roll(f, -1), np.full(m - len(f), f[0])] for f in shape.faces])
    valid = np.array([np.arange(m) < len(f) for f in shape.faces])
    v0 = shape.vertices[idx]
    e = shape.vertices[nxt] - v0
    inward = np.cross(shape.normals[:, None, :], e)
    return v0, e, inward, valid


def mirror_mask(shape: ConvexShape, points: np.ndarray, reach: np.ndarray,
                edges: tuple[np.ndarray, ...] | None = None) -> np.ndarray:
    """(n, F) mask: face polygon k (not just its plane) is closer than ``reach[i]`` to point i.

    Only pairs whose plane is within reach are measured (the polygon is never closer than
    its plane). ``edges``: ``_padded_face_edges(shape)``, when already at hand.
    """
    x = np.asarray(points, dtype=float)
    to_plane = shape.offsets[None, :] - x @ shape.normals.T
    pi, fk = np.nonzero(to_plane < reach[:, None])
    v0, e, inward, valid = _padded_face_edges(shape) if edges is None else edges
    rel = x[pi][:, None, :] - v0[fk]
    inside = np.all((np.einsum("pmk,pmk->pm", rel, inward[fk]) >= 0.0) | ~valid[fk], axis=1)
    ee = e[fk]
    t = np.clip(np.einsum("pmk,pmk->pm", rel, ee) / np.einsum("pmk,pmk->pm", ee, ee), 0.0, 1.0)
    seg = np.where(valid[fk], np.linalg.norm(rel - t[..., None] * ee, axis=2), np.inf)
    dist = np.where(inside, to_plane[pi, fk], seg.min(axis=1))
    mask = np.zeros(to_plane.shape, dtype=bool)
    mask[pi, fk] = dist < reach[pi]
    return mask


def _mirror(shape: ConvexShape, seeds: np.ndarray, mask: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Seeds followed by the images of seed ``src[k]`` across plane ``plane[k]`` where
    ``mask[src, plane]``; returns (points, src, plane)."""
    src, plane = np.nonzero(mask)
    dist = shape.offsets[plane] - np.einsum("ij,ij->i", seeds[src], shape.normals[plane])
    images = seeds[src] + 2.0 * dist[:, None] * shape.normals[plane]
    return np.vstack([seeds, images]), src, plane


# --------------------------------------------------------------- Lloyd step (Delaunay)
#: Delaunay simplices: the three vertices of the face opposite vertex i.
_OTHER = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]])

#: Lloyd steps tolerate cells sticking out of the parent by this much (times h); the final
#: diagram is checked to OUTSIDE_REL.
LLOYD_OUTSIDE_REL = 1e-3

#: Lloyd steps move each mirror image at random by up to this much times its distance to its
#: seed, and at least LLOYD_JOGGLE_FLOOR h; see _lloyd_step.
LLOYD_JOGGLE_REL = 1e-7
LLOYD_JOGGLE_FLOOR = 1e-10

#: Random initial seeds closer than this (times h) to the parent's boundary are redrawn, so no
#: seed nearly coincides with its own mirror image.
SEED_MARGIN_REL = 1e-6


class _ClipError(RuntimeError):
    """A Lloyd step could not clip every cell to the parent."""


def _circumcentres(x: np.ndarray) -> np.ndarray:
    """Circumcentres of tetrahedra ``(T, 4, 3)``."""
    a = x[:, 0]
    u, v, w = x[:, 1] - a, x[:, 2] - a, x[:, 3] - a
    vw, wu, uv = np.cross(v, w), np.cross(w, u), np.cross(u, v)
    den = 2.0 * np.einsum("ij,ij->i", u, vw)
    num = (np.einsum("ij,ij->i", u, u)[:, None] * vw + np.einsum("ij,ij->i", v, v)[:, None] * wu
           + np.einsum("ij,ij->i", w, w)[:, None] * uv)
    return a + num / den[:, None]


def _voronoi_volumes(pts: np.ndarray, simp: np.ndarray, nb: np.ndarray, cc: np.ndarray,
                     n: int) -> tuple[np.ndarray, np.ndarray]:
    """(volume, first moment) of the Voronoi cells of the first n of `pts` from their Delaunay
    tetrahedra `simp` (neighbours `nb`, circumcentres `cc`): each internal triangle's dual
    Voronoi edge, cut into the tetrahedra of each of the triangle's vertices (used by the Lloyd
    steps of the particle and of the periodic block, driver/bcm/block.py)."""
    t_idx, i_idx = np.nonzero(nb > np.arange(len(simp))[:, None])  # each internal triangle once
    tv = simp[t_idx[:, None], _OTHER[i_idx]]
    touches = tv.min(axis=1) < n  # triangles between images only do not matter
    t_idx, i_idx, tv = t_idx[touches], i_idx[touches], tv[touches]
    t2 = nb[t_idx, i_idx]
    x = pts[tv]
    normal = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    t_minus = np.einsum("ij,ij->i", pts[simp[t_idx, i_idx]] - x[:, 0], normal) < 0.0
    c_minus = np.where(t_minus[:, None], cc[t_idx], cc[t2])
    c_plus = np.where(t_minus[:, None], cc[t2], cc[t_idx])
    vol = np.zeros(n)
    mom = np.zeros((n, 3))
    # vertex p of triangle (a, b, c) with q the next vertex and r the previous one: the ordered
    # pair (p, q) is an even permutation ((q-p) x (r-p) = +N), (p, r) an odd one, so the two
    # tetrahedra of p are (p, (p+q)/2, c-, c+) and (p, (p+r)/2, c+, c-), sharing Z below
    for pi, qi, ri in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        real = tv[:, pi] < n
        p = x[real, pi]
        cm, cp = c_minus[real], c_plus[real]
        z = np.cross(cm - p, cp - p)
        v_q = np.einsum("ij,ij->i", x[real, qi] - p, z) / 12.0
        v_r = -np.einsum("ij,ij->i", x[real, ri] - p, z) / 12.0
        # centroids (p + m + c- + c+) / 4 with m the edge midpoints
        first = ((v_q + v_r)[:, None] * (p + cm + cp) + v_q[:, None] * 0.5 * (p + x[real, qi])
                 + v_r[:, None] * 0.5 * (p + x[real, ri])) / 4.0
        owner = tv[real, pi]
        vol += np.bincount(owner, weights=v_q + v_r, minlength=n)
        for ax in range(3):
            mom[:, ax] += np.bincount(owner, weights=first[:, ax], minlength=n)
    return vol, mom


def _lloyd_step(shape: ConvexShape, seeds: np.ndarray, mirror: np.ndarray, h: float
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Volume, mass centroid and extent (largest seed-vertex distance) of every clipped cell.

    From the Delaunay tetrahedralisation of the seeds and their mirror images, the images
    joggled (relative size ``LLOYD_JOGGLE_REL``) so that every tetrahedron has a well-defined
    circumcentre (a Voronoi vertex; cells and centroids move by ~1e-7 h, far below ``tol``). The Voronoi ridge of
    the Delaunay edge pq is the polygon of the circumcentres of the tetrahedra around pq; its
    side dual to the triangle pqr runs from c- to c+, the circumcentres of the tetrahedra on
    the - and + side of N = (q - p) x (r - p), counter-clockwise about q - p. So the cell of p
    is the sum over its triangles pqr (both orders of q, r) of the signed tetrahedra
    (p, (p + q)/2, c-, c+) — no ordering of ridge polygons needed (tested against the exact
    Voronoi construction). Returns (volume, centroid,
    extent, mirror mask actually used).
    """
    n = len(seeds)
    mirror = mirror.copy()
    for _ in range(3):
        pts, src, _ = _mirror(shape, seeds, mirror)
        # break the exact symmetry of the images (a seed, another seed and their two images are
        # coplanar): a Delaunay tetrahedron of four coplanar sites has no circumcentre. The
        # joggle is relative to the seed-image distance (it tilts the mirror plane by at most
        # LLOYD_JOGGLE_REL radians), but not below LLOYD_JOGGLE_FLOOR h, far above Qhull's
        # precision: a smaller one is merged away and the merged facet triangulated into
        # tetrahedra whose circumspheres are not empty.
        span = np.linalg.norm(pts[n:] - seeds[src], axis=1, keepdims=True)
        size = np.maximum(LLOYD_JOGGLE_REL * span, LLOYD_JOGGLE_FLOOR * h)
        pts[n:] += size * np.random.default_rng(0).uniform(-1.0, 1.0, (len(pts) - n, 3))
        tri = Delaunay(pts)
        simp, nb = tri.simplices, tri.neighbors
        cc = _circumcentres(pts[simp])
        # cells that are unbounded (a hull face with a real seed) or stick out of the parent
        ht, hi = np.nonzero(nb < 0)
        hull_verts = simp[ht[:, None], _OTHER[hi]]
        out = (cc @ shape.normals.T - shape.offsets).max(axis=1) > LLOYD_OUTSIDE_REL * h
        bad = np.unique(np.concatenate([hull_verts[hull_verts < n], simp[out][simp[out] < n]]))
        if len(bad) == 0:
            break
        mirror[bad] = True
    else:
        raise _ClipError("could not clip the Voronoi cells to the parent")
    vol, mom = _voronoi_volumes(pts, simp, nb, cc, n)
    extent = np.zeros(n)
    real = simp < n
    np.maximum.at(extent, simp[real], np.linalg.norm(cc[np.nonzero(real)[0]] - pts[simp[real]], axis=1))
    return vol, mom / vol[:, None], extent, mirror


# ------------------------------------------------------------ final diagram (Voronoi)
@dataclass
class _Ridges:
    """Voronoi ridges with at least one real seed: sites (r, 2) into ``sites``, vertex loops
    counter-clockwise about ``sites[points[:, 1]] - sites[points[:, 0]]``, flat with ``ptr``."""

    sites: np.ndarray
    points: np.ndarray
    ptr: np.ndarray
    verts: np.ndarray
    vor_vertices: np.ndarray
    mirror_src: np.ndarray
    mirror_plane: np.ndarray


def _sort_loops(ridge_of: np.ndarray, verts: np.ndarray, coords: np.ndarray, axis: np.ndarray,
                n_ridges: int) -> np.ndarray:
    """Permutation sorting flat loop entries by ridge, then by angle about ``axis[ridge]``."""
    n = axis / np.linalg.norm(axis, axis=1, keepdims=True)
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u = np.cross(n, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(n, u)
    counts = np.bincount(ridge_of, minlength=n_ridges)
    centre = np.stack([np.bincount(ridge_of, weights=coords[verts, k], minlength=n_ridges)
                       for k in range(3)], axis=1) / np.maximum(counts, 1)[:, None]
    q = coords[verts] - centre[ridge_of]
    ang = np.arctan2((q * v[ridge_of]).sum(axis=1), (q * u[ridge_of]).sum(axis=1))
    return np.lexsort((ang, ridge_of))


def _clipped_voronoi(shape: ConvexShape, seeds: np.ndarray, mirror: np.ndarray, h: float) -> _Ridges:
    """Voronoi ridges of the seeds clipped to the parent, via mirror images (module docstring).

    Qhull's Voronoi (not triangulated) merges cospherical sites into one vertex, which keeps
    vertices on parent planes and on parent edges exact to round-off.
    """
    n = len(seeds)
    mirror = mirror.copy()
    for _ in range(3):
        pts, src, plane = _mirror(shape, seeds, mirror)
        vor = Voronoi(pts)
        rp = vor.ridge_points
        keep = np.flatnonzero(rp.min(axis=1) < n)
        rv = vor.ridge_vertices
        lengths = np.fromiter((len(rv[k]) for k in keep), dtype=np.int64, count=len(keep))
        verts = np.fromiter(itertools.chain.from_iterable(rv[k] for k in keep), dtype=np.int64,
                            count=int(lengths.sum()))
        ridge_of = np.repeat(np.arange(len(keep)), lengths)
        points = rp[keep]
        bad_ridge = np.zeros(len(keep), dtype=bool)
        bad_ridge[ridge_of[verts < 0]] = True
        ok = verts >= 0
        outside = (vor.vertices[verts[ok]] @ shape.normals.T - shape.offsets).max(axis=1) > OUTSIDE_REL * h
        bad_ridge[ridge_of[ok][outside]] = True
        bad = np.unique(points[bad_ridge].ravel())
        bad = bad[bad < n]
        if len(bad) == 0:
            order = _sort_loops(ridge_of, verts, vor.vertices, pts[points[:, 1]] - pts[points[:, 0]], len(keep))
            return _Ridges(sites=pts, points=points, ptr=np.concatenate([[0], np.cumsum(lengths)]),
                           verts=verts[order], vor_vertices=vor.vertices, mirror_src=src, mirror_plane=plane)
        mirror[bad] = True
    raise RuntimeError("could not clip the Voronoi cells to the parent")


def _exact_volumes_centroids(ridges: _Ridges, seeds: np.ndarray
                             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Volume, centroid and extent of every cell from the exact clipped diagram: each ridge
    polygon fanned into triangles, each forming a tetrahedron with the seed of every real
    cell on either side (the seed is inside its convex cell: |det| / 6 is its volume)."""
    n = len(seeds)
    c = ridges.vor_vertices
    loop, i0, i1, i2 = _fan(ridges.ptr)
    a, b, d = c[ridges.verts[i0]], c[ridges.verts[i1]], c[ridges.verts[i2]]
    vol = np.zeros(n)
    mom = np.zeros((n, 3))
    extent = np.zeros(n)
    entry_ridge = np.repeat(np.arange(len(ridges.points)), np.diff(ridges.ptr))
    for side in (0, 1):
        owner = ridges.points[loop, side]
        real = owner < n
        o = owner[real]
        s = seeds[o]
        v6 = np.abs(np.einsum("ij,ij->i", a[real] - s, np.cross(b[real] - s, d[real] - s))) / 6.0
        vol += np.bincount(o, weights=v6, minlength=n)
        cen = (s + a[real] + b[real] + d[real]) / 4.0
        for ax in range(3):
            mom[:, ax] += np.bincount(o, weights=v6 * cen[:, ax], minlength=n)
        owner = ridges.points[entry_ridge, side]
        real = owner < n
        np.maximum.at(extent, owner[real], np.linalg.norm(c[ridges.verts[real]] - seeds[owner[real]], axis=1))
    return vol, mom / vol[:, None], extent


def _fan(ptr: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Fan triangles of flat loops: (loop, first, second, third) positions in the flat array."""
    n_tri = np.diff(ptr) - 2
    loop = np.repeat(np.arange(len(n_tri)), n_tri)
    k = np.arange(n_tri.sum()) - np.repeat(np.cumsum(n_tri) - n_tri, n_tri)
    s = ptr[loop]
    return loop, s, s + 1 + k, s + 2 + k


def _loop_positions(ptr: np.ndarray, rows: np.ndarray, reverse: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Flat positions of loops ``rows`` (reversed where asked) and the new loops' ptr."""
    lengths = np.diff(ptr)[rows]
    new_ptr = np.concatenate([[0], np.cumsum(lengths)])
    row = np.repeat(np.arange(len(rows)), lengths)
    k = np.arange(new_ptr[-1]) - new_ptr[row]
    start = ptr[rows][row]
    return np.where(reverse[row], start + lengths[row] - 1 - k, start + k), new_ptr


# ---------------------------------------------------------------------------------- Lloyd
def random_points_in_shape(shape: ConvexShape, n: int, rng: np.random.Generator,
                           margin: float = 0.0) -> np.ndarray:
    """``n`` points uniform in the shape (farther than ``margin`` from its boundary): rejection
    sampling from its bounding box."""
    lo, hi = shape.vertices.min(axis=0), shape.vertices.max(axis=0)
    out = np.empty((0, 3))
    while len(out) < n:
        p = lo + (hi - lo) * rng.random((2 * (n - len(out)) + 16, 3))
        # strictly inside: a seed on a parent plane would be its own mirror image
        out = np.vstack([out, p[shape.contains(p, tol=-margin)]])
    return out[:n]


def tessellate(shape: ConvexShape, n_cells: int = 1728, seed: int = 1, max_iter: int = 400,
               tol: float = 2e-3, min_face_area_rel: float = 1e-10) -> Tessellation:
    """Clipped centroidal Voronoi tessellation of ``shape`` into ``n_cells`` cells.

    Lloyd iterations from uniform random seeds (``default_rng(seed)``) stop when the RMS seed
    displacement of a step is below ``tol * h`` (h = mean cell size) or after ``max_iter``
    steps (``Tessellation.converged`` says which). Faces with area below
    ``min_face_area_rel`` times the mean internal face area are degenerate (edge or vertex
    contacts) and dropped. See the module docstring for the method and conventions.
    """
    if n_cells < 2:
        raise ValueError(f"n_cells must be >= 2, got {n_cells}")
    if not (tol > 0 and max_iter >= 1):
        raise ValueError(f"need tol > 0 and max_iter >= 1, got tol={tol}, max_iter={max_iter}")
    rng = np.random.default_rng(seed)
    h = (shape.volume / n_cells) ** (1.0 / 3.0)
    seeds = random_points_in_shape(shape, n_cells, rng, margin=SEED_MARGIN_REL * h)
    reach = np.full(n_cells, FIRST_REACH_REL * h)
    residuals = []
    edges = _padded_face_edges(shape)
    for _ in range(max_iter):
        mirror = mirror_mask(shape, seeds, reach, edges)
        try:
            _, centroids, extent, _ = _lloyd_step(shape, seeds, mirror, h)
        except _ClipError:  # degenerate beyond the joggle: use the exact (slower) diagram
            ridges = _clipped_voronoi(shape, seeds, mirror, h)
            _, centroids, extent = _exact_volumes_centroids(ridges, seeds)
        step = np.linalg.norm(centroids - seeds, axis=1)
        residuals.append(float(np.sqrt(np.mean(step**2))) / h)
        # a cell can touch a face polygon only within its extent; the next cell is at most a
        # little larger than this one moved by its seed's step
        reach = REACH_MARGIN * extent + 2.0 * step
        seeds = centroids
        if residuals[-1] < tol:
            break
    key = tessellation_key(shape, n_cells, seed, tol, max_iter, min_face_area_rel)
    return _finish(shape, seeds, reach, h, min_face_area_rel, key=key, seed=int(seed), tol=float(tol),
                   max_iter=int(max_iter), residuals=np.asarray(residuals), converged=residuals[-1] < tol)


def clipped_voronoi(shape: ConvexShape, seeds: np.ndarray,
                    min_face_area_rel: float = 1e-10) -> Tessellation:
    """The Voronoi cells of given seeds (strictly inside the shape), clipped to it; no Lloyd
    iterations (``n_iter = 0``, ``seed = -1``). For hand-checkable layouts and custom seeds."""
    seeds = np.array(seeds, dtype=float).reshape(-1, 3)
    n = len(seeds)
    if n < 2:
        raise ValueError(f"need at least 2 seeds, got {n}")
    h = (shape.volume / n) ** (1.0 / 3.0)
    key = tessellation_key(shape, n, -1, 0.0, 0, min_face_area_rel, seeds=seeds)
    return _finish(shape, seeds, np.full(n, FIRST_REACH_REL * h), h, min_face_area_rel, key=key, seed=-1,
                   tol=0.0, max_iter=0, residuals=np.zeros(0), converged=False)


def _finish(shape: ConvexShape, seeds: np.ndarray, reach: np.ndarray, h: float, min_face_area_rel: float,
            **record) -> Tessellation:
    ridges = _clipped_voronoi(shape, seeds, mirror_mask(shape, seeds, reach), h)
    arrays = _build(shape, seeds, ridges, h, min_face_area_rel)
    return Tessellation(shape_params=dict(shape.params), n_cells=len(seeds),
                        min_face_area_rel=float(min_face_area_rel), n_iter=len(record["residuals"]),
                        _shape=shape, **record, **arrays)


# -------------------------------------------------------------------------- final geometry
def _build(shape: ConvexShape, seeds: np.ndarray, ridges: _Ridges, h: float,
           min_face_area_rel: float) -> dict:
    """Cells, faces and interfaces from the clipped diagram of the final seeds (flat arrays)."""
    n = len(seeds)
    sites = ridges.sites
    n_r = len(ridges.points)
    # one vertex per point: merge coincident Voronoi vertices, drop repeats within a ridge
    used = np.unique(ridges.verts)
    merged, mapping = merge_close_points(ridges.vor_vertices[used], VERTEX_MERGE_REL * h)
    new_id = np.full(len(ridges.vor_vertices), -1)
    new_id[used] = mapping
    ridge_of = np.repeat(np.arange(n_r), np.diff(ridges.ptr))
    vid = new_id[ridges.verts]
    order = np.lexsort((np.arange(len(vid)), vid, ridge_of))
    repeat = np.zeros(len(vid), dtype=bool)
    repeat[order[1:]] = (np.diff(ridge_of[order]) == 0) & (np.diff(vid[order]) == 0)
    ridge_of, vid = ridge_of[~repeat], vid[~repeat]
    counts = np.bincount(ridge_of, minlength=n_r)
    ptr = np.concatenate([[0], np.cumsum(counts)])

    # classify: real|real (internal), real|own image (on parent plane), real|other image
    pa, pb = ridges.points[:, 0], ridges.points[:, 1]
    swap = pa > pb  # loops are ccw about pb - pa; lo's outward normal is hi - lo
    lo, hi = np.minimum(pa, pb), np.maximum(pa, pb)
    img = np.clip(hi - n, 0, None)
    internal = hi < n
    own_image = ~internal & (ridges.mirror_src[img] == lo)
    plane = np.where(own_image, ridges.mirror_plane[img], -1)
    normal = sites[hi] - sites[lo]
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    offset = np.einsum("ij,ij->i", normal, 0.5 * (sites[lo] + sites[hi]))
    normal[own_image] = shape.normals[plane[own_image]]
    offset[own_image] = shape.offsets[plane[own_image]]

    # areas (Newell) of the loops as stored
    x = merged[vid]
    pos = np.arange(len(vid))
    nxt = np.where(pos + 1 == ptr[ridge_of + 1], ptr[ridge_of], pos + 1)
    cr = np.cross(x, x[nxt])
    area_vec = 0.5 * np.stack([np.bincount(ridge_of, weights=cr[:, k], minlength=n_r) for k in range(3)],
                              axis=1)
    area = np.abs(np.einsum("ij,ij->i", area_vec, normal))
    mean_area = area[internal & (counts >= 3)].mean()
    face = (counts >= 3) & (area > min_face_area_rel * mean_area)
    stray = face & ~internal & ~own_image
    if np.any(stray):
        raise RuntimeError(f"{stray.sum()} faces between a cell and another cell's mirror image "
                           f"(largest {area[stray].max() / mean_area:.2e} of the mean face area)")

    # interfaces in order of (i, j), loops ccw about the normal from i = lo to j = hi
    iface_r = np.flatnonzero(face & internal)
    iface_r = iface_r[np.lexsort((hi[iface_r], lo[iface_r]))]
    iface_id = np.full(n_r, -1)
    iface_id[iface_r] = np.arange(len(iface_r))
    ipos, iface_ptr = _loop_positions(ptr, iface_r, swap[iface_r])
    iface_vid = vid[ipos]
    loop, i0, i1, i2 = _fan(iface_ptr)
    p0, p1, p2 = merged[iface_vid[i0]], merged[iface_vid[i1]], merged[iface_vid[i2]]
    w = np.linalg.norm(np.cross(p1 - p0, p2 - p0), axis=1)
    m = len(iface_r)
    iface_centroid = (np.stack([np.bincount(loop, weights=w * (p0 + p1 + p2)[:, k] / 3.0, minlength=m)
                                for k in range(3)], axis=1)
                      / np.bincount(loop, weights=w, minlength=m)[:, None])

    # cell faces: every face ridge for lo (ccw about lo -> hi), internal ones again for hi
    fr = np.flatnonzero(face)
    rows_ridge = np.concatenate([fr, iface_r])
    rows_cell = np.concatenate([lo[fr], hi[iface_r]])
    for_hi = np.concatenate([np.zeros(len(fr), bool), np.ones(len(iface_r), bool)])
    rows_nb = np.where(for_hi, lo[rows_ridge],
                       np.where(internal[rows_ridge], hi[rows_ridge], -1 - plane[rows_ridge]))
    order = np.lexsort((rows_nb, rows_cell))
    rows_ridge, rows_cell, for_hi, rows_nb = rows_ridge[order], rows_cell[order], for_hi[order], rows_nb[order]
    fpos, face_ptr = _loop_positions(ptr, rows_ridge, swap[rows_ridge] != for_hi)
    face_vid = vid[fpos]
    sign = np.where(for_hi, -1.0, 1.0)

    # mass properties: fan every face, reference point = the cell's seed (inside the cell)
    loop, i0, i1, i2 = _fan(face_ptr)
    volume, centroid, inertia = tetra_mass_properties(rows_cell[loop], seeds, merged[face_vid[i0]],
                                                      merged[face_vid[i1]], merged[face_vid[i2]], n)
    moments, axes = principal_axes(inertia)

    # keep only the vertices that are used
    keep, face_vertices = np.unique(face_vid, return_inverse=True)
    renum = np.full(len(merged), -1)
    renum[keep] = np.arange(len(keep))
    return dict(
        seeds=seeds, vertices=merged[keep], volume=volume, centroid=centroid, inertia=inertia,
        principal_moments=moments, principal_axes=axes, quaternion=rotation_to_quaternion(axes),
        cell_face_ptr=np.concatenate([[0], np.cumsum(np.bincount(rows_cell, minlength=n))]),
        face_cell=rows_cell, face_neighbor=rows_nb, face_interface=iface_id[rows_ridge],
        face_normal=normal[rows_ridge] * sign[:, None], face_offset=offset[rows_ridge] * sign,
        face_area=area[rows_ridge], face_ptr=face_ptr, face_vertices=face_vertices.astype(np.int64),
        iface_cells=np.c_[lo[iface_r], hi[iface_r]].reshape(-1, 2), iface_area=area[iface_r],
        iface_normal=normal[iface_r].reshape(-1, 3), iface_centroid=iface_centroid.reshape(-1, 3),
        iface_ptr=iface_ptr, iface_vertices=renum[iface_vid].astype(np.int64),
    )


# ----------------------------------------------------------------------------- rounding
def erode(cell: Cell, r_m: float) -> Cell:
    """The cell shrunk by ``r_m`` (SPEC 1.1): every face plane moved inward by r_m and the
    vertices rebuilt by half-space intersection, so that (eroded cell) + (ball of radius r_m)
    lies inside the cell. Faces whose plane no longer touches the eroded cell disappear; the
    others keep their normal and neighbour. Raises ValueError when r_m reaches the cell's
    inradius."""
    if r_m < 0.0:
        raise ValueError(f"r_m must be >= 0, got {r_m}")
    offsets = cell.offsets - r_m
    interior = cell.centroid
    if np.any(cell.normals @ interior - offsets >= -1e-3 * r_m):
        interior, radius = chebyshev_center(cell.normals, offsets)
        if radius <= 0.0:
            raise ValueError(f"r_m = {r_m} is not below the cell's inradius")
    # A face that nearly vanishes in the erosion can leave vertices closer than the merge
    # tolerance allows the faces to agree on, or drop out as too small and leave a vertex on
    # two edges only (two vertices 1e-5 of the cell's size apart, found in a bed's grain eroded
    # at its own scale; pair bcm/contact refuses such a cell); merge more coarsely (at most 1e-4
    # of the cell's size, far below r_m's effect) until every edge is shared by exactly two
    # faces and every vertex is on three edges or more.
    for rel_tol in (1e-9, 1e-7, 1e-5, 1e-4):
        verts, faces, planes = halfspace_polyhedron(cell.normals, offsets, interior, rel_tol=rel_tol)
        if _is_closed(faces) and _every_vertex_on_three_edges(faces):
            break
    else:
        raise ValueError(f"eroding a cell by r_m = {r_m} gives an inconsistent polyhedron")
    vol, cen, inertia = polyhedron_mass_properties(verts, faces)
    moments, axes = principal_axes(inertia)
    return Cell(vertices=verts, faces=faces, normals=cell.normals[planes], offsets=offsets[planes],
                neighbors=cell.neighbors[planes], volume=vol, centroid=cen, inertia=inertia,
                principal_moments=moments, principal_axes=axes, quaternion=rotation_to_quaternion(axes))


def _every_vertex_on_three_edges(faces: list[np.ndarray]) -> bool:
    """Every vertex of the face loops has at least three distinct neighbours (a vertex on two
    edges only lies on an edge: a face met there was lost)."""
    nbr: dict[int, set[int]] = {}
    for f in faces:
        for a, b in zip(f, np.roll(f, -1)):
            nbr.setdefault(int(a), set()).add(int(b))
            nbr.setdefault(int(b), set()).add(int(a))
    return all(len(n) >= 3 for n in nbr.values())


def _is_closed(faces: list[np.ndarray]) -> bool:
    """Every directed edge appears once and its reverse once: a closed, consistently oriented surface."""
    edges = np.concatenate([np.c_[f, np.roll(f, -1)] for f in faces])
    fwd = {(int(a), int(b)) for a, b in edges}
    return len(fwd) == len(edges) and all((b, a) in fwd for a, b in fwd)


# -------------------------------------------------------------------------------- caching
def cached_tessellation(cache_dir: str | os.PathLike, shape: ConvexShape, n_cells: int = 1728,
                        seed: int = 1, max_iter: int = 400, tol: float = 2e-3,
                        min_face_area_rel: float = 1e-10) -> Tessellation:
    """``tessellate(...)``, read from ``cache_dir/tessellation_<key>.npz`` when present,
    computed and written there otherwise (key: ``tessellation_key``)."""
    key = tessellation_key(shape, n_cells, seed, tol, max_iter, min_face_area_rel)
    path = Path(cache_dir) / f"tessellation_{key}.npz"
    if path.exists():
        tess = Tessellation.load(path)
        if tess.key == key:
            return tess
    tess = tessellate(shape, n_cells=n_cells, seed=seed, max_iter=max_iter, tol=tol,
                      min_face_area_rel=min_face_area_rel)
    tess.save(path)
    return tess
