"""Placing a tessellated particle for an impact (SPEC 1.4): random orientation, just above the plane."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from analysis.rotations import quat_to_matrix
from driver.bcm.polyhedra import rotation_to_quaternion


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """A rotation matrix uniform on SO(3): random axis and angle from a uniform unit quaternion
    (Shoemake's method)."""
    u1, u2, u3 = rng.random(3)
    q = np.array([np.sqrt(1 - u1) * np.sin(2 * np.pi * u2), np.sqrt(1 - u1) * np.cos(2 * np.pi * u2),
                  np.sqrt(u1) * np.sin(2 * np.pi * u3), np.sqrt(u1) * np.cos(2 * np.pi * u3)])
    return quat_to_matrix(q)


@dataclass
class Placement:
    """Rigid motion applied to the tessellation: x_lab = rotation @ (x - pivot) + offset."""

    rotation: np.ndarray  # (3, 3)
    pivot: np.ndarray  # (3,)
    offset: np.ndarray  # (3,)

    def apply(self, points: np.ndarray) -> np.ndarray:
        return (np.asarray(points) - self.pivot) @ self.rotation.T + self.offset

    def orient(self, body_to_lab: np.ndarray) -> np.ndarray:
        """Quaternions of the cells' new orientations, from their body->lab matrices (n, 3, 3)."""
        return rotation_to_quaternion(self.rotation @ body_to_lab)


def impact_placement(vertices: np.ndarray, pivot: np.ndarray, rotation: np.ndarray, plane_z: float,
                     lowest_offset: float) -> Placement:
    """Rotate about `pivot`, then lift so the lowest vertex sits `lowest_offset` above the plane
    (lowest_offset includes the rounding radius and the initial gap)."""
    rotated = (vertices - pivot) @ rotation.T
    return Placement(rotation=rotation, pivot=np.asarray(pivot, dtype=float),
                     offset=np.array([0.0, 0.0, plane_z + lowest_offset - rotated[:, 2].min()]))
