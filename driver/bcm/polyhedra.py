"""Convex polyhedra for BCM: the parent shapes (SPEC 1.1) and the geometry shared with the cells.

A convex polyhedron is held both ways: as a set of half-spaces ``n_k . x <= h_k`` (unit
outward normals ``n_k``, offsets ``h_k``) and as vertices plus faces, each face a vertex-index
loop ordered counter-clockwise seen from outside (so the right-hand rule gives the outward
normal). Vertices are always rebuilt from the half-spaces, never moved.

Parent shapes, all centred on their centroid at the origin:

- ``truncated_pentakis_dodecahedron`` — the Goldberg polyhedron GP(3,0), 92 faces. Built as
  the intersection of 92 half-spaces (construction and the conditions that fix its free
  parameters in that function's docstring).
- ``cube`` — a cube of given side.
- ``icosphere_like`` — a sphere-like polyhedron: the convex hull of a subdivided icosahedron
  projected on the sphere.

Sizes: ``diameter_kind="circumscribed"`` scales to ``d = 2 max |vertex|`` (the smallest
sphere about the centre holding the shape); ``"equal_volume"`` to the sphere of equal volume,
``V = pi d^3 / 6``.

Mass properties (unit density) come from a tetrahedral decomposition: each face is fanned
into triangles ``(a, b, c)`` that form, with a reference point ``r``, tetrahedra of signed
volume ``V_t = det(a - r, b - r, c - r) / 6`` (positive for outward-ordered faces). With
``y_i`` the four corners relative to ``r`` (``y_0 = 0``) and ``s = sum_i y_i``,

    int x dV   = V_t s / 4,
    int x x^T dV = V_t / 20 (sum_i y_i y_i^T + s s^T)         (Tonon 2004, exact),

summed over tetrahedra; the second moment ``C`` is moved to the centroid ``g`` with
``C_g = C - V g g^T`` and the inertia tensor is ``I = tr(C_g) 1 - C_g``.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from scipy.optimize import fsolve, linprog
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import ConvexHull, HalfspaceIntersection, cKDTree

DiameterKind = Literal["circumscribed", "equal_volume"]
GOLDEN = (1.0 + math.sqrt(5.0)) / 2.0


# ------------------------------------------------------------------------ polygons, polyhedra
def polygon_vector_area(points: np.ndarray) -> np.ndarray:
    """Vector area (Newell) of a closed planar loop ``(n, 3)``: area times the right-hand normal."""
    p = np.asarray(points, dtype=float)
    return 0.5 * np.cross(p, np.roll(p, -1, axis=0)).sum(axis=0)


def order_loop(points: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Indices that order coplanar points of a convex polygon counter-clockwise about ``normal``."""
    p = np.asarray(points, dtype=float)
    n = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    q = p - p.mean(axis=0)
    return np.argsort(np.arctan2(q @ v, q @ u), kind="stable")


