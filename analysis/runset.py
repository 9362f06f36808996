"""Analysis of a set of finished runs (a sweep, or run directories named on the command line):
the scaling tools of SPEC 2.5 for BPM shear runs and the sweep-level measures of SPEC 1.5 for
BCM impacts, written as tables, plots and a one-page report.

Which runs a set holds (survey_runs, load_runs) is decided here; which analysis a group of
runs gets, by the scenario registry (driver/sets.py), which passes each analysis the
parameters its runs are compared by (`params`: config mapping -> runs-table columns).

Only the runs' result tables are read (never the dumps), so a set is analysed in seconds and
a run re-analysed by `driver post` feeds the set with its new tables.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Callable, Iterable

import numpy as np
import pandas as pd
import yaml

from analysis.bcm_impact import ENERGY_CHANNELS
from analysis.plots import PlotGuard, plot_curves, plot_energy_split, plot_histograms, plot_mass_pdf, plot_measures
from analysis.report import Report, write_report
from analysis.scaling import (BREAKUP_FRACTION, Curve, Threshold, breakup_definitions, finite_rate_rescale,
                              finite_size_rescale, fit_finite_rate, fit_finite_size, fit_growth, fit_loglog,
                              fit_moment_collapse, fit_threshold_power, moment_curves, moment_rescale, omega_0, omega_1,
                              omega_1_largest, power_law, threshold_power)
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


#: the result tables a run's set analysis reads besides summary.json, from its config mapping
TablesOf = Callable[[dict], Iterable[str]]
#: the parameters a set compares runs by (columns of the runs table), from a config mapping
ParamsOf = Callable[[dict], dict]


def survey_runs(paths: list[Path], required: TablesOf | None = None) -> tuple[list[Path], list[dict]]:
    """The run directories among `paths` (a run directory itself, or a directory holding run
    directories, a sweep, searched one level down), split into those a set analysis can read
    (finished, with their summary and the result tables `required` names for their config)
    and those it leaves out, each as {run_dir, state, reason}."""
    finished: list[Path] = []
    left: dict[Path, dict] = {}
    for p in map(Path, paths):
        if (p / "config.resolved.yaml").exists():
            cands = [p]
        elif p.is_dir():
            cands = sorted(q for q in p.iterdir() if (q / "config.resolved.yaml").exists())
        else:
            raise RunSetError(f"{p}: neither a run directory nor a directory of runs")
        for q in cands:
            state, reason = _left_out_reason(q, required)
            if reason is None:
                finished.append(q)
            else:
                left[q] = {"run_dir": q, "state": state, "reason": reason}
    return list(dict.fromkeys(finished)), list(left.values())


def no_runs(paths: list[Path], left: list[dict]) -> RunSetError:
    why = "; ".join(f"{r['run_dir']}: {r['reason']}" for r in left[:10])
    return RunSetError(f"no finished runs in {', '.join(map(str, paths))}" + (f" ({why})" if why else ""))


def _left_out_reason(run_dir: Path, required: TablesOf | None) -> tuple[str, str | None]:
    """(state, why the run cannot enter a set analysis, or None when it can)."""
    status = run_dir / "status.json"
    if not status.exists():
        return "new", "no status.json: the run never started"
    try:
        st = json.loads(status.read_text())
    except (OSError, ValueError) as exc:
        return "unknown", f"status.json unreadable ({exc})"
    state = str(st.get("state", "unknown"))
    if state != "finished":
        where = f" in phase {st['phase']}" if st.get("phase") else ""
        error = f": {st['error']}" if st.get("error") else ""
        done = "; its LAMMPS part had finished (driver run RUN_DIR --resume analyses it)" if st.get("lammps_done") else ""
        return state, f"not finished: {state}{where}{error}{done}"
    summary = run_dir / "results" / "summary.json"
    try:
        json.loads(summary.read_text())
    except FileNotFoundError:
        return state, "finished, but results/summary.json is missing (driver post RUN_DIR rebuilds it)"
    except (OSError, ValueError) as exc:
        return state, f"results/summary.json unreadable ({exc})"
    try:
        tables = list(required(yaml.safe_load((run_dir / "config.resolved.yaml").read_text()))) if required else []
    except (OSError, KeyError, TypeError, ValueError, yaml.YAMLError) as exc:
        return state, f"config.resolved.yaml unreadable ({exc})"
    missing = [t for t in tables if not (run_dir / "results" / f"{t}.parquet").exists()]
    if missing:
        return state, (f"finished, but results/{', '.join(f'{t}.parquet' for t in missing)} missing "
                       "(driver post RUN_DIR rebuilds them)")
    return state, None


def load_runs(run_dirs: list[Path]) -> list[dict]:
    """[{dir, cfg, summary}] of each run."""
    return [{"dir": d, "cfg": yaml.safe_load((d / "config.resolved.yaml").read_text()),
             "summary": json.loads((d / "results" / "summary.json").read_text())} for d in run_dirs]


def check_breakup_fraction(breakup_fraction: float) -> None:
    if not 0 < breakup_fraction <= 1:
        raise RunSetError(f"break-up fraction {breakup_fraction:g}: must be in (0, 1]")


def _run_row(r: dict, params: ParamsOf) -> dict:
    """One included run: name, directory, parameters, the summary's scalar entries, and the
    figures its analysis failed to draw and its energy flags (lists in the summary)."""
    summ = r["summary"]
    return {"run": r["cfg"]["name"], "run_dir": str(r["dir"]), "included": True, "state": "finished", "left_out": "",
            **params(r["cfg"]),
            **{k: v for k, v in summ.items() if not isinstance(v, (dict, list))},
            "plots_failed": ", ".join(f["plot"] for f in summ.get("plots_failed", [])),
            **({"energy_flags": len(summ["energy_flags"])} if "energy_flags" in summ else {})}


def _left_out_rows(left: list[dict], params: ParamsOf) -> pd.DataFrame:
    """Rows of the runs table for the runs left out: name and parameters where the config
    reads, state and reason."""
    rows = []
    for r in left:
        row = {"run": Path(r["run_dir"]).name, "run_dir": str(r["run_dir"]), "included": False, "state": r["state"],
               "left_out": r["reason"]}
        try:
            cfg = yaml.safe_load((Path(r["run_dir"]) / "config.resolved.yaml").read_text())
            row.update({"run": cfg["name"], **params(cfg)})
        except (OSError, KeyError, TypeError, ValueError, yaml.YAMLError):
            pass
        rows.append(row)
    return pd.DataFrame(rows)


def _runs_table(table: pd.DataFrame, left: list[dict], params: ParamsOf) -> pd.DataFrame:
    """The set's runs table: the runs analysed, then those left out with their reasons."""
    return pd.concat([table, _left_out_rows(left, params)], ignore_index=True) if left else table


