"""What the BPM toughness tests share (SPEC 2.3): mode I (analysis/mode1.py) and mode II
(analysis/mode2.py) each read a loading record whose peak gives the toughness, check that the
sample failed after it and that the peak came quasi-statically, and compare runs over a set by
one model parameter (`toughness_set`).
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from analysis.plots import PlotGuard
from analysis.report import Report, clear_report, write_report
from analysis.tables import save_table

#: The sample has failed when the mean stress over the last quarter of the records after the
#: peak is below this fraction of the peak (a mean: the broken halves ring, undamped, about zero).
FAILED_FRACTION = 0.5
#: Fewest times a sound wave (mode I; a shear wave in mode II) crosses the sample before the
#: peak (as analysis/moduli.py asks of a phase): a faster loading loads the void by waves, not
#: quasi-statically (measured in mode I, L = 40: the peak after 14 crossings at rate 1e-4,
#: sigma_c 1 % above that at half the rate).
MIN_CROSSINGS = 5.0
#: Breaks whose distance from the nearest tip is reported (the first ones, by step).
FIRST_BREAKS = 10


def peak_and_end(stress: pd.Series) -> tuple[int, float, float, bool]:
    """(row of the peak, the peak, the mean over the last quarter of the records after it,
    failed): failed when at least two records follow the peak and that mean is below
    FAILED_FRACTION of it. `stress` is a column of a record with the default index."""
    k = int(stress.idxmax())
    peak = float(stress.iloc[k])
    after = stress.iloc[k + 1:]
    final = float(after.tail(max(1, len(after) // 4)).mean()) if len(after) else peak
    failed = bool(len(after) >= 2 and final < FAILED_FRACTION * peak)
    return k, peak, final, failed


def toughness_set(runs: list[dict], out: Path, plots: bool, left_out: list[dict] | None, x: str, cols: tuple[str, ...],
                  ratio: str, name: str, xlabel: str, ylabels: tuple[str, str], what: str) -> dict:
    """The set analysis of a toughness test: table `runs` (one row per run) and `toughness`
    (mean and standard deviation of `cols` per value of `x`), the figure of `ratio` (where the
    runs have it, else the toughness `name`) against x, and the report."""
    out = Path(out)
    rows = [{"run": r["cfg"]["name"], "run_dir": str(r["dir"]),
             **{k: v for k, v in r["summary"].items() if not isinstance(v, (list, dict))}} for r in runs]
    table = pd.DataFrame(rows).sort_values(x).reset_index(drop=True)
    save_table(table, out / "runs")
    points = table.groupby(x)[[c for c in cols if c in table]].agg(["mean", "std"])
    points.columns = [f"{a}_{b}" for a, b in points.columns]
    points = points.reset_index()
    save_table(points, out / "toughness")
    guard = PlotGuard()
    png = out / "plots" / f"toughness_vs_{x.removesuffix('_deg')}.png"
    y = ratio if f"{ratio}_mean" in points else name
    if plots:
        guard.draw(png.stem, png, plot_toughness, points, x, y, xlabel, ylabels[y != name], png)
    clear_report(out)
    shown = x.removesuffix("_deg")
    rep = Report(f"BPM {what} against {shown}", f"{len(table)} runs")
    rep.table(points, f"{name} per {shown} (mean and standard deviation over runs)")
    if plots and not guard.failed:
        rep.figure(png, f"{y} against {shown}")
    write_report(rep, out)
    return {"runs": len(table), "left_out": left_out or []}


def plot_toughness(points: pd.DataFrame, x: str, y: str, xlabel: str, ylabel: str, path: Path) -> None:
    """The mean of `y` against `x` over a set, with its standard deviation as error bars."""
    import matplotlib.pyplot as plt  # noqa: PLC0415
    from runfiles.atomic import atomic_save  # noqa: PLC0415

    fig, ax = plt.subplots(figsize=(5.0, 3.6), dpi=150)
    ax.errorbar(points[x], points[f"{y}_mean"], yerr=points[f"{y}_std"].fillna(0), fmt="o-")
    ax.set(xlabel=xlabel, ylabel=ylabel)
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p))
    plt.close(fig)
