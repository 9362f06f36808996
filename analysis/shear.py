"""Measures of a BPM shear run (SPEC 2.5) from its run directory: tables, summary, plots, report
(`ShearAnalysis`)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Iterator

import numpy as np
import pandas as pd

from analysis.completeness import RunRefused
from analysis.dumps import AtomFrame, DumpError, LocalFrame, bond_pairs, read_atom_dump, read_local_dump
from analysis.grain_table import frame_grains
from analysis.pictures import render_particles_2d, render_particles_3d
from analysis.plots import plot_nm, plot_stress
from analysis.powerlaw import MIN_FIT_GRAINS, exponent_flag, grains_fitted
from analysis.report import Report, provenance_line
from analysis.run_analysis import RunAnalysis
from analysis.statistics import SMALL_GRAIN_CUT, fit_grain_tau, frame_measures, mass_distribution
from analysis.stress import N_BLOCKS, STRESS_WINDOW, inertial_number, stress_measures, stress_windows
from analysis.tracking import lineage_table
from runfiles.records import SHEAR_RECORD, read_record


def read_thermo(path: Path) -> pd.DataFrame:
    """The `fix print` record of a shear run (one row per record, columns by the file's title;
    runfiles/records.py SHEAR_RECORD)."""
    return read_record(path, SHEAR_RECORD.names)


class ShearAnalysis(RunAnalysis):
    """Tables, plots, summary and report of a shear run: the stress series and its windows,
    then per snapshot (one frame each) the grains, N(M), its power-law fit and the frame's
    measures, and the grains' lineage between snapshots.

    Cut short: the snapshots before the first missing or truncated one are analysed, what was
    left out is listed in the warnings, and the summary is flagged; refused when not even the
    first snapshot can be read."""

    summary_tail = ("plots_failed", "warnings")  # the order shear summaries have always had

    def _prepare(self) -> None:
        model = self.cfg["model"]
        self.dim = int(model["dimension"])
        self.system = json.loads((self.run_dir / "system.json").read_text())
        self.snaps = json.loads((self.run_dir / "snapshots.json").read_text())
        self.n_atoms = int(self.system["n_particles"])
        self.cut = SMALL_GRAIN_CUT[self.dim]
        self.thresholds = tuple(t for t in self.cfg["output"].get("count_above", ()) if t != self.cut)
        # Stress series.
        stress = stress_measures(read_thermo(self.run_dir / "thermo.dat"), self.dim)
        stress["density"] = self.n_atoms / stress["vol"]  # all masses m = 1
        stress["I"] = inertial_number(self.cfg["scenario"]["strain_rate"], self.system["mean_diameter"],
                                      stress["density"], stress["P"])
        self.stress = stress
        self.grain_rows, self.nm_rows, self.frame_rows, self.fit_rows, self.all_labels = [], [], [], [], []

    def _frames(self) -> Iterator[tuple[dict, AtomFrame, LocalFrame]]:
        """(snapshot, atoms, bonds) of each snapshot in order; a run cut short stops at the first
        one it cannot read (and self.snaps is cut there)."""
        snaps = self.snaps
        for k, snap in enumerate(snaps):
            try:
                atoms = read_atom_dump(self.run_dir / snap["atoms"])[-1]
                bonds = read_local_dump(self.run_dir / snap["bonds"])[-1]
            except (FileNotFoundError, DumpError) as exc:
                if not self.cut_short:
                    raise
                if k == 0:
                    raise RunRefused(f"the run did not finish and its first snapshot cannot be read ({exc}): "
                                     "nothing to analyse") from exc
                self.warnings.append(f"snapshots from strain {snap['strain']:g} on left out: {exc}")
                self.snaps = snaps[:k]
                return
            yield snap, atoms, bonds

    def _single_frame(self, frame: tuple[dict, AtomFrame, LocalFrame]) -> None:
        """Grains at one snapshot: labels, one row per grain, N(M), its fit, one row per frame."""
        snap, atoms, bonds = frame
        cut = self.cut
        labels, table = grains_of_frame(atoms, bonds, self.n_atoms, self.dim)
        masses = table["mass"].to_numpy()
        table.insert(0, "step", snap["step"])
        table.insert(0, "strain", snap["strain"])
        self.grain_rows.append(table)
        self.all_labels.append(labels)
        nm = mass_distribution(masses, m_min=cut)
        self.fit_rows.append(_fit_tau(masses, table["percolating"].to_numpy(), cut, snap))
        nm.insert(0, "strain", snap["strain"])
        self.nm_rows.append(nm)
        self.frame_rows.append({"strain": snap["strain"], "step": snap["step"],
                                "intact_bonds": int(bonds_intact(bonds).sum()),
                                **frame_measures(masses, table["percolating"], cut, self.thresholds)})

    def _conclude(self) -> None:
        model, scen, snaps, stress = self.cfg["model"], self.cfg["scenario"], self.snaps, self.stress
        cut, fit_rows, frame_rows = self.cut, self.fit_rows, self.frame_rows
        grains = pd.concat(self.grain_rows, ignore_index=True)
        nm_all = pd.concat(self.nm_rows, ignore_index=True)
        frames = pd.DataFrame(frame_rows)
        fits = pd.DataFrame(fit_rows)
        tracking = lineage_table(self.all_labels)
        strain_of = dict(enumerate(s["strain"] for s in snaps))
        tracking.insert(1, "strain_parent", tracking["frame"].map(lambda k: strain_of[k - 1]))
        tracking.insert(2, "strain_child", tracking["frame"].map(strain_of))

        # mu, P and sqrt(J2) averaged over strain windows, the last one the summary's (steady flow)
        windows = stress_windows(stress)
        final_window = windows.iloc[-1] if len(windows) else None
        self.results.tables.update(stress=stress, stress_windows=windows, grains=grains, nm=nm_all, frames=frames,
                                   nm_fits=fits, tracking=tracking)
        self.title = f"BPM {self.dim}D, L = {model['L']:g}, edot = {scen['strain_rate']:g}, k_A = {model['k_A']:g}"
        self.nm_all, self.frames, self.fits = nm_all, frames, fits

        last = stress.iloc[-1]
        if self.cut_short:
            self.cut_short_note = (f"the run did not finish: measured on its snapshots up to strain "
                                   f"{snaps[-1]['strain']:g} and its stress record up to strain {float(last.strain):g}")
        self.results.summary = {
            "n_particles": self.n_atoms,
            "bonds_per_particle": self.system["bonds_per_particle"],
            "angles_per_particle": self.system["angles_per_particle"],
            "final_strain": float(last.strain),
            "bonds_broken": int(last.bonds_broken),
            "angles_broken": int(last.angles_broken),
            "grains_at_strain": {f"{r['strain']:g}": r["n_grains"] for r in frame_rows},
            f"grains_M>={cut}_at_strain": {f"{r['strain']:g}": r[f"n_grains_M>={cut}"] for r in frame_rows},
            **_window_summary(final_window),
            # one instantaneous record, for reference only: mu_mean is the measure
            "mu_last_record": float(last.mu) if np.isfinite(last.mu) else None,
            "tau_final": fit_rows[-1]["tau"], "tau_final_sigma": fit_rows[-1]["sigma"],
            "tau_final_flag": fit_rows[-1]["tau_flag"],
        }

    def _plot(self) -> None:
        title, last_fit = self.title, self.fit_rows[-1]
        # a flagged fit is no result: no slope drawn through the data
        self.draw("nm", plot_nm, self.nm_all[self.nm_all.strain > 0], self.png("nm"), title,
                  fit=None if last_fit["tau_flag"] else last_fit)
        self.draw("stress", plot_stress, self.stress, self.png("stress"), title)
        self.draw("grains", _picture, self.run_dir, self.snaps[-1], self.all_labels[-1], self.dim, self.system,
                  f"{title}, strain {self.snaps[-1]['strain']:g}")

    def _report(self) -> Report:
        return shear_report(self.run_dir, self.cfg, self.results.summary, self.frames, self.fits, self.title)


def _window_summary(window) -> dict:
    """Summary entries of the last strain window (analysis.stress.stress_windows): the means of
    mu, P and sqrt(J2) over it and their block-average standard errors."""
    keys = {"stress_window": None, "stress_window_records": 0}
    for col in ("mu", "P", "sqrtJ2"):
        keys.update({f"{col}_mean": None, f"{col}_se": None})
    if window is None:
        return keys
    keys.update({"stress_window": [float(window.strain_lo), float(window.strain_hi)],
                 "stress_window_records": int(window.n),
                 "stress_window_rule": (f"records with strain in ({window.strain_lo:.4g}, {window.strain_hi:.4g}], the "
                                        f"last {STRESS_WINDOW:.0%} of the strain reached; standard errors from "
                                        f"{N_BLOCKS} block means")})
    for col in ("mu", "P", "sqrtJ2"):
        mean, se = window[f"{col}_mean"], window[f"{col}_se"]
        keys[f"{col}_mean"] = None if mean is None or not np.isfinite(mean) else float(mean)
        keys[f"{col}_se"] = None if se is None or not np.isfinite(se) else float(se)
    return keys


def bonds_intact(bonds: LocalFrame) -> np.ndarray:
    """Intact-bond mask of a bond snapshot (type > 0; broken bonds are written with type 0)."""
    return bond_pairs(bonds)[1] > 0


def grains_of_frame(atoms: AtomFrame, bonds: LocalFrame, n_atoms: int, dim: int) -> tuple[np.ndarray, pd.DataFrame]:
    """Grain label per atom (ordered by atom id) and the grain table of one snapshot of a run
    (analysis.grain_table.frame_grains), checking that it holds the run's atoms 1..n_atoms."""
    if len(atoms.ids) != n_atoms or atoms.ids[0] != 1 or atoms.ids[-1] != n_atoms:
        raise ValueError(f"atom dump at step {atoms.timestep} holds ids {atoms.ids[0]}..{atoms.ids[-1]} "
                         f"({len(atoms.ids)} atoms), expected 1..{n_atoms}")
    return frame_grains(atoms, bonds, dim)