def _report_left_out(rep: Report, left: list[dict], n_used: int) -> None:
    if not left:
        return
    rep.text(f"{len(left)} of {len(left) + n_used} runs were LEFT OUT of this analysis (runs table: included = "
             "False, with the reason in left_out); every figure and fit below is without them.")
    rep.table(pd.DataFrame([{"run_dir": str(r["run_dir"]), "state": r["state"], "reason": r["reason"]}
                            for r in left]), "runs left out, and why", max_rows=100)


def _report_plot_failures(rep: Report, table: pd.DataFrame, guard: PlotGuard) -> None:
    if "plots_failed" in table:
        bad = table[table.plots_failed.fillna("").astype(str) != ""]
        if len(bad):
            rep.text(f"{len(bad)} runs have figures that failed to draw (runs table: plots_failed); their "
                     "measures are complete.")
    for fail in guard.failed:
        rep.text(f"Set figure {fail['plot']} failed ({fail['error']}).")


# ---------------------------------------------------------------------------------------
# BPM shear: SPEC 2.5 scaling


def analyse_shear_set(runs: list[dict], out: Path, plots: bool = True, strain: float | None = None,
                      n_bootstrap: int = 100, left_out: list[dict] | None = None, *, params: ParamsOf) -> dict:
    """Growth exponent phi per run; tau, and the finite-size (alpha, gamma), finite-rate
    (nu alpha) and second-moment (alpha, nu) collapses of SPEC 2.5 wherever the set varies L
    and/or edot, at one strain (default: the largest measure strain all runs reached).
    left_out: runs not analysed (survey_runs), listed in the runs table and the report."""
    left_out = left_out or []
    dims = {int(r["cfg"]["model"]["dimension"]) for r in runs}
    if len(dims) > 1:
        raise RunSetError("2D and 3D runs cannot be scaled together")
    d = dims.pop()
    cut = SMALL_GRAIN_CUT[d]
    table = pd.DataFrame([_run_row(r, params) for r in runs])
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
    # exponents and collapses compare sizes and rates of one material: one analysis per material
    materials = _materials(runs)
    nm["material"] = nm.run_dir.map(materials)
    collapses = {}
    for material in dict.fromkeys(materials.values()):
        members = [k for k, m in materials.items() if m == material]
        _scale_material(fits, collapses, material, table[table.run_dir.isin(members)], nm[nm.material == material],
                        masses, frames, strain, d, cut, n_bootstrap)
    fits_df = pd.DataFrame(fits, columns=["fit", "runs", "parameter", "value", "sigma", "quality", "method", "flag"])
    save_table(_runs_table(table, left_out, params), out / "runs")
    save_table(nm, out / "nm")
    save_table(fits_df, out / "fits")
    title = f"BPM {d}D shear, {len(runs)} runs, strain {strain:g}"
    guard = PlotGuard()
    if plots:
        nm_curves = [(f"{materials[k] + ', ' if materials[k] else ''}L = {t.L.iloc[0]:g}, edot = {t.edot.iloc[0]:g}",
                      t.m_mean.to_numpy(), t.N.to_numpy()) for k, t in nm.groupby("run_dir", sort=False)]
        guard.draw("nm", out / "plots" / "nm.png", plot_curves, nm_curves,
                   out / "plots" / "nm.png", "grain mass $M$ [m]", "$N(M)$ [grains per unit mass, 1/m]", title)
        guard.draw("growth", out / "plots" / "growth.png", plot_curves,
                   [(Path(d).name, f.strain, f[f"n_grains_M>={cut}"]) for d, f in frames.items()],
                   out / "plots" / "growth.png",
                   r"true strain $\varepsilon$ [-]", f"grains with $M \\geq {cut}$ [-]", title)
        for key, (fit, sel, rescale, xl, yl) in collapses.items():
            p = list(fit.params.values())
            pts = [(f"L = {c.params['L']:g}, edot = {c.params.get('edot', float('nan')):g}", *rescale(c, p)) for c in sel]
            note = ", ".join(f"{k} = {v:.3g} ± {fit.sigma[k]:.2g}" for k, v in fit.params.items())
            path = out / "plots" / _collapse_png(key)
            guard.draw(f"collapse {key}", path, plot_curves, pts, path, xl, yl, f"{title}: {key}", note)
    rep = Report(f"Shear set: {title}", f"{len(runs)} runs: " + ", ".join(str(r["dir"]) for r in runs))
    _report_left_out(rep, left_out, len(runs))
    rep.table(fits_df.assign(flag=fits_df.flag.astype(object).where(fits_df.flag.notna(), "")),
              "fitted exponents (SPEC 2.5) with standard errors; quality: collapse cost (near 1 for a good collapse "
              "with Poisson errors), KS distance for tau, 1 - R^2 for growth; flag: at the edge of its range")
    shown = ["run", "L", "edot", "k_A", "seed", "n_particles", "bonds_broken", "mu_mean", "mu_se", "P_mean", "P_se",
             "sqrtJ2_mean", "sqrtJ2_se", "tau_final", "tau_final_sigma", "plots_failed"]
    rep.table(table[[c for c in shown if c in table]], "runs (mu, P, sqrt(J2): means over the last 20 % of the "
                                                      "strain, ± block-average standard errors)")
    _report_plot_failures(rep, table, guard)
    for png, cap in [("nm.png", "N(M) of every run"), ("growth.png", "grains above the cut against strain")]:
        rep.figure(out / "plots" / png, cap)
    for key in collapses:
        rep.figure(out / "plots" / _collapse_png(key), f"{key} collapse")
    if not collapses:
        rep.text("No collapse: the set needs two or more sizes L (finite size, with tau fitted) or rates edot "
                 "(finite rate); the second moment needs both.")
    write_report(rep, out)
    return {"strain": strain, "fits": fits_df.to_dict(orient="records"), "left_out": _left_out_result(left_out),
            "plots_failed": guard.failed}