def merge_close_points(points: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Merge points closer than ``tol`` (transitively). Returns (unique points, old -> new index).

    Each group is represented by its lowest-index member, so the result is deterministic.
    """
    p = np.asarray(points, dtype=float)
    n = len(p)
    pairs = cKDTree(p).query_pairs(tol, output_type="ndarray")
    if len(pairs) == 0:
        return p.copy(), np.arange(n)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    # relabel groups in order of their first member
    first = np.full(label.max() + 1, n)
    np.minimum.at(first, label, np.arange(n))
    order = np.argsort(first)
    new_of_label = np.empty_like(order)
    new_of_label[order] = np.arange(len(order))
    mapping = new_of_label[label]
    return p[np.sort(first)], mapping


def chebyshev_center(normals: np.ndarray, offsets: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre and radius of the largest ball inside ``{x : n_k . x <= h_k}`` (unit normals)."""
    a = np.c_[np.asarray(normals, float), np.ones(len(offsets))]
    res = linprog(c=[0.0, 0.0, 0.0, -1.0], A_ub=a, b_ub=np.asarray(offsets, float),
                  bounds=[(None, None)] * 3 + [(0.0, None)], method="highs")
    if res.status != 0:
        raise ValueError(f"half-space set is empty or unbounded: {res.message}")
    return res.x[:3], float(res.x[3])


def halfspace_polyhedron(normals: np.ndarray, offsets: np.ndarray, interior: np.ndarray | None = None,
                         rel_tol: float = 1e-9) -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
    """Vertices and faces of the bounded polyhedron ``{x : n_k . x <= h_k}``.

    ``normals`` (F, 3) are unit outward normals. Vertices closer than ``rel_tol`` times the
    polyhedron's size are merged (several planes through one vertex); a plane is a face when at
    least three non-collinear vertices lie on it within that tolerance.

    Returns (vertices (V, 3), faces: list of index loops counter-clockwise seen from outside,
    plane index of each face (n_faces,)).
    """
    normals = np.asarray(normals, dtype=float)
    offsets = np.asarray(offsets, dtype=float)
    if interior is None:
        interior, radius = chebyshev_center(normals, offsets)
        if radius <= 0.0:
            raise ValueError("half-space set has no interior")
    interior = np.asarray(interior, dtype=float)
    if np.any(normals @ interior - offsets >= 0.0):
        raise ValueError("interior point is not strictly inside every half-space")
    hs = HalfspaceIntersection(np.c_[normals, -offsets], interior)
    pts = hs.intersections
    size = np.abs(pts - interior).max()
    tol = rel_tol * size
    pts, _ = merge_close_points(pts, tol)
    dist = pts @ normals.T - offsets
    faces, planes = [], []
    for k in range(len(normals)):
        idx = np.flatnonzero(np.abs(dist[:, k]) <= tol)
        if len(idx) < 3:
            continue
        loop = idx[order_loop(pts[idx], normals[k])]
        if polygon_vector_area(pts[loop]) @ normals[k] <= tol * size:
            continue  # the plane touches only an edge
        faces.append(loop)
        planes.append(k)
    used = np.unique(np.concatenate(faces))
    new = np.full(len(pts), -1)
    new[used] = np.arange(len(used))
    return pts[used], [new[f] for f in faces], np.asarray(planes)


def fan_triangles(faces: list[np.ndarray]) -> np.ndarray:
    """Triangles ``(T, 3)`` of vertex indices fanning each face loop from its first vertex."""
    tris = [np.c_[np.full(len(f) - 2, f[0]), f[1:-1], f[2:]] for f in faces]
    return np.concatenate(tris).astype(np.int64)


def tetra_mass_properties(owner: np.ndarray, ref: np.ndarray, a: np.ndarray, b: np.ndarray,
                          c: np.ndarray, n_owner: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Volume, centroid and inertia tensor about the centroid (unit density) of many polyhedra.

    Each row ``t`` is a tetrahedron ``(ref[owner[t]], a[t], b[t], c[t])`` counted with its signed
    volume towards polyhedron ``owner[t]``; ``ref`` (n_owner, 3) is one reference point per
    polyhedron (anywhere; a point near the polyhedron keeps round-off small). Formulas in the
    module docstring. Returns volume (n,), centroid (n, 3), inertia (n, 3, 3).
    """
    owner = np.asarray(owner, dtype=np.int64)
    r = ref[owner]
    ya, yb, yc = a - r, b - r, c - r
    vol_t = np.einsum("ij,ij->i", ya, np.cross(yb, yc)) / 6.0
    s = ya + yb + yc
    second = (np.einsum("ti,tj->tij", ya, ya) + np.einsum("ti,tj->tij", yb, yb)
              + np.einsum("ti,tj->tij", yc, yc) + np.einsum("ti,tj->tij", s, s))
    second *= (vol_t / 20.0)[:, None, None]
    vol = np.bincount(owner, weights=vol_t, minlength=n_owner)
    first = np.stack([np.bincount(owner, weights=vol_t * s[:, k] / 4.0, minlength=n_owner)
                      for k in range(3)], axis=1)
    c_ref = np.stack([np.bincount(owner, weights=second[:, i, j], minlength=n_owner)
                      for i in range(3) for j in range(3)], axis=1).reshape(n_owner, 3, 3)
    g = first / vol[:, None]
    c_g = c_ref - vol[:, None, None] * np.einsum("ni,nj->nij", g, g)
    inertia = np.trace(c_g, axis1=1, axis2=2)[:, None, None] * np.eye(3) - c_g
    return vol, ref + g, inertia


def polyhedron_mass_properties(vertices: np.ndarray, faces: list[np.ndarray]
                               ) -> tuple[float, np.ndarray, np.ndarray]:
    """Volume, centroid and inertia tensor about the centroid (unit density) of one polyhedron.

    Faces must be ordered counter-clockwise seen from outside.
    """
    v = np.asarray(vertices, dtype=float)
    t = fan_triangles(faces)
    vol, cen, inertia = tetra_mass_properties(np.zeros(len(t), dtype=np.int64), v.mean(axis=0)[None],
                                              v[t[:, 0]], v[t[:, 1]], v[t[:, 2]], 1)
    return float(vol[0]), cen[0], inertia[0]


def principal_axes(inertia: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments (ascending) and axes of inertia tensors ``(..., 3, 3)``.

    The axes are the columns of a proper rotation matrix ``R`` (det +1) mapping body (principal)
    coordinates to the lab frame: ``I_lab = R diag(moments) R^T``. Sign convention, for
    reproducibility: the largest-magnitude component of the first two axes is positive; the
    third is their cross product.
    """
    moments, axes = np.linalg.eigh(np.asarray(inertia, dtype=float))
    axes = axes.copy()
    for k in range(2):
        col = axes[..., :, k]
        big = np.take_along_axis(col, np.abs(col).argmax(axis=-1)[..., None], axis=-1)
        axes[..., :, k] = col * np.where(big < 0.0, -1.0, 1.0)
    axes[..., :, 2] = np.cross(axes[..., :, 0], axes[..., :, 1])
    return moments, axes


def rotation_to_quaternion(rot: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(w, x, y, z)``, ``w >= 0``, of rotation matrices ``(..., 3, 3)``.

    ``R`` acts on column vectors (``x_lab = R x_body``); Shepperd's method, branch on the
    largest of ``(tr R, R_xx, R_yy, R_zz)``.
    """
    r = np.asarray(rot, dtype=float)
    shape = r.shape[:-2]
    r = r.reshape(-1, 3, 3)
    q = np.empty((len(r), 4))
    tr = np.trace(r, axis1=1, axis2=2)
    diag = np.stack([tr, r[:, 0, 0], r[:, 1, 1], r[:, 2, 2]], axis=1)
    branch = diag.argmax(axis=1)
    for k in range(4):
        m = branch == k
        if not m.any():
            continue
        rr = r[m]
        if k == 0:
            w = 0.5 * np.sqrt(1.0 + tr[m])
            q[m] = np.stack([w, (rr[:, 2, 1] - rr[:, 1, 2]) / (4 * w), (rr[:, 0, 2] - rr[:, 2, 0]) / (4 * w),
                             (rr[:, 1, 0] - rr[:, 0, 1]) / (4 * w)], axis=1)
        else:
            i = k - 1
            j, l = (i + 1) % 3, (i + 2) % 3
            s = 0.5 * np.sqrt(1.0 + rr[:, i, i] - rr[:, j, j] - rr[:, l, l])
            qq = np.empty((m.sum(), 4))
            qq[:, 0] = (rr[:, l, j] - rr[:, j, l]) / (4 * s)
            qq[:, 1 + i] = s
            qq[:, 1 + j] = (rr[:, j, i] + rr[:, i, j]) / (4 * s)
            qq[:, 1 + l] = (rr[:, l, i] + rr[:, i, l]) / (4 * s)
            q[m] = qq
    q *= np.where(q[:, :1] < 0.0, -1.0, 1.0)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return q.reshape(shape + (4,))


# ------------------------------------------------------------------------------ ConvexShape
@dataclass(eq=False)
class ConvexShape:
    """A convex polyhedron, centroid at the origin.

    normals (F, 3) unit outward, offsets (F,) with the shape ``{x : normals @ x <= offsets}``;
    vertices (V, 3); faces[k] the vertex loop of plane k, counter-clockwise seen from outside;
    volume, centroid (3,); ``params`` the arguments that rebuild it (``build_shape(**params)``),
    also the shape's part of a tessellation cache key.
    """

    normals: np.ndarray
    offsets: np.ndarray
    vertices: np.ndarray
    faces: list[np.ndarray]
    volume: float
    centroid: np.ndarray
    params: dict = field(default_factory=dict)

    def contains(self, points: np.ndarray, tol: float = 0.0) -> np.ndarray:
        """Boolean mask of points ``(..., 3)`` with ``n_k . x <= h_k + tol`` for every face."""
        p = np.asarray(points, dtype=float)
        return np.all(p @ self.normals.T <= self.offsets + tol, axis=-1)

    @property
    def edges(self) -> np.ndarray:
        """Undirected edges ``(E, 2)``, ``i < j``, each once."""
        e = np.concatenate([np.c_[f, np.roll(f, -1)] for f in self.faces])
        return np.unique(np.sort(e, axis=1), axis=0)

    @property
    def circumscribed_diameter(self) -> float:
        return 2.0 * float(np.linalg.norm(self.vertices, axis=1).max())

    @property
    def equal_volume_diameter(self) -> float:
        return (6.0 * self.volume / math.pi) ** (1.0 / 3.0)


def _shape_from_halfspaces(normals: np.ndarray, offsets: np.ndarray, params: dict) -> ConvexShape:
    """Build a ConvexShape from half-spaces and move it so its centroid is the origin."""
    verts, faces, planes = halfspace_polyhedron(normals, offsets)
    if len(planes) != len(normals):
        raise ValueError(f"{len(normals) - len(planes)} redundant planes in the parent shape")
    vol, cen, _ = polyhedron_mass_properties(verts, faces)
    offsets = offsets - normals @ cen
    verts = verts - cen
    return ConvexShape(normals=normals, offsets=offsets, vertices=verts, faces=faces, volume=vol,
                       centroid=np.zeros(3), params=params)


def _scaled(shape: ConvexShape, diameter: float, diameter_kind: DiameterKind) -> ConvexShape:
    """Scale a shape (centroid at the origin) to the requested diameter."""
    if not diameter > 0.0:
        raise ValueError(f"diameter must be > 0, got {diameter!r}")
    if diameter_kind == "circumscribed":
        s = diameter / shape.circumscribed_diameter
    elif diameter_kind == "equal_volume":
        s = diameter / shape.equal_volume_diameter
    else:
        raise ValueError(f"diameter_kind must be 'circumscribed' or 'equal_volume', got {diameter_kind!r}")
    return ConvexShape(normals=shape.normals.copy(), offsets=shape.offsets * s, vertices=shape.vertices * s,
                       faces=[f.copy() for f in shape.faces], volume=shape.volume * s**3,
                       centroid=np.zeros(3), params=dict(shape.params))


# --------------------------------------------------------------------- the GP(3,0) parent
def icosahedron() -> tuple[np.ndarray, np.ndarray]:
    """Unit vertex directions (12, 3) and faces (20, 3) of the regular icosahedron."""
    v = []
    for s1 in (-1.0, 1.0):
        for s2 in (-1.0, 1.0):
            v += [(0.0, s1, s2 * GOLDEN), (s1, s2 * GOLDEN, 0.0), (s2 * GOLDEN, 0.0, s1)]
    v = np.array(v) / math.hypot(1.0, GOLDEN)
    dots = v @ v.T
    adj = dots > 0.4  # neighbours: cos = 1/sqrt5 = 0.447; next shell: -0.447
    faces = sorted({tuple(sorted((i, j, k))) for i in range(12) for j in range(12) for k in range(12)
                    if adj[i, j] and adj[j, k] and adj[i, k] and i != j != k != i})
    return v, np.array(faces)


def _gp30_planes(theta: float, h6: float, h60: float) -> tuple[np.ndarray, np.ndarray]:
    """The 92 half-spaces of GP(3,0) for the kis angle ``theta`` and offsets (pentagon offset 1).

    Order: 12 pentagons (icosahedron vertex directions), 20 regular hexagons (icosahedron face
    centres = dodecahedron vertex directions), 60 hexagons, one per directed icosahedron edge
    A -> B, normal ``cos(theta) A + sin(theta) t_AB`` with ``t_AB`` the unit tangent at A
    towards B (the face normals of a pentakis dodecahedron; theta fixes the kis height).
    """
    v, faces = icosahedron()
    n5 = v
    n6 = v[faces].sum(axis=1)
    n6 /= np.linalg.norm(n6, axis=1, keepdims=True)
    adj = (v @ v.T) > 0.4
    np.fill_diagonal(adj, False)
    a_idx, b_idx = np.nonzero(adj)
    a, b = v[a_idx], v[b_idx]
    t = b - (a * b).sum(axis=1, keepdims=True) * a
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    n60 = math.cos(theta) * a + math.sin(theta) * t
    normals = np.concatenate([n5, n6, n60])
    offsets = np.concatenate([np.ones(12), np.full(20, h6), np.full(60, h60)])
    return normals, offsets


def _gp30_residuals(x: np.ndarray) -> np.ndarray:
    """Residuals of the three conditions that fix GP(3,0) (see truncated_pentakis_dodecahedron)."""
    theta, h6, h60 = x
    v, _ = icosahedron()
    adj = (v @ v.T) > 0.4
    np.fill_diagonal(adj, False)
    A = 0
    B = int(np.flatnonzero(adj[A])[0])
    C = int(np.flatnonzero(adj[A] & adj[B])[0])
    normals, offsets = _gp30_planes(theta, h6, h60)
    a_idx, b_idx = np.nonzero(adj)
    directed = {(int(i), int(j)): 32 + k for k, (i, j) in enumerate(zip(a_idx, b_idx))}
    _, faces = icosahedron()
    hexa = {frozenset(map(int, f)): 12 + k for k, f in enumerate(faces)}

    def meet(*planes):
        return np.linalg.solve(normals[list(planes)], offsets[list(planes)])

    p_ab, p_ac, p_ba = directed[A, B], directed[A, C], directed[B, A]
    h_abc = hexa[frozenset((A, B, C))]
    pent_c = meet(A, p_ab, p_ac)           # pentagon vertex between P(A->B) and P(A->C)
    corner = meet(h_abc, p_ab, p_ac)        # hexagon ABC vertex near A
    edge_c = meet(h_abc, p_ab, p_ba)        # hexagon ABC vertex on edge AB
    n_h = normals[h_abc]

    def radius(x):
        return np.linalg.norm(x - (x @ n_h) * n_h)

    l6 = np.linalg.norm(corner - edge_c)      # regular-hexagon side
    l_pp = np.linalg.norm(pent_c - corner)    # between P(A->B) and P(A->C)
    # 1: regular hexagons; 2: pentagon and hexagon vertices on one sphere; 3: l_pp = l6
    # (with 1 and 2 the edges across an icosahedron edge, P(A->B)|P(B->A), then also have length l6)
    return np.array([radius(corner) - radius(edge_c), np.linalg.norm(pent_c) - np.linalg.norm(corner),
                     l_pp - l6])


@functools.lru_cache(maxsize=1)
def _gp30_unit() -> tuple[tuple[float, float, float], ConvexShape]:
    theta_ab = math.acos(1.0 / math.sqrt(5.0))
    # start near the solution (a guess from the geodesic, all offsets 1, lands on a spurious
    # root where the 60 planes are redundant)
    x = fsolve(_gp30_residuals, [theta_ab / 3.0, 0.985, 0.985], xtol=1e-13)
    if np.abs(_gp30_residuals(x)).max() > 1e-13:
        raise RuntimeError(f"GP(3,0) parameters did not converge: residuals {_gp30_residuals(x)}")
    normals, offsets = _gp30_planes(*x)
    return tuple(float(t) for t in x), _shape_from_halfspaces(normals, offsets, {})


def truncated_pentakis_dodecahedron(diameter: float = 2e-3,
                                    diameter_kind: DiameterKind = "circumscribed") -> ConvexShape:
    """The Goldberg polyhedron GP(3,0) (SPEC 1.1): 92 faces, 180 vertices, 270 edges.

    Construction: intersection of 92 half-spaces with icosahedral symmetry,

    - 12 pentagons: normals along the icosahedron vertex directions, offset 1 (sets the scale);
    - 20 hexagons: normals along the icosahedron face centres (dodecahedron vertices), offset h6;
    - 60 hexagons: the face normals of a pentakis dodecahedron, one per directed icosahedron edge
      A -> B, tilted from A towards B by the kis angle theta, offset h60.

    Symmetry alone makes the pentagons regular and the 20 hexagons equilateral with a mirror
    through every vertex, so they have alternating angles; the 60 hexagons have one mirror
    (the plane of A, B and the centre). The three free parameters (theta, h6, h60) are solved
    (``fsolve``, residuals ~1e-15) from three conditions:

    1. the 20 hexagons are regular (their two vertex classes equidistant from the face centre;
       this fixes the kis angle, theta = 0.35040541 rad);
    2. all 180 vertices lie on one sphere (so the circumscribed diameter is the diameter of the
       sphere through every vertex);
    3. every edge not bounding a pentagon has the same length b: the regular-hexagon sides and
       both classes of edges between two 60-hexagons. The pentagon side is a = 0.80685 b, so a
       60-hexagon has sides a, b, b, b, b, b.

    It fills 0.95278 of its circumscribed sphere (sphericity 0.98851); along the one-parameter
    family that satisfies 1 and 2 the largest fraction, 0.95288, is reached within 0.2 % of
    this h60, so it is about as round as GP(3,0) with regular pentagons and hexagons gets.
    (Asking instead for pentagon side = hexagon side has no solution with all 92 faces.)

    This is a truncated pentakis dodecahedron: the 60 planes alone meet in fives above every
    icosahedron vertex and in sixes above every dodecahedron vertex (the pentakis
    dodecahedron); the pentagon and hexagon planes truncate those vertices.
    """
    _, unit = _gp30_unit()
    shape = _scaled(unit, diameter, diameter_kind)
    shape.params = {"kind": "truncated_pentakis_dodecahedron", "diameter": float(diameter),
                    "diameter_kind": diameter_kind}
    return shape


# ------------------------------------------------------------------------------ other shapes
def cube(side: float = 2e-3) -> ConvexShape:
    """Axis-aligned cube of the given side, centred at the origin."""
    if not side > 0.0:
        raise ValueError(f"side must be > 0, got {side!r}")
    normals = np.concatenate([np.eye(3), -np.eye(3)])
    shape = _shape_from_halfspaces(normals, np.full(6, side / 2.0), {})
    shape.params = {"kind": "cube", "side": float(side)}
    return shape


def icosphere_like(diameter: float = 2e-3, diameter_kind: DiameterKind = "circumscribed",
                   subdivisions: int = 2) -> ConvexShape:
    """Sphere-like polyhedron: convex hull of an icosahedron whose triangles are split in four
    ``subdivisions`` times, new vertices projected on the sphere (subdivisions 0, 1, 2, 3 give
    20, 80, 320, 1280 triangular faces)."""
    if not 0 <= int(subdivisions) <= 4:
        raise ValueError(f"subdivisions must be in 0..4, got {subdivisions!r}")
    v, faces = icosahedron()
    verts = [tuple(p) for p in v]
    index = {}

    def midpoint(i, j):
        key = (min(i, j), max(i, j))
        if key not in index:
            m = np.add(verts[i], verts[j])
            verts.append(tuple(m / np.linalg.norm(m)))
            index[key] = len(verts) - 1
        return index[key]

    tris = [tuple(f) for f in faces]
    for _ in range(int(subdivisions)):
        new = []
        for i, j, k in tris:
            a, b, c = midpoint(i, j), midpoint(j, k), midpoint(k, i)
            new += [(i, a, c), (a, j, b), (c, b, k), (a, b, c)]
        tris = new
    hull = ConvexHull(np.array(verts))
    eq = hull.equations  # n . x + c <= 0, unit normals
    planes, _ = merge_close_points(np.c_[eq[:, :3], -eq[:, 3]], 1e-9)  # coplanar hull facets
    planes[:, :3] /= np.linalg.norm(planes[:, :3], axis=1, keepdims=True)
    unit = _shape_from_halfspaces(planes[:, :3], planes[:, 3], {})
    shape = _scaled(unit, diameter, diameter_kind)
    shape.params = {"kind": "icosphere_like", "diameter": float(diameter), "diameter_kind": diameter_kind,
                    "subdivisions": int(subdivisions)}
    return shape


_BUILDERS = {
    "truncated_pentakis_dodecahedron": truncated_pentakis_dodecahedron,
    "cube": cube,
    "icosphere_like": icosphere_like,
}


def build_shape(kind: str, **kwargs) -> ConvexShape:
    """Build a parent shape by name from its ``params`` (``build_shape(**shape.params)``)."""
    if kind not in _BUILDERS:
        raise ValueError(f"unknown shape kind {kind!r}; known: {sorted(_BUILDERS)}")
    return _BUILDERS[kind](**kwargs)
