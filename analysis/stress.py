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
