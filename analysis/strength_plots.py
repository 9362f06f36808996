"""Figures of the crushing test (SPEC 4.1): one grain's force against displacement with F_c,
the Weibull probability plot of a size, and the size effect.

Apart from analysis/plots.py so that analysis/strength.py stays free of matplotlib and these
figures live beside the one concept they show. As there: Agg backend, greyscale-readable,
axes with units (SI, a prefix chosen from the data: µm, kN, MPa). Each function returns its Figure,
built without pyplot's registry so that nothing is left open, and also writes it atomically
as PNG when given a path.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.ticker  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from numpy.typing import ArrayLike  # noqa: E402

from analysis.strength import Peak, SizeEffect, Stiffness, WeibullFit, median_rank_survival  # noqa: E402
from runfiles.atomic import atomic_save  # noqa: E402


def _prefix(value: float) -> tuple[float, str]:
    """(factor, SI prefix) that bring |value| into [1, 1000): 2.5e-5 -> (1e6, "µ")."""
    exp = int(np.clip(3 * np.floor(np.log10(abs(value)) / 3), -24, 24)) if value and np.isfinite(value) else 0
    return 10.0 ** -exp, matplotlib.ticker.EngFormatter.ENG_PREFIXES[exp]


def _quantity(value: float, unit: str, interval: tuple[float, float] | None = None) -> str:
    """'9.54 [8.9, 10.2] MPa': four significant digits, one prefix for the value and its interval."""
    factor, prefix = _prefix(value)
    text = f"{value * factor:.4g}"
    if interval is not None and np.all(np.isfinite(interval)):
        text += f" [{interval[0] * factor:.4g}, {interval[1] * factor:.4g}]"
    return f"{text} {prefix}{unit}"


def _interval(lo: float, hi: float) -> str:
    return f" [{lo:.3g}, {hi:.3g}]" if np.isfinite(lo) and np.isfinite(hi) else ""


def _finish(fig: Figure, ax, path: Path | None, title: str) -> Figure:
    for axis in (ax.xaxis, ax.yaxis):
        if axis.get_scale() == "log":
            # 1, 2 and 5 per decade: the data often span less than a decade
            axis.set_major_locator(matplotlib.ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
            axis.set_minor_formatter(matplotlib.ticker.NullFormatter())  # labelled minor ticks overlap
    if title:
        ax.set_title(title, fontsize=9)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7, frameon=False)
    fig.tight_layout()
    if path is not None:
        atomic_save(Path(path), lambda p: fig.savefig(p, format="png"))
    return fig


def plot_force_displacement(displacement: ArrayLike, force: ArrayLike, peak: Peak, stiffness: Stiffness | None = None,
                            path: Path | None = None, title: str = "") -> Figure:
    """Platen force against displacement, F_c marked (filled when the force dropped after it,
    open when it never did: F_c is then only the largest force recorded); `stiffness` draws
    its fitted line over its window."""
    u, f = np.asarray(displacement, dtype=float), np.asarray(force, dtype=float)
    ku, pu = _prefix(float(np.max(np.abs(u))))
    kf, pf = _prefix(float(np.max(np.abs(f))))
    fig = Figure(figsize=(5.0, 4.0), dpi=150)
    ax = fig.subplots()
    ax.plot(u * ku, f * kf, "k-", lw=1.0)
    how = "first peak" if peak.dropped else "no drop: largest force recorded"
    ax.plot([peak.displacement * ku], [peak.F_c * kf], "o", color="k", mfc="k" if peak.dropped else "white", ms=7,
            label=f"$F_c$ = {_quantity(peak.F_c, 'N')} ({how})")
    if stiffness is not None:
        w = u[stiffness.start:stiffness.stop]
        ws = np.array([w.min(), w.max()])
        f0 = float(np.mean(f[stiffness.start:stiffness.stop]) - stiffness.slope * np.mean(w))  # the line's centroid
        ax.plot(ws * ku, (f0 + stiffness.slope * ws) * kf, "--", color="0.5", lw=2.0,
                label=f"loading stiffness {_quantity(stiffness.slope, 'N/m')} ({stiffness.n} samples)")
    ax.set_xlabel(f"platen displacement from first contact [{pu}m]")
    ax.set_ylabel(f"platen force [{pf}N]")
    return _finish(fig, ax, path, title)


def plot_weibull(sigma: ArrayLike, fit: WeibullFit, path: Path | None = None, title: str = "") -> Figure:
    """Weibull probability plot: ln(-ln P_s) against sigma on a log axis (i.e. against
    ln sigma), the grains at Benard's median ranks and the fitted law, a straight line of
    slope m through ln(-ln P_s) = 0 at sigma_0; m and sigma_0 with their intervals in the
    legend."""
    s, ps = median_rank_survival(sigma)
    fig = Figure(figsize=(5.0, 4.0), dpi=150)
    ax = fig.subplots()
    ax.semilogx(s, np.log(-np.log(ps)), "o", color="k", mfc="white", ms=5,
                label=f"{fit.n} grains (median ranks)")
    x = np.geomspace(s.min(), s.max(), 50)
    pct = f"{100 * fit.confidence:g} %"
    ax.semilogx(x, fit.m * np.log(x / fit.sigma_0), "k-", lw=1.0,
                label=f"fit: $m$ = {fit.m:.3g}{_interval(*fit.m_interval)}\n"
                      rf"$\sigma_0$ = {_quantity(fit.sigma_0, 'Pa', fit.sigma_0_interval)}"
                      + (f" ({pct} intervals)" if fit.n_boot else ""))
    ax.axhline(0.0, color="0.6", lw=0.5)  # P_s = 1/e: sigma = sigma_0
    ax.xaxis.set_major_formatter(matplotlib.ticker.EngFormatter(unit="Pa"))
    ax.set_xlabel(r"characteristic stress $\sigma_c = F_c/d^2$ (log scale)")
    ax.set_ylabel(r"$\ln(-\ln P_s)$ [-]")
    if fit.flag:
        ax.text(0.03, 0.97, fit.flag, transform=ax.transAxes, fontsize=7, va="top")
    return _finish(fig, ax, path, title)


def plot_size_effect(effect: SizeEffect, path: Path | None = None, title: str = "") -> Figure:
    """Median sigma_c against d, log-log, with the bootstrap interval of each median, the fitted
    d^(-b) and, for comparison, a line of slope -3/m (m of the group with the most grains)
    through the same centre (geometric mean of the sizes and of the fitted medians)."""
    g = effect.groups
    fig = Figure(figsize=(5.0, 4.0), dpi=150)
    ax = fig.subplots()
    err = np.vstack([g.sigma_median - g.sigma_median_lo, g.sigma_median_hi - g.sigma_median]).clip(0)
    ax.errorbar(g.d, g.sigma_median, yerr=np.nan_to_num(err), fmt="o", color="k", mfc="white", ms=5, capsize=2,
                label=r"median $\sigma_c$ per size")
    d = np.geomspace(g.d.min(), g.d.max(), 50)
    pct = f"{100 * effect.confidence:g} %"
    ax.loglog(d, effect.median(d), "k-", lw=1.0,
              label=f"fit: $b$ = {effect.b:.3g}{_interval(*effect.b_interval)}")
    if np.isfinite(effect.b_weibull):
        centre = float(np.exp(np.mean(np.log(g.d))))
        ref = g.iloc[effect.reference]
        ax.loglog(d, effect.median(centre) * (d / centre) ** -effect.b_weibull, "--", color="0.4", lw=1.0,
                  label=f"weakest link: 3/$m$ = {effect.b_weibull:.3g}{_interval(*effect.b_weibull_interval)}"
                        f"\n($m$ at d = {_quantity(ref.d, 'm')}, {int(ref.n)} grains)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.xaxis.set_major_formatter(matplotlib.ticker.EngFormatter(unit="m"))
    ax.yaxis.set_major_formatter(matplotlib.ticker.EngFormatter(unit="Pa"))
    ax.set_xlabel("grain size $d$")
    ax.set_ylabel(r"median $\sigma_c = F_c/d^2$" + (f" ({pct} intervals)" if effect.n_boot else ""))
    return _finish(fig, ax, path, title)