def shear_report(run_dir: Path, cfg: dict, summary: dict, frames: pd.DataFrame, fits: pd.DataFrame,
                 title: str) -> Report:
    """The one-page report of a shear run."""
    rep = Report(f"{cfg['name']}: {title}", provenance_line(run_dir))
    rep.values({k: v for k, v in summary.items() if not isinstance(v, (dict, list))}, "summary (LJ units: a, m, u)")
    if summary.get("stress_window_rule"):
        rep.text(f"mu_mean, P_mean and sqrtJ2_mean (± *_se): {summary['stress_window_rule']}; every window in "
                 "results/stress_windows.")
    for fail in summary.get("plots_failed", []):
        rep.text(f"Figure {fail['plot']} failed ({fail['error']}); the analysis is complete without it.")
    if summary.get("tau_final_flag"):
        rep.text(f"Warning: tau_final ({summary['tau_final']}) is not a result: {summary['tau_final_flag']}.")
    rep.figure(run_dir / "plots" / "nm.png", "N(M) at the measure strains with the discrete MLE slope")
    rep.figure(run_dir / "plots" / "stress.png", "shear stress, pressure, stress ratio and inertial number against strain")
    rep.figure(run_dir / "plots" / "grains.png", "particles coloured by grain at the last strain")
    rep.table(frames, "one row per snapshot (moments M_n = sum over grains of M^n)")
    rep.table(fits, "power-law fits of N(M): discrete maximum likelihood over the n grains with M >= cut, "
                     "the largest finite grain (the remnant) left out, the law truncated at xmax; a row with a "
                     "tau_flag is not a result (analysis.powerlaw.exponent_flag: tau in (1, 3], n >= "
                     f"{MIN_FIT_GRAINS})")
    return rep


