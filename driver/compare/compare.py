"""`driver compare`: calibrate both models (reusing the cache), run the grid with both, and
write one directory:

    calibration.json    each model's parameters, at every G_c of the grid (params.py)
    runs/<model>/G_c<G_c>/velocity<v>_seed<s>/   the run directories (a re-run resumes them;
                        omega<w>_seed<s> on an omega grid)
    runs.csv/.parquet   the tidy table: every run of both models (state, error, wall time,
                        summary; the G_c measures with the material's G_c, stats.py)
    points.csv/.parquet the side-by-side table: per (G_c, grid point, measure) both models' n,
                        mean, std, the difference, the combined standard error, z, verdict
    points_wide.csv     the same, one row per (G_c, grid point)
    agreement.csv       per measure: points that agree, differ, are undetermined
    crossovers.csv      omega_0 and omega_1 of each model per G_c, side by side
    fragment_masses.csv, shape_factor.csv   p(m/m_max) and p(S_f) of each model (all runs)
    plots/              both models on the same axes
    report.md/.html     where the models agree within error bars and where not, in words

A grid point is a velocity (both models hit the plane at the same v_0) or, with grid.omega, a
damage potential (each model's particle at the v_0 that gives that omega with the material's
G_c: driver/compare/omega.py); the runs of a point are paired over its seeds.

With `test: crush` a grid point is a particle size (runs/<model>/G_c<G_c>/diameter<d>..._seed<s>),
and the crossovers and fragment distributions give way to the Weibull fits and size effects of
driver/compare/crush.py (weibull.csv, size_effect.csv, strength_pairs.csv). With `test: compress`
both models fill the same bed (runs/<model>/G_c<G_c>/seed<s>): driver/compare/bed.py (beds.csv,
the compression and grading curves side by side).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from rich.console import Console

from analysis.plots import PlotGuard
from analysis.report import Report, clear_report, write_report
from analysis.statistics import histogram_table, normalised_mass_distribution
from analysis.tables import save_table
from driver.compare import stats
from driver.compare.params import calibrate_bcm, calibrate_bpm, grid_parameters, lambda_c_table
from driver.compare.runs import MODELS, g_values, grid_runs, n_cells_of, run_grid
from driver.calibration.material import MaterialFile
from driver.compare.schema import CompareFile, material_of
from driver.config import RunConfig
from runfiles.atomic import atomic_write_json

COMPARE_MARKER = ".brittle-compare"


def calibrate_both(cmp: CompareFile, compare_path: Path, cache: Path, workers: int, console: Console
                   ) -> tuple[dict[str, Any], MaterialFile]:
    """Both models' calibration for the compare file (params.py) with the per-G_c parameters,
    and the material (the compare file's resolutions in it)."""
    mat, reuse, where = material_of(cmp, compare_path)
    bcm = calibrate_bcm(mat, cache, workers, console, reuse)
    bpm = calibrate_bpm(mat, cache, workers, console)
    G_ref = mat.material.toughness(3)[0]
    grid = g_values(cmp, mat)
    bpm["lambda_c_by_G_c"] = lambda_c_table(bpm, mat, grid, cmp.bpm.lambda_c, G_ref)
    bpm["parameters"]["lambda_c_at_material_G_c"] = (
        cmp.bpm.lambda_c if cmp.bpm.lambda_c is not None else bpm["parameters"]["lambda_c"])
    bpm["lambda_c_note"] = ("given in the compare file, scaled to other G_c as lambda_c - 1 ~ sqrt(G_c)"
                            if cmp.bpm.lambda_c is not None else
                            "calibrated: the 3D mode-I curve at the chosen k_A, inverted at each G_c's K_IC")
    return {"material_source": str(where), "material": mat.model_dump(mode="json"), "G_c_material": G_ref,
            "bcm_n_cells": n_cells_of(mat), "bcm": bcm, "bpm": bpm,
            "grid": grid_parameters(bcm, bpm, grid)}, mat


def tidy_table(runs: list[tuple[dict[str, Any], RunConfig]], test: str = "impact") -> pd.DataFrame:
    """Every run of both models (driver/sweep.py sweep_table) with its wall time; for the
    impact, the G_c measures with the material's G_c (stats.common_measures)."""
    from driver.sweep import _wall_seconds, sweep_table  # noqa: PLC0415

    table = sweep_table(runs)
    table["wall_seconds"] = [_wall_seconds(cfg.run_dir()) if s == "finished" else None
                             for (_, cfg), s in zip(runs, table["state"])]
    return stats.common_measures(table) if test == "impact" else table


def fragment_tables(table: pd.DataFrame, axis: str = "velocity"
                    ) -> tuple[dict[str, pd.DataFrame], dict[str, pd.DataFrame], pd.DataFrame]:
    """p(m/m_max) per (model, G_c) and p(S_f) per model (multi-element fragments), over all
    finished runs; and the fragments of every run (model, G_c, run_dir columns added)."""
    parts = []
    for r in table[table.state == "finished"].itertuples():
        f = Path(r.run_dir) / "results" / "fragments.parquet"
        if f.exists():
            parts.append(pd.read_parquet(f).assign(model=r.model, G_c=r.G_c, **{axis: getattr(r, axis)},
                                                   run_dir=r.run_dir))
    if not parts:
        return {}, {}, pd.DataFrame()
    frags = pd.concat(parts, ignore_index=True)
    frags["m_over_m_max"] = frags.mass / frags.groupby("run_dir").mass.transform("max")
    mass, sf = {}, {}
    for (model, g), grp in frags.groupby(["model", "G_c"], sort=True):
        mass[f"{model.upper()}, G_c = {g:g} J/m²"] = normalised_mass_distribution(grp.m_over_m_max.to_numpy())
    multi = frags[~frags.single_cell.astype(bool)]
    finite = multi.shape_factor[np.isfinite(multi.shape_factor)]
    if len(finite):
        edges = np.linspace(float(finite.min()), float(finite.max()) + 1e-9, 16)
        for model, grp in multi.groupby("model", sort=True):
            sf[model.upper()] = histogram_table(grp.shape_factor.to_numpy(), bins=edges)
    return mass, sf, frags


def _fmt(v: float) -> str:
    return "n/a" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.3g}"


