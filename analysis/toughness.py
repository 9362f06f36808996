"""BPM mode-I toughness (SPEC 2.3): K_IC from the peak stress of a mode1 run
(driver/bpm/mode1.py), where the first bonds broke relative to the void's tips, and K_IC / E
against lambda_c over a set of runs.

The elliptic void of full axes 2c x 2b (b << c) stands for a centre crack of length 2c: a
sharp crack's K = Y sigma sqrt(pi c) is used with the void's half major axis c (the void's
finite tip radius b^2 / c makes the measured K_IC an upper bound of the sharp-crack value).
Finite width W: Feddersen's factor for a centre crack in a plate in uniform tension,

    Y = sqrt(sec(pi c / W)),    within 0.3 % for 2c / W <= 0.7

(Tada, Paris & Irwin, The Stress Analysis of Cracks Handbook, 3rd ed. 2000, centre crack in a
strip; the unit refuses wider voids). It is the factor of a long strip: a square sample (height = W) is
somewhat more compliant, which the factor leaves out. sigma_c is the largest far-field stress
of the record (the grips' force over the width, times the slab thickness in 3D; the crack runs
once it is passed). In 3D the void is a through-thickness cylinder in a periodic slab: plane
strain, with the same K formula.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.breaks import read_break_log
from analysis.crack import crack_fronts, plot_fronts, rayleigh_speed, steady_speed
from analysis.plots import PlotGuard
from analysis.report import Report, clear_report, provenance_line, write_report
from analysis.tables import save_table
from runfiles.records import MODE1_RECORD, read_record

#: The sample has failed when the mean stress over the last quarter of the records after the
#: peak is below this fraction of the peak (a mean: the broken halves ring, undamped, about zero).
FAILED_FRACTION = 0.5
#: Fewest times a sound wave crosses the sample before the peak (as analysis/moduli.py asks of a
#: phase): a faster pull loads the void by waves, not quasi-statically (measured, L = 40: the
#: peak after 14 crossings at rate 1e-4, sigma_c 1 % above that at half the rate).
MIN_CROSSINGS = 5.0
#: Breaks whose distance from the nearest tip is reported (the first ones, by step).
FIRST_BREAKS = 10


def feddersen_factor(c: float, width: float) -> float:
    """Y = sqrt(sec(pi c / W)) of a centre crack of half length c in a plate of width W."""
    return math.sqrt(1.0 / math.cos(math.pi * c / width))


def toughness(sigma_c: float, c: float, width: float) -> float:
    """K_IC = Y sigma_c sqrt(pi c) (module docstring)."""
    return feddersen_factor(c, width) * sigma_c * math.sqrt(math.pi * c)


def tip_distances(events: pd.DataFrame, centre: np.ndarray, c: float) -> np.ndarray:
    """Distance of each event's position (x, y) from the nearer of the tips centre +- (c, 0)."""
    xy = events[["x", "y"]].to_numpy(float) - np.asarray(centre, float)[:2]
    return np.hypot(np.abs(xy[:, 0]) - c, xy[:, 1])


def _density(system: dict, c: float) -> float:
    """Number density of the sample (m = 1): particles over its area less the void's, times the
    slab thickness in 3D (per unit area in 2D)."""
    area = float(system["width"]) * float(system["height"]) - math.pi * c * float(system["void_semi_axes"][1])
    return system["n_particles"] / (area * float(system.get("thickness", 1.0)))