#: Model keys that make a material: a scaling analysis compares runs of one material only.
MATERIAL_KEYS = ("dimension", "k_A", "lambda_c", "theta_c_deg", "gamma", "timestep")


def _collapse_png(key: str) -> str:
    """File name of a collapse plot: 'k_A=4: finite rate' -> collapse_k_A4_finite_rate.png."""
    return "collapse_" + re.sub(r"[^A-Za-z0-9.]+", "_", key.replace("=", "")).strip("_") + ".png"


def _materials(runs: list[dict]) -> dict[str, str]:
    """Each run's material label (run_dir -> 'k_A=4' etc., naming only the keys of
    MATERIAL_KEYS that differ within the set; '' when the set is one material)."""
    values = {str(r["dir"]): tuple(r["cfg"]["model"].get(k) for k in MATERIAL_KEYS) for r in runs}
    varying = [i for i, _ in enumerate(MATERIAL_KEYS) if len({v[i] for v in values.values()}) > 1]
    return {d: ", ".join(f"{MATERIAL_KEYS[i]}={v[i]:g}" if isinstance(v[i], (int, float)) else
                         f"{MATERIAL_KEYS[i]}={v[i]}" for i in varying) for d, v in values.items()}


#: config keys that never define a parameter point of an impact set: the run's identity and
#: where and how it ran; the impact variable and the seed are handled apart
_NOT_A_VARIANT = ("name", "seed", "output.", "execution.", "scenario.velocity", "model.interface.G_c")