def _points(n: int) -> str:
    return f"{n} point" + ("" if n == 1 else "s")


def point_label(axis: str, value: float) -> str:
    """A grid point in words: `v = 2 m/s`, `omega = 0.2`, `d = 2 mm` or `30 grains`."""
    if axis == "n_grains":
        return f"{value:g} grains"
    if axis == "diameter":
        return f"d = {value * 1e3:g} mm"
    return f"v = {value:g} m/s" if axis == "velocity" else f"omega = {value:g}"


def agreement_words(points: pd.DataFrame, summary: pd.DataFrame, pairs: pd.DataFrame, z_agree: float,
                    axis: str = "velocity", measures: dict[str, tuple[str, str]] | None = None) -> list[str]:
    """The report's sentences, generated from the tables: per measure where the models agree
    within error bars and where they differ (the points and their z), then the crossovers."""
    out, silent = [], []
    for s in summary.itertuples():
        label = (measures or stats.MEASURES).get(s.measure, (s.measure, s.measure))[1]
        p = points[points.measure == s.measure]
        if s.agree + s.differ == 0:
            silent.append(s.measure)
            continue
        where = "; ".join(f"G_c = {r.G_c:g}, {point_label(axis, getattr(r, axis))}: "
                          f"BCM {_fmt(r.mean_bcm)} ± {_fmt(r.std_bcm)}, "
                          f"BPM {_fmt(r.mean_bpm)} ± {_fmt(r.std_bpm)}, z = {r.z:+.2g}"
                          for r in p[p.verdict == "differ"].itertuples())
        if s.differ == 0:
            head = f"agree within error bars at all {s.agree} points with a verdict"
        elif s.agree == 0:
            head = f"differ at all {s.differ} points with a verdict"
        else:
            head = f"agree within error bars at {_points(s.agree)} and differ at {s.differ}"
        tail = f" ({s.undetermined} undetermined, {s.missing} missing)" if s.undetermined + s.missing else ""
        out.append(f"{s.measure} ({label}): {head}{tail}." + (f" They differ at {where}." if where else ""))
    if silent:
        out.append(f"No verdict at any point for {', '.join(silent)}: fewer than two runs of a model at every "
                   "point (no error bar), or the measure missing in a model (e.g. no multi-element fragment for "
                   "the shapes).")
    for r in pairs.itertuples():
        out.append(f"{r.threshold} at G_c = {r.G_c:g}: BCM in [{_fmt(r.lo_bcm)}, {_fmt(r.hi_bcm)}], BPM in "
                   f"[{_fmt(r.lo_bpm)}, {_fmt(r.hi_bpm)}]: the brackets "
                   + ("overlap (agree)." if r.verdict == "agree" else "do not overlap (differ)."))
    return out


