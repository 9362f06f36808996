"""Figures a physicist would put in a paper: log-log N(M), stress ratio against strain.

Greyscale-readable (markers and line styles differ, not only colours), axes with units.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from runfiles.atomic import atomic_save  # noqa: E402

_MARKERS = "osD^v<>ph*"
_LINES = ["-", "--", "-.", ":"]
_THRESHOLD_LINES = ["--", ":", "-."]
_THRESHOLD_NAMES = {"--": "dashed", ":": "dotted", "-.": "dash-dot"}


class PlotGuard:
    """The one way the analyses draw figures: a figure never decides whether an analysis (or
    the run behind it) succeeded. `draw(name, path, fn, ...)` calls fn(...); when it raises, the
    failure ({"plot": name, "error": "Type: message"}) is kept in `failed` (the summary's
    plots_failed), the figures it left open are closed, and a figure of that name left by an
    earlier analysis is removed so that the report does not show it as this one's."""

    def __init__(self) -> None:
        self.failed: list[dict[str, str]] = []

    def draw(self, name: str, path: Path, fn: Callable, *args, **kwargs) -> bool:
        """True when the figure was drawn."""
        open_before = set(plt.get_fignums())
        try:
            fn(*args, **kwargs)
            return True
        except Exception as exc:  # noqa: BLE001 -- any error of a figure is recorded, none is fatal
            self.failed.append({"plot": name, "error": f"{type(exc).__name__}: {exc}"})
            for num in set(plt.get_fignums()) - open_before:
                plt.close(num)
            Path(path).unlink(missing_ok=True)
            return False


def plot_nm(nm: pd.DataFrame, path: Path, title: str = "", mass_unit: str = "m", fit: dict | None = None,
            by: str = "strain", legend: str = r"$\varepsilon$ = {:g}") -> None:
    """N(M) per strain (or per value of column `by`), log-log, at each bin's mean grain mass. nm
    has columns `by`, m_mean, N; `fit` (strain, tau, sigma, xmin) draws the fitted slope through
    the last strain's data."""
    fig, ax = plt.subplots(figsize=(5.0, 4.0), dpi=150)
    for k, (eps, grp) in enumerate(nm.groupby(by, sort=True)):
        grp = grp[grp["N"] > 0]
        if grp.empty:
            continue
        ax.loglog(grp["m_mean"], grp["N"], marker=_MARKERS[k % len(_MARKERS)],
                  linestyle=_LINES[k % len(_LINES)], color=str(0.75 * k / max(1, nm[by].nunique() - 1)),
                  mfc="white", label=legend.format(eps))
    if fit and fit.get("tau") is not None:
        last = nm[(nm[by] == fit[by]) & (nm.N > 0)]
        if not last.empty:
            x = np.array([last.m_mean.min(), last.m_mean.max()])
            y0 = np.exp(np.mean(np.log(last.N) + fit["tau"] * np.log(last.m_mean)))
            ax.loglog(x, y0 * x ** -fit["tau"], "k:", lw=1.0,
                      label=rf"$M^{{-\tau}}$, $\tau$ = {fit['tau']:.2f} $\pm$ {fit['sigma']:.2f}")
    ax.set_xlabel(f"grain mass $M$ [{mass_unit}]")
    ax.set_ylabel(f"$N(M)$ [grains per unit mass, 1/{mass_unit}]")
    if title:
        ax.set_title(title, fontsize=9)
    if ax.has_data():
        ax.legend(fontsize=8, frameon=False)
    else:
        ax.text(0.5, 0.5, "no grains above the size cut yet", ha="center", transform=ax.transAxes)
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p, format="png"))
    plt.close(fig)


