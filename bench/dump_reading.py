"""Dump reading speed (issue 4 figure): synthetic LAMMPS text dumps read by analysis.dumps.

Writes a bond `dump local` (atom1 atom2 type, frames of --entries rows) and an atom
`dump custom` (14 columns, frames of --atoms rows) of about --mb megabytes each into a
temporary directory, then prints MB/s (best of --reps whole-file reads; the files are in the
page cache after writing, so this is parsing speed). Target: >= 100 MB/s.

    python bench/dump_reading.py [--mb 1000] [--reps 3]
"""

from __future__ import annotations

import argparse
import io
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.dumps import read_atom_dump, read_local_dump


def write_frames(path: Path, target_mb: float, n: int, header, body) -> None:
    """Frames of n rows until the file holds target_mb; one random body is written under
    every timestep (the reader parses each frame anew, so this measures the same work as
    distinct frames, and writing a 1 GB file takes seconds rather than minutes)."""
    buf = io.StringIO()
    body(np.random.default_rng(1), n).to_csv(buf, sep=" ", header=False, index=False, float_format="%.6g")
    text = buf.getvalue()
    written, step = 0, 0
    with open(path, "w") as fh:
        while written < target_mb * 1e6:
            frame = header(step, n) + text
            fh.write(frame)
            written += len(frame)
            step += 1000


def bond_header(step: int, n: int) -> str:
    return (f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ENTRIES\n{n}\nITEM: BOX BOUNDS pp pp pp\n"
            + "0 100\n" * 3 + "ITEM: ENTRIES c_bl[1] c_bl[2] c_bl[3]\n")


def bond_body(rng, n: int) -> pd.DataFrame:
    a = rng.integers(1, 7_000_000, n)
    return pd.DataFrame({"a": a, "b": a + rng.integers(1, 50, n), "t": rng.integers(0, 2, n)})


ATOM_COLS = "id type x y z vx vy vz c_q[1] c_q[2] c_q[3] c_q[4] mass radius".split()


def atom_header(step: int, n: int) -> str:
    return (f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n{n}\nITEM: BOX BOUNDS pp pp pp\n"
            + "-800 800\n" * 3 + "ITEM: ATOMS " + " ".join(ATOM_COLS) + "\n")


def atom_body(rng, n: int) -> pd.DataFrame:
    df = pd.DataFrame({"id": rng.permutation(n) + 1, "type": rng.integers(1, 3, n)})
    for c in ATOM_COLS[2:]:
        df[c] = rng.normal(size=n)
    return df


def best_rate(fn, path: Path, reps: int) -> tuple[float, int]:
    mb = path.stat().st_size / 1e6
    best, frames = float("inf"), 0
    for _ in range(reps):
        t0 = time.perf_counter()
        frames = len(fn(path))
        best = min(best, time.perf_counter() - t0)
    return mb / best, frames


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--mb", type=float, default=1000.0)
    ap.add_argument("--entries", type=int, default=1_000_000)
    ap.add_argument("--atoms", type=int, default=500_000)
    ap.add_argument("--reps", type=int, default=3)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        bonds, atoms = Path(tmp) / "bonds.lammpstrj", Path(tmp) / "atoms.lammpstrj"
        write_frames(bonds, args.mb, args.entries, bond_header, bond_body)
        write_frames(atoms, args.mb, args.atoms, atom_header, atom_body)
        for label, fn, path in [("dump local (bonds, 3 int columns)", read_local_dump, bonds),
                                ("dump custom (atoms, 14 columns)", read_atom_dump, atoms)]:
            rate, frames = best_rate(fn, path, args.reps)
            print(f"{label:36s} {path.stat().st_size / 1e6:7.1f} MB, {frames} frames: {rate:6.1f} MB/s "
                  f"(target >= 100)")


if __name__ == "__main__":
    main()