def _flatten(node, prefix: str = "") -> dict:
    if not isinstance(node, dict):
        return {prefix: node}
    out = {}
    for k, v in node.items():
        out.update(_flatten(v, f"{prefix}.{k}" if prefix else str(k)))
    return out


def impact_variants(runs: list[dict]) -> dict[str, str]:
    """Each run's variant label (run_dir -> 'model.broken.stiffness=interface, ...'): the
    config keys that differ within the set, other than the impact variable (the velocity),
    G_c (grouped apart) and the seed, and the run's identity (name, output, execution); ''
    for every run when no other key varies. A set that varies a model option is analysed per
    variant: its points, crossovers and fits never pool runs of two options."""
    flat = {str(r["dir"]): _flatten(r["cfg"]) for r in runs}
    keys = sorted({k for f in flat.values() for k in f})
    varying = [k for k in keys if not k.startswith(_NOT_A_VARIANT)
               and len({repr(f.get(k)) for f in flat.values()}) > 1]

    def text(v) -> str:
        return f"{v:g}" if isinstance(v, float) else str(v)

    return {d: ", ".join(f"{k}={text(f.get(k))}" for k in varying) for d, f in flat.items()}


def _scale_material(fits: list, collapses: dict, material: str, table: pd.DataFrame, nm: pd.DataFrame,
                    masses: dict, frames: dict, strain: float, d: int, cut: int, n_bootstrap: int) -> None:
    """tau and the SPEC 2.5 collapses of one material's runs (fits and collapses named with
    the material when the set has several)."""
    prefix = f"{material}: " if material else ""
    ref = table.sort_values(["L", "edot"], ascending=[False, True]).iloc[0]["run_dir"]
    tau, sigma_tau = None, None
    ref_masses, ref_percolating = masses[ref]
    pl = fit_grain_tau(ref_masses, cut, ref_percolating, n_bootstrap=n_bootstrap)
    if pl is not None:
        tau, sigma_tau = pl.tau, max(pl.sigma, pl.sigma_bootstrap or 0.0)
        fits.append({"fit": f"{prefix}N(M) ~ M^-tau at strain {strain:g}", "runs": ref, "parameter": "tau",
                     "value": tau, "sigma": sigma_tau, "quality": pl.ks,
                     "method": f"{pl.method}; range [{cut}, {pl.xmax:g}]"})
    curves = [Curve(t.m_mean.to_numpy(), t.N.to_numpy(), {"L": float(t.L.iloc[0]), "edot": float(t.edot.iloc[0])},
                    1.0 / np.sqrt(np.maximum(t["count"].to_numpy(dtype=float), 1)))
              for _, t in nm.groupby("run_dir", sort=False)]
    # fewer than 2 resamples cannot give a spread: errors from the curvature of the cost instead
    kw = {"n_bootstrap": n_bootstrap, "seed": 0} if n_bootstrap >= 2 else {"uncertainty": "curvature"}
    Ls, rates = sorted(table.L.unique()), sorted(table.edot.unique())
    if len(Ls) >= 2 and tau is not None:
        for rate in rates:
            sel = [c for c in curves if c.params["edot"] == rate]
            if len({c.params["L"] for c in sel}) < 2:
                continue
            _try_collapse(fits, collapses, f"{prefix}finite size at edot {rate:g}", sel,
                          lambda cs: fit_finite_size(cs, tau, sigma_tau=sigma_tau, bounds=FINITE_SIZE_BOUNDS,
                                                     n_grid=25, **kw), FINITE_SIZE_BOUNDS,
                          lambda c, p: finite_size_rescale(c.x, c.y, c.params["L"], p[0], p[1], tau),
                          r"$M / L^\alpha$", r"$N\,L^{\alpha\tau-\gamma}$")
    if len(rates) >= 2:
        _try_collapse(fits, collapses, f"{prefix}finite rate", curves,
                      lambda cs: fit_finite_rate(cs, d, bounds=FINITE_RATE_BOUNDS, n_grid=60, **kw),
                      FINITE_RATE_BOUNDS,
                      lambda c, p: finite_rate_rescale(c.x, c.y, c.params["L"], c.params["edot"], p[0], d),
                      r"$M\,\dot\varepsilon^{\nu\alpha}$", r"$N / (L^d \dot\varepsilon^{2\nu\alpha})$")
    m2 = table.assign(M2=[frames[r].loc[np.isclose(frames[r].strain, strain), "M2"].iloc[0] for r in table.run_dir])
    if len(Ls) >= 2 and m2.groupby("L").edot.nunique().min() >= 2:
        _try_collapse(fits, collapses, f"{prefix}second moment", moment_curves(m2.L, m2.edot, m2.M2),
                      lambda cs: fit_moment_collapse(cs, d, bounds=MOMENT_BOUNDS, n_grid=25, **kw), MOMENT_BOUNDS,
                      lambda c, p: moment_rescale(c.x, c.y, c.params["L"], p[0], p[1], d),
                      r"$\dot\varepsilon L^{1/\nu}$", r"$\langle M^2\rangle / L^{d+\alpha}$",
                      runs=f"{len(m2)} runs ({m2.L.nunique()} curves, one per L)")


