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
