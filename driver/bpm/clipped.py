"""A BPM particle (SPEC 3): a periodic packing clipped to the BCM parent shape, its bond
network, and each bond's area.

Clipping. The parent (driver/bcm/particle.py: parent_shape, in units of a) is centred in the
periodic box of a jammed packing (driver/bpm/packing.py) whose side leaves `margin` a between
the parent's circumscribed sphere and the box faces. The particles whose centre lies inside the
parent are kept, with the bonds and angles of the packing's periodic Delaunay network
(driver/bpm/network.py, SPEC 2.1) between kept particles: the network of the bulk solid,
cut, with its free surface left as it is (no relaxation, no new surface bonds). A bond never
joins two kept particles through a periodic image (they are closer than the box side minus
two margins), and a segment between two points of a convex parent stays inside it, so no bond
crosses the outside.

Bond areas (SPEC 1.5, 3). A bond's area is the area of the radical (power) Voronoi face
between its two particles. The 3D packing is monodisperse, and with equal radii the radical
tessellation is the ordinary Voronoi tessellation of the centres; so the cells here are the
ordinary Voronoi cells of the kept particles' centres, clipped exactly to the parent
(driver/bcm/tessellation.py: clipped_voronoi, mirror images across the parent's planes). Inside
the parent every point belongs to the cell of its nearest kept particle, so the cells fill the
parent: their volumes sum to the parent's volume, and a particle's cell volume is its share of
the particle (fragment volumes). A bond whose two cells share no face (a Delaunay edge whose
face lies outside the parent, or degenerate) has area 0; those are counted.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from driver.bcm.particle import parent_shape
from driver.bcm.polyhedra import ConvexShape
from driver.bpm.cuts import keep_subnetwork
from driver.bpm.network import Network
from driver.bpm.packing import Packing


def parent_in_a(shape: str, diameter_m: float, diameter_kind: str, a_m: float) -> ConvexShape:
    """The parent shape in units of a, centroid at the origin."""
    return parent_shape(shape, diameter_m / a_m, diameter_kind)


def box_side(parent: ConvexShape, margin: float) -> float:
    """Packing box side, in a: the parent's circumscribed diameter plus `margin` on each side."""
    return float(parent.circumscribed_diameter + 2.0 * margin)


@dataclass
class ClippedParticle:
    """Kept particles (positions relative to the parent's centroid, in a), their network
    (0-based, renumbered in packing order), and which packing particles were kept."""

    positions: np.ndarray
    network: Network
    kept: np.ndarray
    facts: dict


def clip_packing(packing: Packing, net: Network, parent: ConvexShape) -> ClippedParticle:
    """The particles of `packing` whose centres lie inside `parent` placed at the box centre,
    with the bonds and angles of `net` between them (module docstring)."""
    if packing.dimension != 3:
        raise ValueError("a BPM particle is 3D only")
    lo, hi = (np.asarray(b, float) for b in packing.box)
    L = hi - lo
    if np.any(L < parent.circumscribed_diameter + 2.0 * 1.25):
        raise ValueError(f"packing box {L.tolist()} too small for a parent of circumscribed diameter "
                         f"{parent.circumscribed_diameter:.4g} a")
    centre = 0.5 * (lo + hi)
    rel = packing.positions - centre
    inside = parent.contains(rel)
    b = net.bonds
    direct = rel[b[:, 1]] - rel[b[:, 0]]
    through_image = np.any(np.abs(direct) > 0.5 * L, axis=1)
    keep_bond = inside[b[:, 0]] & inside[b[:, 1]] & ~through_image
    sample, network, _ = keep_subnetwork(packing, net, inside, keep_bond)
    facts = {"packing_particles": int(packing.n), "particles": int(inside.sum()),
             "bonds": int(network.n_bonds), "angles": int(network.n_angles),
             "bonds_per_particle": float(network.bonds_per_particle),
             "angles_per_particle": float(network.angles_per_particle),
             "bonds_through_images_between_kept": int((inside[b[:, 0]] & inside[b[:, 1]] & through_image).sum()),
             "box_side_a": float(L[0])}
    return ClippedParticle(positions=sample.positions - centre, network=network, kept=inside, facts=facts)


@dataclass
class VoronoiCells:
    """Voronoi cells of the particles clipped to the parent (module docstring), in a:
    volume (n,), and each bond's face area (n_bonds,)."""

    volume: np.ndarray
    bond_area: np.ndarray
    n_bonds_without_face: int
    parent_volume: float


def voronoi_cells(parent: ConvexShape, positions: np.ndarray, bonds: np.ndarray) -> VoronoiCells:
    """Cell volumes and bond face areas of particles at `positions` (relative to the parent's
    centroid, strictly inside it); bonds (m, 2) 0-based."""
    from driver.bcm.tessellation import clipped_voronoi  # noqa: PLC0415

    tess = clipped_voronoi(parent, positions)
    area = face_areas_of(tess.iface_cells, tess.iface_area, bonds, len(positions))
    return VoronoiCells(volume=np.asarray(tess.volume, float), bond_area=area,
                        n_bonds_without_face=int(np.sum(area <= 0.0)), parent_volume=float(parent.volume))


def face_areas_of(iface_cells: np.ndarray, iface_area: np.ndarray, bonds: np.ndarray, n: int) -> np.ndarray:
    """The area of the face shared by each bond's two cells (0 where they share none)."""
    pairs = np.sort(np.asarray(iface_cells, np.int64), axis=1)
    keys = pairs[:, 0] * n + pairs[:, 1]
    order = np.argsort(keys)
    keys, areas = keys[order], np.asarray(iface_area, float)[order]
    b = np.sort(np.asarray(bonds, np.int64).reshape(-1, 2), axis=1)
    q = b[:, 0] * n + b[:, 1]
    pos = np.clip(np.searchsorted(keys, q), 0, max(len(keys) - 1, 0))
    found = (len(keys) > 0) & (keys[pos] == q)
    return np.where(found, areas[pos] if len(keys) else 0.0, 0.0)

