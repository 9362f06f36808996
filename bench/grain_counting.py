"""Grain counting speed: connected components of a large bond network (issue 2 figure).

Builds a synthetic network of N particles with ~6 N bonds (random near-neighbour pairs on a
periodic 3D lattice, a fraction broken), then times `grains_from_bond_dump` (the function a
run uses). Prints particles, bonds, seconds and peak memory.

    python bench/grain_counting.py [--n 1000000] [--bonds-per-particle 6] [--broken 0.3]
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np

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


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--bonds-per-particle", type=float, default=6.0)
    ap.add_argument("--broken", type=float, default=0.3)
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
    print(f"peak memory      {peak:,.0f} MiB (whole process)")


if __name__ == "__main__":
    main()