def calibration_rows(cal: dict[str, Any]) -> pd.DataFrame:
    """The calibration table of the report: per model its parameters and where they come from."""
    b, p = cal["bcm"], cal["bpm"]
    rows = [("BCM", "n_cells", cal["bcm_n_cells"], "", "the compare file's resolution"),
            ("BCM", "k_n", b["parameters"]["kn"], "N/m", "moduli curve: E"),
            ("BCM", "k_t / k_n", b["parameters"]["kt_over_kn"], "", "moduli curve: nu"),
            ("BCM", "fracture slope s", b["fracture_slope"]["slope"], "", "fracture curve: W/A per interface G_c"),
            ("BPM", "particles across", p["parameters"]["grain_diameter_in_a"], "", "the compare file's resolution"),
            ("BPM", "k_A", p["parameters"]["k_A"], "u", "3D moduli curve: nu"
             + ("" if p["reach"]["nu"]["reached"] else " (OUT OF REACH: nearest)")),
            ("BPM", "a", p["units"]["length_a_m"], "m", "resolution"),
            ("BPM", "m", p["units"]["mass_m_kg"], "kg", "density"),
            ("BPM", "u", p["units"]["energy_u_J"], "J", "E"),
            ("BPM", "lambda_c - 1 at the material's G_c", p["parameters"]["lambda_c_at_material_G_c"] - 1.0, "",
             p["lambda_c_note"] + ("" if all(r["reached"] for r in p.get("lambda_c_by_G_c", []))
                                   else " (OUT OF REACH at some G_c: nearest)"))]
    rows += [(r["model"].upper(), f"{r['parameter']}{' - 1' if r['model'] == 'bpm' else ''} at G_c = {r['G_c']:g}",
              r["value"] - (1.0 if r["model"] == "bpm" else 0.0), "J/m^2" if r["model"] == "bcm" else "",
              "per grid G_c") for r in cal["grid"]]
    return pd.DataFrame(rows, columns=["model", "parameter", "value", "unit", "from"])


def _report_head(cmp: CompareFile, cal: dict[str, Any], table: pd.DataFrame) -> Report:
    """The report's title and its calibration section (both tests)."""
    done = table[table.state == "finished"]
    rep = Report(f"Comparison {cmp.name}: BCM and BPM, {cmp.test}",
                 f"material {cal['material_source']}; {len(table)} runs ({len(done)} finished, "
                 f"{len(table) - len(done)} not)")
    rep.heading("Calibration")
    rep.text(f"Both models calibrated to density {cal['material']['material']['density']:g} kg/m³, E = "
             f"{cal['material']['material']['E']:.4g} Pa, nu = {cal['material']['material']['nu']:g}, G_c = "
             f"{cal['G_c_material']:.4g} J/m² (SPEC 3). The BPM's nu reached: {cal['bpm']['achieved']['nu']:.4g}"
             + ("" if cal["bpm"]["reach"]["nu"]["reached"] else f" ({cal['bpm']['reach']['nu'].get('note', '')})")
             + (". Measures holding G_c (W_f = 2 A G_c, W_s, omega, eta, chi, W_c) use the material's G_c in both "
                "models; the BCM's own (its interface G_c) are the runs table's <name>_model columns."
                if cmp.test == "impact" else "."))
    rep.table(calibration_rows(cal), "calibration table")
    rep.heading("Where the models agree")
    return rep


