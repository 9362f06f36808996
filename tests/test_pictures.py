"""Offscreen pictures render to PNG files for both models."""

from __future__ import annotations

import numpy as np

from analysis.pictures import grain_colours, render_cells, render_particles_2d, render_particles_3d

CUBE = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
FACES = [np.array(f) for f in ([0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3])]


def _is_png(path) -> bool:
    return path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 5000


def test_colours_single_items_grey():
    cols = grain_colours(np.array([0, 0, 1]))
    assert np.allclose(cols[2], (0.85, 0.85, 0.85, 1.0)) and not np.allclose(cols[0], cols[2])


def test_render_cells_and_particles(tmp_path):
    cells = [CUBE * 1e-4, (CUBE + [1.2, 0, 0]) * 1e-4, (CUBE + [0, 1.2, 0]) * 1e-4]
    render_cells(cells, [FACES] * 3, np.array([0, 0, 1]), tmp_path / "cells.png", "three cubes")
    assert _is_png(tmp_path / "cells.png")
    rng = np.random.default_rng(0)
    pos = rng.random((50, 3)) * 10
    render_particles_2d(pos, np.full(50, 0.5), rng.integers(0, 4, 50), np.array([[0, 10], [0, 10], [-1, 1]]),
                        tmp_path / "p2.png")
    render_particles_3d(pos, rng.integers(0, 4, 50), tmp_path / "p3.png")
    assert _is_png(tmp_path / "p2.png") and _is_png(tmp_path / "p3.png")


def _pyramid_cell(shift):
    """A square pyramid: one quadrilateral face and four triangles (a ragged face list)."""
    verts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1.0]]) + shift
    return verts * 1e-4, [np.array([0, 3, 2, 1]), *(np.array([i, (i + 1) % 4, 4]) for i in range(4))]


def test_render_cells_limits_finite_whatever_memory_holds(tmp_path, monkeypatch):
    """Faces of different lengths, rendered while freshly allocated float memory holds what an
    earlier figure of the process left there (here the float maximum): mplot3d >= 3.9 padded
    the ragged faces into np.empty, autoscaled from the padding and raised 'Axis limits cannot
    be NaN or Inf' (10 of 32 impact runs). Faces are now padded by the caller."""
    import matplotlib.pyplot as plt

    real_empty = np.empty

    def dirty_empty(shape, dtype=float, *args, **kw):
        out = real_empty(shape, dtype, *args, **kw)
        if np.issubdtype(out.dtype, np.floating):
            out.fill(np.finfo(float).max)
        return out

    cells = [_pyramid_cell([0, 0, 0]), _pyramid_cell([1.5, 0, 0])]
    monkeypatch.setattr(np, "empty", dirty_empty)
    fig_before = plt.get_fignums()
    render_cells([c[0] for c in cells], [c[1] for c in cells], np.array([0, 1]), tmp_path / "ragged.png")
    monkeypatch.undo()
    assert _is_png(tmp_path / "ragged.png") and plt.get_fignums() == fig_before


def test_finite_cube_limits():
    from analysis.pictures import finite_cube_limits

    centre, half = finite_cube_limits(np.array([[0, 0, 0], [2, 1, 0], [np.nan, 5, 5], [np.inf, 0, 0]]))
    assert np.allclose(centre, [1, 0.5, 0]) and half == 1.0
    centre, half = finite_cube_limits(np.full((2, 3), np.nan))
    assert np.allclose(centre, 0) and half == 1.0
    assert finite_cube_limits(np.ones((3, 3)))[1] > 0


def test_visible_faces_drop_back_faces_and_a_fragments_inside():
    """Two unit cubes side by side along x, seen from +x (towards_viewer = +x): of each cube,
    the faces turned away (-x) are hidden and, when both cubes are one fragment, so are the
    two faces pressed together; as two fragments, the near cube's -x face is still hidden (it
    faces away) and the far cube's +x face is kept (a gap may show it)."""
    from analysis.pictures import visible_faces

    cubes = [CUBE, CUBE + [1.0, 0, 0]]
    faces = [FACES, FACES]
    # each face's offset along x from its cube's centre: +0.5 for the +x face, -0.5 for -x, 0 else
    offset_x = np.array([[c[f][:, 0].mean() - c[:, 0].mean() for f in FACES] for c in cubes])
    plus_x, minus_x = offset_x > 0.4, offset_x < -0.4
    one = visible_faces(cubes, faces, np.array([0, 0]), np.array([1.0, 0.0, 0.0]))
    two = visible_faces(cubes, faces, np.array([0, 1]), np.array([1.0, 0.0, 0.0]))
    # seen along +x only the +x faces (and the edge-on ones, normal . view = 0) are turned towards the viewer
    assert not one[0][plus_x[0]].any() and one[1][plus_x[1]].all()  # cube 0's +x face touches cube 1
    assert two[0][plus_x[0]].all() and two[1][plus_x[1]].all()
    assert not one[0][minus_x[0]].any() and not two[1][minus_x[1]].any()
    assert sum(m.sum() for m in one) == 1 + 2 * 4 and sum(m.sum() for m in two) == 2 + 2 * 4
