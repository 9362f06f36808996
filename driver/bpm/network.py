"""Bond and angle network of the BPM solid from a periodic Delaunay triangulation (SPEC 2.1).

Periodic Delaunay: the points within a margin of the box faces are replicated as periodic
images, scipy's Delaunay triangulates originals + images, and the simplices with at least
one original vertex are kept, their image vertices mapped back to the originals. A kept
simplex is a true simplex of the periodic triangulation when its empty circumsphere lies
inside the replicated region (no point outside the region can then fall inside it); this is
checked, and the margin doubled until it holds.

Bonds are the Delaunay edges (3D: only those shorter than max_length, default 5/4 a on the
`contact` packing and 5/4 * 2^(1/6) a on `lj_minimum`; see driver/bpm/section.py).
Angles come from the unique triangles (2D: the Delaunay triangles; 3D: the triangular faces
of the tetrahedra): one angle at each vertex whose two arms are both kept bonds.
Lengths and angles use the minimum-image convention.

On a periodic 2D triangulation (a torus, Euler characteristic 0) E = 3N and F = 2N exactly,
hence 6 bonds and 6 angles per particle; in 3D the pruning of long edges leaves about 11
bonds and 24 angles per particle on a jammed packing.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy.spatial import Delaunay

from driver.bpm.packing import Packing
from driver.bpm.section import MAX_BOND_LENGTH_3D  # noqa: F401 (re-exported: the default lives with the config)

#: SPEC 2.1: in 3D only Delaunay edges shorter than 5/4 * 2^(1/6) a become bonds: read literally
#: on the `lj_minimum` packing (nearest neighbours at about 2^(1/6) a); the same edges are those
#: shorter than 5/4 a on the `contact` packing, 2^(1/6) times smaller (MAX_BOND_LENGTH_3D).

#: Smallest box edge, in largest diameters, for which minimum images are unambiguous.
MIN_BOX_DIAMETERS = 4.0


@dataclass
class Network:
    """Bonds and three-body angles of a packing (0-based atom indices).

    bonds: (Nb, 2) int64, i < j, sorted lexicographically, unique.
    r0: (Nb,) bond lengths (minimum image).
    angles: (Na, 3) int64 rows (i, vertex, k), i < k, sorted by (vertex, i, k), unique.
    theta0: (Na,) angles in radians, in (0, pi).
    n_atoms: number of particles N.
    """

    bonds: np.ndarray
    r0: np.ndarray
    angles: np.ndarray
    theta0: np.ndarray
    n_atoms: int

    @property
    def n_bonds(self) -> int:
        return len(self.bonds)

    @property
    def n_angles(self) -> int:
        return len(self.angles)

    @property
    def bonds_per_particle(self) -> float:
        """Mean coordination 2 Nb / N (each bond has two ends)."""
        return 2.0 * self.n_bonds / self.n_atoms

    @property
    def angles_per_particle(self) -> float:
        """Na / N (each angle has one vertex)."""
        return self.n_angles / self.n_atoms


def minimum_image(d: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """Separation vectors d (..., dim) folded to the nearest periodic image."""
    return d - lengths * np.round(d / lengths)


def delaunay_network(packing: Packing, max_length: float | None) -> Network:
    """Bonds (Delaunay edges shorter than max_length; None keeps all) and angles of a packing.

    SPEC 2.1: pass max_length=None in 2D and the model's bond_max_length in 3D.
    Raises ValueError for a box edge shorter than MIN_BOX_DIAMETERS largest diameters.
    """
    dim = packing.dimension
    if dim not in (2, 3):
        raise ValueError(f"dimension must be 2 or 3, got {dim}")
    n = packing.n
    L = np.asarray(packing.lengths, dtype=np.float64)
    dmax = 2.0 * float(np.max(packing.radii))
    if np.any(L < MIN_BOX_DIAMETERS * dmax):
        raise ValueError(
            f"box edges {L.tolist()} shorter than {MIN_BOX_DIAMETERS:g} diameters "
            f"({MIN_BOX_DIAMETERS * dmax:g}): minimum images are ambiguous")
    if n <= dim + 1:
        raise ValueError(f"{n} particles are too few for a {dim}D triangulation")

    x = np.mod(packing.positions[:, :dim] - packing.box[0][:dim], L)
    x[x >= L] = 0.0  # mod rounds tiny negative offsets up to L
    ext, origin, simp_ext = _periodic_simplices(x, L, dmax)
    simplices = origin[simp_ext]

    # Edges: every vertex pair of every kept simplex, mapped to originals and deduplicated.
    pairs = np.array(list(itertools.combinations(range(dim + 1), 2)))
    true_vec = ext[simp_ext[:, pairs[:, 1]]] - ext[simp_ext[:, pairs[:, 0]]]
    if np.any(np.abs(true_vec) >= 0.5 * L):
        raise ValueError("a Delaunay edge spans half the box: minimum image would shorten it; "
                         "use a larger box")
    edges = np.sort(simplices[:, pairs].reshape(-1, 2), axis=1)
    edges = _unique_rows(edges)
    if np.any(edges[:, 0] == edges[:, 1]):
        raise ValueError("a particle is joined to its own image: box too small")
    r0 = np.linalg.norm(minimum_image(x[edges[:, 1]] - x[edges[:, 0]], L), axis=1)
    if max_length is not None:
        keep = r0 < max_length
        edges, r0 = edges[keep], r0[keep]

    # Triangles: 2D the simplices themselves, 3D the four faces of each tetrahedron.
    faces = np.array(list(itertools.combinations(range(dim + 1), 3)))
    tri = _unique_rows(np.sort(simplices[:, faces].reshape(-1, 3), axis=1))

    # Candidate angle at each corner of each triangle: (arm, vertex, arm) with arms sorted.
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    cand = np.concatenate([np.stack([b, a, c], axis=1),
                           np.stack([a, b, c], axis=1),
                           np.stack([a, c, b], axis=1)])
    ok = _is_bond(edges, n, cand[:, 0], cand[:, 1]) & _is_bond(edges, n, cand[:, 1], cand[:, 2])
    angles = cand[ok]
    angles = _unique_rows(angles[:, [1, 0, 2]])[:, [1, 0, 2]]  # sorted by (vertex, i, k)
    u = minimum_image(x[angles[:, 0]] - x[angles[:, 1]], L)
    w = minimum_image(x[angles[:, 2]] - x[angles[:, 1]], L)
    cos = np.einsum("ij,ij->i", u, w) / (np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1))
    theta0 = np.arccos(np.clip(cos, -1.0, 1.0))

    return Network(bonds=edges, r0=r0, angles=angles, theta0=theta0, n_atoms=n)


def _periodic_simplices(x: np.ndarray, L: np.ndarray, dmax: float
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Simplices of the periodic Delaunay triangulation touching an original point.

    Returns (ext, origin, simplices): the replicated points (P, dim), the original index of
    each (P,), and the kept simplices (M, dim + 1) as indices into ext (see module docstring).
    """
    n = len(x)
    margin = 2.5 * dmax  # a jammed packing's circumradii are below one diameter
    while True:
        margin = min(margin, float(L.min()))  # images of one neighbouring box at most
        ext, origin = _replicate(x, L, margin)
        tri = Delaunay(ext)
        simp = tri.simplices[np.any(tri.simplices < n, axis=1)]
        if _inside_region(ext[simp], L, margin):
            return ext, origin, simp
        if margin >= L.min():
            raise ValueError("periodic Delaunay triangulation needs images beyond one box: "
                             "packing too sparse for its box")
        margin *= 2.0


