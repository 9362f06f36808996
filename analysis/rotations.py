"""Rotations of rigid cells: the one quaternion-to-matrix of the Python side (the plugins'
is MathExtra::quat_to_mat, whose convention this follows), used by the builder to place a
particle, by the analysis to put cell vertices in space, and by the tests."""

from __future__ import annotations

import numpy as np


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of unit quaternions (..., 4) = (w, x, y, z), body to
    space: x_space = R x_body (normalise first a quaternion read from a file)."""
    q = np.asarray(q, dtype=float)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([
        np.stack([w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z], -1),
    ], -2)
