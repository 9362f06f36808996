"""The analysis of the BCM calibrate scenario (SPEC 3), the tests on a periodic block of cells
(built by driver/bcm/calibrate.py, the unit driver/scenarios/bcm_calibrate.py): the moduli of a
`moduli` run (`BlockModuliAnalysis`), the fracture measures of a `fracture` run
(`BlockFractureAnalysis`), and the calibration curves of a set of runs (`analyse_block_set`).

moduli: each phase fitted as in analysis/moduli.py (stress against strain over the upper part
of the phase, with an intercept), B from the half-rate compression, G the mean of the three
half-rate shear planes, then (3D, SPEC 2.3)

    E = 9 B G / (3 B + G),   nu = (3 B - 2 G) / (6 B + 2 G);

and the reduced moduli B h / k_n, G h / k_n (functions of k_t / k_n alone, by dimensional
analysis of springs between cells of size h); the full-rate phases check the rate
(RATE_TOLERANCE), the shortest phase must last
MIN_CROSSINGS sound-crossing times L / c_l, c_l^2 = (B + 4 G / 3) / rho_s (flagged otherwise),
and a phase in which an interface broke is flagged.

fracture (mode I pull along z of a notched block, uniaxial strain): the tensile strength is the
peak of sigma_zz = -p_zz. The energy released is the elastic energy the broken interfaces held
when they broke (the break log's `energy`, SPEC 1.2's Delta W_p of the stored springs; the
Griffith criterion releases it when Delta W_p / (2 S) >= G_c), divided by the new crack surface:

    G_released = sum_b W_b / (2 A_lig),  A_lig = (1 - notch) Lx Ly (the projected ligament the
                 crack crosses: the crack plane less the notch; two new surfaces);
    G_break    = sum_b W_b / (2 sum_b S_b)  (per unit of the broken interfaces' own area, >= G_c);

their ratio to G_c is the roughness of the crack (broken area over the ligament) times the
overshoot of the last step. Separation: the stress at the end of the pull below
SEPARATED_FRACTION of the peak (flagged otherwise).

A moduli run cut short is refused (its phases are incomplete: run it again); a fracture run cut
short is measured on the record it left and flagged (analysis/completeness.py).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.breaks import read_break_log
from analysis.moduli import (RATE_TOLERANCE, elastic_constants, linear_fit, moduli_flags, moduli_of, phase_fits,
                             plot_phases)
from analysis.plots import PlotGuard
from analysis.report import Report, clear_report, provenance_line, write_report
from analysis.run_analysis import RunAnalysis
from analysis.tables import save_table
from runfiles.records import BCM_BLOCK_RECORD, read_record

#: The block has separated when the end stress is below this fraction of the peak.
SEPARATED_FRACTION = 0.05


def _load(run_dir: Path) -> tuple[dict, pd.DataFrame]:
    system = json.loads((run_dir / "system.json").read_text())
    return system, read_record(run_dir / "thermo.dat", BCM_BLOCK_RECORD.names)


def _block_report(run_dir: Path, title: str, summary: dict, flags: list[str], tables: list[tuple[pd.DataFrame, str]],
                  figure: tuple[Path, str] | None) -> Report:
    """The report of a block test: its summary in SI units, its flags, tables and figure."""
    rep = Report(title, provenance_line(run_dir))
    rep.values({k: v for k, v in summary.items() if not isinstance(v, (list, dict))}, "SI units")
    for f in flags:
        rep.text(f"FLAG: {f}")
    for table, caption in tables:
        rep.table(table, caption)
    if figure is not None:
        rep.figure(*figure)
    return rep


def block_moduli(record: pd.DataFrame, system: dict, density: float) -> tuple[dict, pd.DataFrame]:
    """(summary, per-phase fits) of a moduli run's record (module docstring)."""
    fits = phase_fits(record, system["phases"], 3)
    rates = sorted(set(fits.rate))
    slow, fast = rates[0], rates[-1]
    B, B_se, G, G_se = moduli_of(fits, slow)
    B_fast, _, G_fast, _ = moduli_of(fits, fast)
    E, nu = elastic_constants(B, G, 3)
    # error propagation of E and nu from B and G (independent fits)
    dE = math.hypot(9 * G ** 2 / (3 * B + G) ** 2 * B_se, 27 * B ** 2 / (3 * B + G) ** 2 * G_se)
    dnu = math.hypot(9 * G / (2 * (3 * B + G) ** 2) * B_se, 9 * B / (2 * (3 * B + G) ** 2) * G_se)
    rate_dev = max(abs(B_fast - B) / abs(B), abs(G_fast - G) / abs(G))
    c_l = math.sqrt((B + 4 * G / 3) / density)
    shortest = min(ph["steps"] for ph in system["phases"]) * system["timestep"]
    crossings = shortest / (system["side"] / c_l)
    flags = moduli_flags(crossings, rate_dev, fast, slow, int(fits.bonds_broken.sum()), "interfaces",
                         "raise scenario.block.crossings")
    summary = {"B": B, "B_se": B_se, "G": G, "G_se": G_se, "E": E, "E_se": dE, "nu": nu, "nu_se": dnu,
               "B_at_rate": B_fast, "G_at_rate": G_fast, "rate_deviation": rate_dev, "rate_flagged":
               rate_dev > RATE_TOLERANCE, "strain_rate": system["strain_rate"], "sound_speed": c_l,
               "sound_crossings": crossings, "c0": system["c0"], "crossing_time": system["crossing_time"],
               "cell_size": system["cell_size"], "n_cells": system["n_cells"], "flags": flags, "flagged": bool(flags)}
    return summary, fits