def _left_out_result(left: list[dict]) -> list[dict]:
    return [{"run_dir": str(r["run_dir"]), "state": r["state"], "reason": r["reason"]} for r in left]


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
                     "sigma": np.nan, "quality": np.nan, "method": f"not fitted: {exc}", "flag": None})
        return
    for (k, v), (lo, hi) in zip(fit.params.items(), bounds):
        edge = "; AT THE EDGE of its range [{:g}, {:g}]: not constrained".format(lo, hi) if min(
            abs(v - lo), abs(v - hi)) < 1e-3 * (hi - lo) else ""
        few = (f"; ONLY {fit.n_terms} point comparisons: indicative, the error understates it"
               if fit.n_terms < MIN_TRUSTED_TERMS else f"; {fit.n_terms} point comparisons")
        fits.append({"fit": f"{key} collapse", "runs": runs, "parameter": k, "value": v,
                     "sigma": fit.sigma[k], "quality": fit.cost, "method": f"{fit.method}{few}{edge}",
                     "flag": f"{k} at the edge of its range [{lo:g}, {hi:g}]: not constrained" if edge else None})
    collapses[key] = (fit, curves, rescale, xlabel, ylabel)


# ---------------------------------------------------------------------------------------
# BCM impact: SPEC 1.5 sweep level

MEASURES = ["omega", "D_w", "eta", "eta_released", "e_k2", "chi", "W_c_over_W_s", "W_f_released_over_W_f",
            "n_fragments", "n_fragments_multi_cell", "largest_fragment_mass_fraction", "second_fragment_mass_fraction",
            "mass_tau", "shape_shape_factor_mean", "balance_residual"]
# the energy split of SPEC 1.5's W_k^- per run, as fractions of W_k^-: the dissipation channels
# (analysis.bcm_impact.ENERGY_CHANNELS), fracture (W_f as booked and as released), the rebound and
# the elastic energy left; (column, summary key, label)
ENERGY_SPLIT = [(f"split_{name}", f"W_c_{name}", what) for name, _, what in ENERGY_CHANNELS] + [
    ("split_fracture", "W_f", "fracture W_f = 2 A G_c"),
    ("split_fracture_released", "W_f_released", "fracture as released by the springs, W_f + switch"),
    ("split_kinetic", "W_k_plus", "kinetic W_k^+ (restitution e_k^2)"),
    ("split_elastic", "elastic_end", "elastic energy left")]
CRACKS = "cracks_D_w>0"  # the definition of omega_0: first cracks, D_w > 0


