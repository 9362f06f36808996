"""Both models' crushes on the same axes (driver/compare/crush.py): the force against the platen's
travel of every grain, the crush measures against the grain size, the Weibull plots of sigma_c
and the size effect. Styles as the impact comparison's (driver/compare/plots.py STYLE)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import EngFormatter, FixedLocator, LogLocator, NullFormatter, NullLocator  # noqa: E402
import pandas as pd  # noqa: E402

from analysis.strength import median_rank_survival  # noqa: E402
from driver.compare.crush import CRUSH_MEASURES, force_curves, with_strengths  # noqa: E402
from driver.compare.plots import STYLE, point_means  # noqa: E402
from runfiles.atomic import atomic_save  # noqa: E402


def _save(fig, path: Path, title: str) -> None:
    if title:
        fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p, format="png"))
    plt.close(fig)


def _log_pascals(axis) -> None:
    """A log axis in Pa with engineering labels at 1, 2 and 5 of each decade (a range within
    one decade still gets a label; the other minor ticks unlabelled)."""
    axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(EngFormatter(unit="Pa"))
    axis.set_minor_formatter(NullFormatter())


def _size_axis(ax, sizes_mm) -> None:
    """The grain size axis (log when there are several sizes) ticked and labelled at the sizes."""
    sizes_mm = sorted(set(float(d) for d in sizes_mm))
    if len(sizes_mm) > 1:
        ax.set_xscale("log")
    ax.xaxis.set_major_locator(FixedLocator(sizes_mm))
    ax.xaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}"))
    ax.xaxis.set_minor_locator(NullLocator())
    ax.set_xlabel("grain size d [mm]")


def _panels(n: int, width: float = 4.2, height: float = 3.4):
    ncol = min(3, n)
    nrow = int(np.ceil(n / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(width * ncol, height * nrow), dpi=120, squeeze=False)
    for k in range(n, nrow * ncol):
        axes[k // ncol][k % ncol].set_visible(False)
    return fig, [axes[k // ncol][k % ncol] for k in range(n)]


def plot_force_curves(curves: dict[tuple[str, float], list[dict[str, Any]]], path: Path, title: str = "") -> None:
    """One panel per grain size: every grain's upper-platen force against the platen's travel
    from first contact, both models, F_c of each grain marked."""
    sizes = sorted({d for _, d in curves})
    fig, axes = _panels(len(sizes))
    for ax, d in zip(axes, sizes):
        for model, (name, marker, colour) in STYLE.items():
            for k, c in enumerate(curves.get((model, d), [])):
                ax.plot(c["u"] * 1e6, c["F"], color=colour, lw=0.8, alpha=0.7, label=name if k == 0 else None)
                ax.plot(c["u_c"] * 1e6, c["F_c"], marker, color=colour, mfc="white", ms=5)
        ax.set_xlabel("platen displacement from first contact [µm]")
        ax.set_ylabel("upper platen force [N]")
        ax.set_title(f"d = {d * 1e3:g} mm (markers: $F_c$)", fontsize=8)
        ax.legend(fontsize=7, frameon=False)
    _save(fig, path, title)


def plot_measures_vs_size(table: pd.DataFrame, cols: list[str], path: Path, title: str = "") -> None:
    """One panel per measure: means over the seeds against the grain size d, the standard
    deviation as the error bar, one line style per G_c, both models."""
    cols = [c for c in cols if c in table]
    pts = point_means(table, cols, "diameter")
    gcs = sorted(pts.G_c.unique())
    fig, axes = _panels(len(cols))
    for ax, col in zip(axes, cols):
        for model, (name, marker, colour) in STYLE.items():
            for j, g in enumerate(gcs):
                p = pts[(pts.model == model) & (pts.G_c == g)].sort_values("diameter")
                if p.empty:
                    continue
                ax.errorbar(p.diameter * 1e3, p[f"{col}_mean"], yerr=p[f"{col}_std"].fillna(0.0), marker=marker,
                            mfc="white", color=colour, linestyle=["-", "--", "-.", ":"][j % 4], capsize=2,
                            label=name + (f", $G_c$ = {g:g}" if len(gcs) > 1 else ""))
        _size_axis(ax, pts.diameter * 1e3)
        ax.set_ylabel(CRUSH_MEASURES.get(col, (col,))[0])
        if col == cols[0] and ax.has_data():
            ax.legend(fontsize=7, frameon=False)
    _save(fig, path, title)


def plot_weibull_both(table: pd.DataFrame, weibull: pd.DataFrame, path: Path, title: str = "") -> None:
    """One panel per (strength, G_c, size): ln(-ln P_s) of each model's grains that dropped at
    Benard's median ranks against the strength (log), and each model's fitted law, m and sigma_0
    in the legend."""
    table = with_strengths(table)
    done = table[(table.state == "finished") & table.dropped.astype(bool)] if "state" in table else table
    points = sorted({(st, g, d) for st, g, d in zip(weibull.strength, weibull.G_c, weibull.diameter)})
    fig, axes = _panels(len(points))
    for ax, (strength, g, d) in zip(axes, points):
        for model, (name, marker, colour) in STYLE.items():
            s = done[(done.model == model) & (done.G_c == g) & (done.diameter == d)][strength].to_numpy(float)
            s = s[np.isfinite(s)]
            if len(s) == 0:
                continue
            xs, ps = median_rank_survival(s)
            ax.plot(xs, np.log(-np.log(ps)), marker, color=colour, mfc="white", ms=5, label=f"{name}, {len(s)} grains")
            fit = weibull[(weibull.model == model) & (weibull.G_c == g) & (weibull.diameter == d)
                          & (weibull.strength == strength)]
            if len(fit) and np.isfinite(fit.m.iloc[0]):
                m, s0 = float(fit.m.iloc[0]), float(fit.sigma_0.iloc[0])
                x = np.geomspace(xs.min(), xs.max(), 50)
                ax.plot(x, m * np.log(x / s0), "-", color=colour, lw=1.0,
                        label=rf"$m$ = {m:.3g}, $\sigma_0$ = {s0 / 1e6:.3g} MPa")
        ax.axhline(0.0, color="0.6", lw=0.5)
        ax.set_xscale("log")
        _log_pascals(ax.xaxis)
        ax.set_xlabel(r"$\sigma_c = F_c/d^2$ (log)" if strength == "sigma_c" else r"$\sigma_{max} = F_{max}/d^2$ (log)")
        ax.set_ylabel(r"$\ln(-\ln P_s)$ [-]")
        ax.set_title(f"{strength}, G_c = {g:g} J/m², d = {d * 1e3:g} mm", fontsize=8)
        ax.legend(fontsize=7, frameon=False)
    _save(fig, path, title)


def plot_size_effects(effects: dict, path: Path, title: str = "") -> None:
    """One panel per strength: the median against d (log-log) with each model's fitted d^(-b),
    one line style per G_c."""
    strengths = sorted({st for _, _, st in effects})
    fig, axes = _panels(len(strengths), 5.0, 4.0)
    gcs = sorted({g for _, g, _ in effects})
    for (model, g, strength), eff in sorted(effects.items()):
        ax = axes[strengths.index(strength)]
        name, marker, colour = STYLE[model]
        grp = eff.groups
        err = np.vstack([grp.sigma_median - grp.sigma_median_lo, grp.sigma_median_hi - grp.sigma_median]).clip(0)
        ls = ["-", "--", "-.", ":"][gcs.index(g) % 4]
        ax.errorbar(grp.d * 1e3, grp.sigma_median, yerr=np.nan_to_num(err), fmt=marker, color=colour, mfc="white",
                    capsize=2)
        d = np.geomspace(grp.d.min(), grp.d.max(), 30)
        ax.plot(d * 1e3, eff.median(d), ls, color=colour,
                label=f"{name}" + (f", $G_c$ = {g:g}" if len(gcs) > 1 else "")
                      + f": b = {eff.b:.3g} [{eff.b_interval[0]:.3g}, {eff.b_interval[1]:.3g}], "
                        f"3/m = {eff.b_weibull:.3g}")
    # d here is each grain's height between the platens (median per size): ticked at round values
    heights = [d * 1e3 for eff in effects.values() for d in eff.groups.d]
    lo, hi = min(heights), max(heights)
    sizes = [v * 10.0 ** e for e in range(int(np.floor(np.log10(lo))), int(np.ceil(np.log10(hi))) + 1)
             for v in (1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 7.0) if lo * 0.95 <= v * 10.0 ** e <= hi * 1.05] or heights
    for ax, strength in zip(axes, strengths):
        ax.set_yscale("log")
        _log_pascals(ax.yaxis)
        _size_axis(ax, sizes)
        ax.set_ylabel(r"median $\sigma_c$ (log)" if strength == "sigma_c" else r"median $\sigma_{max}$ (log)")
        ax.legend(fontsize=7, frameon=False)
    _save(fig, path, title)


def draw_crush(guard, table: pd.DataFrame, weibull: pd.DataFrame, effects: dict, plot_dir: Path, title: str
               ) -> dict[str, Path]:
    """Every figure of a crush comparison through `guard` (analysis.plots.PlotGuard), from the
    runs table, the Weibull table and the size effects (driver/compare/crush.py); name -> path."""
    files = {k: plot_dir / f"{k}.png" for k in ("force_displacement", "measures_vs_size", "fragments_vs_size",
                                                 "weibull", "size_effect")}
    guard.draw("force_displacement", files["force_displacement"], plot_force_curves, force_curves(table),
               files["force_displacement"], title)
    guard.draw("measures_vs_size", files["measures_vs_size"], plot_measures_vs_size, table,
               ["F_c", "sigma_c", "F_max", "sigma_max", "u_c", "loading_stiffness", "W_p_at_F_c", "D_w_at_F_c"],
               files["measures_vs_size"], title)
    guard.draw("fragments_vs_size", files["fragments_vs_size"], plot_measures_vs_size, table,
               ["D_w_end", "largest_fragment_mass_fraction", "n_fragments_multi_cell", "shape_elongation_mean",
                "shape_flatness_mean", "F_max_over_F_c"], files["fragments_vs_size"], title)
    if weibull.m.notna().any():
        guard.draw("weibull", files["weibull"], plot_weibull_both, table, weibull, files["weibull"], title)
    if effects:
        guard.draw("size_effect", files["size_effect"], plot_size_effects, effects, files["size_effect"], title)
    return {k: v for k, v in files.items() if v.exists()}
