"""Periodic centroidal Voronoi tessellation of a box: the space-filling block of BCM cells for
the calibration scenarios (SPEC 3: "BCM effective moduli measured by the calibration scenarios
on a block of cells"; cells and interfaces as in SPEC 1.1-1.2, with periodic images bonded).

Box. ``[0, Lx) x [0, Ly) x [0, Lz)``, periodic in x, y and z. Seeds always lie in the box; a
cell is the Voronoi cell of its seed among all seeds and their periodic images, in absolute
coordinates around its seed, so it sticks out of the box where its seed is near a side.

Periodic images. The Voronoi diagram is computed by Qhull (``scipy.spatial.Voronoi``) for the
seeds plus every image ``x_j + s L`` (s integer, not 0) within a margin ``m`` of the box.
Why a margin is enough, and the check that makes it exact: let ``C'`` be the computed cell of
seed p (a superset of its true periodic cell C, since fewer sites cut it) and ``R`` its
extent (largest distance from p to a vertex). A site q cuts ``C'`` only if its bisector with p
crosses ``C'``, i.e. ``|q - p| / 2 < R``; such a q lies within ``2 R`` of p, so within ``2 R``
of the box. Hence if ``2 R <= m`` for every cell (and every cell is bounded), every site that
could cut any cell is in the diagram and ``C' = C``. Otherwise the diagram is recomputed with
``m = 2.2 R_max`` (or ``2 m`` while some cell is unbounded); since ``C`` is inside ``C'`` this
is always enough. Measured for 1728 cells (h = (V / N)^(1/3), the mean cell size): the
largest extent is 1.5 h for uniform random seeds and 0.83 h once converged (0.71 h for the
truncated octahedron of the body-centred cubic lattice). The first step starts with
``m = 4 h``, later steps with 2.2 times the last step's largest extent plus twice its largest
seed step (about 1.8 h near convergence), so recomputations are rare.

Lloyd's method (SPEC 1.1): seeds uniform at random in the box (``numpy.random.
default_rng(seed)``), then repeatedly build the periodic cells, move each seed to its cell's
mass centroid and wrap it back into the box, until the RMS seed step (minimum image: the step
from a seed to the centroid of its own cell) is below ``tol * h``, or ``max_iter`` steps.
The steps integrate the cells from the Delaunay tetrahedralisation of the same sites
(``_lloyd_step``: twice as fast as Qhull's Voronoi, no polygon ordering; it agrees with the
Voronoi cells to round-off, and a degenerate triangulation falls back to them); 1728 cells
take about 110 steps and 8 to 13 s on one core, 300 cells about 115 steps and 2 s.
The final cells are those of the final (wrapped) seeds; each cell's centroid lies within the
cell, so at most a cell size outside the box, and within about ``tol * h`` of its seed once
converged.

Faces and interfaces. Every face of a cell is a Voronoi ridge between its seed and another
site, which is either another seed j (shift 0) or an image ``x_j + s L`` (j may be the cell
itself when N is small). The same geometric face is then also a face of cell j, against the
image ``x_i - s L``: the two copies differ by the translation ``s L`` (and round-off). Each
such pair is one interface ``(i, j, s)`` with ``i < j``, or ``i == j`` and ``s``
lexicographically positive (first non-zero component > 0); the other copy is its partner
row. Faces below ``min_face_area_rel`` times the mean face area (none in practice) and ridges
with fewer than three vertices (cells touching along an edge or at a vertex, e.g. diagonal
neighbours of a lattice) are not faces. Every face must have its partner; a face without one
is an error.

Periodic bonds and LAMMPS. A pair (i, j) can share several faces through different images,
and a cell can share a face with its own image, when the box is less than about two cell sizes
across. LAMMPS finds a bond's partner by the minimum-image convention, so it can represent an
interface only when the neighbour ``c_j + s L`` is the minimum image of centroid ``c_j`` seen
from ``c_i`` (every component of ``c_j + s L - c_i`` below half the box). The tessellation
handles every case; ``minimum_image_violations`` lists the interfaces LAMMPS cannot represent
and ``require_minimum_image`` refuses them with a clear error (for the data-file writers).

Conventions: cell face loops counter-clockwise seen from outside the cell; interface normals
from i to the image of j, polygons counter-clockwise about them, in cell i's absolute
coordinates. Mass properties for unit density (multiply by rho_s); formulas in ``polyhedra``.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import os
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
from scipy.spatial import Delaunay, Voronoi

from driver.bcm.polyhedra import principal_axes, rotation_to_quaternion, tetra_mass_properties
from driver.bcm.tessellation import _OTHER, _circumcentres, _fan, _loop_positions, _sort_loops, _voronoi_volumes
from runfiles.atomic import atomic_save

#: Bumped whenever the algorithm changes what given arguments produce; part of the cache key.
ALGORITHM_VERSION = 1

#: Margin of periodic images around the box in the first Lloyd step, times h (module docstring).
FIRST_MARGIN_REL = 4.0

#: The margin is REACH_MARGIN times twice the largest cell extent (plus the seeds' steps).
REACH_MARGIN = 1.1

#: Recomputations of one diagram with a larger margin before giving up.
MAX_MARGIN_TRIES = 6


# ------------------------------------------------------------------------------- data type
@dataclass(eq=False)
class BlockTessellation:
    """A periodic centroidal Voronoi tessellation of a box: flat arrays, ready for ``np.savez``.

    Box: ``lengths`` (3,) = (Lx, Ly, Lz), the box ``[0, L)`` in each direction, periodic.

    Cells (n = n_cells), absolute coordinates: ``seeds`` (n, 3) generators, wrapped into the
    box; ``volume`` (n,); ``centroid`` (n, 3) of the cell polyhedron around its seed (not
    wrapped: up to a cell size outside the box; see ``wrapped_centroid``);
    ``inertia`` (n, 3, 3) about the centroid; ``principal_moments`` (n, 3) ascending;
    ``principal_axes`` (n, 3, 3), columns, a proper rotation R with ``x_lab = R x_body``;
    ``quaternion`` (n, 4) (w, x, y, z) of R. Unit density.

    Cell vertices: ``vertices`` (v, 3) absolute, grouped by cell: cell i owns rows
    ``cell_vertex_ptr[i]:cell_vertex_ptr[i+1]`` (its own copy: a vertex shared by cells
    appears once per cell). ``cell_polyhedron(i)`` gives them with local face indices.

    Cell faces (one row per face per cell; every interface appears twice, once from each side),
    grouped by cell (rows ``cell_face_ptr[i]:cell_face_ptr[i+1]``), ordered by neighbour and
    shift: ``face_cell`` (f,); ``face_neighbor`` (f,) the cell j across; ``face_shift`` (f, 3)
    int, the neighbour is ``seeds[j] + face_shift * lengths``; ``face_interface`` (f,);
    ``face_partner`` (f,) the row of the same face seen from j; ``face_normal`` (f, 3) unit
    outward; ``face_offset`` (f,) (``face_normal . x <= face_offset`` inside); ``face_area``
    (f,); loops ``face_vertices[face_ptr[a]:face_ptr[a+1]]``, indices into ``vertices`` (rows
    of the face's cell), counter-clockwise seen from outside the cell.

    Interfaces (m), each geometric face once: ``iface_cells`` (m, 2) (i, j) with i < j, or
    i == j and the shift lexicographically positive; ``iface_shift`` (m, 3) int, the image of
    j bonded to i is ``x_j + iface_shift * lengths``; ``iface_faces`` (m, 2) the face rows of
    i and of j; ``iface_area`` (m,); ``iface_normal`` (m, 3) from i to the image of j;
    ``iface_centroid`` (m, 3) and polygons ``vertices[iface_vertices[iface_ptr[k]:
    iface_ptr[k+1]]]`` counter-clockwise about the normal, both in cell i's absolute
    coordinates (subtract ``iface_shift * lengths`` for the copy near cell j).

    Lloyd record: ``residuals`` (n_iter,) RMS seed step over h; ``converged`` when the last
    is below ``tol``. ``seed`` is -1 for given initial seeds. ``key`` is the cache key.
    """

    n_cells: int
    seed: int
    tol: float
    max_iter: int
    min_face_area_rel: float
    key: str
    n_iter: int
    converged: bool
    lengths: np.ndarray
    residuals: np.ndarray
    seeds: np.ndarray
    volume: np.ndarray
    centroid: np.ndarray
    inertia: np.ndarray
    principal_moments: np.ndarray
    principal_axes: np.ndarray
    quaternion: np.ndarray
    cell_vertex_ptr: np.ndarray
    vertices: np.ndarray
    cell_face_ptr: np.ndarray
    face_cell: np.ndarray
    face_neighbor: np.ndarray
    face_shift: np.ndarray
    face_interface: np.ndarray
    face_partner: np.ndarray
    face_normal: np.ndarray
    face_offset: np.ndarray
    face_area: np.ndarray
    face_ptr: np.ndarray
    face_vertices: np.ndarray
    iface_cells: np.ndarray
    iface_shift: np.ndarray
    iface_faces: np.ndarray
    iface_area: np.ndarray
    iface_normal: np.ndarray
    iface_centroid: np.ndarray
    iface_ptr: np.ndarray
    iface_vertices: np.ndarray

    # ---- derived quantities
    @property
    def box_volume(self) -> float:
        return float(np.prod(self.lengths))

    @property
    def mean_cell_size(self) -> float:
        """h = (Lx Ly Lz / n_cells)^(1/3)."""
        return float((self.box_volume / self.n_cells) ** (1.0 / 3.0))

    @property
    def residual(self) -> float:
        """Last Lloyd step's RMS seed step over h (nan without Lloyd steps)."""
        return float(self.residuals[-1]) if len(self.residuals) else float("nan")

    @property
    def n_interfaces(self) -> int:
        return len(self.iface_area)

    @property
    def wrapped_centroid(self) -> np.ndarray:
        """(n, 3) centroids wrapped into the box."""
        return wrap(self.centroid, self.lengths)

    def face_loop(self, face: int) -> np.ndarray:
        """Indices into ``vertices`` of face row ``face``, counter-clockwise from outside its cell."""
        return self.face_vertices[self.face_ptr[face]:self.face_ptr[face + 1]]

    def interface_polygon(self, k: int) -> np.ndarray:
        """Vertex coordinates (p, 3) of interface k near cell i, counter-clockwise about its normal."""
        return self.vertices[self.iface_vertices[self.iface_ptr[k]:self.iface_ptr[k + 1]]]

    def cell_polyhedron(self, i: int) -> tuple[np.ndarray, list[np.ndarray]]:
        """Cell i: absolute vertices (v, 3) and faces as local index loops, ccw from outside."""
        start = self.cell_vertex_ptr[i]
        rows = range(self.cell_face_ptr[i], self.cell_face_ptr[i + 1])
        return (self.vertices[start:self.cell_vertex_ptr[i + 1]],
                [self.face_loop(a) - start for a in rows])

    def faces_per_cell(self) -> np.ndarray:
        """Number of faces (= interfaces, counting a self-interface twice) of each cell (n,)."""
        return np.diff(self.cell_face_ptr)

    def minimum_image_violations(self) -> np.ndarray:
        """Interfaces whose bonded image of j is not the minimum image of centroid j seen from
        centroid i (some component of ``c_j + s L - c_i`` at least half the box): LAMMPS, which
        finds bond partners by minimum image, cannot represent them. Always includes
        self-interfaces and pairs bonded through two images. A component within 1e-9 of half
        the box is a tie (either image is nearest): a violation too."""
        i, j = self.iface_cells.T
        d = self.centroid[j] + self.iface_shift * self.lengths - self.centroid[i]
        return np.flatnonzero(np.any(np.abs(d) >= (0.5 - 1e-9) * self.lengths, axis=1))

    def require_minimum_image(self) -> None:
        """Raise ValueError when some interface cannot be represented under the minimum-image
        convention (see ``minimum_image_violations``): the box is too small for its cells."""
        bad = self.minimum_image_violations()
        if len(bad):
            k = int(bad[0])
            raise ValueError(
                f"{len(bad)} of {self.n_interfaces} interfaces of the periodic block bond a cell to a "
                f"periodic image that is not the nearest one (first: cells {tuple(self.iface_cells[k])}, "
                f"shift {tuple(self.iface_shift[k])}); LAMMPS bonds need a box wider than about two "
                f"cells in each direction (box {tuple(self.lengths)}, mean cell size {self.mean_cell_size:.4g})")

    # ---- persistence
    _META = ("n_cells", "seed", "tol", "max_iter", "min_face_area_rel", "key", "n_iter", "converged")

    def save(self, path: str | os.PathLike) -> Path:
        """Write all arrays and parameters to ``path`` (.npz), atomically."""
        meta = {k: getattr(self, k) for k in self._META}
        arrays = {f.name: getattr(self, f.name) for f in fields(self) if f.name not in self._META}
        return atomic_save(path, lambda tmp: np.savez(tmp, meta=np.array(json.dumps(meta, sort_keys=True)),
                                                      **arrays))

    @classmethod
    def load(cls, path: str | os.PathLike) -> "BlockTessellation":
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            arrays = {k: data[k] for k in data.files if k != "meta"}
        return cls(**meta, **arrays)


# ----------------------------------------------------------------------------- pure helpers
def wrap(points: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """Points wrapped into ``[0, L)`` in each direction."""
    w = np.mod(points, lengths)
    return np.where(w >= lengths, 0.0, w)  # mod of a tiny negative number rounds up to L


def block_key(lengths: np.ndarray, n_cells: int, seed: int, tol: float, max_iter: int,
              min_face_area_rel: float, initial_seeds: np.ndarray | None = None) -> str:
    """Hash of everything that determines a block (box, n_cells, seed, tolerances, algorithm
    version; the initial seeds when given): 16 hex digits of SHA-256."""
    blob = json.dumps({"lengths": [float(x) for x in lengths], "n_cells": int(n_cells), "seed": int(seed),
                       "tol": float(tol), "max_iter": int(max_iter),
                       "min_face_area_rel": float(min_face_area_rel), "version": ALGORITHM_VERSION},
                      sort_keys=True).encode()
    if initial_seeds is not None:
        blob += np.ascontiguousarray(initial_seeds, dtype="<f8").tobytes()
    return hashlib.sha256(blob).hexdigest()[:16]


def periodic_images(seeds: np.ndarray, lengths: np.ndarray, margin: float
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The seeds followed by their images ``x + s L`` (s != 0) within ``margin`` of the box.

    Returns (sites (p, 3), source seed of each site (p,), integer shift of each site (p, 3));
    the first n sites are the seeds themselves with shift 0.
    """
    n = len(seeds)
    reach = np.ceil(margin / lengths).astype(int)
    shifts = np.array(list(itertools.product(*(range(-k, k + 1) for k in reach))))
    shifts = shifts[np.any(shifts != 0, axis=1)]
    images = seeds[None, :, :] + (shifts * lengths)[:, None, :]
    near = np.all((images >= -margin) & (images <= lengths + margin), axis=2)
    s_idx, src = np.nonzero(near)
    return (np.vstack([seeds, images[s_idx, src]]), np.r_[np.arange(n), src],
            np.vstack([np.zeros((n, 3), dtype=np.int64), shifts[s_idx]]))


# ------------------------------------------------------------------------ periodic diagram
@dataclass
class _Ridges:
    """Voronoi ridges with at least one real seed: ``points`` (r, 2) into ``sites``, vertex
    loops counter-clockwise about ``sites[points[:, 1]] - sites[points[:, 0]]``, flat with
    ``ptr``; ``extent`` (n,) of every real cell; the margin that made the diagram exact."""

    sites: np.ndarray
    src: np.ndarray
    shift: np.ndarray
    points: np.ndarray
    ptr: np.ndarray
    verts: np.ndarray
    vor_vertices: np.ndarray
    extent: np.ndarray
    margin: float


def _periodic_voronoi(seeds: np.ndarray, lengths: np.ndarray, margin: float) -> _Ridges:
    """The exact periodic Voronoi ridges of the seeds (margin check in the module docstring)."""
    n = len(seeds)
    for _ in range(MAX_MARGIN_TRIES):
        sites, src, shift = periodic_images(seeds, lengths, margin)
        vor = Voronoi(sites)
        rp = vor.ridge_points
        keep = np.flatnonzero(rp.min(axis=1) < n)
        rv = vor.ridge_vertices
        counts = np.fromiter((len(rv[k]) for k in keep), dtype=np.int64, count=len(keep))
        verts = np.fromiter(itertools.chain.from_iterable(rv[k] for k in keep), dtype=np.int64,
                            count=int(counts.sum()))
        ridge_of = np.repeat(np.arange(len(keep)), counts)
        points = rp[keep]
        extent = np.zeros(n)
        finite = verts >= 0
        for side in (0, 1):
            owner = points[ridge_of, side]
            real = owner < n
            dist = np.full(len(verts), np.inf)
            dist[finite] = np.linalg.norm(vor.vertices[verts[finite]] - sites[owner[finite]], axis=1)
            np.maximum.at(extent, owner[real], dist[real])
        ok, new_margin = _enough(extent, margin)
        if ok:
            # ridges of fewer than 3 vertices (an edge or a point) are not faces
            face = counts >= 3
            sel = face[ridge_of]
            ridge_of = np.repeat(np.arange(face.sum()), counts[face])
            verts, points, counts = verts[sel], points[face], counts[face]
            order = _sort_loops(ridge_of, verts, vor.vertices, sites[points[:, 1]] - sites[points[:, 0]],
                                len(points))
            return _Ridges(sites=sites, src=src, shift=shift, points=points,
                           ptr=np.concatenate([[0], np.cumsum(counts)]), verts=verts[order],
                           vor_vertices=vor.vertices, extent=extent, margin=float(margin))
        margin = new_margin
    raise RuntimeError(f"could not build the periodic Voronoi diagram of {n} seeds in a box "
                       f"{tuple(lengths)} (margin up to {margin:.4g})")


def _cell_rows(ridges: _Ridges, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One row per face per real cell: (ridge, cell, other site, flat positions into
    ``ridges.verts`` of the loop counter-clockwise from outside the cell, loop ptr)."""
    pa, pb = ridges.points[:, 0], ridges.points[:, 1]
    side_a, side_b = np.flatnonzero(pa < n), np.flatnonzero(pb < n)
    ridge = np.concatenate([side_a, side_b])
    cell = np.concatenate([pa[side_a], pb[side_b]])
    other = np.concatenate([pb[side_a], pa[side_b]])
    # loops run ccw about b - a: outward for a, reversed for b
    reverse = np.concatenate([np.zeros(len(side_a), bool), np.ones(len(side_b), bool)])
    pos, ptr = _loop_positions(ridges.ptr, ridge, reverse)
    return ridge, cell, other, pos, ptr


def _volumes_centroids(ridges: _Ridges, seeds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Volume and mass centroid of every cell: each face fanned into triangles, each a
    tetrahedron with the cell's seed (inside its convex cell, so every volume is positive)."""
    n = len(seeds)
    _, cell, _, pos, ptr = _cell_rows(ridges, n)
    x = ridges.vor_vertices[ridges.verts[pos]]
    loop, i0, i1, i2 = _fan(ptr)
    owner = cell[loop]
    s = seeds[owner]
    a, b, c = x[i0], x[i1], x[i2]
    v6 = np.einsum("ij,ij->i", a - s, np.cross(b - s, c - s)) / 6.0
    vol = np.bincount(owner, weights=v6, minlength=n)
    cen = (s + a + b + c) / 4.0
    mom = np.stack([np.bincount(owner, weights=v6 * cen[:, k], minlength=n) for k in range(3)], axis=1)
    return vol, mom / vol[:, None]


def _enough(extent: np.ndarray, margin: float) -> tuple[bool, float]:
    """Whether a diagram built with ``margin`` is exact for cells of these extents, and the
    margin to retry with when it is not (module docstring)."""
    if not np.all(np.isfinite(extent)):
        return False, 2.0 * margin
    return 2.0 * extent.max() <= margin, 2.0 * REACH_MARGIN * extent.max()


def _lloyd_step(seeds: np.ndarray, lengths: np.ndarray, margin: float
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Volume, mass centroid and extent of every periodic cell from the Delaunay
    tetrahedralisation of the seeds and their images (twice as fast as Qhull's Voronoi).

    The Voronoi ridge of the Delaunay edge pq is the polygon of the circumcentres of the
    tetrahedra around pq, so the cell of p is the sum over its triangles pqr of the signed
    tetrahedra (p, (p + q)/2, c-, c+) (derivation in ``tessellation._lloyd_step``, which clips
    instead of wrapping). Periodic images are translates, so four sites are cospherical only
    for special layouts (a lattice); there Qhull's triangulation can hold flat tetrahedra,
    caught as non-finite circumcentres or volumes that do not fill the box: returns None and
    the caller uses the Voronoi diagram.
    """
    n = len(seeds)
    for _ in range(MAX_MARGIN_TRIES):
        pts, _, _ = periodic_images(seeds, lengths, margin)
        tri = Delaunay(pts)
        simp, nb = tri.simplices, tri.neighbors
        with np.errstate(divide="ignore", invalid="ignore"):
            cc = _circumcentres(pts[simp])
        # only tetrahedra with a seed matter (images alone can be flat: a seed's images
        # two periods apart are collinear when the margin exceeds the box)
        if not np.all(np.isfinite(cc[simp.min(axis=1) < n])):
            return None
        extent = np.zeros(n)
        real = simp < n
        np.maximum.at(extent, simp[real], np.linalg.norm(cc[np.nonzero(real)[0]] - pts[simp[real]], axis=1))
        ht, hi = np.nonzero(nb < 0)
        on_hull = simp[ht[:, None], _OTHER[hi]]
        extent[on_hull[on_hull < n]] = np.inf  # an unbounded cell
        ok, new_margin = _enough(extent, margin)
        if ok:
            break
        margin = new_margin
    else:
        return None
    vol, mom = _voronoi_volumes(pts, simp, nb, cc, n)
    box = float(np.prod(lengths))
    if np.any(vol <= 0.0) or abs(vol.sum() - box) > 1e-9 * box:
        return None
    return vol, mom / vol[:, None], extent


# ---------------------------------------------------------------------------------- Lloyd
def periodic_cvt(lengths, n_cells: int, seed: int, tol: float = 2e-3, max_iter: int = 400,
                 initial_seeds: np.ndarray | None = None,
                 min_face_area_rel: float = 1e-10) -> BlockTessellation:
    """Periodic centroidal Voronoi tessellation of the box ``[0, L)`` (``lengths`` (3,)) into
    ``n_cells`` cells (SPEC 1.1 Lloyd's method with periodic images; module docstring).

    Seeds start uniform at random (``default_rng(seed)``), or at ``initial_seeds`` (n, 3)
    (wrapped into the box; ``seed`` is then recorded as -1). Lloyd steps stop when the RMS
    seed step is below ``tol * h`` (h = mean cell size) or after ``max_iter`` steps
    (``max_iter = 0``: the periodic Voronoi tessellation of the initial seeds). Faces below
    ``min_face_area_rel`` times the mean face area are dropped as degenerate.
    """
    lengths = np.asarray(lengths, dtype=float).reshape(3)
    if np.any(lengths <= 0):
        raise ValueError(f"box lengths must be > 0, got {tuple(lengths)}")
    if n_cells < 1:
        raise ValueError(f"n_cells must be >= 1, got {n_cells}")
    if not (tol > 0 and max_iter >= 0):
        raise ValueError(f"need tol > 0 and max_iter >= 0, got tol={tol}, max_iter={max_iter}")
    if initial_seeds is not None:
        given = np.array(initial_seeds, dtype=float).reshape(-1, 3)
        if len(given) != n_cells:
            raise ValueError(f"{len(given)} initial seeds for n_cells = {n_cells}")
        seeds, seed = wrap(given, lengths), -1
    else:
        seeds = np.random.default_rng(seed).random((n_cells, 3)) * lengths
        seeds = wrap(seeds, lengths)  # random() * L can round up to L
    h = (np.prod(lengths) / n_cells) ** (1.0 / 3.0)
    margin = FIRST_MARGIN_REL * h
    residuals = []
    for _ in range(max_iter):
        fast = _lloyd_step(seeds, lengths, margin)
        if fast is None:
            ridges = _periodic_voronoi(seeds, lengths, margin)
            _, centroids = _volumes_centroids(ridges, seeds)
            extent = ridges.extent
        else:
            _, centroids, extent = fast
        # the centroid of a seed's own cell: the step is already the minimum-image one
        step = np.linalg.norm(centroids - seeds, axis=1)
        residuals.append(float(np.sqrt(np.mean(step**2))) / h)
        # the next cells are at most a little larger than these, moved by the seeds' steps
        margin = 2.0 * (REACH_MARGIN * extent.max() + step.max())
        seeds = wrap(centroids, lengths)
        if residuals[-1] < tol:
            break
    key = block_key(lengths, n_cells, seed, tol, max_iter, min_face_area_rel,
                    None if initial_seeds is None else np.asarray(initial_seeds, dtype=float))
    arrays = _build(seeds, lengths, _periodic_voronoi(seeds, lengths, margin), min_face_area_rel)
    return BlockTessellation(n_cells=int(n_cells), seed=int(seed), tol=float(tol), max_iter=int(max_iter),
                             min_face_area_rel=float(min_face_area_rel), key=key, n_iter=len(residuals),
                             converged=bool(residuals and residuals[-1] < tol), lengths=lengths,
                             residuals=np.asarray(residuals, dtype=float), **arrays)


# -------------------------------------------------------------------------- final geometry
def _build(seeds: np.ndarray, lengths: np.ndarray, ridges: _Ridges, min_face_area_rel: float) -> dict:
    """Cells, faces and interfaces of the final periodic diagram (flat arrays)."""
    n = len(seeds)
    ridge, cell, other, pos, ptr = _cell_rows(ridges, n)
    vid = ridges.verts[pos]
    x = ridges.vor_vertices[vid]
    j = ridges.src[other]
    shift = ridges.shift[other]  # the cell's own site has shift 0
    d = ridges.sites[other] - seeds[cell]
    normal = d / np.linalg.norm(d, axis=1, keepdims=True)
    offset = np.einsum("ij,ij->i", normal, seeds[cell] + 0.5 * d)
    row_of = np.repeat(np.arange(len(cell)), np.diff(ptr))
    nxt = np.where(np.arange(len(vid)) + 1 == ptr[row_of + 1], ptr[row_of], np.arange(len(vid)) + 1)
    cr = np.cross(x, x[nxt])  # Newell: loops are ccw about the outward normal
    area = 0.5 * np.einsum("ij,ij->i", np.stack([np.bincount(row_of, weights=cr[:, k], minlength=len(cell))
                                                  for k in range(3)], axis=1), normal)
    keep = area > min_face_area_rel * area.mean()

    # rows ordered by (cell, neighbour, shift); shifts coded in mixed radix (monotone in lex order)
    big = int(np.abs(shift).max()) if len(shift) else 0
    base = 2 * big + 1
    code = ((shift[:, 0] + big) * base + (shift[:, 1] + big)) * base + (shift[:, 2] + big)
    anti = ((big - shift[:, 0]) * base + (big - shift[:, 1])) * base + (big - shift[:, 2])
    rows = np.flatnonzero(keep)
    rows = rows[np.lexsort((code[rows], j[rows], cell[rows]))]
    cell, j, shift, code, anti = cell[rows], j[rows], shift[rows], code[rows], anti[rows]
    normal, offset, area = normal[rows], offset[rows], area[rows]
    pos, face_ptr = _loop_positions(ptr, rows, np.zeros(len(rows), bool))
    vid, x = vid[pos], x[pos]

    # partner rows: (j, i, -s) for (i, j, s); the keys are sorted already
    cube = base**3
    key = (cell * n + j) * cube + code
    want = (j * n + cell) * cube + anti
    partner = np.searchsorted(key, want)
    found = partner < len(key)
    found[found] &= key[partner[found]] == want[found]
    if not np.all(found):
        a = int(np.flatnonzero(~found)[0])
        raise RuntimeError(f"{(~found).sum()} faces of the periodic block have no partner (first: cell "
                           f"{cell[a]}, neighbour {j[a]}, shift {tuple(shift[a])}, area {area[a]:.3e})")
    owner = (cell < j) | ((cell == j) & (code > big * (base * base + base + 1)))
    iface_rows = np.flatnonzero(owner)
    face_interface = np.full(len(rows), -1)
    face_interface[iface_rows] = np.arange(len(iface_rows))
    face_interface[partner[iface_rows]] = np.arange(len(iface_rows))

    # per-cell vertex copies: unique (cell, Voronoi vertex) pairs, grouped by cell
    entry_cell = np.repeat(cell, np.diff(face_ptr))
    n_vor = len(ridges.vor_vertices)
    uniq, face_vertices = np.unique(entry_cell * n_vor + vid, return_inverse=True)
    vertices = ridges.vor_vertices[uniq % n_vor]
    cell_vertex_ptr = np.concatenate([[0], np.cumsum(np.bincount(uniq // n_vor, minlength=n))])

    # mass properties: fan every face, reference point = the cell's seed (inside the cell)
    loop, i0, i1, i2 = _fan(face_ptr)
    volume, centroid, inertia = tetra_mass_properties(cell[loop], seeds, x[i0], x[i1], x[i2], n)
    moments, axes = principal_axes(inertia)

    # interfaces: the owner row's loop, ccw about the normal from i to the image of j
    ipos, iface_ptr = _loop_positions(face_ptr, iface_rows, np.zeros(len(iface_rows), bool))
    loop, i0, i1, i2 = _fan(iface_ptr)
    p0, p1, p2 = x[ipos][i0], x[ipos][i1], x[ipos][i2]
    w = np.linalg.norm(np.cross(p1 - p0, p2 - p0), axis=1)
    m = len(iface_rows)
    iface_centroid = (np.stack([np.bincount(loop, weights=w * (p0 + p1 + p2)[:, k] / 3.0, minlength=m)
                                for k in range(3)], axis=1)
                      / np.bincount(loop, weights=w, minlength=m)[:, None])
    return dict(
        seeds=seeds, volume=volume, centroid=centroid, inertia=inertia, principal_moments=moments,
        principal_axes=axes, quaternion=rotation_to_quaternion(axes), cell_vertex_ptr=cell_vertex_ptr,
        vertices=vertices, cell_face_ptr=np.concatenate([[0], np.cumsum(np.bincount(cell, minlength=n))]),
        face_cell=cell, face_neighbor=j, face_shift=shift.astype(np.int64), face_interface=face_interface,
        face_partner=partner, face_normal=normal, face_offset=offset, face_area=area, face_ptr=face_ptr,
        face_vertices=face_vertices.astype(np.int64),
        iface_cells=np.c_[cell[iface_rows], j[iface_rows]].reshape(-1, 2),
        iface_shift=shift[iface_rows].astype(np.int64).reshape(-1, 3),
        iface_faces=np.c_[iface_rows, partner[iface_rows]].reshape(-1, 2), iface_area=area[iface_rows],
        iface_normal=normal[iface_rows].reshape(-1, 3), iface_centroid=iface_centroid.reshape(-1, 3),
        iface_ptr=iface_ptr, iface_vertices=face_vertices[ipos].astype(np.int64),
    )


# -------------------------------------------------------------------------------- caching
def cached_periodic_cvt(lengths, n_cells: int, seed: int, tol: float = 2e-3, max_iter: int = 400,
                        cache_dir: str | os.PathLike | None = None,
                        min_face_area_rel: float = 1e-10) -> BlockTessellation:
    """``periodic_cvt(...)``, read from ``cache_dir/block_<key>.npz`` when present, computed
    and written there otherwise (key: ``block_key``). Default ``cache_dir``:
    ``driver.cache.cache_base() / "blocks"``."""
    if cache_dir is None:
        from driver.cache import cache_base  # the project's one cache location
        cache_dir = cache_base() / "blocks"
    lengths = np.asarray(lengths, dtype=float).reshape(3)
    key = block_key(lengths, n_cells, seed, tol, max_iter, min_face_area_rel)
    path = Path(cache_dir) / f"block_{key}.npz"
    if path.exists():
        block = BlockTessellation.load(path)
        if block.key == key:
            return block
    block = periodic_cvt(lengths, n_cells, seed, tol=tol, max_iter=max_iter, min_face_area_rel=min_face_area_rel)
    block.save(path)
    return block
