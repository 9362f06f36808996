"""Grain-mass statistics (SPEC 2.5): N(M) in logarithmic bins, moments, counts."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd

from analysis.powerlaw import PowerLawFit, fit_power_law

# SPEC 2.5: grains lighter than this are left out of N(M) (in particle masses m).
SMALL_GRAIN_CUT = {2: 3, 3: 4}


def log_bin_edges(m_min: float, m_max: float, bins_per_decade: int = 5) -> np.ndarray:
    """Logarithmic bin edges covering [m_min, m_max] (inclusive)."""
    if m_max < m_min:
        return np.array([m_min, m_min * 10 ** (1 / bins_per_decade)])
    n = max(1, int(np.ceil(np.log10(m_max / m_min) * bins_per_decade + 1e-9)))
    edges = m_min * 10 ** (np.arange(n + 1) / bins_per_decade)
    if edges[-1] <= m_max:
        edges = np.append(edges, edges[-1] * 10 ** (1 / bins_per_decade))
    return edges


def mass_distribution(masses: np.ndarray, m_min: float, bins_per_decade: int = 5,
                      integer_masses: bool = True) -> pd.DataFrame:
    """N(M): number of grains per unit mass in logarithmic bins, grains with M >= m_min.

    With integer masses (BPM: M = number of particles) a bin's width is the number of
    integers it holds, so N(M) is exactly a count per unit mass. Columns: m_lo, m_hi,
    m_center (geometric), m_mean (mean mass of the bin's grains: the abscissa to fit
    exponents against, since the law varies across a wide bin), count, width, N.
    """
    masses = np.asarray(masses, dtype=float)
    kept = masses[masses >= m_min]
    if len(kept) == 0:
        return pd.DataFrame(columns=["m_lo", "m_hi", "m_center", "m_mean", "count", "width", "N"])
    edges = log_bin_edges(m_min, kept.max(), bins_per_decade)
    counts, _ = np.histogram(kept, bins=edges)
    sums, _ = np.histogram(kept, bins=edges, weights=kept)
    lo, hi = edges[:-1], edges[1:]
    width = (np.ceil(hi) - np.ceil(lo)) if integer_masses else (hi - lo)
    ok = width > 0
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)
    df = pd.DataFrame({"m_lo": lo[ok], "m_hi": hi[ok], "m_center": np.sqrt(lo * hi)[ok], "m_mean": mean[ok],
                       "count": counts[ok], "width": width[ok]})
    df["N"] = df["count"] / df["width"]
    return df


def moments(masses: np.ndarray, orders=(1, 2, 3)) -> dict[str, float]:
    """<M^n> = sum over grains of M^n (SPEC 2.5: not normalised)."""
    m = np.asarray(masses, dtype=float)
    return {f"M{n}": float(np.sum(m ** n)) for n in orders}


def frame_measures(masses: np.ndarray, percolating: np.ndarray, m_min: float,
                   thresholds: tuple[float, ...] = ()) -> dict[str, float]:
    """One frame's row (SPEC 2.5): grain count, grains with M >= m_min and with M >= each
    threshold, largest grain, percolating grains, moments <M^n> = sum of M^n over all grains,
    and M2_nonpercolating, the second moment without grains that wrap the periodic box (the
    intact solid: M^2 ~ N^2 dominates <M^2> until it breaks up)."""
    m = np.asarray(masses, dtype=float)
    perc = np.asarray(percolating, dtype=bool)
    row = {"n_grains": int(len(m)), f"n_grains_M>={m_min:g}": int(np.sum(m >= m_min))}
    for t in thresholds:
        row[f"n_grains_M>={t:g}"] = int(np.sum(m >= t))
    row.update({"largest_grain": float(m.max()), "percolating_grains": int(perc.sum()), **moments(m),
                "M2_nonpercolating": float(np.sum(m[~perc] ** 2))})
    return row


def fit_grain_tau(masses: np.ndarray, m_min: float, percolating: np.ndarray | None = None, discrete: bool = True,
                  n_bootstrap: int = 0, min_grains: int = 10) -> PowerLawFit | None:
    """tau of N(M) ~ M^-tau (SPEC 2.5) by maximum likelihood over the grains M >= m_min.

    Grains that wrap the periodic box (`percolating`) are not finite grains, and the largest
    finite grain is the remnant of the solid until late strains, no draw from the law: both
    are left out. The law is truncated at the largest grain fitted, since a finite system cuts
    it off and an unbounded fit then overestimates tau (1.88 instead of 1.80 for 3e4 grains of
    a discrete law cut at M = 256). None with fewer than min_grains grains fitted.
    """
    m = np.asarray(masses, dtype=float)
    if percolating is not None:
        m = m[~np.asarray(percolating, dtype=bool)]
    kept = np.sort(m[m >= m_min])
    if len(kept) <= min_grains or kept[-2] <= m_min:
        return None
    largest, rest = kept[-1], kept[:-1]
    fit = fit_power_law(rest, xmin=m_min, xmax=float(rest[-1]), discrete=discrete, n_bootstrap=n_bootstrap, seed=0)
    left_out = "percolating grains and the largest finite grain" if percolating is not None and np.any(
        percolating) else "the largest grain"
    return replace(fit, method=fit.method + f"; {left_out} (M = {largest:g}) left out")


def count_above(masses: np.ndarray, threshold: float) -> int:
    return int(np.sum(np.asarray(masses) >= threshold))


def normalised_mass_distribution(masses: np.ndarray, bins_per_decade: int = 5) -> pd.DataFrame:
    """p(m / m_max) of fragments (SPEC 1.5): probability density of x = m / m_max (m_max = the
    largest fragment's mass) in logarithmic bins over [min x, 1], all fragments counted.

    Columns: x_lo, x_hi, x_center (geometric), x_mean (mean x of the bin's fragments), count, p
    (count / (n_fragments * bin width), so that sum p * width = 1).
    """
    m = np.asarray(masses, dtype=float)
    cols = ["x_lo", "x_hi", "x_center", "x_mean", "count", "p"]
    if len(m) == 0 or m.max() <= 0:
        return pd.DataFrame(columns=cols)
    x = m / m.max()
    # edges 10^(-k / bins_per_decade) down from exactly 1 (no bin reaches past x = 1, where no
    # fragment can be); np.histogram closes the last bin, so x = 1 is counted
    k = max(1, int(np.ceil(-np.log10(x.min()) * bins_per_decade - 1e-9)))
    if 10 ** (-k / bins_per_decade) > x.min():
        k += 1
    edges = 10.0 ** (-np.arange(k, -1, -1) / bins_per_decade)
    counts, _ = np.histogram(x, bins=edges)
    sums, _ = np.histogram(x, bins=edges, weights=x)
    lo, hi = edges[:-1], edges[1:]
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)
    return pd.DataFrame({"x_lo": lo, "x_hi": hi, "x_center": np.sqrt(lo * hi), "x_mean": mean,
                         "count": counts, "p": counts / (len(x) * (hi - lo))})


def fit_mass_ratio_law(runs: list[np.ndarray], n_bootstrap: int = 200, min_fragments: int = 20
                       ) -> PowerLawFit | None:
    """tau of p(m/m_max) ~ (m/m_max)^-tau (SPEC 1.5) over the fragments of one or several runs.

    Each run's masses are divided by its largest; that fragment (x = 1 by definition, not a
    draw from the law) is left out, the others pooled, and the law fitted by continuous maximum
    likelihood truncated at x = 1 (no fragment can lie beyond), the lower end chosen by the
    smallest KS distance, with a bootstrap error. None with fewer than min_fragments pooled."""
    pooled = []
    for m in runs:
        m = np.asarray(m, dtype=float)
        if len(m) > 1:
            pooled.append(np.delete(m, np.argmax(m)) / m.max())
    x = np.concatenate(pooled) if pooled else np.empty(0)
    x = x[x > 0]
    if len(x) < min_fragments or x.min() >= 1.0:
        return None
    return fit_power_law(x, xmax=1.0, discrete=False, n_bootstrap=n_bootstrap, seed=0)


def histogram_table(values: np.ndarray, bins: np.ndarray | int, value_range: tuple[float, float] | None = None
                    ) -> pd.DataFrame:
    """Probability density of values in linear bins: lo, hi, center, count, p."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    counts, edges = np.histogram(v, bins=bins, range=value_range)
    width = np.diff(edges)
    with np.errstate(invalid="ignore", divide="ignore"):
        p = counts / (max(len(v), 1) * width)
    return pd.DataFrame({"lo": edges[:-1], "hi": edges[1:], "center": 0.5 * (edges[:-1] + edges[1:]),
                         "count": counts, "p": p})
