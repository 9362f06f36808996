"""Periodic centroidal Voronoi tessellation of a box: the BCM calibration block (SPEC 1.1-1.2,
SPEC 3). Expectations come from the definition of a periodic Voronoi cell (nearest seed under
periodic images), exact identities (volumes fill the box, every face seen from both sides) and
lattices whose cells are known by hand, never from the code's own output."""

from __future__ import annotations

import itertools
import time
from collections import Counter

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from driver.bcm import block as B
from driver.bcm.polyhedra import polyhedron_mass_properties, polygon_vector_area
from runfiles.cells import read_cells, write_cells

SHIFTS = np.array(list(itertools.product((-1, 0, 1), repeat=3)))


# ----------------------------------------------------------------------------- helpers
def lattice_seeds(lengths, counts):
    """Cell centres of a counts[0] x counts[1] x counts[2] grid of boxes filling the box."""
    axes = [(np.arange(c) + 0.5) * (L / c) for L, c in zip(lengths, counts)]
    return np.array(np.meshgrid(*axes, indexing="ij")).reshape(3, -1).T


def same_loop_reversed(p, q, tol):
    """q, read backwards, is a cyclic rotation of p (the same polygon, opposite orientation)."""
    q = q[::-1]
    return len(p) == len(q) and any(np.abs(np.roll(q, r, axis=0) - p).max() < tol for r in range(len(q)))