def _impact_analysis(cmp: CompareFile, table: pd.DataFrame, out: Path, plots: bool, guard: PlotGuard, title: str,
                     rep: Report) -> tuple[dict[str, Any], dict[str, Path]]:
    """The impact's side-by-side tables, crossovers, fragment distributions, figures and words."""
    axis = cmp.grid.axis
    # on an omega grid omega is the grid point itself (equal in both models by construction)
    measures = [m for m in stats.MEASURES if not (axis == "omega_target" and m == "omega")]
    points = stats.side_by_side(table, measures, z_agree=cmp.z_agree, keys=("G_c", axis))
    summary = stats.agreement_summary(points, axis)
    cross = stats.crossovers(table, cmp.breakup_fraction, axis) if (table.state == "finished").any() else pd.DataFrame(
        columns=["model", "G_c", "threshold", "value", "lo", "hi"])
    pairs = stats.crossover_pairs(cross)
    mass, sf, _ = fragment_tables(table, axis)
    save_table(points, out / "points")
    save_table(stats.wide(points, axis=axis), out / "points_wide")
    save_table(summary, out / "agreement")
    save_table(cross, out / "crossovers")
    save_table(pairs, out / "crossover_pairs")
    if mass:
        save_table(pd.concat([t.assign(label=k) for k, t in mass.items()], ignore_index=True), out / "fragment_masses")
    if sf:
        save_table(pd.concat([t.assign(model=k) for k, t in sf.items()], ignore_index=True), out / "shape_factor")
    figures = {}
    if plots and (table.state == "finished").any():
        from driver.compare.plots import draw_all  # noqa: PLC0415

        figures = draw_all(guard, table, cross, mass, sf, out / "plots", title, axis)
    rep.text(f"Agree within error bars: |z| <= {cmp.z_agree:g}, z = (BPM mean - BCM mean) / sqrt(s_BCM²/n_BCM + "
             "s_BPM²/n_BPM) over the seeds of a point; a point with one run of a model has no error bar "
             "(undetermined). Crossovers agree when their brackets between grid points overlap. "
             + ("Pairing: both models at the same impact velocity v_0 (their omega differ where their A_0 / M do)."
                if axis == "velocity" else
                "Pairing: both models at the same damage potential omega (with the material's G_c); each "
                "particle hit at its own v_0 = sqrt(4 omega A_0 G_c / M) (the runs table's velocity)."))
    for line in agreement_words(points, summary, pairs, cmp.z_agree, axis):
        rep.text(line)
    rep.table(summary, "verdicts per measure (agreement.csv)")
    if len(pairs):
        rep.table(pairs, "crossovers side by side (crossover_pairs.csv; brackets [lo, hi] on the common omega)")
    rep.table(points, "per point, side by side (points.csv)", max_rows=60)
    done = table[table.state == "finished"]
    gained = done[done.e_k2 > 1.0] if "e_k2" in done else done.iloc[0:0]
    if len(gained):
        rep.text(f"Flag: in {len(gained)} runs the kinetic energy after the impact exceeds the impact's (e_k^2 > 1): "
                 + "; ".join(f"{r.model.upper()} v = {r.velocity:g} m/s seed {r.seed}: e_k^2 = {r.e_k2:.3g}"
                             for r in gained.itertuples())
                 + ". Energy came from the model itself (broken elements releasing stored or overlap energy), not "
                   "from the impact: these points are not a result for that model.")
    return {"agreement": summary.to_dict(orient="records"), "crossovers": pairs.to_dict(orient="records")}, figures


