"""The break-event log of a run: `breaks.dat`, written by LAMMPS's fix breakable/log.

One line per broken element (bond, angle or BCM interface), after a header line naming the
columns (plugins/doc/fix_breakable_log.md):

    # step time id1 id2 id3 kind x y z energy area

step: time step of the force evaluation that broke it; time: simulation time (LAMMPS units of
the run); id1..id3: atom IDs (bond, interface: id1 < id2 and id3 = 0; angle: id2 = vertex);
kind: bond | angle | interface; x y z: midpoint of the two atoms (bond, interface) or the
vertex (angle), wrapped into a periodic box; energy: what the element held when it
broke (SPEC 2.2 Eq. 2 for a bond, Eq. 3-4 for an angle, the interface's stored elastic energy
for BCM); area: the interface area (0 for bonds and angles).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from analysis.tables import save_table

LOG_NAME = "breaks.dat"
TABLE_NAME = "breaks"  # results/breaks.parquet, results/breaks.csv
COLUMNS = ("step", "time", "id1", "id2", "id3", "kind", "x", "y", "z", "energy", "area")
KINDS = ("bond", "angle", "interface")
_INTEGER = ("step", "id1", "id2", "id3")


def read_break_log(path: str | Path) -> pd.DataFrame:
    """The events of a break log as a DataFrame with the columns named by its header
    (COLUMNS at least, in that order; further columns follow), one row per event, in the
    file's order (step, then kind, then ids).

    Raises ValueError naming the file when the header is missing or lacks a needed column,
    or when a line has the wrong number of fields or an unknown kind.
    """
    path = Path(path)
    lines = path.read_text().splitlines()
    if not lines or not lines[0].startswith("#"):
        raise ValueError(f"{path}: no header line (`# {' '.join(COLUMNS)}`) at the top")
    names = lines[0].lstrip("#").split()
    missing = [c for c in COLUMNS if c not in names]
    if missing:
        raise ValueError(f"{path}: header lacks column(s) {', '.join(missing)} "
                         f"(has: {' '.join(names)})")
    rows = [ln.split() for ln in lines[1:] if ln.strip() and not ln.startswith("#")]
    bad = next((k for k, r in enumerate(rows) if len(r) != len(names)), None)
    if bad is not None:
        raise ValueError(f"{path}: an event line has {len(rows[bad])} fields, the header "
                         f"names {len(names)}: {' '.join(rows[bad])!r}")
    df = pd.DataFrame(rows, columns=names)
    for c in names:
        if c == "kind":
            continue
        df[c] = pd.to_numeric(df[c]).astype(np.int64 if c in _INTEGER else np.float64)
    unknown = sorted(set(df["kind"]) - set(KINDS))
    if unknown:
        raise ValueError(f"{path}: unknown kind(s) {', '.join(unknown)} (known: {', '.join(KINDS)})")
    ordered = list(COLUMNS) + [c for c in names if c not in COLUMNS]
    return df[ordered].reset_index(drop=True)


def write_break_table(run_dir: str | Path) -> pd.DataFrame:
    """Read `<run_dir>/breaks.dat` and write it as results/breaks.parquet and results/breaks.csv
    (each atomically); returns the table. FileNotFoundError if the run wrote no log."""
    run_dir = Path(run_dir)
    df = read_break_log(run_dir / LOG_NAME)
    save_table(df, run_dir / "results" / TABLE_NAME)
    return df
