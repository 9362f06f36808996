"""BPM elastic calibration (SPEC 2.3): B, G, E and nu from a moduli run's record, and their
curves against k_A over a set of runs.

Each phase of the run (driver/bpm/moduli.py) deforms the undeformed solid at a constant rate:
the stress is fitted linearly against the phase's strain over (FIT_FROM, 1] of the largest
strain, past the start-up transient (the stress grows from rest within a sound-crossing time),
with an intercept (a steady viscous stress at constant rate shifts the curve, not its slope).
B = dP / d eps_v, G = d tau / d gamma (3D: the mean over the three shear planes, its error the
combined standard error), then

    2D: E = 4 B G / (B + G),   nu = (B - G) / (B + G)
    3D: E = 9 B G / (3 B + G), nu = (3 B - 2 G) / (6 B + 2 G)

from the half-rate phases; the full-rate phases check that the moduli do not depend on the
rate (relative difference above RATE_TOLERANCE: flagged), and the shortest phase must last
MIN_CROSSINGS sound-crossing times L / c_l of the box, c_l^2 = (B + G) / rho in 2D,
(B + 4 G / 3) / rho in 3D, rho the number density (m = 1): flagged otherwise. A phase in which
bonds broke is not elastic: flagged.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.plots import PlotGuard
from analysis.report import Report, clear_report, provenance_line, write_report
from analysis.run_analysis import RunAnalysis
from analysis.tables import save_table
from runfiles.records import MODULI_RECORD, read_record

#: Fit window: strains above this fraction of the largest strain of the phase.
FIT_FROM = 0.2
#: Largest relative difference of a modulus between the rate and half the rate.
RATE_TOLERANCE = 0.05
#: Fewest times a longitudinal sound wave crosses the box during the shortest phase: below
#: it the solid cannot relax non-affinely while it is deformed, and both rates give moduli
#: near the affine ones (measured: 2D L = 12 at rate 0.1, 0.5 crossings, B = 1.02 B_affine at
#: both rates), which the rate comparison alone does not catch.
MIN_CROSSINGS = 5.0


def stress_of(record: pd.DataFrame, load: str, dimension: int) -> pd.Series:
    """P = tr(p) / d for compression, tau_ij = -p_ij for a shear tilt 'xy', 'xz', 'yz'."""
    if load == "compression":
        return sum(record[f"p{a}{a}"] for a in "xyz"[:dimension]) / dimension
    return -record[f"p{load}"]


def linear_fit(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """(slope, its standard error, intercept) of a least-squares line."""
    (slope, intercept), cov = np.polyfit(x, y, 1, cov=True)
    return float(slope), float(math.sqrt(cov[0, 0])), float(intercept)


def phase_fits(record: pd.DataFrame, phases: list[dict], dimension: int) -> pd.DataFrame:
    """One row per phase: load, rate, slope (the modulus) and its standard error, intercept,
    points fitted, and the bonds and angles broken during the phase."""
    rows = []
    for ph in phases:
        rec = record[(record.phase == ph["index"]) & (record.step > ph["start"])]
        top = rec.strain.max()
        win = rec[rec.strain > FIT_FROM * top]
        if len(win) < 3:
            raise ValueError(f"phase {ph['index']} ({ph['load']}): {len(win)} records in the fit window, too few "
                             "to fit a modulus")
        slope, se, icpt = linear_fit(win.strain.to_numpy(), stress_of(win, ph["load"], dimension).to_numpy())
        before = record[record.step <= ph["start"]].tail(1)
        broken = int(rec.bonds_broken.max() - (before.bonds_broken.iloc[0] if len(before) else 0))
        rows.append({"phase": ph["index"], "load": ph["load"], "rate": ph["rate"], "modulus": slope,
                     "modulus_se": se, "intercept": icpt, "points": len(win), "max_strain": float(top),
                     "bonds_broken": broken})
    return pd.DataFrame(rows)


def elastic_constants(B: float, G: float, dimension: int) -> tuple[float, float]:
    """(E, nu) of an isotropic solid from B and G (SPEC 2.3)."""
    if dimension == 2:
        return 4 * B * G / (B + G), (B - G) / (B + G)
    return 9 * B * G / (3 * B + G), (3 * B - 2 * G) / (6 * B + 2 * G)


def moduli_of(fits: pd.DataFrame, rate: float) -> tuple[float, float, float, float]:
    """(B, its se, G, its se) of the phases at `rate` (G: mean over the shear planes)."""
    at = fits[np.isclose(fits.rate, rate)]
    comp, shear = at[at.load == "compression"].iloc[0], at[at.load != "compression"]
    return (float(comp.modulus), float(comp.modulus_se), float(shear.modulus.mean()),
            float(np.sqrt((shear.modulus_se ** 2).sum()) / len(shear)))


def moduli_flags(crossings: float, rate_dev: float, fast: float, slow: float, broken: int, elements: str,
                 remedy: str) -> list[str]:
    """The checks of a moduli run (module docstring), as flags: too few sound crossings in the
    shortest phase, moduli that depend on the rate, elements broken (`remedy`: what to change
    for the first two)."""
    flags = []
    if crossings < MIN_CROSSINGS:
        flags.append(f"rate: the shortest phase lasts {crossings:.2g} sound-crossing times of the box (< "
                     f"{MIN_CROSSINGS:g}): the solid is deformed faster than it can relax; {remedy}")
    if rate_dev > RATE_TOLERANCE:
        flags.append(f"rate: the moduli at rate {fast:g} differ from those at {slow:g} by {rate_dev:.1%} "
                     f"(> {RATE_TOLERANCE:.0%}): {remedy}")
    if broken > 0:
        flags.append(f"{broken} {elements} broke: the test left the elastic range (lower scenario.max_strain)")
    return flags


class ModuliAnalysis(RunAnalysis):
    """Tables (results/moduli_phases), figure (plots/moduli.png), report and summary of a BPM
    moduli run. Cut short: refused (its phases are incomplete; a moduli run is short)."""

    refuses_cut_short = "a moduli run that did not finish has no moduli: run it again"

    def _prepare(self) -> None:
        self.dim = int(self.cfg["model"]["dimension"])
        self.system = json.loads((self.run_dir / "system.json").read_text())
        self.record = read_record(self.run_dir / "thermo.dat", MODULI_RECORD.names)

    def _conclude(self) -> None:
        cfg, dim, system, record = self.cfg, self.dim, self.system, self.record
        fits = phase_fits(record, system["phases"], dim)
        self.results.tables["moduli_phases"] = fits
        rates = sorted(set(fits.rate))
        slow, fast = rates[0], rates[-1]
        B, B_se, G, G_se = moduli_of(fits, slow)
        B_fast, _, G_fast, _ = moduli_of(fits, fast)
        E, nu = elastic_constants(B, G, dim)
        rate_dev = max(abs(B_fast - B) / abs(B), abs(G_fast - G) / abs(G))
        rho = system["n_particles"] / float(record.vol.iloc[0])
        c_l = math.sqrt((B + (G if dim == 2 else 4 * G / 3)) / rho)
        length = float(record.vol.iloc[0]) ** (1 / dim)
        shortest = min(ph["steps"] for ph in system["phases"]) * float(cfg["model"]["timestep"])
        crossings = shortest / (length / c_l)
        flags = moduli_flags(crossings, rate_dev, fast, slow, int(fits.bonds_broken.sum()), "bonds",
                             "deform more slowly")
        self.results.summary = {
            "k_A": cfg["model"]["k_A"], "B": B, "B_se": B_se, "G": G, "G_se": G_se, "E": E, "nu": nu,
            "B_at_rate": B_fast, "G_at_rate": G_fast, "rate_deviation": rate_dev,
            "number_density": rho, "sound_speed": c_l, "sound_crossings": crossings,
            "B_affine": system["B_affine"], "G_affine": system["G_affine"],
            "B_over_affine": B / system["B_affine"], "G_over_affine": G / system["G_affine"],
            "flags": flags, "flagged": bool(flags)}
        self.fits = fits

    def _plot(self) -> None:
        self.draw("moduli", plot_phases, self.record, self.system["phases"], self.fits, self.dim, self.png("moduli"))

    def _report(self) -> Report:
        summary = self.results.summary
        rep = Report(f"BPM moduli: {self.cfg['name']}", provenance_line(self.run_dir))
        rep.values({k: v for k, v in summary.items() if not isinstance(v, (list, dict))}, "moduli (LJ units)")
        for f in summary["flags"]:
            rep.text(f"FLAG: {f}")
        rep.table(self.fits, "one fit per phase (stress against strain over the fit window)")
        if self.plots and not self.guard.failed:
            rep.figure(self.png("moduli"), "stress against strain per phase, with the fitted lines")
        return rep


def plot_phases(record: pd.DataFrame, phases: list[dict], fits: pd.DataFrame, dimension: int, path: Path) -> None:
    """Stress against strain per phase (compression, shears), with each phase's fitted line."""
    import matplotlib.pyplot as plt  # noqa: PLC0415
    from runfiles.atomic import atomic_save  # noqa: PLC0415

    fig, axes = plt.subplots(1, 2, figsize=(9.0, 3.6), dpi=150)
    for ph, fit in zip(phases, fits.itertuples()):
        rec = record[(record.phase == ph["index"]) & (record.step > ph["start"])]
        ax = axes[0] if ph["load"] == "compression" else axes[1]
        y = stress_of(rec, ph["load"], dimension)
        line, = ax.plot(rec.strain, y, ".", ms=2, label=f"{ph['load']}, rate {ph['rate']:g}")
        xs = np.array([FIT_FROM * fit.max_strain, fit.max_strain])
        ax.plot(xs, fit.intercept + fit.modulus * xs, "-", color=line.get_color(), lw=1)
    axes[0].set(xlabel=r"volumetric strain $\varepsilon_v$", ylabel="P", title="bulk modulus B")
    axes[1].set(xlabel=r"shear strain $\gamma$", ylabel=r"$\tau$", title="shear modulus G")
    for ax in axes:
        ax.legend(fontsize=6)
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p))
    plt.close(fig)


