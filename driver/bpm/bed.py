"""A bed of BPM grains (issue 25, point 1): many bonded-particle grains placed in a rigid box.

Each grain is the BPM particle of SPEC 3 at its own size: a jammed packing from a pool
(model.assembly.tessellations of them, seeds 1..P, cached: every run of a material reuses
them), shifted periodically by a random offset (so two grains cut from one packing differ),
clipped to the parent shape at the grain's diameter (driver/bpm/clipped.py), with the
Delaunay bonds and angles between its kept particles only (SPEC 2.1): no bond joins two
grains. One LJ length a for the bed (model.particle.units): a grain of diameter d holds about
0.5 (d / a)^3 particles. Turned by its random orientation and centred where the dense start
(driver/assembly.py) put its bounding sphere (the parent's circumscribed sphere plus a
particle's radius a / 2). Every particle carries its grain id as its LAMMPS molecule id (data
file, dumps; the break log's ids map to it through system.json's grain_particles: particles
are numbered grain by grain).

Grains of different grains meet through the model's own non-bonded repulsion (SPEC 2.1 Eq. 1,
with its damping, Eq. 5), the law that acts between the fragments of one broken grain: a
broken bond turns into that repulsion, so one law holds between any two particles without an
intact bond, whether they were ever bonded or not.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from driver.assembly import dense_start, grain_sizes, loose_start
from driver.bpm.clipped import box_side, clip_packing, parent_in_a, voronoi_cells
from driver.bpm.impact import DIAMETER, lj_units, plane_law, write_sphere_data, write_voronoi_tables
from driver.bpm.network import Network, delaunay_network, repulsion_at_break
from driver.bpm.packing import Packing, cached_packing
from driver.cache import cache_base


@dataclass
class BpmBed:
    """Every particle of the bed in the lab (LJ units, 0-based, grain by grain)."""

    positions: np.ndarray   # (n, 3), a
    grain: np.ndarray       # (n,) grain id, 1-based
    bonds: np.ndarray       # (m, 2)
    angles: np.ndarray      # (k, 3) (i, vertex, j)
    r0: np.ndarray          # (m,) bond lengths, a
    bond_area: np.ndarray   # (m,) Voronoi face areas, a^2
    volume: np.ndarray      # (n,) Voronoi volumes, a^3 (each grain's sum: its parent's volume)


def _shifted(packing: Packing, offset: np.ndarray) -> Packing:
    """The periodic packing with every position moved by `offset` and wrapped into its box."""
    lo, hi = (np.asarray(b, float) for b in packing.box)
    x = lo + np.mod(packing.positions + offset - lo, hi - lo)
    return Packing(positions=x, radii=packing.radii, types=packing.types, box=packing.box,
                   dimension=packing.dimension, relaxation=packing.relaxation)


def build_bpm_bed(cfg) -> tuple[BpmBed, np.ndarray, object, dict]:
    """(bed, grain diameters (m), dense start (m), facts) of a run's BPM bed (module docstring)."""
    m, p, asm = cfg.model, cfg.model.particle, cfg.model.assembly
    un = lj_units(p.units)
    a = un["a"]
    rng = np.random.default_rng([cfg.seed, 25])  # the BCM bed's streams: same sizes and start
    sizes = grain_sizes(asm.sizes, asm.n_grains, rng)
    unit = parent_in_a(p.shape, p.diameter, p.diameter_kind, a)
    # bounding sphere: the parent's circumscribed sphere at the grain's size, plus a sphere's radius
    radii = (0.5 * unit.circumscribed_diameter * sizes / p.diameter + 0.5 * DIAMETER) * a
    start = dense_start(loose_start(radii, asm.box, rng, asm.max_attempts))
    L = box_side(parent_in_a(p.shape, float(sizes.max()), p.diameter_kind, a), p.margin)
    cache = cache_base() / "packings"
    pool = {}
    pick_rng = np.random.default_rng([cfg.seed, 26])
    pick = pick_rng.integers(0, asm.tessellations, len(sizes))
    rotations = start.rotations.as_matrix()
    xs, grains, bonds, angles, r0, areas, vols, first = [], [], [], [], [], [], [], 0
    for g, (k, d) in enumerate(zip(pick, sizes)):
        if k not in pool:  # the periodic network does not change with a periodic shift: once per packing
            packing = cached_packing(cache, 3, L, int(k) + 1, m.packing_fraction, m.packing or "contact")
            pool[k] = (packing, delaunay_network(packing, m.bond_max_length))
        packing, net = pool[k]
        packing = _shifted(packing, pick_rng.uniform(0.0, L, 3))
        parent = parent_in_a(p.shape, float(d), p.diameter_kind, a)
        clipped = clip_packing(packing, net, parent)
        cells = voronoi_cells(parent, clipped.positions, clipped.network.bonds)
        xs.append(clipped.positions @ rotations[g].T + start.centres[g] / a)
        grains.append(np.full(len(clipped.positions), g + 1))
        bonds.append(clipped.network.bonds + first)
        angles.append(clipped.network.angles + first)
        r0.append(clipped.network.r0)
        areas.append(cells.bond_area)
        vols.append(cells.volume)
        first += len(clipped.positions)
    bed = BpmBed(positions=np.concatenate(xs), grain=np.concatenate(grains), bonds=np.concatenate(bonds),
                 angles=np.concatenate(angles), r0=np.concatenate(r0), bond_area=np.concatenate(areas),
                 volume=np.concatenate(vols))
    return bed, sizes, start, {"packing_side_a": L, "packings": sorted(int(k) + 1 for k in pool)}