def _crush_analysis(cmp: CompareFile, table: pd.DataFrame, out: Path, plots: bool, guard: PlotGuard, title: str,
                    rep: Report) -> tuple[dict[str, Any], dict[str, Path]]:
    """The crush's side-by-side tables, Weibull fits and size effects, figures and words
    (driver/compare/crush.py)."""
    from driver.compare import crush  # noqa: PLC0415

    points = stats.side_by_side(table, list(crush.CRUSH_MEASURES), z_agree=cmp.z_agree, keys=("G_c", "diameter"))
    summary = stats.agreement_summary(points, "diameter")
    weibull = crush.weibull_table(table)
    sizes, effects = crush.size_effect_table(table)
    pairs = crush.interval_pairs(weibull, sizes)
    for name, frame in (("points", points), ("points_wide", stats.wide(points, axis="diameter")),
                        ("agreement", summary), ("weibull", weibull), ("size_effect", sizes),
                        ("strength_pairs", pairs)):
        save_table(frame, out / name)
    figures = {}
    if plots and (table.state == "finished").any():
        from driver.compare.crush_plots import draw_crush  # noqa: PLC0415

        figures = draw_crush(guard, table, weibull, effects, out / "plots", title)
    rep.text(f"Both models crush grains of the same sizes (d, the parent's diameter) and seeds between two platens "
             f"(SPEC 4.1), the upper one at the same speed. Agree within error bars: |z| <= {cmp.z_agree:g}, z = (BPM "
             "mean - BCM mean) / sqrt(s_BCM²/n_BCM + s_BPM²/n_BPM) over the seeds of a point; a point with one run of "
             "a model has no error bar (undetermined). The fitted figures (Weibull m and sigma_0 per point, the "
             "size-effect b and 3/m per G_c) agree when their 95 % bootstrap intervals overlap. The strength "
             "statistics take the grains whose force dropped (F_c a first peak).")
    for line in agreement_words(points, summary, pd.DataFrame(columns=["threshold"]), cmp.z_agree, "diameter",
                                crush.CRUSH_MEASURES):
        rep.text(line)
    for line in crush.strength_words(pairs, weibull):
        rep.text(line)
    for line in crush.crush_flags(table):
        rep.text(f"Flag: {line}")
    rep.table(summary, "verdicts per measure (agreement.csv)")
    rep.table(pairs, "Weibull and size-effect figures side by side (strength_pairs.csv; intervals [lo, hi])")
    rep.table(weibull, "Weibull fits of sigma_c per model and point (weibull.csv)")
    rep.table(points, "per point, side by side (points.csv)", max_rows=60)
    return {"agreement": summary.to_dict(orient="records"), "strength": pairs.to_dict(orient="records"),
            "weibull": weibull.to_dict(orient="records"), "size_effect": sizes.to_dict(orient="records")}, figures


def _bed_analysis(cmp: CompareFile, table: pd.DataFrame, out: Path, plots: bool, guard: PlotGuard, title: str,
                  rep: Report) -> tuple[dict[str, Any], dict[str, Path]]:
    """The beds' side-by-side tables, figures and words (driver/compare/bed.py)."""
    from driver.compare import bed  # noqa: PLC0415

    table = bed.with_last_state(table)
    points = stats.side_by_side(table, list(bed.BED_MEASURES), z_agree=cmp.z_agree, keys=("G_c", "n_grains"))
    summary = stats.agreement_summary(points, "n_grains")
    for name, frame in (("points", points), ("points_wide", stats.wide(points, axis="n_grains")),
                        ("agreement", summary), ("beds", table)):
        save_table(frame.drop(columns=[c for c in frame.columns if frame[c].map(
            lambda v: isinstance(v, (list, dict))).any()]), out / name)
    figures = {}
    if plots and (table.state == "finished").any():
        from driver.compare.bed_plots import draw_bed  # noqa: PLC0415

        figures = draw_bed(guard, bed.bed_curves(table), out / "plots", title)
    rep.text(f"Both models fill the same bed ({cmp.assembly.get('n_grains', '?')} grains: the same count, sizes and "
             "box, the same seeds; each model places its grains itself, so the two beds are two samples of one "
             "grading) and compress it in the rigid box to the same target stress (scenario). Agree within error "
             f"bars: |z| <= {cmp.z_agree:g}, z = (BPM mean - BCM mean) / sqrt(s_BCM²/n_BCM + s_BPM²/n_BPM) over the "
             "seeds; a point with one run of a model has no error bar (undetermined).")
    for line in agreement_words(points, summary, pd.DataFrame(columns=["threshold"]), cmp.z_agree, "n_grains",
                                bed.BED_MEASURES):
        rep.text(line)
    for line in bed.bed_flags(table):
        rep.text(f"Flag: {line}")
    rep.table(summary, "verdicts per measure (agreement.csv)")
    rep.table(points, "per point, side by side (points.csv)", max_rows=60)
    return {"agreement": summary.to_dict(orient="records")}, figures


