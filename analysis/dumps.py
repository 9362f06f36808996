"""Readers for LAMMPS text dumps.

`dump local` frames change length every frame, so frames are found by scanning for
`ITEM: TIMESTEP` and each block is parsed with numpy (never line by line in Python).
"""

from __future__ import annotations

import gzip
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np


class DumpError(ValueError):
    """A dump is truncated or inconsistent; the message names file, frame and line."""


@dataclass
class LocalFrame:
    """One frame of a `dump local` file: columns by header name, shape (n,) each."""

    timestep: int
    box: np.ndarray  # (3, 2) lo, hi
    columns: dict[str, np.ndarray]

    def __len__(self) -> int:
        return len(next(iter(self.columns.values()))) if self.columns else 0


def _open_text(path: Path) -> str:
    raw = path.read_bytes()
    if raw[:2] == b"\x1f\x8b":
        raw = gzip.decompress(raw)
    return raw.decode()


def read_local_dump(path: str | Path) -> list[LocalFrame]:
    """All frames of a `dump local` / `write_dump local` file (plain or gzip)."""
    path = Path(path)
    text = _open_text(path)
    lines = text.splitlines()
    frames: list[LocalFrame] = []
    i, nlines = 0, len(lines)
    while i < nlines:
        if not lines[i].startswith("ITEM: TIMESTEP"):
            if lines[i].strip():
                raise DumpError(f"{path}: frame {len(frames)}, line {i + 1}: expected 'ITEM: TIMESTEP'")
            i += 1
            continue
        start = i
        try:
            step = int(lines[i + 1])
            if not lines[i + 2].startswith("ITEM: NUMBER OF"):
                raise ValueError("missing NUMBER OF ENTRIES")
            n = int(lines[i + 3])
            if not lines[i + 4].startswith("ITEM: BOX BOUNDS"):
                raise ValueError("missing BOX BOUNDS")
            box = np.array([[float(v) for v in lines[i + 5 + k].split()[:2]] for k in range(3)])
            header = lines[i + 8]
            if not header.startswith("ITEM: ENTRIES"):
                raise ValueError("missing ENTRIES header")
            names = header.split()[2:]
        except (IndexError, ValueError) as exc:
            raise DumpError(f"{path}: frame {len(frames)} (line {start + 1}) has a bad header: {exc}") from None
        body_start = i + 9
        if body_start + n > nlines:
            raise DumpError(f"{path}: frame {len(frames)} (timestep {step}, line {start + 1}) is truncated: "
                            f"{n} entries announced, {nlines - body_start} present")
        block = "\n".join(lines[body_start:body_start + n])
        data = np.loadtxt(io.StringIO(block), ndmin=2) if n else np.empty((0, len(names)))
        if data.shape[1] != len(names):
            raise DumpError(f"{path}: frame {len(frames)} (timestep {step}): {data.shape[1]} columns, "
                            f"header names {len(names)}")
        frames.append(LocalFrame(step, box, {nm: data[:, k] for k, nm in enumerate(names)}))
        i = body_start + n
    return frames


def bond_pairs(frame: LocalFrame) -> tuple[np.ndarray, np.ndarray]:
    """(pairs of 1-based atom ids (n, 2) int, bond types (n,) int) of a bond dump frame.

    Columns are taken by position (atom1, atom2, type) as the driver writes them.
    """
    cols = list(frame.columns.values())
    if len(cols) < 3:
        raise DumpError(f"bond frame at timestep {frame.timestep} has {len(cols)} columns, need atom1 atom2 type")
    pairs = np.stack([cols[0], cols[1]], axis=1).astype(np.int64)
    return pairs, cols[2].astype(np.int64)