def plot_stress(stress: pd.DataFrame, path: Path, title: str = "") -> None:
    """sqrt(J2) and P, the stress ratio mu and the inertial number I against strain (LJ units)."""
    panels = 3 if "I" in stress else 2
    fig, axes = plt.subplots(panels, 1, figsize=(5.0, 2.2 * panels + 0.6), dpi=150, sharex=True)
    ax1, ax2 = axes[0], axes[1]
    ax1.plot(stress.strain, stress.sqrtJ2, "k-", label=r"$\sqrt{J_2}$")
    ax1.plot(stress.strain, stress.P, "k--", label="$P$")
    ax1.set_ylabel(r"stress [$u/a^d$]")
    ax1.legend(fontsize=8, frameon=False)
    # mu and I are undefined while the solid is still near zero pressure (they diverge as
    # P -> 0): show them where P is sizeable, on log axes so the loading transient and the
    # steady flow are both readable.
    sizeable = (stress.P > 0.05 * stress.P.max()).to_numpy()
    ax2.semilogy(stress.strain[sizeable], stress.mu[sizeable], "k-")
    ax2.set_ylabel(r"$\mu = \sqrt{J_2}/P$ [-]")
    if panels == 3:
        axes[2].semilogy(stress.strain[sizeable], stress.I[sizeable], "k-")
        axes[2].set_ylabel(r"$I = \dot\varepsilon \langle d\rangle \sqrt{\rho/P}$ [-]")
    axes[-1].set_xlabel(r"true strain $\varepsilon$ [-] (" + r"$\mu$, $I$ where $P > 0.05\,P_{max}$)")
    if title:
        ax1.set_title(title, fontsize=9)
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p, format="png"))
    plt.close(fig)


def plot_energies(energies: pd.DataFrame, wk_minus: float, path: Path, title: str = "",
                  labels: dict[str, str] | None = None) -> None:
    """Energy budget of an impact against time, as fractions of W_k^- (SPEC 1.5); `labels`
    replaces the legend of a column (kinetic, elastic, W_f, dissipated)."""
    fig, ax = plt.subplots(figsize=(7.5, 4.0), dpi=150)
    t = energies.time * 1e6
    names = {"kinetic": "kinetic $W_k$", "elastic": "elastic (interfaces + contacts)",
             "W_f": "fracture $W_f = 2AG_c$", "dissipated": "dissipated $W_c$", **(labels or {})}
    for col, style in [("kinetic", "k-"), ("elastic", "k--"), ("W_f", "k-."), ("dissipated", "k:")]:
        ax.plot(t, energies[col] / wk_minus, style, label=names[col])
    total = (energies.kinetic + energies.elastic + energies.W_f + energies.dissipated) / wk_minus
    ax.plot(t, total, color="0.6", lw=2.5, alpha=0.6, label="sum", zorder=0)
    ax.set_xlabel(r"time [$\mu$s]")
    ax.set_ylabel(r"energy / $W_k^-$")
    # beside the axes, never over the curves
    ax.legend(fontsize=8, frameon=False, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    if title:
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p, format="png"))
    plt.close(fig)


def _finish(fig, ax, path: Path, title: str) -> None:
    for axis in (ax.xaxis, ax.yaxis):
        if axis.get_scale() == "log":
            axis.set_minor_formatter(matplotlib.ticker.NullFormatter())  # labelled minor ticks overlap
    if title:
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p, format="png"))
    plt.close(fig)


def plot_mass_pdf(tables: dict[str, pd.DataFrame], path: Path, title: str = "", fits: dict[str, dict] | None = None
                  ) -> None:
    """p(m / m_max) log-log, one curve per label (e.g. per G_c or per run), each bin at its
    fragments' mean x; fits[label] (tau, sigma, xmin, xmax) draws the fitted slope over its range."""
    fig, ax = plt.subplots(figsize=(5.0, 4.0), dpi=150)
    for k, (label, tab) in enumerate(tables.items()):
        t = tab[tab["p"] > 0]
        if t.empty:
            continue
        grey = str(0.7 * k / max(1, len(tables) - 1))
        ax.loglog(t.x_mean, t.p, marker=_MARKERS[k % len(_MARKERS)], linestyle=_LINES[k % len(_LINES)], color=grey,
                  mfc="white", label=label)
        fit = (fits or {}).get(label)
        if fit and fit.get("tau") is not None:
            inside = t[(t.x_mean >= fit["xmin"]) & (t.x_mean <= (fit.get("xmax") or 1.0))]
            if len(inside):
                x = np.array([inside.x_mean.min(), inside.x_mean.max()])
                y0 = np.exp(np.mean(np.log(inside.p) + fit["tau"] * np.log(inside.x_mean)))
                ax.loglog(x, y0 * x ** -fit["tau"], ":", color=grey, lw=1.2,
                          label=rf"fit $\tau$ = {fit['tau']:.2f} $\pm$ {fit['sigma']:.2f}")
    ax.set_xlabel(r"fragment mass $m / m_{max}$ [-]")
    ax.set_ylabel(r"$p(m/m_{max})$ [probability density, -]")
    if ax.has_data():
        ax.legend(fontsize=7, frameon=False)
    else:
        ax.text(0.5, 0.5, "no fragments", ha="center", transform=ax.transAxes)
    _finish(fig, ax, path, title)


