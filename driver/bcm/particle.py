"""A BCM particle ready for LAMMPS (SPEC 1.1-1.4): tessellation, rounded cores, placement.

The rigid body of a cell is its Voronoi cell: mass and inertia of the unrounded polyhedron
(the rounding removes O(r_m) of volume at edges and vertices; we keep the cell's own mass so
the particle's mass is exactly rho_s V). Its body frame is the cell's principal frame with
origin at the centroid. Contacts use the core, eroded by r_m (face planes moved inward and
vertices rebuilt, SPEC 1.1), plus the rounding radius r_m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from driver.bcm.placement import Placement, impact_placement, random_rotation
from driver.bcm.polyhedra import ConvexShape, build_shape
from driver.bcm.tessellation import Tessellation, cached_tessellation, erode


def parent_shape(kind: str, diameter: float, diameter_kind: str) -> ConvexShape:
    """The parent polyhedron; a cube's 'diameter' is its circumscribed or equal-volume diameter."""
    if kind == "cube":
        side = diameter / math.sqrt(3.0) if diameter_kind == "circumscribed" else diameter * (math.pi / 6) ** (1 / 3)
        return build_shape("cube", side=side)
    return build_shape(kind, diameter=diameter, diameter_kind=diameter_kind)


@dataclass
class Particle:
    """Cells in the lab frame after placement (arrays over cells, 0-based)."""

    tess: Tessellation
    placement: Placement
    r_m: float
    centroids: np.ndarray  # (n, 3) lab
    quats: np.ndarray  # (n, 4) body -> lab
    masses: np.ndarray  # (n,)
    moments: np.ndarray  # (n, 3) principal moments (kg m^2)
    core_vertices: list[np.ndarray]  # body frame, per cell: eroded by r_m (contact geometry)
    core_faces: list[list[np.ndarray]]
    cell_vertices: list[np.ndarray]  # body frame, per cell: the Voronoi cell (mass, fragment shapes)
    cell_faces: list[list[np.ndarray]]
    bound_radius: np.ndarray  # (n,) circumradius of the Voronoi cell about its centroid
    interface_polygons: list[np.ndarray]  # lab frame, reference state

    @property
    def n_cells(self) -> int:
        return len(self.masses)


def parent_centroid(tess: Tessellation) -> np.ndarray:
    """The tessellated parent's centroid: the cells' centroids weighted by their volumes."""
    return (tess.centroid * tess.volume[:, None]).sum(0) / tess.volume.sum()


def cell_bodies(tess: Tessellation, r_m: float) -> tuple[list, list, list, list, np.ndarray]:
    """Each cell in its body frame (principal axes, origin at its centroid): the core eroded by
    r_m (vertices, faces), the Voronoi cell itself (vertices, faces), and its bounding radius."""
    n = tess.n_cells
    cores_v, cores_f, cells_v, cells_f, bound = [], [], [], [], np.empty(n)
    for i in range(n):
        cell = tess.cell(i)
        core = erode(cell, r_m) if r_m > 0 else cell
        cores_v.append((core.vertices - tess.centroid[i]) @ tess.principal_axes[i])  # R^T (v - c)
        cores_f.append(core.faces)
        cells_v.append((cell.vertices - tess.centroid[i]) @ tess.principal_axes[i])
        cells_f.append(cell.faces)
        # bounding radius of the whole (unrounded) cell: it holds the rounded core and the
        # interface polygons, whose corners lie farther out than the core's
        bound[i] = np.linalg.norm(cell.vertices - tess.centroid[i], axis=1).max()
    return cores_v, cores_f, cells_v, cells_f, bound


def build_particle(tess: Tessellation, density: float, rounding: float, rng: np.random.Generator,
                   plane_z: float, gap: float, orient: bool = True) -> Particle:
    """Erode the cells by r_m = rounding * h, orient the particle at random about its centroid and
    place its lowest rounded point `gap` above the plane z = plane_z."""
    r_m = rounding * tess.mean_cell_size
    cores_v, cores_f, cells_v, cells_f, bound = cell_bodies(tess, r_m)
    rotation = random_rotation(rng) if orient else np.eye(3)
    pivot = parent_centroid(tess)
    lab_core = np.concatenate([v @ tess.principal_axes[i].T + tess.centroid[i] for i, v in enumerate(cores_v)])
    placement = impact_placement(lab_core, pivot, rotation, plane_z, r_m + gap)
    polys = [placement.apply(tess.interface_polygon(k)) for k in range(tess.n_interfaces)]
    return Particle(
        tess=tess, placement=placement, r_m=r_m, centroids=placement.apply(tess.centroid),
        quats=placement.orient(tess.principal_axes), masses=density * tess.volume,
        moments=density * tess.principal_moments, core_vertices=cores_v, core_faces=cores_f,
        cell_vertices=cells_v, cell_faces=cells_f, bound_radius=bound, interface_polygons=polys)


def particle_tessellation(model, seed: int, cache_dir: Path) -> Tessellation:
    """The (cached) tessellation of a config's parent shape and cell count."""
    shape = parent_shape(model.shape, model.diameter, model.diameter_kind)
    return cached_tessellation(cache_dir, shape, n_cells=model.n_cells, seed=seed,
                               max_iter=model.lloyd_max_iter, tol=model.lloyd_tol)


def contact_timestep(masses: np.ndarray, k_max: float, steps_per_period: float) -> tuple[float, float]:
    """(dt, period): the shortest contact period 2 pi sqrt(m_red / k) with m_red = m_min / 2
    (two of the lightest cells) and the stiffest spring, divided by steps_per_period."""
    period = 2 * math.pi * math.sqrt(0.5 * float(np.min(masses)) / k_max)
    return period / steps_per_period, period
