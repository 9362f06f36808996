"""The comparison's statistics, as pure functions on tables (issue 13, point 3).

The tidy table has one row per run of either model: `model`, `G_c` (the material's fracture
energy of the grid point), `velocity`, `seed` (and `omega_target` on an omega grid), `state`,
and the run's summary. The measures that
hold G_c (SPEC 1.5: W_f = 2 A G_c, W_s = 2 A_0 G_c, omega, eta, chi, W_c) are taken with the
material's G_c in both models (`common_measures`), so that one omega axis and one W_f mean the
same in both: the BCM's own figures use its interface G_c (a calibrated model parameter,
G_c / s, driver/compare/params.py) and are kept as <name>_model. W_f is also given as the
energy the broken elements held when they broke (W_f_held, from the break record; SPEC 3) with
eta_held = W_f_held / W_k^-.

Agreement at a parameter point (`side_by_side`): the difference of the two means in units of
their combined standard error, z = (mean_bpm - mean_bcm) / sqrt(s_bcm^2 / n_bcm + s_bpm^2 /
n_bpm) (s the standard deviation over seeds, ddof 1). The models agree within error bars
where |z| <= z_agree (2 by default); a point with one run of either model has no error bar
and is `undetermined`; equal means with no spread agree, different ones differ.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from analysis.scaling import Threshold, omega_0, omega_1_largest

#: The measures compared point by point: column -> (label for tables and plots, meaning).
MEASURES: dict[str, tuple[str, str]] = {
    "omega": (r"$\omega$", "damage potential W_k^- / (2 A_0 G_c)"),
    "D_w": (r"$D_w$", "damage: broken area fraction A / A_0"),
    "e_k2": (r"$e_k^2$", "restitution W_k^+ / W_k^-"),
    "eta": (r"$\eta$", "fracture efficiency 2 A G_c / W_k^-"),
    "eta_held": (r"$\eta_{held}$", "fracture efficiency with W_f held by the broken elements"),
    "chi": (r"$\chi$", "W_k^+ / W_f"),
    "W_c_over_W_s": (r"$W_c/W_s$", "dissipated energy over 2 A_0 G_c"),
    "largest_fragment_mass_fraction": (r"$m_1/M$", "largest fragment's mass fraction"),
    "n_fragments_multi_cell": (r"$N_{frag}$", "fragments of two or more elements"),
    "shape_elongation_mean": (r"$\langle b/a \rangle$", "mean elongation b/a (multi-element fragments)"),
    "shape_flatness_mean": (r"$\langle c/b \rangle$", "mean flatness c/b (multi-element fragments)"),
    "shape_shape_factor_mean": (r"$\langle S_f \rangle$", "mean shape factor"),
}
VERDICTS = ("agree", "differ", "undetermined", "missing")


def common_measures(table: pd.DataFrame) -> pd.DataFrame:
    """`table` with the G_c measures of SPEC 1.5 taken with the material's G_c (column G_c) from
    A, A0, W_k_minus and W_k_plus; the model's own kept as <name>_model. chi is NaN where no
    element broke (W_f = 0). eta_held and W_f_held_over_W_f from W_f_held where present."""
    t = table.copy()
    if t.empty or "A" not in t:
        return t
    for col in ("W_f", "W_s", "omega", "eta", "chi", "W_c", "W_c_over_W_s"):
        if col in t:
            t[f"{col}_model"] = t[col]
    g = t["G_c"].astype(float)
    t["W_f"] = 2.0 * t["A"] * g
    t["W_s"] = 2.0 * t["A0"] * g
    t["omega"] = t["W_k_minus"] / t["W_s"]
    t["eta"] = t["W_f"] / t["W_k_minus"]
    t["chi"] = (t["W_k_plus"] / t["W_f"]).where(t["W_f"] > 0)
    t["W_c"] = t["W_k_minus"] - t["W_k_plus"] - t["W_f"]
    t["W_c_over_W_s"] = t["W_c"] / t["W_s"]
    if "W_f_held" in t:
        t["eta_held"] = t["W_f_held"] / t["W_k_minus"]
        t["W_f_held_over_W_f"] = (t["W_f_held"] / t["W_f"]).where(t["W_f"] > 0)
    return t


def z_score(mean_a: float, std_a: float, n_a: int, mean_b: float, std_b: float, n_b: int
            ) -> tuple[float, float, float]:
    """(difference b - a, combined standard error, z = difference / error); NaN error and z when
    either side has fewer than two runs; z = 0 or +-inf when both spreads are zero."""
    diff = mean_b - mean_a
    if n_a < 2 or n_b < 2 or not (math.isfinite(std_a) and math.isfinite(std_b)):
        return diff, math.nan, math.nan
    se = math.sqrt(std_a ** 2 / n_a + std_b ** 2 / n_b)
    if se == 0.0:
        return diff, 0.0, 0.0 if diff == 0 else math.copysign(math.inf, diff)
    return diff, se, diff / se


def verdict(mean_a: float, mean_b: float, z: float, z_agree: float) -> str:
    """agree (|z| <= z_agree), differ, undetermined (no error bar), missing (a mean is absent)."""
    if not (np.isfinite(mean_a) and np.isfinite(mean_b)):
        return "missing"
    if math.isnan(z):
        return "undetermined"
    return "agree" if abs(z) <= z_agree else "differ"


def side_by_side(table: pd.DataFrame, measures: list[str] | None = None, z_agree: float = 2.0,
                 keys: tuple[str, ...] = ("G_c", "velocity"), models: tuple[str, str] = ("bcm", "bpm")
                 ) -> pd.DataFrame:
    """One row per (parameter point, measure): n, mean and std over seeds of each model side by
    side, the difference (second model - first), the combined standard error, z and the verdict
    (module docstring). Only finished runs (state) count; a measure absent in a model is missing."""
    a, b = models
    done = table[table["state"] == "finished"] if "state" in table else table
    measures = [m for m in (measures or list(MEASURES)) if m in done]
    rows = []
    for point, grp in done.groupby(list(keys), sort=True):
        point = point if isinstance(point, tuple) else (point,)
        for m in measures:
            row = dict(zip(keys, point))
            row["measure"] = m
            stats = {}
            for model in models:
                v = pd.to_numeric(grp.loc[grp["model"] == model, m], errors="coerce").to_numpy(float)
                v = v[np.isfinite(v)]
                stats[model] = (len(v), float(v.mean()) if len(v) else math.nan,
                                float(v.std(ddof=1)) if len(v) > 1 else math.nan)
                row.update({f"n_{model}": stats[model][0], f"mean_{model}": stats[model][1],
                            f"std_{model}": stats[model][2]})
            diff, se, z = z_score(stats[a][1], stats[a][2], stats[a][0], stats[b][1], stats[b][2], stats[b][0])
            row.update({"difference": diff, "combined_se": se, "z": z,
                        "verdict": verdict(stats[a][1], stats[b][1], z, z_agree)})
            rows.append(row)
    cols = [*keys, "measure", *[f"{s}_{m}" for m in models for s in ("n", "mean", "std")], "difference",
            "combined_se", "z", "verdict"]
    return pd.DataFrame(rows, columns=cols)


def wide(points: pd.DataFrame, models: tuple[str, str] = ("bcm", "bpm"), axis: str = "velocity") -> pd.DataFrame:
    """The side-by-side table with one row per parameter point (G_c, `axis`):
    <measure>_<mean|std>_<model>, <measure>_z and <measure>_verdict columns, in the measures' order."""
    if points.empty:
        return pd.DataFrame(columns=["G_c", axis])
    rows = {}
    for r in points.itertuples():
        key = (r.G_c, getattr(r, axis))
        row = rows.setdefault(key, {"G_c": key[0], axis: key[1]})
        for m in models:
            row[f"{r.measure}_mean_{m}"] = getattr(r, f"mean_{m}")
            row[f"{r.measure}_std_{m}"] = getattr(r, f"std_{m}")
        row[f"{r.measure}_z"] = r.z
        row[f"{r.measure}_verdict"] = r.verdict
    return pd.DataFrame(list(rows.values()))