def plot_shapes(fragments: pd.DataFrame, path: Path, title: str = "") -> None:
    """Shape of the multi-cell fragments (SPEC 1.5): p(S_f) and flatness c/b against elongation b/a."""
    t = fragments[~fragments["single_cell"]] if "single_cell" in fragments else fragments
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(8.0, 3.6), dpi=150)
    if len(t):
        ax1.hist(t.shape_factor, bins=min(30, max(5, len(t) // 3)), density=True, color="0.6", edgecolor="k")
        ax2.plot(t.elongation, t.flatness, "o", color="k", mfc="white", ms=4)
    else:
        ax1.text(0.5, 0.5, "no multi-cell fragments", ha="center", transform=ax1.transAxes)
    ax1.set_xlabel(r"shape factor $S_f$ [-]")
    ax1.set_ylabel(r"$p(S_f)$ [-]")
    ax2.set_xlabel("elongation $b/a$ [-]")
    ax2.set_ylabel("flatness $c/b$ [-]")
    ax2.set_xlim(0, 1.02)
    ax2.set_ylim(0, 1.02)
    fig.suptitle(f"{title}\n{len(t)} fragments of two or more cells" if title else "", fontsize=9)
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p, format="png"))
    plt.close(fig)


def plot_curves(curves: list[tuple[str, np.ndarray, np.ndarray]], path: Path, xlabel: str, ylabel: str,
                title: str = "", note: str = "") -> None:
    """Several log-log curves (label, x, y), e.g. the raw N(M) of a set of runs or a collapse."""
    fig, ax = plt.subplots(figsize=(5.0, 4.0), dpi=150)
    for k, (label, x, y) in enumerate(curves):
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        ok = (x > 0) & (y > 0)
        ax.loglog(x[ok], y[ok], marker=_MARKERS[k % len(_MARKERS)], linestyle=_LINES[k % len(_LINES)],
                  color=str(0.7 * k / max(1, len(curves) - 1)), mfc="white", ms=4, label=label)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if note:
        ax.text(0.03, 0.03, note, transform=ax.transAxes, fontsize=8)
    if ax.has_data():
        ax.legend(fontsize=7, frameon=False)
    _finish(fig, ax, path, title)


def _series(points: pd.DataFrame) -> list:
    """The curves of a set's points: one per `series` (G_c and the variant: analysis/runset.py)
    where the table has it, else one per G_c."""
    return list(points.groupby("series" if "series" in points else "G_c", sort=True))


def _series_label(key) -> str:
    return key if isinstance(key, str) else f"$G_c$ = {key:g} J/m²"


def plot_measures(points: pd.DataFrame, path: Path, x: str = "omega", thresholds: dict | None = None,
                  fits: dict | None = None, title: str = "") -> None:
    """SPEC 1.5 sweep level: D_w, eta, e_k^2 and fragment count against omega (x="omega") or
    the impact velocity (x="velocity"), mean +- standard deviation over tessellations, one
    marker per series (G_c, and the variant where the set has several: _series). Against omega:
    thresholds[series] = {name: omega} drawn as vertical lines (dashed, dotted, dash-dot in
    order; e.g. omega_0 and omega_1 under each break-up definition), and fits[(series,
    measure)] = (callable(omega), omega_lo, omega_hi) drawn over the fitted range."""
    panels = [("D_w", "damage $D_w = A/A_0$ [-]"), ("eta", r"fracture efficiency $\eta$ [-]"),
              ("e_k2", "restitution $e_k^2$ [-]"), ("n_fragments", "fragments [-]")]
    xcol = "omega_mean" if x == "omega" else "velocity"
    xlabel = r"damage potential $\omega = W_k^-/W_s$ [-]" if x == "omega" else "impact velocity $v_0$ [m/s]"
    fig, axes = plt.subplots(2, 2, figsize=(8.0, 6.5), dpi=150)
    groups = _series(points)
    for ax, (col, label) in zip(axes.flat, panels):
        for k, (gc, grp) in enumerate(groups):
            grey = str(0.6 * k / max(1, len(groups) - 1))
            grp = grp.sort_values(xcol)
            ax.errorbar(grp[xcol], grp[f"{col}_mean"], yerr=grp[f"{col}_std"].fillna(0),
                        marker=_MARKERS[k % len(_MARKERS)], linestyle=_LINES[k % len(_LINES)], color=grey,
                        mfc="white", ms=5, capsize=2, label=_series_label(gc))
            if x != "omega":
                continue
            f = (fits or {}).get((gc, col))
            if f is not None:
                fn, lo, hi = f
                w = np.geomspace(max(lo, 1e-12), hi, 100)
                ax.plot(w, fn(w), "-", color=grey, lw=0.8)
            th = (thresholds or {}).get(gc, {})
            for (key, v), style in zip(th.items(), _THRESHOLD_LINES):
                if v is not None and np.isfinite(v):
                    ax.axvline(v, color=grey, ls=style, lw=0.8)
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())  # labelled minor ticks overlap
        if col == "n_fragments":
            ax.set_yscale("log")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(label)
    axes.flat[0].legend(fontsize=7, frameon=False)
    names = next((list(t) for t in (thresholds or {}).values() if t), [])
    note = ", ".join(f"{_THRESHOLD_NAMES[style]}: {name}" for name, style in zip(names, _THRESHOLD_LINES)) \
        if x == "omega" else ""
    fig.suptitle("\n".join(t for t in (title, note) if t), fontsize=9)
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p, format="png"))
    plt.close(fig)


