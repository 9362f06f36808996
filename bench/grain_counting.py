"""Grain counting speed: connected components of a large bond network (issue 2 figure).

Builds a synthetic network of N particles with ~6 N bonds (random near-neighbour pairs on a
periodic 3D lattice, a fraction broken), then times `grains_from_bond_dump` (the function a
run uses), then the grain table of `driver post` (analysis.grain_table: bonds walked to
unwrap each grain across the periodic box, centre of mass, velocity, kinetic energy,
gyration tensor). Prints particles, bonds, seconds and peak memory.

    python bench/grain_counting.py [--n 1000000] [--bonds-per-particle 6] [--broken 0.3] [--no-table]
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np

from analysis.grain_table import grain_table
from analysis.grains import grain_sizes, grains_from_bond_dump


def synthetic_bonds(n: int, per_particle: float, broken: float, seed: int = 1):
    rng = np.random.default_rng(seed)
    side = int(round(n ** (1 / 3)))
    n = side ** 3
    idx = np.arange(n)
    x, y, z = idx % side, (idx // side) % side, idx // side ** 2
    offsets = [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (1, 0, 1), (0, 1, 1), (1, -1, 0)]
    nb = int(per_particle * n)
    pairs = []
    for dx, dy, dz in offsets:
        j = ((x + dx) % side) + ((y + dy) % side) * side + ((z + dz) % side) * side ** 2
        pairs.append(np.stack([idx, j], axis=1))
    pairs = np.concatenate(pairs)[:nb]
    types = (rng.random(len(pairs)) >= broken).astype(np.int64)
    return n, pairs + 1, types


def lattice_positions(n: int, seed: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Positions of the lattice sites (spacing 1, jittered) wrapped into the periodic box."""
    side = round(n ** (1 / 3))
    idx = np.arange(n)
    pos = np.stack([idx % side, (idx // side) % side, idx // side ** 2], axis=1).astype(float)
    pos += np.random.default_rng(seed).uniform(-0.2, 0.2, pos.shape)
    box = np.array([[-0.5, side - 0.5]] * 3)
    return np.where(pos < box[:, 0], pos + side, pos), box


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--bonds-per-particle", type=float, default=6.0)
    ap.add_argument("--broken", type=float, default=0.3)
    ap.add_argument("--no-table", action="store_true", help="time the grain labels only")
    args = ap.parse_args()
    n, pairs, types = synthetic_bonds(args.n, args.bonds_per_particle, args.broken)
    t0 = time.perf_counter()
    labels = grains_from_bond_dump(n, pairs, types)
    sizes = grain_sizes(labels)
    dt = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"particles        {n:,}")
    print(f"bonds            {len(pairs):,} ({np.mean(types > 0):.0%} intact)")
    print(f"grains           {len(sizes):,} (largest {int(sizes.max()):,})")
    print(f"grain counting   {dt:.2f} s")
    print(f"peak memory      {peak:,.0f} MiB (whole process, after counting)")
    if args.no_table:
        return
    pos, box = lattice_positions(n)
    vel = np.random.default_rng(3).normal(size=pos.shape)
    intact = pairs[types > 0] - 1
    t0 = time.perf_counter()
    table = grain_table(labels, pos, vel, None, intact, box)
    dt = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"grain table      {dt:.2f} s ({len(table):,} rows, {int(table.percolating.sum())} percolating)")
    print(f"peak memory      {peak:,.0f} MiB (whole process, after the table)")


if __name__ == "__main__":
    main()
