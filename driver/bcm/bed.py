"""A bed of BCM grains (issue 25, point 1): many tessellated particles placed in a rigid box.

Each grain is a tessellation from a pool (model.assembly.tessellations of them, seeds 1..P,
cached: every run of a material reuses them), scaled to the grain's diameter (geometry by s,
areas by s², volumes and masses by s³, moments by s⁵), turned by its random orientation and
centred where the dense start put its bounding sphere (driver/assembly.py). One rounding radius
r_m for the whole bed (pair bcm/contact and the walls take one): `rounding` times the mean cell
size of the smallest grain; each grain's cells are eroded by it at their own scale. Every cell
carries its grain id as its LAMMPS molecule id (data file, dumps), and the interfaces join
cells of one grain only.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from driver.assembly import LooseStart, dense_start, grain_sizes, loose_start
from driver.bcm.impact import bonded_interfaces, timestep_facts
from driver.bcm.lammps_files import write_cell_data, write_interfaces
from driver.bcm.particle import cell_bodies, parent_centroid, particle_tessellation
from driver.bcm.polyhedra import rotation_to_quaternion
from driver.cache import cache_base
from runfiles.cells import write_cells


@dataclass
class BedCells:
    """Every cell of the bed in the lab (arrays over cells, 0-based, grain by grain)."""

    grain: np.ndarray          # (n,) grain id, 1-based
    centroids: np.ndarray      # (n, 3)
    quats: np.ndarray          # (n, 4) body -> lab
    masses: np.ndarray         # (n,)
    moments: np.ndarray        # (n, 3)
    volumes: np.ndarray        # (n,) Voronoi volumes
    bound_radius: np.ndarray   # (n,)
    core_vertices: list        # body frame, eroded by r_m
    core_faces: list
    cell_vertices: list        # body frame, the Voronoi cells
    cell_faces: list
    pairs: np.ndarray          # (m, 2) bonded interfaces, 0-based cell indices
    areas: np.ndarray          # (m,)
    normals: np.ndarray        # (m, 3) lab
    polygons: list             # (m) lab, reference state
    points: int                # interface points (polygon vertices) of the bonded interfaces
    r_m: float


def grain_cells(tess, bodies, s: float, rotation: np.ndarray, centre: np.ndarray, density: float,
                min_interface_area: float) -> dict:
    """One grain: the pool tessellation `tess` (its cell bodies `bodies` eroded at this scale)
    scaled by s, turned by `rotation` about its centroid and centred at `centre`."""
    pivot = parent_centroid(tess)

    def place(x: np.ndarray) -> np.ndarray:
        return s * (np.asarray(x) - pivot) @ rotation.T + centre

    cores_v, cores_f, cells_v, cells_f, bound = bodies
    bonded = bonded_interfaces(tess.iface_area, min_interface_area)
    idx = np.flatnonzero(bonded)
    return dict(
        centroids=place(tess.centroid), quats=rotation_to_quaternion(rotation @ tess.principal_axes),
        masses=density * tess.volume * s**3, moments=density * tess.principal_moments * s**5,
        volumes=tess.volume * s**3, bound_radius=s * bound,
        core_vertices=[s * v for v in cores_v], core_faces=cores_f,
        cell_vertices=[s * v for v in cells_v], cell_faces=cells_f,
        pairs=tess.iface_cells[idx], areas=tess.iface_area[idx] * s**2,
        normals=tess.iface_normal[idx] @ rotation.T, polygons=[place(tess.interface_polygon(k)) for k in idx],
        points=int(np.diff(tess.iface_ptr)[idx].sum()))


def bed_start(assembly, seed: int, bound_radius: float, diameter: float) -> tuple[np.ndarray, LooseStart]:
    """(grain diameters, dense start) of a run: sizes by the assembly's law, the bounding spheres
    (radius bound_radius x d / diameter: the parent's circumscribed radius at its size) placed
    loose by random sequential addition, then settled (driver/assembly.py)."""
    rng = np.random.default_rng([seed, 25])
    sizes = grain_sizes(assembly.sizes, assembly.n_grains, rng)
    radii = bound_radius * sizes / diameter
    loose = loose_start(radii, assembly.box, rng, assembly.max_attempts)
    return sizes, dense_start(loose)


def build_bed(model, seed: int) -> tuple[BedCells, np.ndarray, LooseStart, list]:
    """(cells, grain diameters, start, pool tessellations) of a bed: the pool's tessellations
    (cached), the dense start, each grain from its pool entry (drawn by the seed) at its scale."""
    a = model.assembly
    cache = cache_base() / "tessellations"
    pool = [particle_tessellation(model, k, cache) for k in range(1, a.tessellations + 1)]
    # the parent's bounding radius about its centroid, from the pool's own vertices
    bound = max(float(np.linalg.norm(t.vertices - parent_centroid(t), axis=1).max()) for t in pool)
    sizes, start = bed_start(a, seed, bound, model.diameter)
    rng = np.random.default_rng([seed, 26])
    pick = rng.integers(0, len(pool), len(sizes))
    scale = sizes / model.diameter
    r_m = model.rounding * pool[0].mean_cell_size * float(scale.min())
    bodies: dict[tuple[int, float], tuple] = {}
    parts, first = [], 0
    rotations = start.rotations.as_matrix()
    for g, (k, s) in enumerate(zip(pick, scale)):
        key = (int(k), float(s))
        if key not in bodies:  # erosion at this scale: s x (the unit cell eroded by r_m / s)
            bodies[key] = cell_bodies(pool[k], r_m / s)
        part = grain_cells(pool[k], bodies[key], float(s), rotations[g], start.centres[g], model.density,
                           model.min_interface_area)
        part["pairs"] = part["pairs"] + first
        part["grain"] = np.full(len(part["masses"]), g + 1)
        first += len(part["masses"])
        parts.append(part)

    def cat(name: str) -> np.ndarray:
        return np.concatenate([p[name] for p in parts])

    def chain(name: str) -> list:
        return [x for p in parts for x in p[name]]

    cells = BedCells(
        grain=cat("grain"), centroids=cat("centroids"), quats=cat("quats"), masses=cat("masses"),
        moments=cat("moments"), volumes=cat("volumes"), bound_radius=cat("bound_radius"),
        core_vertices=chain("core_vertices"), core_faces=chain("core_faces"),
        cell_vertices=chain("cell_vertices"), cell_faces=chain("cell_faces"), pairs=cat("pairs"),
        areas=cat("areas"), normals=cat("normals"), polygons=chain("polygons"),
        points=sum(p["points"] for p in parts), r_m=r_m)
    return cells, sizes, start, pool


def write_bed(root, cells: BedCells, box: np.ndarray) -> None:
    """system.data (molecule id = grain id), interfaces.txt, cells.txt and voronoi_cells.txt of a
    bed in `root`; the LAMMPS box holds the rigid box [0, box] with a margin of a cell's size."""
    margin = 2.0 * float(cells.bound_radius.max())
    write_cell_data(root / "system.data", cells.centroids, cells.quats, cells.masses, cells.moments,
                    2.0 * cells.bound_radius, cells.pairs, box=(np.full(3, -margin), np.asarray(box) + margin),
                    grain=cells.grain)
    write_interfaces(root / "interfaces.txt", cells.pairs, cells.areas, cells.normals, cells.polygons)
    write_cells(root / "cells.txt", cells.core_vertices, cells.core_faces)
    write_cells(root / "voronoi_cells.txt", cells.cell_vertices, cells.cell_faces)


def bed_facts(model, cells: BedCells, sizes: np.ndarray, start: LooseStart, pool: list,
              steps_per_period: float, seconds: float) -> dict:
    """system.json's facts of a bed: counts, the grains (diameter, cells, volume, mass, centre at
    the start), the box, the solid volume, A_0 and the time step (as a single particle's,
    driver/bcm/impact.py timestep_facts)."""
    m = model
    grain_volume = np.bincount(cells.grain - 1, weights=cells.volumes)
    counts = np.bincount(cells.grain - 1)
    return {
        "n_grains": int(len(sizes)), "n_cells": int(len(cells.masses)), "n_interfaces": int(len(cells.pairs)),
        "contact_points": cells.points, "A0": float(cells.areas.sum()),
        "mean_interface_area": float(cells.areas.mean()), "interface_stiffness": m.interface_stiffness,
        "mass": float(cells.masses.sum()), "solid_volume": float(grain_volume.sum()),
        "grain_diameter": sizes.tolist(), "grain_cells": counts.tolist(), "grain_volume": grain_volume.tolist(),
        "grain_mass": np.bincount(cells.grain - 1, weights=cells.masses).tolist(),
        "grain_centre": start.centres.tolist(),
        "box": [float(x) for x in start.box], "start_fraction": start.solid_fraction,
        "r_m": cells.r_m, "mean_cell_size": float(pool[0].mean_cell_size * np.mean(sizes) / m.diameter),
        "tessellation_keys": [t.key for t in pool], "build_seconds": seconds,
        **timestep_facts(m, cells.areas, cells.masses, steps_per_period), "max_bound_radius": float(cells.bound_radius.max()),
    }


def place_bed(cfg, rd) -> dict:
    """Build the run's bed and write its files; returns its facts (system.json's first part)."""
    t0 = time.perf_counter()
    cells, sizes, start, pool = build_bed(cfg.model, cfg.seed)
    write_bed(rd.root, cells, start.box)
    return bed_facts(cfg.model, cells, sizes, start, pool, cfg.scenario.steps_per_period, time.perf_counter() - t0)