def _replicate(x: np.ndarray, L: np.ndarray, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """Originals followed by the periodic images lying within margin of the box; with the
    original index of each point."""
    n, dim = x.shape
    pts, origin = [x], [np.arange(n)]
    for shift in itertools.product((-1, 0, 1), repeat=dim):
        if not any(shift):
            continue
        y = x + np.array(shift) * L
        m = np.all((y >= -margin) & (y < L + margin), axis=1)
        pts.append(y[m])
        origin.append(np.nonzero(m)[0])
    return np.concatenate(pts), np.concatenate(origin)


def _inside_region(verts: np.ndarray, L: np.ndarray, margin: float) -> bool:
    """Whether every non-degenerate simplex (M, dim+1, dim) has its circumsphere inside the
    replicated region [-margin, L + margin]^dim.

    Zero-volume simplices (qhull's triangulation of cospherical points, e.g. a lattice) have
    no finite circumsphere; they lie inside the circumspheres of their non-degenerate
    neighbours, which are checked.
    """
    p0 = verts[:, 0]
    D = verts[:, 1:] - p0[:, None, :]                      # (M, dim, dim)
    rhs = 0.5 * np.einsum("mij,mij->mi", D, D)             # |c - p0| = |c - pi|: D c' = |D|^2/2
    det = np.linalg.det(D)
    scale = np.max(np.abs(D), axis=(1, 2)) ** D.shape[1]
    good = np.abs(det) > 1e-10 * scale
    c = np.linalg.solve(D[good], rhs[good][..., None])[..., 0]
    radius = np.linalg.norm(c, axis=1)
    centre = c + p0[good]
    return bool(np.all(centre - radius[:, None] >= -margin)
                and np.all(centre + radius[:, None] <= L + margin))


def _unique_rows(rows: np.ndarray) -> np.ndarray:
    """Unique rows of an int array, sorted lexicographically."""
    if len(rows) == 0:
        return rows.astype(np.int64)
    rows = rows[np.lexsort(rows.T[::-1])]
    new = np.concatenate([[True], np.any(rows[1:] != rows[:-1], axis=1)])
    return rows[new].astype(np.int64)


def _is_bond(bonds: np.ndarray, n: int, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Whether each pair (i, j) is a bond; bonds sorted lexicographically with i < j."""
    keys = bonds[:, 0] * n + bonds[:, 1]
    q = np.minimum(i, j) * n + np.maximum(i, j)
    pos = np.clip(np.searchsorted(keys, q), 0, max(len(keys) - 1, 0))
    return (len(keys) > 0) & (keys[pos] == q)


def repulsion_at_break(r0: np.ndarray, abar: np.ndarray | float, lambda_c: float) -> tuple[int, float, float]:
    """Bonds that break inside the non-bonded repulsion (SPEC 2.2: Eq. 1 acts on pairs not
    bonded): a bond breaks at r = lambda_c r0, and where that is below abar (the pair's sum of
    radii, bonded neighbours that overlap in the packing) its break switches Eq. 1 on with the
    energy U_NB(r) = u [(abar/r)^12 - 2 (abar/r)^6 + 1] > 0, which nothing supplied: energy is
    created. Returns (how many bonds, the largest U_NB per break, the sum over them) in u."""
    r = lambda_c * np.asarray(r0, float)
    ab = np.broadcast_to(np.asarray(abar, float), r.shape)
    inside = r < ab
    q6 = (ab[inside] / r[inside]) ** 6
    u = q6 * q6 - 2.0 * q6 + 1.0
    return int(inside.sum()), float(u.max()) if len(u) else 0.0, float(u.sum())