def analyse_mode1(run_dir: Path, cfg: dict, plots: bool = True, partial: bool = False) -> dict:
    """Summary, results/mode1 (the record), figure plots/mode1.png and report of a mode1 run.
    partial: analysed all the same (a run cut short after the peak still has it)."""
    run_dir = Path(run_dir)
    guard = PlotGuard()
    system = json.loads((run_dir / "system.json").read_text())
    record = read_record(run_dir / "thermo.dat", MODE1_RECORD.names)
    save_table(record, run_dir / "results" / "mode1")
    c = float(system["void_semi_axes"][0])
    width = float(system["width"])
    k = int(record.stress.idxmax())
    peak = record.iloc[k]
    sigma_c = float(peak.stress)
    K = toughness(sigma_c, c, width)
    after = record.stress.iloc[k + 1:]
    final = float(after.tail(max(1, len(after) // 4)).mean()) if len(after) else sigma_c
    failed = bool(len(after) >= 2 and final < FAILED_FRACTION * sigma_c)
    flags = [] if failed else [f"no failure: the stress at the end ({final:.4g}) is not below {FAILED_FRACTION:g} "
                               f"of its peak ({sigma_c:.4g}); pull further (scenario.max_pull_strain)"]
    summary: dict = {"lambda_c": cfg["model"]["lambda_c"], "k_A": cfg["model"]["k_A"], "sigma_c": sigma_c,
                     "peak_step": int(peak.step), "peak_displacement": float(peak.displacement),
                     "geometry_factor": feddersen_factor(c, width), "crack_half_length": c, "width": width,
                     "K_IC": K, "final_mean_stress": final, "failed": failed}
    E = cfg["scenario"].get("E_reference")
    if E:
        summary.update(E_reference=float(E), K_IC_over_E=K / float(E))
        # wave speed sqrt(E / rho), rho the number density of the sample (m = 1): in 2D it is
        # below c_l = sqrt((B + G) / rho) = sqrt(E / ((1 - nu^2) rho)), so the count is a lower bound
        rho = _density(system, c)
        crossings = float(peak.time) / (float(system["height"]) / math.sqrt(float(E) / rho))
        summary["sound_crossings_to_peak"] = crossings
        if crossings < MIN_CROSSINGS:
            flags.append(f"rate: the peak comes after {crossings:.2g} sound crossings of the sample (< "
                         f"{MIN_CROSSINGS:g}): the void is loaded by waves; pull more slowly")
    log = run_dir / "breaks.dat"
    if log.exists():
        bonds = read_break_log(log)
        bonds = bonds[bonds.kind == "bond"].sort_values("step", kind="stable")
        if len(bonds):
            first = bonds.head(FIRST_BREAKS)
            d = tip_distances(first, np.asarray(system["void_centre"]), c)
            summary.update(first_break_step=int(first.step.iloc[0]), first_breaks=len(first),
                           first_breaks_max_tip_distance=float(d.max()),
                           first_breaks_median_tip_distance=float(np.median(d)),
                           bonds_broken_before_peak=int((bonds.step <= peak.step).sum()))
            # crack speed (analysis/crack.py): the fronts along the void's plane, within a band of
            # twice the void's minor axis
            fronts = crack_fronts(bonds, np.asarray(system["void_centre"]), c,
                                  band=4.0 * float(system["void_semi_axes"][1]))
            save_table(fronts, run_dir / "results" / "crack_front")
            summary.update(steady_speed(fronts, c, 0.5 * width))
            B_ref, G_ref = cfg["scenario"].get("B_reference"), cfg["scenario"].get("G_reference")
            c_R = None
            if B_ref and G_ref:
                rho = _density(system, c)
                c_R = rayleigh_speed(float(B_ref), float(G_ref), rho, int(cfg["model"]["dimension"]))
                summary.update(rayleigh_speed=c_R, crack_speed_over_rayleigh=summary["crack_speed"] / c_R,
                               crack_speed_over_rayleigh_se=summary["crack_speed_se"] / c_R)
            if plots and len(fronts):
                png = run_dir / "plots" / "crack_front.png"
                guard.draw("crack_front", png, plot_fronts, fronts, summary, c_R, png)
    summary.update(flags=flags, flagged=bool(flags))
    if plots:
        guard.draw("mode1", run_dir / "plots" / "mode1.png", plot_pull, record, k, run_dir / "plots" / "mode1.png")
    summary["plots_failed"] = guard.failed
    clear_report(run_dir)
    rep = Report(f"BPM mode-I toughness: {cfg['name']}", provenance_line(run_dir))
    rep.values({k_: v for k_, v in summary.items() if not isinstance(v, (list, dict))}, "toughness (LJ units)")
    for f in flags:
        rep.text(f"FLAG: {f}")
    if plots and not guard.failed:
        rep.figure(run_dir / "plots" / "mode1.png", "far-field stress against grip displacement, peak marked")
        if (run_dir / "plots" / "crack_front.png").exists():
            rep.figure(run_dir / "plots" / "crack_front.png", "crack fronts against time, steady-speed fits")
    write_report(rep, run_dir)
    return summary


def plot_pull(record: pd.DataFrame, peak: int, path: Path) -> None:
    import matplotlib.pyplot as plt  # noqa: PLC0415
    from runfiles.atomic import atomic_save  # noqa: PLC0415

    fig, ax = plt.subplots(figsize=(5.0, 3.6), dpi=150)
    ax.plot(record.displacement, record.stress, "-", lw=1)
    ax.plot(record.displacement.iloc[peak], record.stress.iloc[peak], "o", color="C3", label=r"peak $\sigma_c$")
    ax.set(xlabel="grip displacement (a)", ylabel=r"far-field stress $\sigma$")
    ax.legend(fontsize=7)
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p))
    plt.close(fig)


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


def analyse_mode1_set(runs: list[dict], out: Path, plots: bool = True, left_out: list[dict] | None = None) -> dict:
    """K_IC (and K_IC / E where E_reference was given; the crack speed where the runs have it)
    against lambda_c (toughness_set)."""
    return toughness_set(runs, out, plots, left_out, "lambda_c",
                         ("sigma_c", "K_IC", "K_IC_over_E", "crack_speed", "crack_speed_over_rayleigh"),
                         "K_IC_over_E", "K_IC", r"$\lambda_c$", (r"$K_{IC}$", r"$K_{IC}/E$"), "mode-I toughness")


def plot_toughness(points: pd.DataFrame, x: str, y: str, xlabel: str, ylabel: str, path: Path) -> None:
    import matplotlib.pyplot as plt  # noqa: PLC0415
    from runfiles.atomic import atomic_save  # noqa: PLC0415

    fig, ax = plt.subplots(figsize=(5.0, 3.6), dpi=150)
    ax.errorbar(points[x], points[f"{y}_mean"], yerr=points[f"{y}_std"].fillna(0), fmt="o-")
    ax.set(xlabel=xlabel, ylabel=ylabel)
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p))
    plt.close(fig)
