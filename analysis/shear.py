"""Measures of a BPM shear run (SPEC 2.5) from its run directory: tables, summary, plots."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.dumps import AtomFrame, DumpError, LocalFrame, bond_pairs, read_atom_dump, read_local_dump
from analysis.grain_table import frame_grains
from analysis.pictures import render_particles_2d, render_particles_3d
from analysis.plots import PlotGuard, plot_nm, plot_stress
from analysis.powerlaw import MIN_FIT_GRAINS, exponent_flag, grains_fitted
from analysis.report import Report, clear_report, provenance_line, write_report
from analysis.statistics import SMALL_GRAIN_CUT, fit_grain_tau, frame_measures, mass_distribution
from analysis.stress import N_BLOCKS, STRESS_WINDOW, inertial_number, stress_measures, stress_windows
from analysis.tables import save_table
from analysis.tracking import lineage_table
from runfiles.records import SHEAR_RECORD, read_record

def read_thermo(path: Path) -> pd.DataFrame:
    """The `fix print` record of a shear run (one row per record, columns by the file's title;
    runfiles/records.py SHEAR_RECORD)."""
    return read_record(path, SHEAR_RECORD.names)


def analyse_shear(run_dir: Path, cfg: dict, plots: bool = True, partial: bool = False) -> dict:
    """Tables, plots and summary figures of a finished shear run; returns the summary dict.

    cfg is the resolved config as a plain mapping (config.resolved.yaml). partial=True (a run
    that did not finish) analyses the snapshots before the first missing or truncated one and
    lists what was left out under "warnings" in the summary.
    """
    run_dir = Path(run_dir)
    clear_report(run_dir)  # written last: no report = the analysis did not finish
    model, scen = cfg["model"], cfg["scenario"]
    dim = int(model["dimension"])
    system = json.loads((run_dir / "system.json").read_text())
    snaps = json.loads((run_dir / "snapshots.json").read_text())
    n_atoms = int(system["n_particles"])
    cut = SMALL_GRAIN_CUT[dim]
    thresholds = tuple(t for t in cfg["output"].get("count_above", ()) if t != cut)

    # Stress series.
    stress = stress_measures(read_thermo(run_dir / "thermo.dat"), dim)
    stress["density"] = n_atoms / stress["vol"]  # all masses m = 1
    stress["I"] = inertial_number(scen["strain_rate"], system["mean_diameter"], stress["density"], stress["P"])

    # Grains at each snapshot: labels, one row per grain, N(M), one row per frame.
    grain_rows, nm_rows, frame_rows, fit_rows, all_labels = [], [], [], [], []
    warnings_: list[str] = []
    for k, snap in enumerate(snaps):
        try:
            atoms = read_atom_dump(run_dir / snap["atoms"])[-1]
            bonds = read_local_dump(run_dir / snap["bonds"])[-1]
        except (FileNotFoundError, DumpError) as exc:
            if not partial or k == 0:
                raise
            warnings_.append(f"snapshots from strain {snap['strain']:g} on left out: {exc}")
            snaps = snaps[:k]
            break
        labels, table = grains_of_frame(atoms, bonds, n_atoms, dim)
        masses = table["mass"].to_numpy()
        table.insert(0, "step", snap["step"])
        table.insert(0, "strain", snap["strain"])
        grain_rows.append(table)
        all_labels.append(labels)
        nm = mass_distribution(masses, m_min=cut)
        fit_rows.append(_fit_tau(masses, table["percolating"].to_numpy(), cut, snap))
        nm.insert(0, "strain", snap["strain"])
        nm_rows.append(nm)
        frame_rows.append({"strain": snap["strain"], "step": snap["step"], "intact_bonds": int(bonds_intact(bonds).sum()),
                           **frame_measures(masses, table["percolating"], cut, thresholds)})
    grains = pd.concat(grain_rows, ignore_index=True)
    nm_all = pd.concat(nm_rows, ignore_index=True)
    frames = pd.DataFrame(frame_rows)
    fits = pd.DataFrame(fit_rows)
    tracking = lineage_table(all_labels)
    strain_of = dict(enumerate(s["strain"] for s in snaps))
    tracking.insert(1, "strain_parent", tracking["frame"].map(lambda k: strain_of[k - 1]))
    tracking.insert(2, "strain_child", tracking["frame"].map(strain_of))

    # mu, P and sqrt(J2) averaged over strain windows, the last one the summary's (steady flow)
    windows = stress_windows(stress)
    final_window = windows.iloc[-1] if len(windows) else None

    res = run_dir / "results"
    save_table(stress, res / "stress")
    save_table(windows, res / "stress_windows")
    save_table(grains, res / "grains")
    save_table(nm_all, res / "nm")
    save_table(frames, res / "frames")
    save_table(fits, res / "nm_fits")
    save_table(tracking, res / "tracking")
    title = f"BPM {dim}D, L = {model['L']:g}, edot = {scen['strain_rate']:g}, k_A = {model['k_A']:g}"
    guard = PlotGuard()  # a figure that fails is listed in plots_failed; the analysis goes on
    if plots:
        plot_dir = run_dir / "plots"
        # a flagged fit is no result: no slope drawn through the data
        guard.draw("nm", plot_dir / "nm.png", plot_nm, nm_all[nm_all.strain > 0], plot_dir / "nm.png", title,
                   fit=None if fit_rows[-1]["tau_flag"] else fit_rows[-1])
        guard.draw("stress", plot_dir / "stress.png", plot_stress, stress, plot_dir / "stress.png", title)
        guard.draw("grains", plot_dir / "grains.png", _picture, run_dir, snaps[-1], all_labels[-1], dim, system,
                   f"{title}, strain {snaps[-1]['strain']:g}")

    last = stress.iloc[-1]
    summary = {
        "n_particles": n_atoms,
        "bonds_per_particle": system["bonds_per_particle"],
        "angles_per_particle": system["angles_per_particle"],
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
        "plots_failed": guard.failed,
        **({"warnings": warnings_} if warnings_ else {}),
    }
    write_report(shear_report(run_dir, cfg, summary, frames, fits, title), run_dir)
    return summary


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