class BlockModuliAnalysis(RunAnalysis):
    """results/moduli_phases (+ moduli.csv), plots/moduli.png, report and summary of a moduli
    run. Cut short: refused (its phases are incomplete)."""

    refuses_cut_short = "a moduli run that did not finish has no moduli: run it again"

    def _prepare(self) -> None:
        self.system, self.record = _load(self.run_dir)

    def _conclude(self) -> None:
        m = self.cfg["model"]
        summary, fits = block_moduli(self.record, self.system, float(m["density"]))
        kn = float(m["interface"]["kn"])
        # the reduced moduli B h / k_n, G h / k_n depend on k_t / k_n (and the cells' shape) only:
        # the calibration curves that carry over to any k_n and h
        summary |= {"kn": kn, "kt": float(m["interface"]["kt"]), "kt_over_kn": float(m["interface"]["kt"]) / kn,
                    "B_reduced": summary["B"] * summary["cell_size"] / kn,
                    "G_reduced": summary["G"] * summary["cell_size"] / kn}
        self.results.summary = summary
        self.results.tables.update(
            moduli_phases=fits, moduli=pd.DataFrame([{k: v for k, v in summary.items() if not isinstance(v, list)}]))
        self.fits = fits

    def _plot(self) -> None:
        self.draw("moduli", plot_phases, self.record, self.system["phases"], self.fits, 3, self.png("moduli"))

    def _report(self) -> Report:
        summary = self.results.summary
        return _block_report(self.run_dir, f"BCM block moduli: {self.cfg['name']}", summary, summary["flags"],
                             [(self.fits, "one fit per phase (stress against strain over the fit window), Pa")],
                             (self.png("moduli"), "stress against strain per phase, fitted lines")
                             if self.plots and not self.guard.failed else None)


