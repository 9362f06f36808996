"""`driver compare` with `test: crush` (issue 24, point 5; SPEC 4.1): both models, calibrated to
one material, crush grains of the same sizes and seeds between two platens, side by side.

Per grid point (G_c, particle size d) the crush measures of each model over its seeds
(CRUSH_MEASURES: F_c, sigma_c = F_c / d², the travel, work and stiffness up to F_c, the damage,
the fragments at the end), with the impact comparison's verdict on the difference of the means
(driver/compare/stats.py side_by_side: |z| <= z_agree agrees). Per model, point and strength
(analysis/crush.py STRENGTHS: sigma_c of the first peak, SPEC 4.1's, and sigma_max of the largest
force, which differ where the first peak was a local failure), the Weibull fit over the grains
that dropped (analysis.strength.weibull_fit: m, sigma_0 and their pivotal intervals); per
model, G_c and strength, over two sizes or more, the size effect median ~ d^(-b) with 3/m beside
it (analysis.strength.size_effect). These fitted figures agree when their intervals overlap
(`interval_pairs`), as the impact's crossovers do.

Written beside the common tables (compare.py): `weibull.csv` (per model and point),
`size_effect.csv` (per model and G_c), `strength_pairs.csv` (both models' m, sigma_0, b and 3/m
side by side with their verdicts), `plots/` (force against displacement of every grain, the
measures against d, the Weibull plots, the size effect: both models on the same axes).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from analysis.crush import FIRST_PEAK_BELOW_MAX, QUASI_STATIC_TOLERANCE, STRENGTHS
from analysis.strength import MIN_WEIBULL_GRAINS, size_effect, weibull_fit

#: The crush measures compared point by point: column -> (label for plots, meaning and unit).
CRUSH_MEASURES: dict[str, tuple[str, str]] = {
    "F_c": (r"$F_c$ [N]", "first-peak force F_c, N"),
    "sigma_c": (r"$\sigma_c$ [Pa]", "characteristic stress F_c / d², Pa"),
    "F_max": (r"$F_{max}$ [N]", "largest force (the peak before the split the run stopped on), N"),
    "sigma_max": (r"$\sigma_{max}$ [Pa]", "F_max / d², Pa"),
    "u_c": (r"$u_c$ [m]", "platen travel at F_c, m"),
    "loading_stiffness": (r"$K$ [N/m]", "loading stiffness (0.1-0.5 F_c), N/m"),
    "W_p_at_F_c": (r"$W_p(F_c)$ [J]", "platen work up to F_c, J"),
    "F_max_over_F_c": (r"$F_{max}/F_c$", "largest force over F_c (above 1.5: a local first failure)"),
    "D_w_at_F_c": (r"$D_w(F_c)$", "broken area fraction at F_c"),
    "D_w_end": (r"$D_w$ end", "broken area fraction at the end"),
    "largest_fragment_mass_fraction": (r"$m_1/M$", "largest fragment's mass fraction at the end"),
    "n_fragments_multi_cell": (r"$N_{frag}$", "fragments of two or more elements at the end"),
    "shape_elongation_mean": (r"$\langle b/a \rangle$", "mean elongation b/a (multi-element fragments)"),
    "shape_flatness_mean": (r"$\langle c/b \rangle$", "mean flatness c/b (multi-element fragments)"),
}
#: The fitted figures compared by their intervals: name -> (value, lo, hi columns, meaning).
FITTED = {"m": ("m", "m_lo", "m_hi", "Weibull modulus"),
          "sigma_0": ("sigma_0", "sigma_0_lo", "sigma_0_hi", "Weibull sigma_0 (P_s = 1/e), Pa"),
          "b": ("b", "b_lo", "b_hi", "size effect: median strength ~ d^-b"),
          "3/m": ("b_weibull", "b_weibull_lo", "b_weibull_hi", "weakest link 3/m (m at the size with most grains)")}


def _dropped(table: pd.DataFrame) -> pd.DataFrame:
    """The finished runs whose force dropped (F_c a true first peak): the grains a strength
    statistic is taken over (a grain that never dropped has only a lower bound)."""
    done = table[table.state == "finished"] if "state" in table else table
    if "dropped" not in done or done.empty:
        return done.iloc[0:0]
    return done[done.dropped.astype(bool)]


def with_strengths(table: pd.DataFrame) -> pd.DataFrame:
    """`table` with sigma_max = F_max / height² where a run's summary lacks it (STRENGTHS)."""
    if "sigma_max" not in table and {"F_max", "height"} <= set(table.columns):
        return table.assign(sigma_max=table.F_max / table.height ** 2)
    return table