def check_block(b: B.BlockTessellation, rng_seed: int = 0, n_samples: int = 2000):
    """Every structural identity of a periodic block; returns nothing, asserts everything."""
    L, n = b.lengths, b.n_cells
    scale = L.max()
    # volumes fill the box exactly; cells are non-degenerate
    assert b.volume.sum() == pytest.approx(b.box_volume, rel=1e-9)
    assert np.all(b.volume > 0)
    # every face row has its partner: the same face of cell j, seen from the other side
    i_rows, j_rows = b.iface_faces.T
    assert sorted(np.r_[i_rows, j_rows].tolist()) == list(range(len(b.face_cell)))  # each row once
    np.testing.assert_array_equal(b.face_partner[b.face_partner], np.arange(len(b.face_cell)))
    np.testing.assert_array_equal(b.face_interface[i_rows], np.arange(b.n_interfaces))
    np.testing.assert_array_equal(b.face_interface[j_rows], np.arange(b.n_interfaces))
    i, j = b.iface_cells.T
    first_nonzero = b.iface_shift[np.arange(b.n_interfaces), np.argmax(b.iface_shift != 0, axis=1)]
    assert np.all((i < j) | ((i == j) & (first_nonzero > 0)))  # each face once: i <= j
    np.testing.assert_array_equal(b.face_cell[i_rows], i)
    np.testing.assert_array_equal(b.face_cell[j_rows], j)
    np.testing.assert_array_equal(b.face_neighbor[i_rows], j)
    np.testing.assert_array_equal(b.face_shift[i_rows], b.iface_shift)
    np.testing.assert_array_equal(b.face_shift[j_rows], -b.iface_shift)
    np.testing.assert_allclose(b.face_area[j_rows], b.face_area[i_rows], rtol=1e-9)
    np.testing.assert_allclose(b.face_normal[j_rows], -b.face_normal[i_rows], atol=1e-12)
    assert b.face_area.sum() == pytest.approx(2.0 * b.iface_area.sum(), rel=1e-12)
    # no pair (cell, neighbour image) twice: one face per bisector
    keys = Counter(zip(b.face_cell.tolist(), b.face_neighbor.tolist(), map(tuple, b.face_shift.tolist())))
    assert max(keys.values()) == 1
    for k in range(b.n_interfaces):
        poly = b.interface_polygon(k)
        other = b.vertices[b.face_loop(j_rows[k])] + b.iface_shift[k] * L
        assert same_loop_reversed(poly, other, 1e-9 * scale)
        np.testing.assert_array_equal(poly, b.vertices[b.face_loop(i_rows[k])])
        # ccw about the normal from i to j's image, which is the bisector's normal
        va = polygon_vector_area(poly)
        assert va @ b.iface_normal[k] == pytest.approx(b.iface_area[k], rel=1e-9)
        assert np.linalg.norm(va) == pytest.approx(b.iface_area[k], rel=1e-9)
        nb = b.seeds[j[k]] + b.iface_shift[k] * L
        d = nb - b.seeds[i[k]]
        np.testing.assert_allclose(b.iface_normal[k], d / np.linalg.norm(d), atol=1e-12)
        # on the bisector plane: equidistant from seed i and the image of j
        di = np.linalg.norm(poly - b.seeds[i[k]], axis=1)
        dj = np.linalg.norm(poly - nb, axis=1)
        np.testing.assert_allclose(di, dj, atol=1e-9 * scale)
        assert np.abs((b.iface_centroid[k] - poly.mean(axis=0)) @ b.iface_normal[k]) < 1e-9 * scale
    # each cell: a closed, consistently oriented convex polyhedron whose hull has its volume
    for c in range(n):
        verts, faces = b.cell_polyhedron(c)
        directed = Counter((int(a), int(e)) for f in faces for a, e in zip(f, np.roll(f, -1)))
        assert all(v == 1 for v in directed.values()) and all(directed[(e, a)] == 1 for a, e in directed)
        hull = ConvexHull(verts)
        assert hull.volume == pytest.approx(b.volume[c], rel=1e-9)
        assert len(hull.vertices) == len(verts)  # every vertex is a corner
        rows = slice(b.cell_face_ptr[c], b.cell_face_ptr[c + 1])
        assert np.all(verts @ b.face_normal[rows].T - b.face_offset[rows] < 1e-9 * scale)
        assert np.all(verts @ b.face_normal[rows].T - b.face_offset[rows] > -2.0 * scale)
        # the centroid is inside its own cell
        assert np.all(b.face_normal[rows] @ b.centroid[c] < b.face_offset[rows])
    # the definition: a point belongs to the cell of its nearest seed over all periodic images
    # (for points and seeds in [0, L), the nearest image is among shifts -1, 0, 1 per axis)
    x = np.random.default_rng(rng_seed).random((n_samples, 3)) * L
    images = b.seeds[None, :, :] + (SHIFTS * L)[:, None, :]  # (27, n, 3)
    dist = np.linalg.norm(x[:, None, None, :] - images[None], axis=3).reshape(n_samples, -1)
    best = dist.argmin(axis=1)
    shift, cell = SHIFTS[best // n], best % n
    local = x - shift * L  # the point near its seed's own cell
    for c in np.unique(cell):
        rows = slice(b.cell_face_ptr[c], b.cell_face_ptr[c + 1])
        pts = local[cell == c]
        assert np.all(pts @ b.face_normal[rows].T - b.face_offset[rows] <= 1e-12 * scale)


# ------------------------------------------------------------------------ random blocks
@pytest.fixture(scope="module")
def block64():
    return B.periodic_cvt([1.0, 1.3, 0.8], 64, seed=5)


def test_random_block_fills_box_and_every_face_is_matched(block64):
    b = block64
    assert b.converged and b.residual < b.tol and len(b.residuals) == b.n_iter
    assert b.residuals[0] > 10 * b.tol  # random seeds do move
    assert np.all((b.seeds >= 0) & (b.seeds < b.lengths))
    check_block(b)
    # centroids within tol h (about) of their seeds once converged
    h = b.mean_cell_size
    assert np.sqrt(np.mean(np.sum((b.centroid - b.seeds) ** 2, axis=1))) < 2 * b.tol * h
    image = np.floor(b.centroid / b.lengths)  # LAMMPS's image flags of each centroid
    np.testing.assert_allclose(b.wrapped_centroid + image * b.lengths, b.centroid, atol=1e-15)
    assert np.all((b.wrapped_centroid >= 0) & (b.wrapped_centroid < b.lengths))


def test_lloyd_is_deterministic_for_a_seed(block64):
    again = B.periodic_cvt([1.0, 1.3, 0.8], 64, seed=5)
    for name in ("seeds", "volume", "centroid", "inertia", "iface_cells", "iface_shift", "iface_area",
                 "vertices", "face_vertices", "residuals"):
        np.testing.assert_array_equal(getattr(again, name), getattr(block64, name))
    assert again.key == block64.key
    other = B.periodic_cvt([1.0, 1.3, 0.8], 64, seed=6)
    assert other.key != block64.key and not np.allclose(other.seeds, block64.seeds)


def test_fast_lloyd_step_equals_the_voronoi_cells():
    """The Delaunay-based step and the Qhull Voronoi cells are two independent constructions."""
    L = np.array([1.0, 0.7, 1.2])
    seeds = np.random.default_rng(3).random((50, 3)) * L
    h = (L.prod() / 50) ** (1 / 3)
    vol, cen, extent = B._lloyd_step(seeds, L, 4 * h)
    ridges = B._periodic_voronoi(seeds, L, 4 * h)
    vol2, cen2 = B._volumes_centroids(ridges, seeds)
    np.testing.assert_allclose(vol, vol2, rtol=1e-9)
    np.testing.assert_allclose(cen, cen2, atol=1e-9 * h)
    np.testing.assert_allclose(extent, ridges.extent, rtol=1e-9)


def test_too_small_margin_is_enlarged():
    """Images only 0.05 h around the box leave boundary cells unbounded or too large: the
    diagram must be rebuilt with a margin of at least twice the largest cell extent."""
    L = np.ones(3)
    seeds = np.random.default_rng(4).random((40, 3))
    h = (1 / 40) ** (1 / 3)
    small = B._periodic_voronoi(seeds, L, 0.05 * h)
    large = B._periodic_voronoi(seeds, L, 8 * h)
    assert small.margin >= 2 * small.extent.max() and small.margin > 0.05 * h
    np.testing.assert_allclose(B._volumes_centroids(small, seeds)[0], B._volumes_centroids(large, seeds)[0],
                               rtol=1e-12)
    assert B._lloyd_step(seeds, L, 0.05 * h)[0].sum() == pytest.approx(1.0, rel=1e-12)


def test_300_cells_converge_and_bond_by_minimum_image():
    t0 = time.perf_counter()
    b = B.periodic_cvt([1.0, 1.0, 1.0], 300, seed=1)
    elapsed = time.perf_counter() - t0
    print(f"300 cells: {b.n_iter} Lloyd steps, {elapsed:.1f} s, residual {b.residual:.2e}")
    assert b.converged and b.residual < b.tol
    check_block(b, n_samples=1000)
    # a box of ~6.7 cells across: every interface joins nearest images, LAMMPS can bond it
    assert len(b.minimum_image_violations()) == 0
    b.require_minimum_image()
    # Lloyd drives cells towards the 14-faced body-centred cubic cell; random (Poisson)
    # Voronoi cells have 15.54 faces on average
    assert 13.5 < b.faces_per_cell().mean() < 15.0
    assert b.faces_per_cell().sum() == 2 * b.n_interfaces


# ------------------------------------------------------------------ lattices, by hand
@pytest.mark.parametrize("lengths, counts", [((1.5, 1.5, 1.5), (3, 3, 3)), ((0.9, 1.2, 2.0), (3, 3, 4))])
def test_lattice_seeds_give_identical_boxes(lengths, counts):
    """Seeds at the centres of a grid of a x b x c boxes: each cell is its box, with 6 faces
    (areas bc, ac, ab), volume abc, inertia abc/12 diag(b^2+c^2, a^2+c^2, a^2+b^2), and
    Lloyd leaves the seeds where they are (each is its box's centroid)."""
    L = np.array(lengths)
    a, bb, c = L / counts
    seeds = lattice_seeds(L, counts)
    n = len(seeds)
    blk = B.periodic_cvt(L, n, seed=0, initial_seeds=seeds)
    assert blk.n_iter == 1 and blk.residual < 1e-12 and blk.converged and blk.seed == -1
    np.testing.assert_allclose(blk.seeds, seeds, atol=1e-12)
    np.testing.assert_allclose(blk.centroid, seeds, atol=1e-12)
    np.testing.assert_allclose(blk.volume, a * bb * c, rtol=1e-12)
    vol = a * bb * c
    hand = vol / 12 * np.diag([bb**2 + c**2, a**2 + c**2, a**2 + bb**2])
    np.testing.assert_allclose(blk.inertia, np.broadcast_to(hand, (n, 3, 3)), atol=1e-12 * hand.max())
    np.testing.assert_allclose(blk.principal_moments, np.broadcast_to(np.sort(hand.diagonal()), (n, 3)),
                               rtol=1e-12)
    assert np.all(blk.faces_per_cell() == 6)
    assert blk.n_interfaces == 3 * n
    axis = np.abs(blk.iface_normal).argmax(axis=1)
    np.testing.assert_allclose(np.abs(blk.iface_normal[np.arange(blk.n_interfaces), axis]), 1.0, atol=1e-14)
    face_area = np.array([bb * c, a * c, a * bb])
    np.testing.assert_allclose(blk.iface_area, face_area[axis], rtol=1e-12)
    assert Counter(axis.tolist()) == {0: n, 1: n, 2: n}
    assert all(len(blk.interface_polygon(k)) == 4 for k in range(blk.n_interfaces))
    assert len(blk.minimum_image_violations()) == 0  # at least 3 cells across
    check_block(blk, n_samples=500)


def test_cube_cell_mass_properties_by_hand():
    """Unit density cube of side a: volume a^3, inertia a^5/6 times the identity, about the
    cube's centre; the body frame holds the cube centred at the origin."""
    a = 0.25
    seeds = lattice_seeds([1.0, 1.0, 1.0], (4, 4, 4))
    blk = B.periodic_cvt([1.0, 1.0, 1.0], 64, seed=0, initial_seeds=seeds, max_iter=0)
    assert blk.n_iter == 0 and not blk.converged
    np.testing.assert_allclose(blk.volume, a**3, rtol=1e-12)
    np.testing.assert_allclose(blk.inertia, np.broadcast_to(a**5 / 6 * np.eye(3), (64, 3, 3)), atol=1e-12 * a**5)
    verts, faces = body_cells(blk)
    for v in verts:
        assert len(v) == 8
        # an axis-aligned cube's principal frame is any frame: its corners stay at distance
        # sqrt(3) a / 2 from the centre
        np.testing.assert_allclose(np.linalg.norm(v, axis=1), np.sqrt(3) * a / 2, rtol=1e-12)


# ----------------------------------------------------------------- tiny and LAMMPS-facing
def test_single_cell_bonds_to_its_own_images():
    """One seed: its cell is the whole box centred on it (so Lloyd stops at once), and its six
    faces are three interfaces with its own images, shifts e_z, e_y, e_x (lexicographically
    positive, in shift order), of areas Lx Ly, Lx Lz, Ly Lz. They are handled, not refused; the
    minimum-image check refuses them for LAMMPS."""
    L = np.array([1.0, 2.0, 3.0])
    b = B.periodic_cvt(L, 1, seed=7)
    assert b.n_iter == 1 and b.residual < 1e-12
    assert b.volume[0] == pytest.approx(6.0, rel=1e-12)
    np.testing.assert_array_equal(b.iface_cells, [[0, 0]] * 3)
    np.testing.assert_array_equal(b.iface_shift, [[0, 0, 1], [0, 1, 0], [1, 0, 0]])
    np.testing.assert_allclose(b.iface_area, [2.0, 3.0, 6.0], rtol=1e-12)
    hand = 6.0 / 12 * np.diag([2**2 + 3**2, 1 + 3**2, 1 + 2**2])
    np.testing.assert_allclose(b.inertia[0], hand, atol=1e-12 * hand.max())
    check_block(b, n_samples=200)
    assert len(b.minimum_image_violations()) == 3
    with pytest.raises(ValueError, match="not the nearest one"):
        b.require_minimum_image()


def test_two_cells_across_bond_twice_and_are_refused_for_lammps():
    """A 2 x 2 x 2 lattice: each cell meets the same neighbour on both sides along an axis,
    through shifts differing by one box; 6 faces per cell, 24 interfaces (pairs bonded twice),
    none of which LAMMPS's minimum image can tell apart."""
    seeds = lattice_seeds([1.0, 1.0, 1.0], (2, 2, 2))
    b = B.periodic_cvt([1.0, 1.0, 1.0], 8, seed=0, initial_seeds=seeds)
    assert b.n_interfaces == 24 and np.all(b.faces_per_cell() == 6)
    pairs = Counter(map(tuple, b.iface_cells.tolist()))
    assert set(pairs.values()) == {2} and len(pairs) == 12
    np.testing.assert_allclose(b.iface_area, 0.25, rtol=1e-12)
    check_block(b, n_samples=200)
    assert len(b.minimum_image_violations()) == 24
    with pytest.raises(ValueError, match="interfaces of the periodic block"):
        b.require_minimum_image()


def test_two_random_cells_meet_themselves_and_each_other():
    """Two random cells in a box: each has faces with its own images and with several images
    of the other cell; all of them pair up."""
    b = B.periodic_cvt([1.0, 1.0, 1.0], 2, seed=11)
    assert b.converged
    check_block(b, n_samples=300)
    kinds = Counter(map(tuple, b.iface_cells.tolist()))
    assert set(kinds) == {(0, 0), (0, 1), (1, 1)}
    # a face with the other cell counts once per cell, a face with an own image twice
    np.testing.assert_array_equal(b.faces_per_cell(), [2 * kinds[(0, 0)] + kinds[(0, 1)],
                                                       2 * kinds[(1, 1)] + kinds[(0, 1)]])


def body_cells(blk) -> tuple[list[np.ndarray], list[list[np.ndarray]]]:
    """Every cell in its body frame (origin at the centroid, principal axes), as
    runfiles.cells.write_cells takes them: vertices R^T (v - c) and face loops."""
    verts, faces = [], []
    for i in range(blk.n_cells):
        v, f = blk.cell_polyhedron(i)
        verts.append((v - blk.centroid[i]) @ blk.principal_axes[i])
        faces.append(f)
    return verts, faces


def test_body_cells_round_trip_through_the_cells_file(block64, tmp_path):
    """Body frame: centroid at the origin and the inertia diagonal, equal to the principal
    moments; the quaternion rotates body vertices back onto the cell."""
    verts, faces = body_cells(block64)
    path = write_cells(tmp_path / "cells.txt", verts, faces)
    v2, f2 = read_cells(path)
    for c in range(block64.n_cells):
        np.testing.assert_allclose(v2[c], verts[c], rtol=0, atol=0)
        assert all(np.array_equal(x, y) for x, y in zip(f2[c], faces[c]))
        vol, cen, inertia = polyhedron_mass_properties(verts[c], faces[c])
        h = block64.mean_cell_size
        assert vol == pytest.approx(block64.volume[c], rel=1e-9)
        assert np.abs(cen).max() < 1e-9 * h
        np.testing.assert_allclose(inertia, np.diag(block64.principal_moments[c]),
                                   atol=1e-9 * block64.principal_moments[c].max())
        w, x, y, z = block64.quaternion[c]
        rot = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
        lab, _ = block64.cell_polyhedron(c)
        np.testing.assert_allclose(verts[c] @ rot.T + block64.centroid[c], lab, atol=1e-12)


# ------------------------------------------------------------------ persistence, checks
def test_save_load_and_cache(tmp_path, monkeypatch):
    first = B.cached_periodic_cvt([1.0, 1.0, 1.0], 27, seed=2, cache_dir=tmp_path)
    files = list(tmp_path.glob("block_*.npz"))
    assert [f.name for f in files] == [f"block_{first.key}.npz"]

    def refuse(*args, **kwargs):
        raise AssertionError("recomputed instead of read from the cache")

    monkeypatch.setattr(B, "periodic_cvt", refuse)
    again = B.cached_periodic_cvt([1.0, 1.0, 1.0], 27, seed=2, cache_dir=tmp_path)
    for name in ("seeds", "volume", "iface_cells", "iface_shift", "iface_vertices", "residuals", "lengths"):
        np.testing.assert_array_equal(getattr(again, name), getattr(first, name))
    assert (again.n_iter, again.converged, again.seed, again.tol) == (first.n_iter, first.converged, 2, 2e-3)
    keys = {B.block_key(np.ones(3), 27, 2, 2e-3, 400, 1e-10), B.block_key(np.ones(3), 27, 3, 2e-3, 400, 1e-10),
            B.block_key(np.ones(3), 27, 2, 1e-3, 400, 1e-10), B.block_key(np.ones(3), 28, 2, 2e-3, 400, 1e-10),
            B.block_key(np.array([1, 1, 2.0]), 27, 2, 2e-3, 400, 1e-10)}
    assert len(keys) == 5


def test_wrap_and_argument_checks():
    w = B.wrap(np.array([[-1e-17, 1.0, 2.5]]), np.array([1.0, 1.0, 2.0]))
    np.testing.assert_array_equal(w, [[0.0, 0.0, 0.5]])
    with pytest.raises(ValueError, match="box lengths"):
        B.periodic_cvt([1.0, 0.0, 1.0], 8, seed=1)
    with pytest.raises(ValueError, match="n_cells"):
        B.periodic_cvt([1.0, 1.0, 1.0], 0, seed=1)
    with pytest.raises(ValueError, match="initial seeds"):
        B.periodic_cvt([1.0, 1.0, 1.0], 8, seed=1, initial_seeds=np.zeros((7, 3)))