def block_fracture(record: pd.DataFrame, breaks: pd.DataFrame, system: dict, G_c: float) -> tuple[dict, list[str]]:
    """Strength and released energy of a fracture run (module docstring)."""
    sigma = -record.pzz.to_numpy()
    k = int(np.argmax(sigma))
    peak = float(sigma[k])
    end = float(np.mean(sigma[-max(1, len(sigma) // 20):]))
    ifc = breaks[breaks.kind == "interface"] if len(breaks) else breaks
    W = float(ifc.energy.sum()) if len(ifc) else 0.0
    S = float(ifc.area.sum()) if len(ifc) else 0.0
    A = system["crack_plane_area"] * (1.0 - system["notch"])
    G_rel = W / (2 * A)
    G_brk = W / (2 * S) if S > 0 else float("nan")
    # work of the pull per unit volume, sigma_zz d eps (engineering strain of z, x and y held)
    eps = record.strain.to_numpy()
    work = float(np.sum(0.5 * (sigma[1:] + sigma[:-1]) * np.diff(eps)) * system["lengths"][0] * system["lengths"][1]
                 * system["lengths"][2])
    flags = []
    separated = end < SEPARATED_FRACTION * peak
    if not separated:
        flags.append(f"not separated: the stress at the end of the pull is {end / peak:.0%} of the peak (> "
                     f"{SEPARATED_FRACTION:.0%}); raise scenario.block.pull_strain")
    summary = {"G_c": G_c, "tensile_strength": peak, "strain_at_peak": float(eps[k]), "end_stress": end,
               "separated": bool(separated), "broken": int(len(ifc)), "broken_area": S, "ligament_area": A,
               "roughness": S / A, "energy_released": W, "G_released": G_rel, "G_released_over_Gc": G_rel / G_c,
               "G_break": G_brk, "G_break_over_Gc": G_brk / G_c, "work_of_pull": work,
               "work_of_pull_per_area": work / (2 * A), "notch": system["notch"], "strain_rate": system["strain_rate"],
               "cell_size": system["cell_size"], "n_cells": system["n_cells"]}
    return summary, flags


class BlockFractureAnalysis(RunAnalysis):
    """results/fracture (one row), results/breaks, plots/fracture.png, report and summary of a
    fracture run. Cut short: measured on the record and break log it left, flagged."""

    def _prepare(self) -> None:
        self.system, self.record = _load(self.run_dir)
        self.breaks = read_break_log(self.run_dir / "breaks.dat")
        if self.cut_short:
            self.cut_short_note = (f"the run did not finish: measured on its record up to step "
                                   f"{int(self.record.step.iloc[-1])}, before the end of the pull")

    def _conclude(self) -> None:
        summary, flags = block_fracture(self.record, self.breaks, self.system,
                                        float(self.cfg["model"]["interface"]["G_c"]))
        summary |= {"flags": flags, "flagged": bool(flags)}
        self.results.summary = summary
        self.results.tables.update(fracture=pd.DataFrame([{k: v for k, v in summary.items()
                                                           if not isinstance(v, list)}]),
                                   breaks=self.breaks)

    def _plot(self) -> None:
        self.draw("fracture", plot_fracture, self.record, self.png("fracture"))

    def _report(self) -> Report:
        summary = self.results.summary
        return _block_report(self.run_dir, f"BCM block fracture: {self.cfg['name']}", summary, summary["flags"], [],
                             (self.png("fracture"), "stress and broken interfaces against the pull strain")
                             if self.plots and not self.guard.failed else None)


def plot_fracture(record: pd.DataFrame, path: Path) -> None:
    """sigma_zz (MPa) and the broken interfaces against the pull strain."""
    import matplotlib.pyplot as plt  # noqa: PLC0415
    from runfiles.atomic import atomic_save  # noqa: PLC0415

    fig, ax = plt.subplots(figsize=(5.0, 3.6), dpi=150)
    ax.plot(record.strain, -record.pzz / 1e6, "-", lw=1)
    ax.set(xlabel=r"pull strain $\varepsilon_{zz}$", ylabel=r"$\sigma_{zz}$ (MPa)")
    ax2 = ax.twinx()
    ax2.plot(record.strain, record.bonds_broken, "--", color="grey", lw=1)
    ax2.set_ylabel("broken interfaces")
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p))
    plt.close(fig)


def analyse_block_set(runs: list[dict], out: Path, plots: bool = True, left_out: list[dict] | None = None) -> dict:
    """Calibration curves of a set of one test's runs: moduli (B, G, E, nu and the reduced
    B h / k_n, G h / k_n against k_t/k_n, k_n and h; table `moduli`) or fracture (G_released,
    G_break and the strength against G_c; table `fracture`), with the runs table and a figure."""
    out = Path(out)
    tests = {r["cfg"]["scenario"].get("test", "moduli") for r in runs}
    if len(tests) > 1:
        raise ValueError(f"a set of calibration runs mixes the tests {sorted(tests)}: analyse each test apart")
    test = tests.pop()
    rows = []
    for r in runs:
        m = r["cfg"]["model"]
        rows.append({"run": r["cfg"]["name"], "run_dir": str(r["dir"]), "kn": float(m["interface"]["kn"]),
                     "kt": float(m["interface"]["kt"]),
                     "kt_over_kn": float(m["interface"]["kt"]) / float(m["interface"]["kn"]),
                     "G_c_model": float(m["interface"]["G_c"]),
                     **{k: v for k, v in r["summary"].items() if not isinstance(v, (list, dict))}})
    table = pd.DataFrame(rows)
    save_table(table, out / "runs")
    result: dict = {"runs": len(table), "test": test, "left_out": left_out or []}
    if test == "fracture":
        keys, values = ["G_c"], ["G_released", "G_break", "tensile_strength"]
    else:
        keys, values = ["kt_over_kn", "kn", "cell_size"], ["B", "G", "E", "nu", "B_reduced", "G_reduced"]
    points = table.groupby(keys)[values].agg(["mean", "std"])
    points.columns = [f"{a}_{b}" for a, b in points.columns]
    points = points.reset_index()
    save_table(points, out / ("fracture" if test == "fracture" else "moduli"))
    if test == "fracture" and len(points) >= 2:
        # proportionality G_released = a G_c (through the origin), and its largest misfit
        x, y = points.G_c.to_numpy(), points.G_released_mean.to_numpy()
        a = float(np.sum(x * y) / np.sum(x * x))
        result.update(G_released_over_Gc_slope=a, G_released_misfit=float(np.max(np.abs(y - a * x) / y)))
        if len(points) >= 3:  # a line with an intercept needs a third point for its errors
            slope, se, icpt = linear_fit(x, y)
            result.update(G_released_slope=slope, G_released_slope_se=se, G_released_intercept=icpt)
    guard = PlotGuard()
    png = out / "plots" / f"{'fracture' if test == 'fracture' else 'moduli'}_curves.png"
    if plots:
        guard.draw("curves", png, plot_curves, table, keys, values, png)
    clear_report(out)
    rep = Report(f"BCM block {test}: calibration curves", f"{len(table)} runs")
    rep.values({k: v for k, v in result.items() if not isinstance(v, list)}, "fits")
    rep.table(points, "per parameter set (mean and standard deviation over runs)")
    if plots and not guard.failed:
        rep.figure(png, "measures against the parameters that vary")
    write_report(rep, out)
    return result


def plot_curves(table: pd.DataFrame, keys: list[str], values: list[str], path: Path) -> None:
    import matplotlib.pyplot as plt  # noqa: PLC0415
    from runfiles.atomic import atomic_save  # noqa: PLC0415

    varying = [k for k in keys if table[k].nunique() > 1] or keys[:1]
    fig, axes = plt.subplots(len(varying), len(values), figsize=(3.0 * len(values), 2.8 * len(varying)), dpi=120,
                             squeeze=False)
    for row, key in zip(axes, varying):
        for ax, val in zip(row, values):
            ax.plot(table[key], table[val], "o")
            ax.set(xlabel=key, ylabel=val)
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p))
    plt.close(fig)