def weibull_table(table: pd.DataFrame) -> pd.DataFrame:
    """Per (model, G_c, diameter, strength): grains finished and dropped, and the Weibull fit of
    their strength (m, sigma_0 and 95 % pivotal intervals; flag under MIN_WEIBULL_GRAINS grains
    or when there is no fit)."""
    table = with_strengths(table)
    done = table[table.state == "finished"] if "state" in table else table
    broke = _dropped(table)
    rows = []
    for (model, g, d), grp in done.groupby(["model", "G_c", "diameter"], sort=True):
        sel = broke[(broke.model == model) & (broke.G_c == g) & (broke.diameter == d)]
        for strength in STRENGTHS:
            s = sel[strength].to_numpy(float) if strength in sel else np.array([])
            s = s[np.isfinite(s)]
            row: dict[str, Any] = {"model": model, "G_c": g, "diameter": d, "strength": strength, "n": len(grp),
                                   "n_dropped": len(s)}
            if np.unique(s).size >= 2:
                fit = weibull_fit(s)
                row.update(m=fit.m, m_lo=fit.m_interval[0], m_hi=fit.m_interval[1], sigma_0=fit.sigma_0,
                           sigma_0_lo=fit.sigma_0_interval[0], sigma_0_hi=fit.sigma_0_interval[1], flag=fit.flag)
            else:
                row.update(dict.fromkeys(("m", "m_lo", "m_hi", "sigma_0", "sigma_0_lo", "sigma_0_hi"), math.nan),
                           flag=f"{len(s)} grains dropped: no Weibull fit (2 distinct strengths needed)")
            rows.append(row)
    return pd.DataFrame(rows, columns=["model", "G_c", "diameter", "strength", "n", "n_dropped", "m", "m_lo", "m_hi",
                                       "sigma_0", "sigma_0_lo", "sigma_0_hi", "flag"])


def size_effect_table(table: pd.DataFrame) -> tuple[pd.DataFrame, dict]:
    """Per (model, G_c, strength) whose dropped grains span two sizes or more: b of median
    strength ~ d^(-b) (d the grain's height between the platens, grouped by the grid's
    diameter) with its interval, and 3/m beside it; and the SizeEffect objects by (model, G_c,
    strength) for the plots."""
    broke = _dropped(with_strengths(table))
    rows, effects = [], {}
    for (model, g), grp in broke.groupby(["model", "G_c"], sort=True):
        for strength in STRENGTHS:
            have = grp[np.isfinite(grp[strength].to_numpy(float))] if strength in grp else grp.iloc[0:0]
            if have.diameter.nunique() < 2:
                continue
            eff = size_effect(have.height.to_numpy(float), have[strength].to_numpy(float),
                              groups=have.diameter.to_numpy())
            effects[model, g, strength] = eff
            rows.append({"model": model, "G_c": g, "strength": strength, "sizes": eff.groups.shape[0],
                         "grains": int(eff.groups.n.sum()), "b": eff.b, "b_lo": eff.b_interval[0],
                         "b_hi": eff.b_interval[1], "b_weibull": eff.b_weibull,
                         "b_weibull_lo": eff.b_weibull_interval[0], "b_weibull_hi": eff.b_weibull_interval[1]})
    return pd.DataFrame(rows, columns=["model", "G_c", "strength", "sizes", "grains", "b", "b_lo", "b_hi", "b_weibull",
                                       "b_weibull_lo", "b_weibull_hi"]), effects


def interval_verdict(lo_a: float, hi_a: float, lo_b: float, hi_b: float) -> str:
    """agree when the two intervals overlap, differ when they do not, undetermined when either
    has no interval (NaN: too few grains for a fit)."""
    if not all(np.isfinite([lo_a, hi_a, lo_b, hi_b])):
        return "undetermined"
    return "agree" if max(lo_a, lo_b) <= min(hi_a, hi_b) else "differ"


def interval_pairs(weibull: pd.DataFrame, sizes: pd.DataFrame, models: tuple[str, str] = ("bcm", "bpm")
                   ) -> pd.DataFrame:
    """Both models' fitted figures side by side, per strength: m and sigma_0 per (G_c,
    diameter), b and 3/m per G_c (diameter NaN), each with value, lo, hi per model and the
    verdict (interval_verdict; missing when a model has no such figure)."""
    a, b = models
    rows = []
    for frame, names, keys in ((weibull, ("m", "sigma_0"), ["strength", "G_c", "diameter"]),
                               (sizes, ("b", "3/m"), ["strength", "G_c"])):
        for point, grp in frame.groupby(keys, sort=False):
            sides = {m: grp[grp.model == m] for m in models}
            for name in names:
                col, lo, hi, _ = FITTED[name]
                row: dict[str, Any] = {"strength": point[0], "G_c": point[1],
                                       "diameter": point[2] if len(point) > 2 else math.nan, "quantity": name}
                for m in models:
                    r = sides[m].iloc[0] if len(sides[m]) else None
                    row.update({f"value_{m}": float(r[col]) if r is not None else math.nan,
                                f"lo_{m}": float(r[lo]) if r is not None else math.nan,
                                f"hi_{m}": float(r[hi]) if r is not None else math.nan})
                row["verdict"] = ("missing" if not (np.isfinite(row[f"value_{a}"]) and np.isfinite(row[f"value_{b}"]))
                                  else interval_verdict(row[f"lo_{a}"], row[f"hi_{a}"], row[f"lo_{b}"], row[f"hi_{b}"]))
                rows.append(row)
    return pd.DataFrame(rows, columns=["strength", "G_c", "diameter", "quantity",
                                       *[f"{s}_{m}" for m in models for s in ("value", "lo", "hi")], "verdict"])


