"""BPM mode-I toughness (SPEC 2.3): K_IC from the peak stress of a mode1 run
(driver/bpm/mode1.py), where the first bonds broke relative to the void's tips, the crack speed
when the run has the break log (analysis/crack.py), and K_IC / E against lambda_c over a set of
runs (analysis/toughness.py). Mode II beside it: analysis/mode2.py.

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
from analysis.report import Report, provenance_line
from analysis.run_analysis import RunAnalysis
from analysis.toughness import FAILED_FRACTION, FIRST_BREAKS, MIN_CROSSINGS, peak_and_end, toughness_set
from runfiles.records import MODE1_RECORD, read_record


def feddersen_factor(c: float, width: float) -> float:
    """Y = sqrt(sec(pi c / W)) of a centre crack of half length c in a plate of width W."""
    return math.sqrt(1.0 / math.cos(math.pi * c / width))


def mode1_toughness(sigma_c: float, c: float, width: float) -> float:
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


class Mode1Analysis(RunAnalysis):
    """Summary, results/mode1 (the record), results/crack_front, figures plots/mode1.png and
    plots/crack_front.png and report of a mode1 (or crack_speed) run. Cut short: measured on
    the record it left (a run cut short after the peak still has it), flagged."""

    def _prepare(self) -> None:
        self.system = json.loads((self.run_dir / "system.json").read_text())
        self.record = read_record(self.run_dir / "thermo.dat", MODE1_RECORD.names)
        if self.cut_short:
            self.cut_short_note = (f"the run did not finish: measured on its record up to step "
                                   f"{int(self.record.step.iloc[-1])}, before the end of the pull")

    def _conclude(self) -> None:
        cfg, system, record = self.cfg, self.system, self.record
        self.results.tables["mode1"] = record
        c = float(system["void_semi_axes"][0])
        width = float(system["width"])
        k, sigma_c, final, failed = peak_and_end(record.stress)
        peak = record.iloc[k]
        K = mode1_toughness(sigma_c, c, width)
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
        self.fronts, self.c_R = None, None
        log = self.run_dir / "breaks.dat"
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
                self.results.tables["crack_front"] = fronts
                summary.update(steady_speed(fronts, c, 0.5 * width))
                B_ref, G_ref = cfg["scenario"].get("B_reference"), cfg["scenario"].get("G_reference")
                if B_ref and G_ref:
                    rho = _density(system, c)
                    self.c_R = rayleigh_speed(float(B_ref), float(G_ref), rho, int(cfg["model"]["dimension"]))
                    summary.update(rayleigh_speed=self.c_R, crack_speed_over_rayleigh=summary["crack_speed"] / self.c_R,
                                   crack_speed_over_rayleigh_se=summary["crack_speed_se"] / self.c_R)
                self.fronts = fronts
        summary.update(flags=flags, flagged=bool(flags))
        self.results.summary = summary
        self.peak = k

    def _plot(self) -> None:
        if self.fronts is not None and len(self.fronts):
            self.draw("crack_front", plot_fronts, self.fronts, self.results.summary, self.c_R, self.png("crack_front"))
        self.draw("mode1", plot_pull, self.record, self.peak, self.png("mode1"))

    def _report(self) -> Report:
        summary = self.results.summary
        rep = Report(f"BPM mode-I toughness: {self.cfg['name']}", provenance_line(self.run_dir))
        rep.values({k_: v for k_, v in summary.items() if not isinstance(v, (list, dict))}, "toughness (LJ units)")
        for f in summary["flags"]:
            rep.text(f"FLAG: {f}")
        if self.plots and not self.guard.failed:
            rep.figure(self.png("mode1"), "far-field stress against grip displacement, peak marked")
            if self.png("crack_front").exists():
                rep.figure(self.png("crack_front"), "crack fronts against time, steady-speed fits")
        return rep


def plot_pull(record: pd.DataFrame, peak: int, path: Path) -> None:
    """Far-field stress against grip displacement, the peak (row `peak`) marked."""
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


def analyse_mode1_set(runs: list[dict], out: Path, plots: bool = True, left_out: list[dict] | None = None) -> dict:
    """K_IC (and K_IC / E where E_reference was given; the crack speed where the runs have it)
    against lambda_c (analysis/toughness.py toughness_set)."""
    return toughness_set(runs, out, plots, left_out, "lambda_c",
                         ("sigma_c", "K_IC", "K_IC_over_E", "crack_speed", "crack_speed_over_rayleigh"),
                         "K_IC_over_E", "K_IC", r"$\lambda_c$", (r"$K_{IC}$", r"$K_{IC}/E$"), "mode-I toughness")