def plot_energy_split(points: pd.DataFrame, parts: list[tuple[str, str]], path: Path, title: str = "") -> None:
    """Where the impact energy goes (SPEC 1.5 sweep level): each part as a fraction of W_k^-
    against the impact velocity, one panel per G_c, mean +- standard deviation over
    tessellations. parts: (column, label) with points holding <column>_mean and _std; parts
    that are zero at every point are left out (named in the panel)."""
    groups = _series(points)
    legend_rows = (len(parts) + 1) // 2
    height = 4.0 + 0.22 * legend_rows
    fig, axes = plt.subplots(1, len(groups), figsize=(max(7.0, 4.5 * len(groups)), height), dpi=150, squeeze=False)
    legend: dict[str, object] = {}
    for ax, (gc, grp) in zip(axes[0], groups):
        grp = grp.sort_values("velocity")
        silent = []
        for k, (col, label) in enumerate(parts):  # one style per part in every panel
            mean = grp[f"{col}_mean"].to_numpy(dtype=float)
            if not np.any(np.abs(np.nan_to_num(mean)) > 0):
                silent.append(label)
                continue
            line = ax.errorbar(grp.velocity, mean, yerr=grp[f"{col}_std"].fillna(0), marker=_MARKERS[k % len(_MARKERS)],
                               linestyle=_LINES[k % len(_LINES)], color=str(0.6 * (k % 4) / 3), mfc="white", ms=4,
                               capsize=2, lw=1.0, label=label)
            legend.setdefault(label, line)
        ax.axhline(0.0, color="0.5", lw=0.5)
        ax.set_xscale("log")
        if grp.velocity.nunique() <= 10:  # the sampled velocities, labelled
            ax.set_xticks(sorted(grp.velocity.unique()))
        ax.xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xlabel("impact velocity $v_0$ [m/s]")
        ax.set_ylabel("energy / $W_k^-$ [-]")
        ax.set_title(_series_label(gc), fontsize=9)
        if silent:
            ax.text(0.02, 0.02, "zero throughout: " + ", ".join(silent), transform=ax.transAxes, fontsize=6,
                    wrap=True)
    fig.legend(list(legend.values()), list(legend), fontsize=7, frameon=False, loc="lower center", ncol=2)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout(rect=(0, (0.22 * legend_rows + 0.15) / height, 1, 1))
    atomic_save(path, lambda p: fig.savefig(p, format="png"))
    plt.close(fig)


