"""Both models' beds on the same axes (driver/compare/bed.py): the compression curves (void ratio
against sigma_v, log), the grading curves at the last dumped state and the breakage against
stress. Styles as the impact comparison's (driver/compare/plots.py STYLE)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from analysis.plots import PlotGuard  # noqa: E402
from driver.compare.crush_plots import _save  # noqa: E402
from driver.compare.plots import STYLE  # noqa: E402


def plot_compression(curves: dict[str, list[dict[str, Any]]], path: Path, title: str = "") -> None:
    """Every bed's loading branch, void ratio against sigma_v (log), both models."""
    fig, ax = plt.subplots(figsize=(5.5, 4.0), dpi=120)
    for model, (name, _, colour) in STYLE.items():
        for k, c in enumerate(curves.get(model, [])):
            ax.plot(c["sigma_v"], c["void_ratio"], color=colour, lw=0.8, alpha=0.8, label=name if k == 0 else None)
    ax.set(xscale="log", xlabel=r"$\sigma_v$ on the platen [Pa]", ylabel="void ratio e")
    ax.legend(fontsize=7, frameon=False)
    _save(fig, path, title)


def plot_grading(curves: dict[str, list[dict[str, Any]]], path: Path, title: str = "") -> None:
    """Each bed's grading curve (mass passing against the sieve size b) at its last dumped
    state, both models."""
    fig, ax = plt.subplots(figsize=(5.5, 4.0), dpi=120)
    for model, (name, _, colour) in STYLE.items():
        for k, c in enumerate(curves.get(model, [])):
            g = c["grading"]
            if g.empty:
                continue
            last = g[g.state == g.state.iloc[-1]]
            ax.step(last["size"] * 1e3, last["passing"], where="post", color=colour, lw=0.8,
                    label=name if k == 0 else None)
    ax.set(xscale="log", xlabel="sieve size b [mm]", ylabel="mass passing")
    ax.legend(fontsize=7, frameon=False)
    _save(fig, path, title)


def plot_breakage(curves: dict[str, list[dict[str, Any]]], path: Path, title: str = "") -> None:
    """B_r and the fraction of grains broken against sigma_v at the dumped states, both models."""
    fig, axes = plt.subplots(1, 2, figsize=(9.0, 3.6), dpi=120)
    for model, (name, marker, colour) in STYLE.items():
        for k, c in enumerate(curves.get(model, [])):
            s = c["states"]
            if s.empty:
                continue
            s = s[s.sigma_v > 0]
            for ax, col in zip(axes, ("B_r", "fraction_broken")):
                ax.plot(s.sigma_v, s[col], marker=marker, mfc="white", color=colour, lw=0.8,
                        label=name if k == 0 else None)
    for ax, label in zip(axes, ("Hardin's $B_r$", "fraction of grains broken")):
        ax.set(xscale="log", xlabel=r"$\sigma_v$ [Pa]", ylabel=label)
        ax.legend(fontsize=7, frameon=False)
    _save(fig, path, title)


def draw_bed(guard: PlotGuard, curves: dict[str, list[dict[str, Any]]], out: Path, title: str) -> dict[str, Path]:
    """The three figures into `out`, each through the guard; name -> path of those drawn."""
    figures = {}
    for name, fn in (("compression_curves", plot_compression), ("grading_curves", plot_grading),
                     ("breakage", plot_breakage)):
        path = out / f"{name}.png"
        if guard.draw(name, path, fn, curves, path, title):
            figures[name] = path
    return figures