def crossovers(table: pd.DataFrame, breakup_fraction: float = 0.9, axis: str = "velocity") -> pd.DataFrame:
    """omega_0 (first cracks, D_w > 0) and omega_1 (SPEC 1.5's break-up: largest fragment below
    breakup_fraction of the mass) of each model per G_c, located between the grid's points
    (`axis`: velocity or omega_target) on the common omega: columns model, G_c, threshold,
    value, lo, hi (value NaN: only a bound)."""
    done = table[table["state"] == "finished"] if "state" in table else table
    rows = []
    for (model, g), grp in done.groupby(["model", "G_c"], sort=True):
        found: dict[str, Threshold] = {"omega_0": omega_0(grp.omega, grp.D_w, groups=grp[axis])}
        if "largest_fragment_mass_fraction" in grp and grp.largest_fragment_mass_fraction.notna().all():
            found["omega_1"] = omega_1_largest(grp.omega, grp.largest_fragment_mass_fraction, breakup_fraction,
                                               groups=grp[axis])
        for name, th in found.items():
            rows.append({"model": model, "G_c": g, "threshold": name, "value": th.value, "lo": th.lo, "hi": th.hi})
    return pd.DataFrame(rows, columns=["model", "G_c", "threshold", "value", "lo", "hi"])


def crossover_pairs(cross: pd.DataFrame, models: tuple[str, str] = ("bcm", "bpm")) -> pd.DataFrame:
    """The crossovers of the two models side by side per (G_c, threshold); they agree when their
    brackets [lo, hi] overlap (a bracket is the uncertainty of a crossover between velocities)."""
    a, b = models
    rows = []
    for (g, name), grp in cross.groupby(["G_c", "threshold"], sort=True):
        ra, rb = grp[grp.model == a], grp[grp.model == b]
        if ra.empty or rb.empty:
            continue
        ra, rb = ra.iloc[0], rb.iloc[0]
        overlap = max(ra.lo, rb.lo) <= min(ra.hi, rb.hi)
        rows.append({"G_c": g, "threshold": name, f"value_{a}": ra.value, f"lo_{a}": ra.lo, f"hi_{a}": ra.hi,
                     f"value_{b}": rb.value, f"lo_{b}": rb.lo, f"hi_{b}": rb.hi,
                     "verdict": "agree" if overlap else "differ"})
    return pd.DataFrame(rows, columns=["G_c", "threshold", *[f"{s}_{m}" for m in models for s in ("value", "lo", "hi")],
                                       "verdict"])


def agreement_summary(points: pd.DataFrame, axis: str = "velocity") -> pd.DataFrame:
    """Per measure: how many points agree, differ, are undetermined or missing; the largest |z|
    and where it is (at_G_c, at_<axis>)."""
    rows = []
    for m, grp in points.groupby("measure", sort=False):
        counts = grp.verdict.value_counts()
        finite = grp[np.isfinite(grp.z.astype(float))]
        worst = finite.loc[finite.z.abs().idxmax()] if len(finite) else None
        rows.append({"measure": m, "points": len(grp), **{v: int(counts.get(v, 0)) for v in VERDICTS},
                     "max_abs_z": float(abs(worst.z)) if worst is not None else math.nan,
                     "at_G_c": worst.G_c if worst is not None else math.nan,
                     f"at_{axis}": worst[axis] if worst is not None else math.nan})
    return pd.DataFrame(rows, columns=["measure", "points", *VERDICTS, "max_abs_z", "at_G_c", f"at_{axis}"])
