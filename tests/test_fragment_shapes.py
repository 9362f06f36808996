"""Fragment box a >= b >= c (SPEC 1.5) on solids whose values are derived by hand.

1 x 2 x 3 cuboid. a = space diagonal sqrt(14), u = (1, 2, 3)/sqrt(14). Vertex differences
are d = (i, 2j, 3k), i, j, k in {-1, 0, 1}; projected onto the plane normal to u their
squared lengths are |d|^2 - (d.u)^2, largest for d = (1, 2, -3): 14 - 16/14 = 90/7, so
b = sqrt(90/7), v parallel to d - (d.u)u, i.e. to (3, 6, -5). w = u x v is parallel to
(-2, 1, 0); the vertices (i, 2j, 3k).w span (-2i + 2j)/sqrt(5) in [-2, 2]/sqrt(5): c = 4/sqrt(5).

Cube of side s. a = sqrt(3) s; the largest projected difference is d = (1, 1, -1) s with
3 - 1/3 = 8/3: b = sqrt(8/3) s, v parallel to (1, 1, -2); w parallel to (-1, 1, 0): c = sqrt(2) s.

Regular tetrahedron of edge s: all edges are equal, a = s along one edge; the opposite edge
is perpendicular to it, so it projects at full length: b = s (the other projected distances
are the triangle heights s sqrt(3)/2); w joins the midpoints of the two edges: c = s/sqrt(2).
"""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd
import pytest

from analysis.fragment_shapes import box_dimensions, fragment_table, shape_averages, shape_factor, vertices_in_space


def cuboid(lx, ly, lz, origin=(0.0, 0.0, 0.0)):
    return np.array(list(itertools.product([0, lx], [0, ly], [0, lz])), dtype=float) + origin


def random_rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def sf(a, b, c):
    return (1 / a + 1 / b + 1 / c) * np.sqrt(a * a + b * b + c * c) / np.sqrt(3)


CUBOID_123 = (np.sqrt(14), np.sqrt(90 / 7), 4 / np.sqrt(5))


def test_cuboid_1x2x3():
    s = box_dimensions(cuboid(1, 2, 3))
    assert np.allclose([s.a, s.b, s.c], CUBOID_123)
    assert np.isclose(s.elongation, CUBOID_123[1] / CUBOID_123[0])
    assert np.isclose(s.flatness, CUBOID_123[2] / CUBOID_123[1])
    assert np.isclose(s.shape_factor, sf(*CUBOID_123))
    assert np.allclose(s.axes @ s.axes.T, np.eye(3))
    assert np.isclose(abs(s.axes[0] @ np.array([1, 2, 3])) / np.sqrt(14), 1.0)
    assert np.isclose(abs(s.axes[2] @ np.array([-2, 1, 0])) / np.sqrt(5), 1.0)


def test_rotated_translated_cuboid_with_inner_points():
    rng = np.random.default_rng(7)
    pts = np.vstack([cuboid(1, 2, 3), rng.random((200, 3)) * [1, 2, 3]])  # interior points change nothing
    for _ in range(5):
        rot = random_rotation(rng)
        s = box_dimensions(pts @ rot.T + rng.normal(size=3) * 100)
        assert np.allclose([s.a, s.b, s.c], CUBOID_123)


def test_regular_tetrahedron():
    edge = 2.0
    tet = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float) / np.sqrt(8) * edge
    s = box_dimensions(tet @ random_rotation(np.random.default_rng(1)).T)
    assert np.allclose([s.a, s.b, s.c], [edge, edge, edge / np.sqrt(2)])
    assert np.isclose(s.shape_factor, (2 + np.sqrt(2)) * np.sqrt(5 / 6))


def test_cube_shape_factor():
    a, b, c = np.sqrt(3), np.sqrt(8 / 3), np.sqrt(2)
    expected = (1 / np.sqrt(3) + np.sqrt(3 / 8) + 1 / np.sqrt(2)) * np.sqrt(23 / 3) / np.sqrt(3)  # about 3.032
    for side in (1.0, 2.5e-3):
        s = box_dimensions(cuboid(side, side, side))
        assert np.allclose([s.a, s.b, s.c], np.array([a, b, c]) * side)
        assert np.isclose(s.shape_factor, expected) and np.isclose(expected, sf(a, b, c))
    assert np.isclose(shape_factor(1.0, 1.0, 1.0), 3.0)  # its minimum


