"""Figures a physicist would put in a paper: log-log N(M), stress ratio against strain.

Greyscale-readable (markers and line styles differ, not only colours), axes with units.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from driver.rundir import atomic_save  # noqa: E402

_MARKERS = "osD^v<>ph*"
_LINES = ["-", "--", "-.", ":"]


def plot_nm(nm: pd.DataFrame, path: Path, title: str = "", mass_unit: str = "m", fit: dict | None = None) -> None:
    """N(M) per strain, log-log, at each bin's mean grain mass. nm has columns strain, m_mean, N;
    `fit` (strain, tau, sigma, xmin) draws the fitted slope through the last strain's data."""
    fig, ax = plt.subplots(figsize=(5.0, 4.0), dpi=150)
    for k, (eps, grp) in enumerate(nm.groupby("strain", sort=True)):
        grp = grp[grp["N"] > 0]
        if grp.empty:
            continue
        ax.loglog(grp["m_mean"], grp["N"], marker=_MARKERS[k % len(_MARKERS)],
                  linestyle=_LINES[k % len(_LINES)], color=str(0.75 * k / max(1, nm.strain.nunique() - 1)),
                  mfc="white", label=rf"$\varepsilon$ = {eps:g}")
    if fit and fit.get("tau") is not None:
        last = nm[(nm.strain == fit["strain"]) & (nm.N > 0)]
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
    """sqrt(J2), P and mu against strain (LJ units)."""
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(5.0, 5.0), dpi=150, sharex=True)
    ax1.plot(stress.strain, stress.sqrtJ2, "k-", label=r"$\sqrt{J_2}$")
    ax1.plot(stress.strain, stress.P, "k--", label="$P$")
    ax1.set_ylabel(r"stress [$u/a^d$]")
    ax1.legend(fontsize=8, frameon=False)
    # mu is undefined while the solid is still near zero pressure: show it where P is sizeable.
    sizeable = stress.P > 0.05 * stress.P.max()
    ax2.plot(stress.strain[sizeable], stress.mu[sizeable], "k-")
    ax2.set_ylabel(r"$\mu = \sqrt{J_2}/P$ (where $P > 0.05\,P_{max}$)")
    ax2.set_xlabel(r"true strain $\varepsilon$")
    if title:
        ax1.set_title(title, fontsize=9)
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p, format="png"))
    plt.close(fig)


def plot_energies(energies: pd.DataFrame, wk_minus: float, path: Path, title: str = "") -> None:
    """Energy budget of an impact against time, as fractions of W_k^- (SPEC 1.5)."""
    fig, ax = plt.subplots(figsize=(5.5, 4.0), dpi=150)
    t = energies.time * 1e6
    for col, label, style in [("kinetic", "kinetic $W_k$", "k-"), ("elastic", "elastic (interfaces + contacts)", "k--"),
                              ("W_f", "fracture $W_f = 2AG_c$", "k-."), ("dissipated", "dissipated $W_c$", "k:")]:
        ax.plot(t, energies[col] / wk_minus, style, label=label)
    total = (energies.kinetic + energies.elastic + energies.W_f + energies.dissipated) / wk_minus
    ax.plot(t, total, color="0.6", lw=2.5, alpha=0.6, label="sum", zorder=0)
    ax.set_xlabel(r"time [$\mu$s]")
    ax.set_ylabel(r"energy / $W_k^-$")
    ax.legend(fontsize=8, frameon=False, loc="center right")
    if title:
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p, format="png"))
    plt.close(fig)
