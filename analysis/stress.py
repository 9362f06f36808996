"""Stress measures of a shear run (SPEC 2.4) from LAMMPS's pressure tensor."""

from __future__ import annotations

import numpy as np
import pandas as pd


def stress_measures(table: pd.DataFrame, dimension: int) -> pd.DataFrame:
    """Add P, sqrt(J2) and mu = sqrt(J2)/P to a table with columns pxx..pyz.

    The pressure tensor (virial + kinetic) is minus the stress tensor; its deviatoric part
    is the same up to sign, so J2 = 1/2 s:s is read off it directly. In 2D only the in-plane
    components enter and P is the in-plane mean.
    """
    t = table.copy()
    if dimension == 2:
        p = 0.5 * (t.pxx + t.pyy)
        sxx, syy = t.pxx - p, t.pyy - p
        j2 = 0.5 * (sxx ** 2 + syy ** 2) + t.pxy ** 2
    else:
        p = (t.pxx + t.pyy + t.pzz) / 3.0
        sxx, syy, szz = t.pxx - p, t.pyy - p, t.pzz - p
        j2 = 0.5 * (sxx ** 2 + syy ** 2 + szz ** 2) + t.pxy ** 2 + t.pxz ** 2 + t.pyz ** 2
    t["P"] = p
    t["sqrtJ2"] = np.sqrt(j2)
    t["mu"] = np.where(p > 0, t["sqrtJ2"] / p.where(p > 0, np.nan), np.nan)
    return t


def inertial_number(strain_rate: float, mean_diameter: float, density: np.ndarray,
                    pressure: np.ndarray) -> np.ndarray:
    """I = edot <d> sqrt(rho / P) (SPEC 2.4); NaN where P <= 0."""
    p = np.asarray(pressure, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(p > 0, strain_rate * mean_diameter * np.sqrt(np.asarray(density) / p), np.nan)


STRESS_WINDOW = 0.2  # the averaging window: the last 20 % of the strain reached (steady flow)
N_BLOCKS = 10  # blocks behind the standard error of a window mean


def block_mean(values, n_blocks: int = N_BLOCKS) -> dict:
    """Mean of a time-ordered series and its standard error from block averages: the series
    (NaNs dropped) is cut into n_blocks contiguous blocks of (nearly) equal length, and
    SE = std(block means, ddof=1) / sqrt(n_blocks), which accounts for correlations shorter
    than a block (samples a few records apart are correlated; their plain std / sqrt(n)
    understates the error). Fewer than 2 samples per block: fewer blocks, down to 4; below
    that se is None. Returns mean, se, n (samples), blocks."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if not len(v):
        return {"mean": None, "se": None, "n": 0, "blocks": 0}
    blocks = min(n_blocks, len(v) // 2)
    if blocks < 4:
        return {"mean": float(v.mean()), "se": None, "n": int(len(v)), "blocks": 0}
    means = np.array([b.mean() for b in np.array_split(v, blocks)])
    return {"mean": float(v.mean()), "se": float(means.std(ddof=1) / np.sqrt(blocks)), "n": int(len(v)),
            "blocks": int(blocks)}


def stress_windows(stress: pd.DataFrame, width: float = STRESS_WINDOW, n_blocks: int = N_BLOCKS,
                   columns=("mu", "P", "sqrtJ2")) -> pd.DataFrame:
    """Window means of mu, P and sqrt(J2) with block-average standard errors (block_mean):
    consecutive strain windows of `width` times the final strain, the last one ending at it,
    each closed above ((lo, hi], the first [0, hi]). mu is averaged sample by sample (records
    with P <= 0, where it is undefined, left out). One row per window: strain_lo, strain_hi,
    n, then <col>_mean, <col>_se, <col>_blocks per column."""
    strain = stress["strain"].to_numpy(dtype=float)
    final = float(strain.max()) if len(strain) else 0.0
    rows = []
    if not final > 0:
        return pd.DataFrame(rows)
    edges = np.linspace(0.0, final, int(round(1 / width)) + 1)
    for k, (lo, hi) in enumerate(zip(edges[:-1], edges[1:])):
        inside = (strain > lo) & (strain <= hi) if k else (strain >= lo) & (strain <= hi)
        row = {"strain_lo": float(lo), "strain_hi": float(hi), "n": int(inside.sum())}
        for col in columns:
            m = block_mean(stress.loc[inside, col], n_blocks)
            row.update({f"{col}_mean": m["mean"], f"{col}_se": m["se"], f"{col}_blocks": m["blocks"]})
        rows.append(row)
    return pd.DataFrame(rows)