N_BOOTSTRAP = 200  # resamples behind the bootstrap uncertainty of tau (seeded: tables are reproducible)


def _fit_tau(masses: np.ndarray, percolating: np.ndarray, cut: int, snap: dict) -> dict:
    """Discrete maximum-likelihood exponent of N(M) ~ M^-tau (statistics.fit_grain_tau: grains
    M >= cut but the largest finite one, the law truncated at xmax, the largest fitted), with
    its asymptotic (sigma) and bootstrap (sigma_bootstrap) standard errors; n: grains fitted;
    tau_flag: why the fit is not a result (analysis.powerlaw.exponent_flag: tau outside
    (1, 3], fewer than MIN_FIT_GRAINS grains), None when it is one."""
    fit = fit_grain_tau(masses, cut, percolating, n_bootstrap=N_BOOTSTRAP, min_grains=MIN_FIT_GRAINS)
    n = fit.n if fit is not None else grains_fitted(masses, cut, percolating)  # for the flag
    return {"strain": snap["strain"], "step": snap["step"], "xmin": cut, "xmax": None if fit is None else fit.xmax,
            "n": 0 if fit is None else fit.n, "tau": None if fit is None else float(fit.tau),
            "sigma": None if fit is None else float(fit.sigma),
            "sigma_bootstrap": None if fit is None else float(fit.sigma_bootstrap),
            "tau_flag": exponent_flag(None if fit is None else float(fit.tau), n)}


def _picture(run_dir: Path, snap: dict, labels: np.ndarray, dim: int, system: dict, title: str) -> None:
    """Particles of the last snapshot coloured by grain (largest grain first in colour order)."""
    frame = read_atom_dump(run_dir / snap["atoms"])[-1]
    diam = {int(k): v for k, v in system["type_diameters"].items()}
    radii = 0.5 * np.array([diam[int(t)] for t in frame.types])
    lab = labels[frame.ids - 1]
    if dim == 2:
        render_particles_2d(frame.positions, radii, lab, frame.box, run_dir / "plots" / "grains.png", title)
    else:
        render_particles_3d(frame.positions, lab, run_dir / "plots" / "grains.png", title)