def analyse_impact_set(runs: list[dict], out: Path, plots: bool = True, left_out: list[dict] | None = None,
                       breakup_fraction: float = BREAKUP_FRACTION, *, params: ParamsOf) -> dict:
    """Measures against v and omega per G_c (mean and standard deviation over tessellations),
    omega_0 and omega_1 located from the data under every definition (breakup_definitions:
    SPEC 1.5's largest fragment below breakup_fraction, the primary one, and the chip-based
    count), each with its bracket, regime fits (D_w = A (omega - omega_0)^beta above omega_0,
    in physical ranges, flagged at a bound; eta and e_k^2 as power laws of omega from the
    primary break-up on), the energy split against v, p(S_f) over all runs and p(m) per G_c
    with its power-law fit. left_out: runs not analysed, listed in the runs table and report."""
    left_out = left_out or []
    definitions = breakup_definitions(breakup_fraction)
    primary, chips = list(definitions)
    table = pd.DataFrame([_run_row(r, params) for r in runs])
    # one series per (variant, G_c): every varied key but the velocity and the seed
    variants = impact_variants(runs)
    table["variant"] = [variants[str(r["dir"])] for r in runs]
    table["series"] = [f"G_c = {gc:g} J/m²" + (f", {v}" if v else "") for gc, v in zip(table.G_c, table.variant)]
    keys = ["series", "variant", "G_c"] if table.variant.ne("").any() else ["series", "G_c"]
    if "largest_fragment_mass_fraction" in table:
        table[f"breakup_{primary}"] = table.largest_fragment_mass_fraction < breakup_fraction
    table[f"breakup_{chips}"] = table.n_fragments_multi_cell >= 2
    if "W_k_minus" in table:
        for col, key, _ in ENERGY_SPLIT:
            if key in table:
                table[col] = table[key] / table.W_k_minus
    split_cols = [c for c, _, _ in ENERGY_SPLIT if c in table]
    cols = [c for c in MEASURES if c in table] + split_cols
    grouped = table.groupby([*keys, "velocity"], sort=True)
    points = grouped[cols].agg(["mean", "std"])
    points.columns = [f"{a}_{b}" for a, b in points.columns]
    points = points.reset_index()
    points.insert(len(keys) + 1, "n_runs", grouped.size().to_numpy())

    thresholds, threshold_rows, fits, fit_fns, lines = {}, [], [], {}, {}
    for (series, *rest), grp in table.groupby(keys, sort=True):
        gc = rest[-1]
        variant = rest[0] if len(rest) == 2 else ""
        # the key of the summary's thresholds: G_c, with the variant when the set has several
        tkey = f"{gc:g}" + (f", {variant}" if variant else "")
        vcol = {"variant": variant} if len(rest) == 2 else {}
        # bracketed between parameter points (velocities): tessellations of one point differ a little in omega
        found: dict[tuple[str, str], Threshold | str] = {
            ("omega_0", CRACKS): omega_0(grp.omega, grp.D_w, groups=grp.velocity),
            ("omega_1", chips): omega_1(grp.omega, grp.n_fragments_multi_cell, groups=grp.velocity)}
        if "largest_fragment_mass_fraction" not in grp or grp.largest_fragment_mass_fraction.isna().any():
            found[("omega_1", primary)] = ("not located: runs without largest_fragment_mass_fraction in their "
                                           "summary (driver post RUN_DIR measures it)")
        else:
            found[("omega_1", primary)] = omega_1_largest(grp.omega, grp.largest_fragment_mass_fraction,
                                                          breakup_fraction, groups=grp.velocity)
        meaning = {CRACKS: "first cracks: D_w > 0", **definitions}
        thresholds[tkey] = {"omega_0": {}, "omega_1": {}}
        for name, definition in (("omega_0", CRACKS), ("omega_1", primary), ("omega_1", chips)):
            th = found[(name, definition)]
            entry = ({"value": th.value, "lo": th.lo, "hi": th.hi, "half_width": th.half_width, "note": ""}
                     if isinstance(th, Threshold) else
                     {"value": np.nan, "lo": np.nan, "hi": np.nan, "half_width": np.nan, "note": th})
            thresholds[tkey][name][definition] = entry
            threshold_rows.append({**vcol, "G_c": gc, "threshold": name, "definition": definition,
                                   "meaning": meaning[definition], **entry, "n_runs": len(grp)})
            method = (f"bracket [{entry['lo']:.4g}, {entry['hi']:.4g}] between velocities" if not entry["note"]
                      else entry["note"])
            fits.append({**vcol, "G_c": gc, "fit": f"{name} [{definition}] ({meaning[definition]})",
                         "parameter": name,
                         "value": entry["value"], "sigma": entry["half_width"], "n": len(grp), "method": method,
                         "flag": None})
        lines[series] = {f"{name} [{definition}]": thresholds[tkey][name][definition]["value"]
                     for name, definition in (("omega_0", CRACKS), ("omega_1", primary), ("omega_1", chips))}
        try:
            tf = fit_threshold_power(grp.omega, grp.D_w)
            fits += [{**vcol, "G_c": gc, "fit": "D_w = A (omega - omega0)^beta", "parameter": p, "value": v,
                      "sigma": s,
                      "n": tf.n, "method": tf.method, "flag": tf.flag}
                     for p, v, s in (("omega0", tf.omega0, tf.sigma_omega0), ("beta", tf.beta, tf.sigma_beta),
                                     ("A", tf.prefactor, tf.sigma_prefactor))]
            fit_fns[(series, "D_w")] = (lambda w, tf=tf: threshold_power(w, tf.omega0, tf.beta, tf.prefactor),
                                    grp.omega.min(), grp.omega.max())
        except ValueError as exc:
            fits.append({**vcol, "G_c": gc, "fit": "D_w = A (omega - omega0)^beta", "parameter": "-",
                         "value": np.nan,
                         "sigma": np.nan, "n": len(grp), "method": f"not fitted: {exc}", "flag": None})
        # every run of the parameter points from the first break-up (primary definition, the chip
        # count when the runs lack the fragment fractions) on
        rule = primary if f"breakup_{primary}" in grp and not grp.largest_fragment_mass_fraction.isna().any() \
            else chips
        point_omega = grp.groupby("velocity").omega.transform("mean")
        broke = point_omega[grp[f"breakup_{rule}"].astype(bool)]
        above = grp[point_omega >= broke.min()] if len(broke) else grp.iloc[0:0]
        for col in ("eta", "e_k2"):
            fit_name = f"{col} = A omega^b above omega_1 [{rule}]"
            try:
                pf = fit_loglog(above.omega, above[col])
                fits.append({**vcol, "G_c": gc, "fit": fit_name, "parameter": "b", "value": pf.exponent,
                             "sigma": pf.sigma_exponent, "n": pf.n, "method": "log-log least squares", "flag": None})
                fit_fns[(series, col)] = (lambda w, pf=pf: power_law(w, pf.prefactor, pf.exponent),
                                      above.omega.min(), above.omega.max())
            except ValueError as exc:
                fits.append({**vcol, "G_c": gc, "fit": fit_name, "parameter": "-", "value": np.nan, "sigma": np.nan,
                             "n": len(above), "method": f"not fitted: {exc}", "flag": None})

    # fragments of every run: p(S_f) pooled, p(m/m_max) per G_c (and variant)
    series_of = dict(zip(table.run_dir, table.series))
    frags = pd.concat([pd.read_parquet(r["dir"] / "results" / "fragments.parquet").assign(
        run_dir=str(r["dir"]), G_c=float(params(r["cfg"])["G_c"]), series=series_of[str(r["dir"])])
        for r in runs], ignore_index=True)
    frags["m_over_m_max"] = frags.mass / frags.groupby("run_dir").mass.transform("max")
    multi = frags[~frags.single_cell]
    sf = histogram_table(multi.shape_factor, bins=20) if len(multi) else pd.DataFrame()
    mass_tables, mass_fits = {}, {}
    for (label, gc), grp in frags.groupby(["series", "G_c"], sort=True):
        vcol = {"variant": variants[grp.run_dir.iloc[0]]} if "variant" in keys else {}
        mass_tables[label] = normalised_mass_distribution(grp.m_over_m_max.to_numpy())
        pl = fit_mass_ratio_law([g.mass.to_numpy() for _, g in grp.groupby("run_dir")], n_bootstrap=100)
        if pl is not None:
            mass_fits[label] = {"tau": pl.tau, "sigma": max(pl.sigma, pl.sigma_bootstrap or 0.0), "xmin": pl.xmin,
                                "xmax": 1.0}
            fits.append({**vcol, "G_c": gc, "fit": "p(m/m_max) ~ (m/m_max)^-tau, all runs (largest of each left out)",
                         "parameter": "tau",
                         "value": pl.tau, "sigma": mass_fits[label]["sigma"], "n": pl.n,
                         "method": f"{pl.method}; range [{pl.xmin:.3g}, 1]", "flag": None})
    fits_df = pd.DataFrame(fits, columns=[*keys[1:], "fit", "parameter", "value", "sigma", "n", "method", "flag"])
    thresholds_df = pd.DataFrame(threshold_rows)
    mass_pdf = pd.concat([t.assign(label=k) for k, t in mass_tables.items()], ignore_index=True)

    # a set of one variant keeps its tables as they were: series is G_c there
    internal = [] if "variant" in keys else ["series", "variant"]
    save_table(_runs_table(table.drop(columns=internal), left_out, params), out / "runs")
    save_table(points.drop(columns=internal[:1]), out / "points")
    save_table(thresholds_df, out / "thresholds")
    save_table(fits_df, out / "fits")
    save_table(mass_pdf, out / "fragment_masses")
    if len(sf):
        save_table(sf, out / "shape_factor")
    title = f"BCM impacts, {len(runs)} runs"
    guard = PlotGuard()
    plot_dir = out / "plots"
    if plots:
        guard.draw("measures_vs_omega", plot_dir / "measures_vs_omega.png", plot_measures, points,
                   plot_dir / "measures_vs_omega.png", "omega", lines, fit_fns, title)
        guard.draw("measures_vs_velocity", plot_dir / "measures_vs_velocity.png", plot_measures, points,
                   plot_dir / "measures_vs_velocity.png", "velocity", title=title)
        if split_cols:
            guard.draw("energy_split", plot_dir / "energy_split.png", plot_energy_split, points,
                       [(c, label) for c, _, label in ENERGY_SPLIT if c in split_cols], plot_dir / "energy_split.png",
                       title)
        guard.draw("fragment_masses", plot_dir / "fragment_masses.png", plot_mass_pdf, mass_tables,
                   plot_dir / "fragment_masses.png", title, fits=mass_fits)
        if len(sf):
            guard.draw("shape_factor", plot_dir / "shape_factor.png", plot_histograms,
                       {"fragments of two or more cells": sf}, plot_dir / "shape_factor.png",
                       r"shape factor $S_f$ [-]", r"$p(S_f)$ [-]", title)
    rep = Report(f"Impact set: {title}", f"{len(runs)} runs: " + ", ".join(str(r["dir"]) for r in runs))
    _report_left_out(rep, left_out, len(runs))
    rep.table(thresholds_df[[*keys[1:], "threshold", "definition", "value", "lo", "hi", "n_runs", "note"]],
              f"crossovers under every definition, each bracketed [lo, hi] between velocities: "
              + "; ".join(f"{k}: {v}" for k, v in {CRACKS: "first cracks, D_w > 0", **definitions}.items())
              + f" (the break-up rule of SPEC 1.5 is {primary})")
    rep.table(fits_df.assign(flag=fits_df.flag.astype(object).where(fits_df.flag.notna(), "")),
              "crossovers and regime fits per G_c (value ± standard error; omega brackets as half-widths; flag: a "
              "parameter at a bound of its physical range, not constrained by the data)")
    _report_energy_flags(rep, table, points)
    _report_plot_failures(rep, table, guard)
    rep.table(points[[*keys[1:], "velocity", "n_runs", *[c for c in points.columns if c.endswith("_mean")
                                                      and not c.startswith("split_")]]],
              "measures per parameter point (means over tessellations; points.csv has the standard deviations)")
    if split_cols:
        rep.table(points[[*keys[1:], "velocity", *[f"{c}_mean" for c in split_cols]]],
                  "where W_k^- goes, fractions of W_k^- per parameter point (means; split_<channel>: the "
                  "dissipation channels, which sum to W_c measured)")
    rep.figure(plot_dir / "measures_vs_omega.png", "measures against the damage potential omega")
    rep.figure(plot_dir / "measures_vs_velocity.png", "measures against the impact velocity")
    rep.figure(plot_dir / "energy_split.png", "where the impact energy goes, against the impact velocity: "
                                              "dissipation channels, fracture, rebound (e_k^2) and elastic energy left")
    rep.figure(plot_dir / "fragment_masses.png", "fragment mass distributions per G_c")
    rep.figure(plot_dir / "shape_factor.png", "distribution of the shape factor over all runs")
    write_report(rep, out)
    return {"breakup_fraction": breakup_fraction, "omega_1_definition": primary, "thresholds": thresholds,
            "fits": fits_df.to_dict(orient="records"), "left_out": _left_out_result(left_out),
            "plots_failed": guard.failed}