def test_sphere_points_and_large_hull():
    rng = np.random.default_rng(2)
    p = rng.normal(size=(5000, 3))  # every point is a hull vertex: the O(h^2) worst case
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    s = box_dimensions(p)
    assert 1.99 < s.a <= 2.0 and s.b > 1.97 and s.c > 1.95
    assert 3.0 < s.shape_factor < 3.02


def test_degenerate_sets():
    flat = box_dimensions(cuboid(2, 1, 0))  # a rectangle: c = 0, S_f infinite
    assert np.isclose(flat.a, np.sqrt(5)) and flat.c == pytest.approx(0, abs=1e-12)
    assert np.isinf(flat.shape_factor) or flat.shape_factor > 1e10
    line = box_dimensions(np.array([[0, 0, 0], [1, 1, 1], [2, 2, 2.0]]))
    assert np.isclose(line.a, 2 * np.sqrt(3)) and line.b == pytest.approx(0, abs=1e-12)
    assert box_dimensions(np.zeros((3, 3))).a == 0.0
    with pytest.raises(ValueError):
        box_dimensions(np.empty((0, 3)))


def test_fragment_table():
    # Fragment 0: eight unit cubes filling a 2x2x2 cube; fragment 1: one 1x2x3 cuboid cell.
    cells = [cuboid(1, 1, 1, origin=o) for o in itertools.product([0, 1], [0, 1], [0, 1])]
    cells.append(cuboid(1, 2, 3, origin=(10, 0, 0)))
    labels = np.array([0] * 8 + [1])
    masses = np.full(9, 2.0)
    volumes = np.array([1.0] * 8 + [6.0])
    t = fragment_table(labels, masses, volumes, cells)
    assert isinstance(t, pd.DataFrame) and t["fragment"].tolist() == [0, 1]
    assert t["n_cells"].tolist() == [8, 1] and t["mass"].tolist() == [16, 2] and t["volume"].tolist() == [8, 6]
    cube = 2 * np.array([np.sqrt(3), np.sqrt(8 / 3), np.sqrt(2)])
    assert np.allclose(t.loc[0, ["a", "b", "c"]].to_numpy(float), cube)
    assert np.allclose(t.loc[1, ["a", "b", "c"]].to_numpy(float), CUBOID_123)  # computed for single cells too
    assert t["single_cell"].tolist() == [False, True]
    # The CSR form gives the same table.
    offsets = np.concatenate([[0], np.cumsum([len(c) for c in cells])])
    t2 = fragment_table(labels, masses, volumes, (np.concatenate(cells), offsets))
    pd.testing.assert_frame_equal(t, t2)
    avg = shape_averages(t)
    assert avg["n_fragments"] == 1 and np.isclose(avg["shape_factor_mean"], t.loc[0, "shape_factor"])
    assert shape_averages(t, include_single_cells=True)["n_fragments"] == 2
    with pytest.raises(ValueError, match="do not match"):
        fragment_table(labels, masses, volumes, cells[:-1])


def test_vertices_in_space():
    body = cuboid(1, 2, 3) - [0.5, 1, 1.5]
    half_turn_z = np.array([[0.0, 0.0, 0.0, 1.0]])  # (w, x, y, z): 180 degrees about z
    out = vertices_in_space(body, np.array([0, 8]), np.array([[5.0, 0, 0]]), half_turn_z)
    assert np.allclose(out, body * [-1, -1, 1] + [5, 0, 0])
    quarter_x = np.array([[np.cos(np.pi / 4), np.sin(np.pi / 4), 0, 0]])  # 90 degrees about x: y -> z
    out = vertices_in_space(np.array([[0, 1.0, 0]]), np.array([0, 1]), np.zeros((1, 3)), quarter_x)
    assert np.allclose(out, [[0, 0, 1]])
