"""BPM mode-II toughness (SPEC 2.3): K_IIC from the peak shear stress of a mode2 run
(driver/bpm/mode2.py), where the first bonds broke relative to the void's tips and the band, and
K_IIC (and K_IIC / K_IC) against theta_c over a set of runs.

Geometry factor. The periodic box of side L holds one void, its major axis (2c) along the
45-degree line through the box centre; that line closes on itself after P = L sqrt(2), so along
it the sample is an infinite row of collinear cracks of length 2c and period P, loaded by the
remote shear tau on their plane. For that row (Koiter 1959; Tada, Paris & Irwin, The Stress
Analysis of Cracks Handbook, 3rd ed. 2000, periodic array of collinear cracks, the same factor
in mode I and mode II):

    K_II = Y tau sqrt(pi c),    Y = sqrt((P / (pi c)) tan(pi c / P))    (exact for that row)

The neighbouring rows (the void's images shifted by a box edge) lie a perpendicular
L / sqrt(2) away, staggered by P / 2; their interaction is left out (the unit keeps 2c <= P / 2,
so they are over 1.4 major axes away). In 3D (driver/bpm/mode2.py: the periodic slab, the void a
cylinder along z, the band a slab through it, z held fixed) the crack is a through-thickness
crack whose front runs along z, the same in every z plane: a plane-strain problem. The in-plane
stresses of a plane elastic problem loaded by tractions (the remote tau here, the crack faces
free) do not depend on the elastic constants (Michell), so plane strain and plane stress have
the same stress field and the same K_II for the same remote tau: the factor and formula hold
unchanged, with tau the stress per unit volume (3D pressure tensor). As in mode I (analysis/mode1.py), the void's finite tip
radius b^2 / c makes the measured K_IIC an upper bound of a sharp crack's. tau_c is the largest
tau of the record: tau = (sigma_xx - sigma_yy) / 2, the remote stress of the periodic cell
(pressure tensor over the box area, void included) resolved on the 45-degree planes.

Positions of breaks. The break log holds positions in the deformed box; under the pure shear of
true strain eps = edot t about the box centre (fix deform, remap x) the reference position is
x_c + (x - x_c) e^-eps, y_c + (y - y_c) e^eps, then wrapped to the nearest image of the tip or
of the band's line in the undeformed box.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.breaks import read_break_log
from analysis.report import Report, provenance_line
from analysis.run_analysis import RunAnalysis
from analysis.toughness import FAILED_FRACTION, FIRST_BREAKS, MIN_CROSSINGS, peak_and_end, toughness_set
from runfiles.records import MODE2_RECORD, read_record


def collinear_factor(c: float, period: float) -> float:
    """Y = sqrt((P / (pi c)) tan(pi c / P)) of a row of collinear cracks of half length c and period P."""
    x = math.pi * c / period
    return math.sqrt(math.tan(x) / x)


def mode2_toughness(tau_c: float, c: float, period: float) -> float:
    """K_IIC = Y tau_c sqrt(pi c) (module docstring)."""
    return collinear_factor(c, period) * tau_c * math.sqrt(math.pi * c)


def reference_positions(events: pd.DataFrame, centre: np.ndarray, strain_rate: float) -> np.ndarray:
    """Positions (N, 2) of events in the undeformed box: the pure shear of true strain
    eps = edot t about the box centre undone (module docstring)."""
    eps = strain_rate * events.time.to_numpy(float)
    d = events[["x", "y"]].to_numpy(float) - np.asarray(centre, float)[:2]
    return np.asarray(centre, float)[:2] + d * np.stack([np.exp(-eps), np.exp(eps)], axis=1)


def tip_distances(points: np.ndarray, centre: np.ndarray, c: float, angle_deg: float, L: float) -> np.ndarray:
    """Distance of each point (N, 2; undeformed box of side L) from the nearer tip
    centre +- c (cos angle, sin angle), through the nearest periodic image."""
    u = np.array([math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))])
    out = np.full(len(points), np.inf)
    for tip in (np.asarray(centre, float)[:2] + c * u, np.asarray(centre, float)[:2] - c * u):
        d = points - tip
        d -= L * np.round(d / L)
        out = np.minimum(out, np.hypot(d[:, 0], d[:, 1]))
    return out


def band_offsets(points: np.ndarray, centre: np.ndarray, L: float) -> np.ndarray:
    """Perpendicular distance of points (N, 2; undeformed box) from the band's periodic
    45-degree line (driver/bpm/mode2.py: images every L / sqrt(2))."""
    d = np.asarray(points, float) - np.asarray(centre, float)[:2]
    s = (d[:, 1] - d[:, 0]) / math.sqrt(2.0)
    h = L / math.sqrt(2.0)
    return np.abs(s - h * np.round(s / h))


class Mode2Analysis(RunAnalysis):
    """Summary, results/mode2 (the record), figure plots/mode2.png and report of a mode2 run.
    Cut short: measured on the record it left (a run cut short after the peak still has it),
    flagged."""

    def _prepare(self) -> None:
        self.system = json.loads((self.run_dir / "system.json").read_text())
        self.record = read_record(self.run_dir / "thermo.dat", MODE2_RECORD.names)
        if self.cut_short:
            self.cut_short_note = (f"the run did not finish: measured on its record up to step "
                                   f"{int(self.record.step.iloc[-1])}, before the end of the shear")

    def _conclude(self) -> None:
        cfg, system, record = self.cfg, self.system, self.record
        self.results.tables["mode2"] = record
        c = float(system["void_semi_axes"][0])
        period = float(system["crack_period"])
        L = float(system["box_length"])
        centre = np.asarray(system["void_centre"], float)
        k, tau_c, final, failed = peak_and_end(record.tau)
        peak = record.iloc[k]
        K = mode2_toughness(tau_c, c, period)
        flags = [] if failed else [f"no failure: tau at the end ({final:.4g}) is not below {FAILED_FRACTION:g} of its "
                                   f"peak ({tau_c:.4g}); shear further (scenario.max_shear_strain)"]
        summary: dict = {"theta_c_deg": cfg["model"]["theta_c_deg"], "lambda_c": cfg["model"]["lambda_c"],
                         "k_A": cfg["model"]["k_A"], "tau_c": tau_c, "peak_step": int(peak.step),
                         "peak_strain": float(peak.strain), "geometry_factor": collinear_factor(c, period),
                         "crack_half_length": c, "crack_period": period, "band_width": float(system["band_width"]),
                         "K_IIC": K, "final_mean_tau": final, "failed": failed}
        K_IC = cfg["scenario"].get("K_IC_reference")
        if K_IC:
            summary.update(K_IC_reference=float(K_IC), K_IIC_over_K_IC=K / float(K_IC))
        G = cfg["scenario"].get("G_reference")
        if G:
            # shear-wave speed sqrt(G / rho), rho the number density of the sample (m = 1): per area
            # in 2D, per volume of the slab (thickness T) in 3D
            T = float(system.get("thickness", 1.0))
            rho = system["n_particles"] / ((L * L - math.pi * c * float(system["void_semi_axes"][1])) * T)
            crossings = float(peak.time) / (L / math.sqrt(float(G) / rho))
            summary["shear_wave_crossings_to_peak"] = crossings
            if crossings < MIN_CROSSINGS:
                flags.append(f"rate: the peak comes after {crossings:.2g} shear-wave crossings of the sample (< "
                             f"{MIN_CROSSINGS:g}): the void is loaded by waves; shear more slowly")
        log = self.run_dir / "breaks.dat"
        if log.exists():
            bonds = read_break_log(log)
            bonds = bonds[bonds.kind == "bond"].sort_values("step", kind="stable")
            if len(bonds):
                ref = reference_positions(bonds, centre, float(system["strain_rate"]))
                first = ref[:FIRST_BREAKS]
                d = tip_distances(first, centre, c, float(system["void_angle_deg"]), L)
                summary.update(first_break_step=int(bonds.step.iloc[0]), first_breaks=len(first),
                               first_breaks_max_tip_distance=float(d.max()),
                               first_breaks_median_tip_distance=float(np.median(d)),
                               bonds_broken_before_peak=int((bonds.step <= peak.step).sum()),
                               bonds_broken=len(bonds),
                               broken_max_band_offset=float(band_offsets(ref, centre, L).max()))
        summary.update(flags=flags, flagged=bool(flags))
        self.results.summary = summary
        self.peak = k

    def _plot(self) -> None:
        self.draw("mode2", plot_shear, self.record, self.peak, self.png("mode2"))

    def _report(self) -> Report:
        summary = self.results.summary
        rep = Report(f"BPM mode-II toughness: {self.cfg['name']}", provenance_line(self.run_dir))
        rep.values({k_: v for k_, v in summary.items() if not isinstance(v, (list, dict))}, "toughness (LJ units)")
        for f in summary["flags"]:
            rep.text(f"FLAG: {f}")
        if self.plots and not self.guard.failed:
            rep.figure(self.png("mode2"), "shear stress on the 45-degree planes against strain, peak marked")
        return rep


def plot_shear(record: pd.DataFrame, peak: int, path: Path) -> None:
    """tau against the pure-shear strain, the peak (row `peak`) marked."""
    import matplotlib.pyplot as plt  # noqa: PLC0415
    from runfiles.atomic import atomic_save  # noqa: PLC0415

    fig, ax = plt.subplots(figsize=(5.0, 3.6), dpi=150)
    ax.plot(record.strain, record.tau, "-", lw=1)
    ax.plot(record.strain.iloc[peak], record.tau.iloc[peak], "o", color="C3", label=r"peak $\tau_c$")
    ax.set(xlabel=r"pure-shear strain $\varepsilon$", ylabel=r"$\tau = (\sigma_{xx} - \sigma_{yy})/2$")
    ax.legend(fontsize=7)
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p))
    plt.close(fig)


def analyse_mode2_set(runs: list[dict], out: Path, plots: bool = True, left_out: list[dict] | None = None) -> dict:
    """K_IIC (and K_IIC / K_IC where K_IC_reference was given) against theta_c
    (analysis/toughness.py toughness_set)."""
    return toughness_set(runs, out, plots, left_out, "theta_c_deg", ("tau_c", "K_IIC", "K_IIC_over_K_IC"),
                         "K_IIC_over_K_IC", "K_IIC", r"$\theta_c$ (degrees)", (r"$K_{IIC}$", r"$K_{IIC}/K_{IC}$"),
                         "mode-II toughness")