def _report_energy_flags(rep: Report, table: pd.DataFrame, points: pd.DataFrame) -> None:
    """Runs whose W_f differs from the energy their broken interfaces held, and negative
    dissipations: named, so that no such number stands in the report as a result."""
    if "W_f_flag" in table:
        flagged = table[table.W_f_flag.notna() & (table.W_f_flag.astype(str) != "")]
        if len(flagged):
            rep.text(f"Flag: in {len(flagged)} of {len(table)} runs W_f = 2 A G_c differs by more than 1 % from the "
                     "elastic energy the breaks released, W_f + W_c_switch (runs table: W_f_flag, "
                     "W_f_released_over_W_f): there eta, chi and W_c built on W_f are the Griffith convention's "
                     "bookkeeping; eta_released and W_f_released are what the springs gave up.")
    neg = points[points.W_c_over_W_s_mean < 0] if "W_c_over_W_s_mean" in points else points.iloc[0:0]
    if len(neg):
        rep.text("Flag: negative dissipation W_c < 0 (mean over tessellations) at "
                 + ", ".join(f"G_c = {r.G_c:g}, v = {r.velocity:g}" for r in neg.itertuples())
                 + ": not a result; see the runs' energy_flags (W_f booked beyond what the springs held, or the "
                   "balance).")
