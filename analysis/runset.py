"""Analysis of a set of finished runs (a sweep, or run directories named on the command line):
the scaling tools of SPEC 2.5 for BPM shear runs and the sweep-level measures of SPEC 1.5 for
BCM impacts, written as tables, plots and a one-page report.

Only the runs' result tables are read (never the dumps), so a set is analysed in seconds and
a run re-analysed by `driver post` feeds the set with its new tables.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from analysis.plots import plot_curves, plot_histograms, plot_mass_pdf, plot_measures
from analysis.report import Report, clear_report, write_report
from analysis.scaling import (Curve, finite_rate_rescale, finite_size_rescale, fit_finite_rate, fit_finite_size,
                              fit_growth, fit_loglog, fit_moment_collapse, fit_threshold_power, moment_curves, moment_rescale,
                              omega_0, omega_1, power_law, threshold_power)
from analysis.statistics import (SMALL_GRAIN_CUT, fit_grain_tau, fit_mass_ratio_law, histogram_table,
                                 normalised_mass_distribution)
from analysis.tables import save_table


# Search ranges of the collapse exponents (alpha, gamma), (nu alpha,), (alpha, nu).
FINITE_SIZE_BOUNDS = [(0.1, 4.0), (-4.0, 10.0)]
FINITE_RATE_BOUNDS = [(0.01, 3.0)]
MOMENT_BOUNDS = [(0.1, 4.0), (0.1, 5.0)]
MIN_TRUSTED_TERMS = 10  # fewer point comparisons than this: a collapse (and its bootstrap) is flagged


class RunSetError(ValueError):
    """The runs named cannot be analysed together (none finished, or different kinds)."""


# ---------------------------------------------------------------------------------------
# Finding and loading runs


def find_runs(paths: list[Path]) -> list[Path]:
    """Finished run directories among `paths`: a run directory itself, or a directory holding
    run directories (a sweep), searched one level down. Unfinished runs are skipped."""
    found: list[Path] = []
    for p in map(Path, paths):
        if (p / "config.resolved.yaml").exists():
            cands = [p]
        elif p.is_dir():
            cands = sorted(q for q in p.iterdir() if (q / "config.resolved.yaml").exists())
        else:
            raise RunSetError(f"{p}: neither a run directory nor a directory of runs")
        found += [q for q in cands if _finished(q)]
    if not found:
        raise RunSetError(f"no finished runs in {', '.join(map(str, paths))}")
    return list(dict.fromkeys(found))


def _finished(run_dir: Path) -> bool:
    status = run_dir / "status.json"
    return (status.exists() and json.loads(status.read_text()).get("state") == "finished"
            and (run_dir / "results" / "summary.json").exists())


def load_runs(run_dirs: list[Path]) -> list[dict]:
    """[{dir, cfg, summary}] of each run; all must share model and scenario kinds."""
    runs = [{"dir": d, "cfg": yaml.safe_load((d / "config.resolved.yaml").read_text()),
             "summary": json.loads((d / "results" / "summary.json").read_text())} for d in run_dirs]
    kinds = {(r["cfg"]["model"]["kind"], r["cfg"]["scenario"]["kind"]) for r in runs}
    if len(kinds) > 1:
        raise RunSetError(f"runs of different kinds cannot be analysed as one set: {sorted(kinds)}")
    return runs


def analyse_set(paths: list[Path], out: Path, plots: bool = True, strain: float | None = None,
                n_bootstrap: int = 100) -> dict:
    """Tables, plots and report of a set of runs into `out`; returns the fitted figures."""
    runs = load_runs(find_runs(paths))
    out = Path(out)
    clear_report(out)
    kind = runs[0]["cfg"]["scenario"]["kind"]
    if kind == "shear":
        return analyse_shear_set(runs, out, plots, strain, n_bootstrap)
    return analyse_impact_set(runs, out, plots)


# ---------------------------------------------------------------------------------------
# BPM shear: SPEC 2.5 scaling


def analyse_shear_set(runs: list[dict], out: Path, plots: bool = True, strain: float | None = None,
                      n_bootstrap: int = 100) -> dict:
    """Growth exponent phi per run; tau, and the finite-size (alpha, gamma), finite-rate
    (nu alpha) and second-moment (alpha, nu) collapses of SPEC 2.5 wherever the set varies L
    and/or edot, at one strain (default: the largest measure strain all runs reached)."""
    dims = {int(r["cfg"]["model"]["dimension"]) for r in runs}
    if len(dims) > 1:
        raise RunSetError("2D and 3D runs cannot be scaled together")
    d = dims.pop()
    cut = SMALL_GRAIN_CUT[d]
    table = pd.DataFrame([{"run": r["cfg"]["name"], "run_dir": str(r["dir"]), "L": float(r["cfg"]["model"]["L"]),
                           "edot": float(r["cfg"]["scenario"]["strain_rate"]), "k_A": r["cfg"]["model"]["k_A"],
                           "lambda_c": r["cfg"]["model"]["lambda_c"], "seed": r["cfg"]["seed"],
                           **{k: v for k, v in r["summary"].items() if not isinstance(v, (dict, list))}}
                          for r in runs])
    # runs are keyed by their directory: names repeat across sweeps made from one base config
    frames = {str(r["dir"]): pd.read_parquet(r["dir"] / "results" / "frames.parquet") for r in runs}
    if strain is None:
        common = set.intersection(*(set(f.strain.round(12)) for f in frames.values()))
        if not common:
            raise RunSetError("the runs share no measure strain: pass --strain")
        strain = max(common)
    fits: list[dict] = []

    # growth N(M >= cut) ~ eps^phi, per run
    for name, f in frames.items():
        try:
            g = fit_growth(f.strain, f[f"n_grains_M>={cut}"])
            fits.append({"fit": "growth N ~ eps^phi", "runs": name, "parameter": "phi", "value": g.exponent,
                         "sigma": g.sigma_exponent, "quality": 1 - g.r2, "method": f"log-log least squares, {g.n} strains"})
        except ValueError as exc:
            fits.append({"fit": "growth N ~ eps^phi", "runs": name, "parameter": "-", "value": np.nan,
                         "sigma": np.nan, "quality": np.nan, "method": f"not fitted: {exc}"})

    # N(M) at the strain, and tau from the largest (then slowest) run's grains
    nm, masses = [], {}
    for r in runs:
        key = str(r["dir"])
        t = pd.read_parquet(r["dir"] / "results" / "nm.parquet")
        t = t[np.isclose(t.strain, strain)]
        if t.empty:
            raise RunSetError(f"{r['dir']}: no N(M) at strain {strain:g}")
        nm.append(t.assign(run=r["cfg"]["name"], run_dir=key, L=float(r["cfg"]["model"]["L"]),
                           edot=float(r["cfg"]["scenario"]["strain_rate"])))
        g = pd.read_parquet(r["dir"] / "results" / "grains.parquet")
        g = g[np.isclose(g.strain, strain)]
        masses[key] = (g["mass"].to_numpy(), g["percolating"].to_numpy() if "percolating" in g else None)
    nm = pd.concat(nm, ignore_index=True)
    ref = table.sort_values(["L", "edot"], ascending=[False, True]).iloc[0]["run_dir"]
    tau, sigma_tau = None, None
    ref_masses, ref_percolating = masses[ref]
    pl = fit_grain_tau(ref_masses, cut, ref_percolating, n_bootstrap=n_bootstrap)
    if pl is not None:
        tau, sigma_tau = pl.tau, max(pl.sigma, pl.sigma_bootstrap or 0.0)
        fits.append({"fit": f"N(M) ~ M^-tau at strain {strain:g}", "runs": ref, "parameter": "tau", "value": tau,
                     "sigma": sigma_tau, "quality": pl.ks,
                     "method": f"{pl.method}; range [{cut}, {pl.xmax:g}]"})
    curves = [Curve(t.m_mean.to_numpy(), t.N.to_numpy(), {"L": float(t.L.iloc[0]), "edot": float(t.edot.iloc[0])},
                    1.0 / np.sqrt(np.maximum(t["count"].to_numpy(dtype=float), 1)))
              for _, t in nm.groupby("run_dir", sort=False)]
    # fewer than 2 resamples cannot give a spread: errors from the curvature of the cost instead
    kw = {"n_bootstrap": n_bootstrap, "seed": 0} if n_bootstrap >= 2 else {"uncertainty": "curvature"}
    collapses = {}
    Ls, rates = sorted(table.L.unique()), sorted(table.edot.unique())
    if len(Ls) >= 2 and tau is not None:
        for rate in rates:
            sel = [c for c in curves if c.params["edot"] == rate]
            if len({c.params["L"] for c in sel}) < 2:
                continue
            _try_collapse(fits, collapses, f"finite size at edot {rate:g}", sel,
                          lambda cs: fit_finite_size(cs, tau, sigma_tau=sigma_tau, bounds=FINITE_SIZE_BOUNDS,
                                                     n_grid=25, **kw), FINITE_SIZE_BOUNDS,
                          lambda c, p: finite_size_rescale(c.x, c.y, c.params["L"], p[0], p[1], tau),
                          r"$M / L^\alpha$", r"$N\,L^{\alpha\tau-\gamma}$")
    if len(rates) >= 2:
        _try_collapse(fits, collapses, "finite rate", curves,
                      lambda cs: fit_finite_rate(cs, d, bounds=FINITE_RATE_BOUNDS, n_grid=60, **kw),
                      FINITE_RATE_BOUNDS,
                      lambda c, p: finite_rate_rescale(c.x, c.y, c.params["L"], c.params["edot"], p[0], d),
                      r"$M\,\dot\varepsilon^{\nu\alpha}$", r"$N / (L^d \dot\varepsilon^{2\nu\alpha})$")
    m2 = table.assign(M2=[frames[d].loc[np.isclose(frames[d].strain, strain), "M2"].iloc[0] for d in table.run_dir])
    if len(Ls) >= 2 and m2.groupby("L").edot.nunique().min() >= 2:
        _try_collapse(fits, collapses, "second moment", moment_curves(m2.L, m2.edot, m2.M2),
                      lambda cs: fit_moment_collapse(cs, d, bounds=MOMENT_BOUNDS, n_grid=25, **kw), MOMENT_BOUNDS,
                      lambda c, p: moment_rescale(c.x, c.y, c.params["L"], p[0], p[1], d),
                      r"$\dot\varepsilon L^{1/\nu}$", r"$\langle M^2\rangle / L^{d+\alpha}$",
                      runs=f"{len(m2)} runs ({m2.L.nunique()} curves, one per L)")

    fits_df = pd.DataFrame(fits, columns=["fit", "runs", "parameter", "value", "sigma", "quality", "method"])
    save_table(table, out / "runs")
    save_table(nm, out / "nm")
    save_table(fits_df, out / "fits")
    title = f"BPM {d}D shear, {len(runs)} runs, strain {strain:g}"
    if plots:
        label = [f"L = {c.params['L']:g}, edot = {c.params['edot']:g}" for c in curves]
        plot_curves([(lb, c.x, c.y) for lb, c in zip(label, curves)], out / "plots" / "nm.png",
                    "grain mass $M$ [m]", "$N(M)$ [grains per unit mass, 1/m]", title)
        plot_curves([(Path(d).name, f.strain, f[f"n_grains_M>={cut}"]) for d, f in frames.items()],
                    out / "plots" / "growth.png",
                    r"true strain $\varepsilon$ [-]", f"grains with $M \\geq {cut}$ [-]", title)
        for key, (fit, sel, rescale, xl, yl) in collapses.items():
            p = list(fit.params.values())
            pts = [(f"L = {c.params['L']:g}, edot = {c.params.get('edot', float('nan')):g}", *rescale(c, p)) for c in sel]
            note = ", ".join(f"{k} = {v:.3g} ± {fit.sigma[k]:.2g}" for k, v in fit.params.items())
            plot_curves(pts, out / "plots" / f"collapse_{key.replace(' ', '_')}.png", xl, yl, f"{title}: {key}", note)
    rep = Report(f"Shear set: {title}", f"{len(runs)} runs: " + ", ".join(str(r["dir"]) for r in runs))
    rep.table(fits_df, "fitted exponents (SPEC 2.5) with standard errors; quality: collapse cost (near 1 for a "
                       "good collapse with Poisson errors), KS distance for tau, 1 - R^2 for growth")
    shown = ["run", "L", "edot", "k_A", "seed", "n_particles", "bonds_broken", "final_mu", "tau_final",
             "tau_final_sigma"]
    rep.table(table[[c for c in shown if c in table]], "runs")
    for png, cap in [("nm.png", "N(M) of every run"), ("growth.png", "grains above the cut against strain")]:
        rep.figure(out / "plots" / png, cap)
    for key in collapses:
        rep.figure(out / "plots" / f"collapse_{key.replace(' ', '_')}.png", f"{key} collapse")
    if not collapses:
        rep.text("No collapse: the set needs two or more sizes L (finite size, with tau fitted) or rates edot "
                 "(finite rate); the second moment needs both.")
    write_report(rep, out)
    return {"strain": strain, "fits": fits_df.to_dict(orient="records")}


def _try_collapse(fits: list, collapses: dict, key: str, curves: list[Curve], fitter, bounds, rescale,
                  xlabel: str, ylabel: str, runs: str | None = None) -> None:
    """Fit one collapse and keep what its plot needs; curves that do not overlap are reported
    in the fits table, not fatal, and an exponent at the edge of its search range is flagged
    (the data do not constrain it). runs: what the curves are made of, for the table
    (default: one run per curve)."""
    runs = runs or f"{len(curves)} runs"
    try:
        fit = fitter(curves)
    except ValueError as exc:
        fits.append({"fit": f"{key} collapse", "runs": runs, "parameter": "-", "value": np.nan,
                     "sigma": np.nan, "quality": np.nan, "method": f"not fitted: {exc}"})
        return
    for (k, v), (lo, hi) in zip(fit.params.items(), bounds):
        edge = "; AT THE EDGE of its range [{:g}, {:g}]: not constrained".format(lo, hi) if min(
            abs(v - lo), abs(v - hi)) < 1e-3 * (hi - lo) else ""
        few = (f"; ONLY {fit.n_terms} point comparisons: indicative, the error understates it"
               if fit.n_terms < MIN_TRUSTED_TERMS else f"; {fit.n_terms} point comparisons")
        fits.append({"fit": f"{key} collapse", "runs": runs, "parameter": k, "value": v,
                     "sigma": fit.sigma[k], "quality": fit.cost, "method": f"{fit.method}{few}{edge}"})
    collapses[key] = (fit, curves, rescale, xlabel, ylabel)


# ---------------------------------------------------------------------------------------
# BCM impact: SPEC 1.5 sweep level

MEASURES = ["omega", "D_w", "eta", "e_k2", "chi", "W_c_over_W_s", "n_fragments", "n_fragments_multi_cell",
            "largest_fragment_mass_fraction", "mass_tau", "shape_shape_factor_mean", "balance_residual"]


def analyse_impact_set(runs: list[dict], out: Path, plots: bool = True) -> dict:
    """Measures against v and omega per G_c (mean and standard deviation over tessellations),
    omega_0 and omega_1 located from the data, regime fits (D_w = A (omega - omega_0)^beta above
    omega_0; eta and e_k^2 as power laws of omega above omega_1), p(S_f) over all runs and p(m)
    per G_c with its power-law fit."""
    table = pd.DataFrame([{"run": r["cfg"]["name"], "run_dir": str(r["dir"]),
                           "G_c": float(r["cfg"]["model"]["interface"]["G_c"]),
                           "velocity": float(r["cfg"]["scenario"]["velocity"]), "seed": r["cfg"]["seed"],
                           "n_cells": r["cfg"]["model"]["n_cells"],
                           **{k: v for k, v in r["summary"].items() if not isinstance(v, (dict, list))}}
                          for r in runs])
    cols = [c for c in MEASURES if c in table]
    grouped = table.groupby(["G_c", "velocity"], sort=True)
    points = grouped[cols].agg(["mean", "std"])
    points.columns = [f"{a}_{b}" for a, b in points.columns]
    points = points.reset_index()
    points.insert(2, "n_runs", grouped.size().to_numpy())

    thresholds, fits, fit_fns = {}, [], {}
    for gc, grp in table.groupby("G_c", sort=True):
        # break-up: two or more fragments of two or more cells (single chipped cells, e.g. slivers, do not count)
        # bracketed between parameter points (velocities): tessellations of one point differ a little in omega
        w0 = omega_0(grp.omega, grp.D_w, groups=grp.velocity)
        w1 = omega_1(grp.omega, grp.n_fragments_multi_cell, groups=grp.velocity)
        thresholds[gc] = {"omega_0": w0.value, "omega_1": w1.value}
        for name, th in (("omega_0", w0), ("omega_1", w1)):
            fits.append({"G_c": gc, "fit": f"{name} (first {'cracks' if name == 'omega_0' else 'break-up into multi-cell fragments'})",
                         "parameter": name, "value": th.value, "sigma": th.half_width, "n": len(grp),
                         "method": f"bracket [{th.lo:.4g}, {th.hi:.4g}] between velocities"})
        try:
            tf = fit_threshold_power(grp.omega, grp.D_w)
            fits += [{"G_c": gc, "fit": "D_w = A (omega - omega0)^beta", "parameter": p, "value": v, "sigma": s,
                      "n": tf.n, "method": tf.method}
                     for p, v, s in (("omega0", tf.omega0, tf.sigma_omega0), ("beta", tf.beta, tf.sigma_beta),
                                     ("A", tf.prefactor, tf.sigma_prefactor))]
            fit_fns[(gc, "D_w")] = (lambda w, tf=tf: threshold_power(w, tf.omega0, tf.beta, tf.prefactor),
                                    grp.omega.min(), grp.omega.max())
        except ValueError as exc:
            fits.append({"G_c": gc, "fit": "D_w = A (omega - omega0)^beta", "parameter": "-", "value": np.nan,
                         "sigma": np.nan, "n": len(grp), "method": f"not fitted: {exc}"})
        # every run of the parameter points from the first break-up (the point omega_1 found) on
        point_omega = grp.groupby("velocity").omega.transform("mean")
        broke = point_omega[grp.n_fragments_multi_cell > 1]
        above = grp[point_omega >= broke.min()] if len(broke) else grp.iloc[0:0]
        for col in ("eta", "e_k2"):
            try:
                pf = fit_loglog(above.omega, above[col])
                fits.append({"G_c": gc, "fit": f"{col} = A omega^b above omega_1", "parameter": "b",
                             "value": pf.exponent, "sigma": pf.sigma_exponent, "n": pf.n,
                             "method": "log-log least squares"})
                fit_fns[(gc, col)] = (lambda w, pf=pf: power_law(w, pf.prefactor, pf.exponent),
                                      above.omega.min(), above.omega.max())
            except ValueError as exc:
                fits.append({"G_c": gc, "fit": f"{col} = A omega^b above omega_1", "parameter": "-",
                             "value": np.nan, "sigma": np.nan, "n": len(above), "method": f"not fitted: {exc}"})

    # fragments of every run: p(S_f) pooled, p(m/m_max) per G_c
    frags = pd.concat([pd.read_parquet(r["dir"] / "results" / "fragments.parquet").assign(
        run_dir=str(r["dir"]), G_c=float(r["cfg"]["model"]["interface"]["G_c"])) for r in runs], ignore_index=True)
    frags["m_over_m_max"] = frags.mass / frags.groupby("run_dir").mass.transform("max")
    multi = frags[~frags.single_cell]
    sf = histogram_table(multi.shape_factor, bins=20) if len(multi) else pd.DataFrame()
    mass_tables, mass_fits = {}, {}
    for gc, grp in frags.groupby("G_c", sort=True):
        label = f"G_c = {gc:g} J/m²"
        mass_tables[label] = normalised_mass_distribution(grp.m_over_m_max.to_numpy())
        pl = fit_mass_ratio_law([g.mass.to_numpy() for _, g in grp.groupby("run_dir")], n_bootstrap=100)
        if pl is not None:
            mass_fits[label] = {"tau": pl.tau, "sigma": max(pl.sigma, pl.sigma_bootstrap or 0.0), "xmin": pl.xmin,
                                "xmax": 1.0}
            fits.append({"G_c": gc, "fit": "p(m/m_max) ~ (m/m_max)^-tau, all runs (largest of each left out)",
                         "parameter": "tau",
                         "value": pl.tau, "sigma": mass_fits[label]["sigma"], "n": pl.n,
                         "method": f"{pl.method}; range [{pl.xmin:.3g}, 1]"})
    fits_df = pd.DataFrame(fits, columns=["G_c", "fit", "parameter", "value", "sigma", "n", "method"])
    mass_pdf = pd.concat([t.assign(label=k) for k, t in mass_tables.items()], ignore_index=True)

    save_table(table, out / "runs")
    save_table(points, out / "points")
    save_table(fits_df, out / "fits")
    save_table(mass_pdf, out / "fragment_masses")
    if len(sf):
        save_table(sf, out / "shape_factor")
    title = f"BCM impacts, {len(runs)} runs"
    if plots:
        plot_measures(points, out / "plots" / "measures_vs_omega.png", "omega", thresholds, fit_fns, title)
        plot_measures(points, out / "plots" / "measures_vs_velocity.png", "velocity", title=title)
        plot_mass_pdf(mass_tables, out / "plots" / "fragment_masses.png", title, fits=mass_fits)
        if len(sf):
            plot_histograms({"fragments of two or more cells": sf}, out / "plots" / "shape_factor.png",
                            r"shape factor $S_f$ [-]", r"$p(S_f)$ [-]", title)
    rep = Report(f"Impact set: {title}", f"{len(runs)} runs: " + ", ".join(str(r["dir"]) for r in runs))
    rep.table(fits_df, "crossovers and regime fits per G_c (value ± standard error; omega brackets as half-widths)")
    rep.table(points[["G_c", "velocity", "n_runs", *[c for c in points.columns if c.endswith("_mean")]]],
              "measures per parameter point (means over tessellations; points.csv has the standard deviations)")
    rep.figure(out / "plots" / "measures_vs_omega.png", "measures against the damage potential omega")
    rep.figure(out / "plots" / "measures_vs_velocity.png", "measures against the impact velocity")
    rep.figure(out / "plots" / "fragment_masses.png", "fragment mass distributions per G_c")
    rep.figure(out / "plots" / "shape_factor.png", "distribution of the shape factor over all runs")
    write_report(rep, out)
    return {"thresholds": {f"{k:g}": v for k, v in thresholds.items()}, "fits": fits_df.to_dict(orient="records")}