def analyse_compare(cmp: CompareFile, cal: dict[str, Any], runs: list[tuple[dict[str, Any], RunConfig]],
                    out: Path, plots: bool = True) -> dict[str, Any]:
    """The tables, plots and report of the comparison into `out` (module docstring; the crush's:
    driver/compare/crush.py)."""
    out = Path(out)
    clear_report(out)
    table = tidy_table(runs, cmp.test)
    save_table(table.drop(columns=[c for c in table.columns if table[c].map(
        lambda v: isinstance(v, (list, dict))).any()]), out / "runs")
    guard = PlotGuard()
    title = f"{cmp.name}: BCM and BPM, {cmp.test}"
    rep = _report_head(cmp, cal, table)
    body = {"crush": _crush_analysis, "compress": _bed_analysis}.get(cmp.test, _impact_analysis)
    result, figures = body(cmp, table, out, plots, guard, title, rep)
    done = table[table.state == "finished"]
    failed = table[table.state != "finished"]
    walls = done.groupby("model").wall_seconds.agg(["count", "mean", "min", "max"]).reset_index()
    if len(failed):
        rep.text(f"{len(failed)} runs did not finish and are left out: "
                 + "; ".join(f"{r.run_dir} ({r.state}: {r.error})" for r in failed.itertuples()))
    rep.table(walls, "wall time per run, s (each model)")
    for name, path in figures.items():
        rep.figure(path, name.replace("_", " "))
    if guard.failed:
        rep.text("figures not drawn: " + "; ".join(f"{f['plot']}: {f['error']}" for f in guard.failed))
    write_report(rep, out)
    return {"runs": len(table), "finished": len(done), "failed": failed.run_dir.tolist(), **result,
            "wall_seconds": walls.to_dict(orient="records"), "plots_failed": guard.failed}


def run_compare(cmp: CompareFile, compare_path: Path, out: Path, cache: Path, workers: int, console: Console,
                plots: bool = True) -> dict[str, Any]:
    """Calibrate, run the grid, analyse (module docstring); failed runs are recorded, not fatal."""
    from driver.rundir import claim_dir  # noqa: PLC0415

    out = claim_dir(Path(out), COMPARE_MARKER, "comparison directory")
    cal, mat = calibrate_both(cmp, compare_path, cache, workers, console)
    atomic_write_json(out / "calibration.json", cal)
    runs = grid_runs(cmp, mat, cal["bcm"], cal["bpm"], out, str(compare_path))
    per_model = ", ".join(f"{sum(v['model'] == m for v, _ in runs)} {m.upper()}" for m in MODELS)
    console.print(f"compare [bold]{cmp.name}[/]: {len(runs)} runs ({per_model}) in {out}/runs")
    failed = run_grid(runs, workers, console)
    result = analyse_compare(cmp, cal, runs, out, plots)
    result["failed_now"] = failed
    result["calibration"] = calibration_rows(cal).to_dict(orient="records")
    atomic_write_json(out / "compare.json", result)
    return result