def write_bed_data(path: Path, bed: BpmBed, box_a: np.ndarray) -> None:
    """The BPM data file and its references (driver/bpm/impact.py write_sphere_data, molecule =
    grain id), the LAMMPS box around the rigid box [0, box_a] with a margin of two diameters."""
    net = Network(bonds=bed.bonds, r0=bed.r0, angles=bed.angles, theta0=np.zeros(len(bed.angles)),
                  n_atoms=len(bed.positions))
    margin = 2.0 * DIAMETER
    write_sphere_data(path, bed.positions, net, (np.full(3, -margin), np.asarray(box_a, float) + margin),
                      grain=bed.grain)


def place_bpm_bed(cfg, rd) -> dict:
    """Build the run's BPM bed, write its files (system.data, system.refs, bond_areas.txt,
    particle_volumes.txt); returns its facts (system.json's first part)."""
    m, p, sc = cfg.model, cfg.model.particle, cfg.scenario
    t0 = time.perf_counter()
    bed, sizes, start, pool_facts = build_bpm_bed(cfg)
    un = lj_units(p.units)
    a = un["a"]
    box_a = np.asarray(start.box, float) / a
    write_bed_data(rd.root / "system.data", bed, box_a)
    write_voronoi_tables(rd.root, bed.bonds, bed.bond_area, bed.volume, "its grain's parent")
    law = plane_law(p.contact, un)
    dt = min(m.timestep, law["period"] / sc.steps_per_period)
    counts = np.bincount(bed.grain - 1)
    grain_volume = np.bincount(bed.grain - 1, weights=bed.volume) * a ** 3
    A0 = float(bed.bond_area.sum())
    n_in, u_max, u_sum = repulsion_at_break(bed.r0, DIAMETER, m.lambda_c)
    return {
        "n_grains": int(len(sizes)), "n_particles": int(len(bed.positions)), "n_bonds": int(len(bed.bonds)),
        "n_angles": int(len(bed.angles)), "max_r0": float(bed.r0.max()), "units": un, "a_m": a,
        "m_kg": un["m"], "u_J": un["u"], "tau_s": un["tau"], "A0_a2": A0, "A0": A0 * a ** 2,
        "mass": float(len(bed.positions) * un["m"]), "solid_volume": float(grain_volume.sum()),
        "solid_volume_a3": float(grain_volume.sum()) / a ** 3,
        "grain_diameter": sizes.tolist(), "grain_particles": counts.tolist(), "grain_volume": grain_volume.tolist(),
        "grain_mass": (counts * un["m"]).tolist(), "grain_centre": start.centres.tolist(),
        "box": [float(v) for v in start.box], "box_a": box_a.tolist(), "start_fraction": start.solid_fraction,
        "plane": law, "timestep": dt, "timestep_s": dt * un["tau"],
        "timestep_rule": (f"dt = min(model.timestep = {m.timestep:g}, 2 pi sqrt(m / k_n) / {sc.steps_per_period:g}) "
                          f"tau, k_n = {law['kn']:.6g} u/a^2 (the walls' contact)"),
        "bonds_breaking_in_repulsion": n_in, "repulsion_energy_per_break_max": u_max,
        "repulsion_energy_if_all_break": u_sum, **pool_facts, "build_seconds": time.perf_counter() - t0,
    }
