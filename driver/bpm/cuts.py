"""Cutting a BPM sample out of a packing and its network (SPEC 2.1: an angle exists only on two
intact bonds): the subnetwork on kept atoms and bonds, and the tests of an elliptic void (which
points lie inside it, which bond segments meet it) that the toughness tests (mode1.py, mode2.py)
cut with; the BPM particle (clipped.py) keeps the subnetwork inside its parent the same way."""

from __future__ import annotations

import math

import numpy as np

from driver.bpm.network import Network
from driver.bpm.packing import Packing


def _ellipse_frame(points: np.ndarray, centre: np.ndarray, semi: np.ndarray, angle: float) -> np.ndarray:
    """Points (N, >= 2) in the ellipse's frame scaled by its semi-axes, where the ellipse is the
    unit disk: rotated by -angle about the centre (angle: the major axis from +x, radians,
    counter-clockwise), then divided by the semi-axes. angle = 0 skips the rotation, so an
    axis-aligned ellipse gives exactly the floats it always gave."""
    q = np.asarray(points, float)[:, :2] - centre
    if angle:
        c, s = math.cos(angle), math.sin(angle)
        q = np.stack([c * q[:, 0] + s * q[:, 1], -s * q[:, 0] + c * q[:, 1]], axis=1)
    return q / semi


def inside_ellipse(points: np.ndarray, centre: np.ndarray, semi: np.ndarray, angle: float = 0.0) -> np.ndarray:
    """Whether each point (N, >= 2) lies strictly inside the ellipse of semi-axes `semi` (major,
    minor) around `centre`, its first axis at `angle` (radians) from +x."""
    q = _ellipse_frame(points, centre, semi, angle)
    return np.einsum("ij,ij->i", q, q) < 1.0


def segment_meets_ellipse(p0: np.ndarray, p1: np.ndarray, centre: np.ndarray, semi: np.ndarray,
                          angle: float = 0.0) -> np.ndarray:
    """Whether each segment p0 -> p1 ((N, 2) each) meets the closed ellipse of semi-axes `semi`
    around `centre`, its first axis at `angle` (radians) from +x: in the ellipse's frame scaled by
    the semi-axes (an affine map, so segments stay segments) the ellipse is the unit disk, and
    the segment's closest point to the origin is at t* = clamp(-q0.d / d.d, 0, 1)."""
    q0 = _ellipse_frame(p0, centre, semi, angle)
    d = _ellipse_frame(p1, centre, semi, angle) - q0
    dd = np.einsum("ij,ij->i", d, d)
    t = np.clip(-np.einsum("ij,ij->i", q0, d) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
    closest = q0 + t[:, None] * d
    return np.einsum("ij,ij->i", closest, closest) <= 1.0


def keep_subnetwork(packing: Packing, net: Network, keep_atom: np.ndarray, keep_bond: np.ndarray
                    ) -> tuple[Packing, Network, np.ndarray]:
    """The packing and network reduced to the atoms `keep_atom` and the bonds `keep_bond` (both
    ends of a kept bond must be kept atoms), renumbered in order, with the angles whose two arms
    are kept bonds (SPEC 2.1: an angle exists only on two intact bonds); and which angles were kept."""
    b, n = net.bonds, packing.n
    kept = b[keep_bond, 0] * n + b[keep_bond, 1]  # bonds are stored with i < j

    def arm(i: np.ndarray, j: np.ndarray) -> np.ndarray:
        return np.isin(np.minimum(i, j) * n + np.maximum(i, j), kept)

    a = net.angles.reshape(-1, 3)
    keep_angle = arm(a[:, 0], a[:, 1]) & arm(a[:, 1], a[:, 2])
    new_index = np.cumsum(keep_atom) - 1  # monotone: sorted bonds and angles stay sorted
    x = packing.positions
    sample = Packing(positions=x[keep_atom], radii=packing.radii[keep_atom], types=packing.types[keep_atom],
                     box=packing.box, dimension=packing.dimension, relaxation=packing.relaxation)
    network = Network(bonds=new_index[b[keep_bond]], r0=net.r0[keep_bond], angles=new_index[a[keep_angle]],
                      theta0=net.theta0[keep_angle], n_atoms=int(keep_atom.sum()))
    return sample, network, keep_angle