def crush_flags(table: pd.DataFrame) -> list[str]:
    """The report's flags on single grains, from the runs table: no drop (F_c only the largest
    force), a local first failure (F_max above FIRST_PEAK_BELOW_MAX F_c), not quasi-static (the
    platens' forces apart by more than QUASI_STATIC_TOLERANCE of F_c while loading)."""
    done = table[table.state == "finished"] if "state" in table else table
    out = []

    def names(rows: pd.DataFrame) -> str:
        return ", ".join(f"{r.model.upper()} d = {r.diameter * 1e3:g} mm seed {r.seed}" for r in rows.itertuples())

    def grains(n: int) -> str:
        return f"{n} grain" + ("" if n == 1 else "s")

    if "dropped" in done:
        never = done[~done.dropped.astype(bool)]
        if len(never):
            out.append(f"{grains(len(never))} never dropped (F_c only the largest force recorded; left out of the "
                       f"Weibull and size-effect fits): {names(never)}.")
    if "F_max_over_F_c" in done:
        local = done[done.F_max_over_F_c > FIRST_PEAK_BELOW_MAX]
        if len(local):
            out.append(f"{grains(len(local))} carried more than {FIRST_PEAK_BELOW_MAX:g} F_c after their first drop (a "
                       f"local failure under a platen made the first peak; F_c is still that peak): {names(local)}.")
    if "force_mismatch_loading" in done:
        fast = done[done.force_mismatch_loading > QUASI_STATIC_TOLERANCE]
        if len(fast):
            out.append(f"{grains(len(fast))} not quasi-static (the platens' forces more than "
                       f"{QUASI_STATIC_TOLERANCE:g} F_c apart, rms, while loading; lower scenario.platen_speed): "
                       f"{names(fast)}.")
    return out


def strength_words(pairs: pd.DataFrame, weibull: pd.DataFrame) -> list[str]:
    """The report's sentences on the fitted figures, from strength_pairs and the Weibull table."""
    out, unfitted = [], []
    for r in pairs.itertuples():
        where = (f"{r.strength}, G_c = {r.G_c:g}"
                 + (f", d = {r.diameter * 1e3:g} mm" if np.isfinite(r.diameter) else ""))
        if r.verdict == "missing":
            unfitted.append(f"{r.quantity} ({where})")
            continue
        sides = "; ".join(f"{m.upper()} {getattr(r, f'value_{m}'):.3g} [{getattr(r, f'lo_{m}'):.3g}, "
                          f"{getattr(r, f'hi_{m}'):.3g}]" for m in ("bcm", "bpm"))
        verdict = {"agree": "the intervals overlap (agree)", "differ": "the intervals do not overlap (differ)",
                   "undetermined": "no interval on one side (undetermined)"}[r.verdict]
        out.append(f"{r.quantity} ({FITTED[r.quantity][3]}), {where}: {sides}: {verdict}.")
    if unfitted:
        out.append(f"Not fitted in one model or both (fewer than 2 grains that dropped at a size, or fewer than 2 "
                   f"sizes): {', '.join(unfitted)}.")
    few = weibull[(weibull.n_dropped >= 2) & (weibull.n_dropped < MIN_WEIBULL_GRAINS)]
    if len(few):
        out.append(f"Weibull fits over fewer than {MIN_WEIBULL_GRAINS} grains ({len(few)} of {len(weibull)}): their "
                   "intervals are wide and the maximum-likelihood m is biased upwards (analysis/strength.py "
                   "MIN_WEIBULL_GRAINS); an overlap of such intervals says little.")
    return out


def force_curves(table: pd.DataFrame) -> dict[tuple[str, float], list[dict[str, Any]]]:
    """Each finished grain's force against displacement (its results/crush table: u, F_upper)
    with its F_c and u_c, by (model, diameter)."""
    out: dict[tuple[str, float], list[dict[str, Any]]] = {}
    done = table[table.state == "finished"] if "state" in table else table
    for r in done.itertuples():
        f = Path(r.run_dir) / "results" / "crush.parquet"
        if not f.exists():
            continue
        rec = pd.read_parquet(f, columns=["u", "F_upper"])
        out.setdefault((r.model, r.diameter), []).append(
            {"u": rec.u.to_numpy(), "F": rec.F_upper.to_numpy(), "u_c": r.u_c, "F_c": r.F_c, "seed": r.seed})
    return out
