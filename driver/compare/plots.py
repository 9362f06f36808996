"""Both models on the same axes: the measures against the common omega (means over seeds with
their standard deviations as error bars, each model's omega_0 and omega_1 as vertical lines),
the fragment shapes against omega, p(m/m_max) and p(S_f) of each model."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from analysis.plots import plot_histograms, plot_mass_pdf  # noqa: E402
from driver.compare.stats import MEASURES  # noqa: E402
from runfiles.atomic import atomic_save  # noqa: E402

#: model -> (name, marker, colour): greyscale-readable (markers differ, not only colours)
STYLE = {"bcm": ("BCM", "o", "black"), "bpm": ("BPM", "s", "tab:red")}
_G_LINES = ["-", "--", "-.", ":"]


def point_means(table: pd.DataFrame, cols: list[str], axis: str = "velocity") -> pd.DataFrame:
    """Means and standard deviations over seeds per (model, G_c, grid point `axis`: velocity or
    omega_target) of the finished runs."""
    done = table[table["state"] == "finished"] if "state" in table else table
    cols = [c for c in cols if c in done]
    g = done.groupby(["model", "G_c", axis], sort=True)[cols]
    out = g.agg(["mean", "std"])
    out.columns = [f"{a}_{b}" for a, b in out.columns]
    return out.reset_index()


def plot_vs_omega(table: pd.DataFrame, cross: pd.DataFrame, cols: list[str], path: Path, title: str = "",
                  axis: str = "velocity") -> None:
    """One panel per measure against omega (log), both models, one line style per G_c; the
    means over the seeds of each grid point (`axis`)."""
    cols = [c for c in cols if c in table]
    pts = point_means(table, ["omega", *cols], axis)
    n = len(cols)
    ncol = min(3, n)
    nrow = int(np.ceil(n / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.2 * ncol, 3.4 * nrow), dpi=120, squeeze=False)
    gcs = sorted(pts.G_c.unique())
    for k, col in enumerate(cols):
        ax = axes[k // ncol][k % ncol]
        for model, (name, marker, colour) in STYLE.items():
            for j, g in enumerate(gcs):
                p = pts[(pts.model == model) & (pts.G_c == g)].sort_values("omega_mean")
                if p.empty:
                    continue
                label = name + (f", $G_c$ = {g:g}" if len(gcs) > 1 else "")
                ax.errorbar(p.omega_mean, p[f"{col}_mean"], yerr=p[f"{col}_std"].fillna(0.0),
                            xerr=p.omega_std.fillna(0.0), marker=marker, mfc="white", color=colour,
                            linestyle=_G_LINES[j % len(_G_LINES)], capsize=2, label=label)
            for _, th in cross[cross.model == model].iterrows():
                if np.isfinite(th.value):
                    ax.axvline(th.value, color=colour, lw=0.8, linestyle="--" if th.threshold == "omega_0" else ":")
        ax.set_xscale("log")
        ax.set_xlabel(r"damage potential $\omega = W_k^- / (2 A_0 G_c)$ [-]")
        ax.set_ylabel(f"{MEASURES.get(col, (col,))[0]} [-]")
        if k == 0 and ax.has_data():
            ax.legend(fontsize=7, frameon=False)
    for k in range(n, nrow * ncol):
        axes[k // ncol][k % ncol].set_visible(False)
    fig.suptitle((title + "\n" if title else "") + r"vertical lines: $\omega_0$ dashed, $\omega_1$ dotted, "
                 "in each model's colour", fontsize=8)
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p, format="png"))
    plt.close(fig)


def plot_crossovers(cross: pd.DataFrame, path: Path, title: str = "") -> None:
    """omega_0 and omega_1 of each model against G_c, the bracket [lo, hi] as the error bar
    (an unbounded side drawn to the plot's edge with an arrow-less bar)."""
    fig, ax = plt.subplots(figsize=(5.0, 4.0), dpi=120)
    for model, (name, marker, colour) in STYLE.items():
        for th, ls in (("omega_0", "--"), ("omega_1", ":")):
            c = cross[(cross.model == model) & (cross.threshold == th)].sort_values("G_c")
            if c.empty:
                continue
            lo = c.lo.where(np.isfinite(c.lo), np.nan)
            hi = c.hi.where(np.isfinite(c.hi), np.nan)
            mid = c.value.where(np.isfinite(c.value), (lo.fillna(hi) + hi.fillna(lo)) / 2)
            ax.errorbar(c.G_c, mid, yerr=[(mid - lo).fillna(0.0), (hi - mid).fillna(0.0)], marker=marker,
                        mfc="white" if th == "omega_0" else colour, color=colour, linestyle=ls, capsize=3,
                        label=f"{name} {th.replace('omega', 'ω')}")
    ax.set_xlabel(r"$G_c$ [J/m$^2$]")
    ax.set_ylabel(r"crossover $\omega$ [-]")
    ax.set_yscale("log")
    if ax.has_data():
        ax.legend(fontsize=7, frameon=False)
    else:
        ax.text(0.5, 0.5, "no crossover located", ha="center", transform=ax.transAxes)
    if title:
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p, format="png"))
    plt.close(fig)


def draw_all(guard, table: pd.DataFrame, cross: pd.DataFrame, mass_tables: dict, sf_tables: dict, plot_dir: Path,
             title: str, axis: str = "velocity") -> dict[str, Path]:
    """Every figure of the comparison through `guard` (analysis.plots.PlotGuard); name -> path."""
    files = {"measures_vs_omega": plot_dir / "measures_vs_omega.png",
             "shapes_vs_omega": plot_dir / "shapes_vs_omega.png",
             "crossovers": plot_dir / "crossovers.png",
             "fragment_masses": plot_dir / "fragment_masses.png",
             "shape_factor": plot_dir / "shape_factor.png"}
    guard.draw("measures_vs_omega", files["measures_vs_omega"], plot_vs_omega, table, cross,
               ["D_w", "e_k2", "eta", "eta_held", "chi", "W_c_over_W_s"], files["measures_vs_omega"], title, axis)
    guard.draw("shapes_vs_omega", files["shapes_vs_omega"], plot_vs_omega, table, cross,
               ["shape_elongation_mean", "shape_flatness_mean", "largest_fragment_mass_fraction"],
               files["shapes_vs_omega"], title, axis)
    guard.draw("crossovers", files["crossovers"], plot_crossovers, cross, files["crossovers"], title)
    guard.draw("fragment_masses", files["fragment_masses"], plot_mass_pdf, mass_tables, files["fragment_masses"],
               title)
    if sf_tables:
        guard.draw("shape_factor", files["shape_factor"], plot_histograms, sf_tables, files["shape_factor"],
                   r"shape factor $S_f$ [-]", r"$p(S_f)$ [-]", title)
    return {k: v for k, v in files.items() if v.exists()}