def analyse_moduli_set(runs: list[dict], out: Path, plots: bool = True, left_out: list[dict] | None = None) -> dict:
    """B, G, E, nu against k_A over a set of moduli runs (one row per run and the mean and
    standard deviation per k_A), G against k_A fitted linearly (slope, residual), the relative
    change of B over the k_A range; table `moduli`, figure plots/moduli_vs_kA.png."""
    out = Path(out)
    rows = [{"run": r["cfg"]["name"], "run_dir": str(r["dir"]), "dimension": r["cfg"]["model"]["dimension"],
             **{k: v for k, v in r["summary"].items() if not isinstance(v, (list, dict))}} for r in runs]
    table = pd.DataFrame(rows).sort_values("k_A").reset_index(drop=True)
    save_table(table, out / "runs")
    cols = ["B", "G", "E", "nu", "B_affine", "G_affine"] + (["number_density"] if "number_density" in table else [])
    points = table.groupby("k_A")[cols].agg(["mean", "std"])
    points.columns = [f"{a}_{b}" for a, b in points.columns]
    points = points.reset_index()
    save_table(points, out / "moduli")
    result: dict = {"runs": len(table), "left_out": left_out or []}
    if len(points) >= 2:
        slope, se, icpt = linear_fit(points.k_A.to_numpy(), points.G_mean.to_numpy())
        resid = points.G_mean - (icpt + slope * points.k_A)
        result.update(G_slope=slope, G_slope_se=se, G_intercept=icpt,
                      G_fit_max_residual=float(np.abs(resid).max() / np.abs(points.G_mean).max()),
                      B_relative_change=float((points.B_mean.max() - points.B_mean.min()) / points.B_mean.mean()))
    guard = PlotGuard()
    if plots:
        guard.draw("moduli_vs_kA", out / "plots" / "moduli_vs_kA.png", plot_moduli_vs_ka, points,
                   out / "plots" / "moduli_vs_kA.png")
    clear_report(out)
    rep = Report("BPM moduli against k_A", f"{len(table)} runs")
    rep.values({k: v for k, v in result.items() if not isinstance(v, list)}, "fits")
    rep.table(points, "moduli per k_A (mean and standard deviation over runs)")
    if plots and not guard.failed:
        rep.figure(out / "plots" / "moduli_vs_kA.png", "B, G and nu against k_A, with the affine estimates")
    write_report(rep, out)
    return result


def plot_moduli_vs_ka(points: pd.DataFrame, path: Path) -> None:
    """B and G (with their affine estimates) and nu against k_A over a set."""
    import matplotlib.pyplot as plt  # noqa: PLC0415
    from runfiles.atomic import atomic_save  # noqa: PLC0415

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(9.0, 3.6), dpi=150)
    for name, style in (("B", "o-"), ("G", "s-")):
        ax.errorbar(points.k_A, points[f"{name}_mean"], yerr=points[f"{name}_std"].fillna(0), fmt=style, label=name)
        ax.plot(points.k_A, points[f"{name}_affine_mean"], "--", label=f"{name} affine")
    ax.set(xlabel="$k_A$", ylabel="modulus (LJ units)")
    ax.legend(fontsize=7)
    ax2.errorbar(points.k_A, points.nu_mean, yerr=points.nu_std.fillna(0), fmt="o-")
    ax2.set(xlabel="$k_A$", ylabel=r"Poisson's ratio $\nu$")
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p))
    plt.close(fig)