def plot_histograms(tables: dict[str, pd.DataFrame], path: Path, xlabel: str, ylabel: str, title: str = "") -> None:
    """Probability densities (tables with center, p) as step lines, one per label."""
    fig, ax = plt.subplots(figsize=(5.0, 4.0), dpi=150)
    for k, (label, t) in enumerate(tables.items()):
        ax.step(t.center, t.p, where="mid", linestyle=_LINES[k % len(_LINES)],
                color=str(0.6 * k / max(1, len(tables) - 1)), label=label)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if ax.has_data():
        ax.legend(fontsize=7, frameon=False)
    _finish(fig, ax, path, title)


def plot_losses(series: dict[str, tuple[pd.DataFrame, pd.DataFrame]], path: Path, title: str = "") -> None:
    """Four panels per run label (series[label] = (channels_in_time, losses_by_depth)): the
    loss channels against time (shares of W_k^-), the losses per slab of depth below the
    contact, the broken interfaces that stay closed with the normal force they carry beside
    the plane's force, and the Coulomb slip on broken interfaces (summed over their points)."""
    from analysis.interface_losses import TIME_CHANNELS  # noqa: PLC0415

    labels = list(series)
    fig, axes = plt.subplots(len(labels), 4, figsize=(18.0, 3.6 * len(labels)), dpi=100, squeeze=False)
    styles = ["-", "--", ":", "-.", (0, (5, 1)), (0, (3, 1, 1, 1)), (0, (1, 2))]
    for row, label in zip(axes, labels):
        ts, depth = series[label]
        ax = row[0]
        t_us = ts.time * 1e6
        for k, (name, _) in enumerate(TIME_CHANNELS):
            if name in ts:
                ax.plot(t_us, ts[name], ls=styles[k % len(styles)], color=str(0.55 * (k % 3) / 2), label=name)
        ax.set_xlabel("time [µs]")
        ax.set_ylabel("energy / $W_k^-$")
        ax.set_title(f"{label}: losses in time", fontsize=9)
        ax.legend(fontsize=6, frameon=False)
        ax = row[1]
        mid = 0.5 * (depth.depth_lo + depth.depth_hi)
        width = (depth.depth_hi - depth.depth_lo).iloc[0]
        bottom = np.zeros(len(depth))
        for k, col in enumerate(("W_friction_share", "W_switch_share", "W_damp_broken_share", "W_damp_intact_share")):
            ax.barh(mid, depth[col], height=0.9 * width, left=bottom, color=str(0.15 + 0.25 * k), edgecolor="k",
                    lw=0.3, label=col.replace("_share", ""))
            bottom = bottom + depth[col].to_numpy()
        ax.set_xlabel("energy / $W_k^-$ per slab")
        ax.set_ylabel("depth above the contact / d")
        ax.set_title(f"{label}: losses by depth (broken per slab at right)", fontsize=9)
        for y, n, b in zip(mid, depth.interfaces, depth.broken):
            if n:
                ax.text(ax.get_xlim()[1], y, f" {b}/{n}", fontsize=6, va="center")
        ax.legend(fontsize=6, frameon=False, loc="upper right")
        ax = row[2]
        if "broken_closed" in ts:
            ax.plot(t_us, ts.broken, "-", color="0.6", label="broken interfaces")
            ax.plot(t_us, ts.broken_closed, "-", color="k", label="broken and closed")
            ax.set_ylabel("interfaces")
            ax2 = ax.twinx()
            ax2.plot(t_us, ts.closed_force, "--", color="k", lw=0.9, label="normal force on closed broken points")
            if "wall_force" in ts:
                ax2.plot(t_us, ts.wall_force, ":", color="0.4", label="plane force")
            ax2.set_ylabel("force [N]")
            h1, l1 = ax.get_legend_handles_labels()
            h2, l2 = ax2.get_legend_handles_labels()
            ax.legend(h1 + h2, l1 + l2, fontsize=6, frameon=False, loc="upper left")
        ax.set_xlabel("time [µs]")
        ax.set_title(f"{label}: broken interfaces that stay closed", fontsize=9)
        ax = row[3]
        if "slip" in ts:
            ax.plot(t_us, ts.slip * 1e3, "-", color="k")
        ax.set_xlabel("time [µs]")
        ax.set_ylabel("slip, summed over the points [mm]")
        ax.set_title(f"{label}: Coulomb slip on broken interfaces", fontsize=9)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p, format="png"))
    plt.close(fig)
