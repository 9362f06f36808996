"""Crack speed (SPEC 2.3): where the crack front is against time, from the break-event log of a
mode-I test, its steady speed, and the Rayleigh wave speed it is bounded by.

Front. A mode-I crack from an elliptic void of half-length c runs along the void's plane from
both tips. Each broken bond beyond a tip (|x - x_c| > c) and within `band` of the plane
(|y - y_c| < band) is a point of the crack; the front of a side is the running maximum of
|x - x_c| over that side's breaks in time order, so a break behind the front (a bond left
standing and breaking later) does not move it back.

Steady speed. A least-squares line of the front against time over the middle of its path,
from c + LO (W/2 - c) to c + HI (W/2 - c) (the crack accelerates from the tip and feels the free
edge at the end), per side; the speed is the mean of the sides that have enough points.

Rayleigh speed (linear elasticity; in 2D the network is a plane medium): with the shear speed
c_s = sqrt(G / rho) and the longitudinal speed c_l = sqrt((B + G) / rho) in 2D,
sqrt((B + 4 G / 3) / rho) in 3D, xi = c_R / c_s is the root in (0, 1) of
(2 - xi^2)^2 = 4 sqrt(1 - xi^2) sqrt(1 - xi^2 c_s^2 / c_l^2). A mode-I crack cannot run faster.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from scipy.optimize import brentq

#: The part of the front's path (from the tip to the free edge) the steady speed is fitted on.
LO, HI = 0.25, 0.75
#: Fewest front advances a side needs for its speed.
MIN_POINTS = 4


def crack_fronts(bonds: pd.DataFrame, centre: np.ndarray, c: float, band: float) -> pd.DataFrame:
    """time, side (+1: x > x_c, -1), distance of the break from the centre along x, and the
    front (its running maximum per side), one row per bond break beyond a tip within `band`
    of the void's plane, in time order."""
    dx = bonds.x.to_numpy(float) - centre[0]
    near = (np.abs(dx) > c) & (np.abs(bonds.y.to_numpy(float) - centre[1]) < band)
    ev = pd.DataFrame({"time": bonds.time.to_numpy(float)[near], "side": np.sign(dx[near]).astype(int),
                       "distance": np.abs(dx[near])}).sort_values("time", kind="stable")
    ev["front"] = ev.groupby("side").distance.cummax()
    return ev.reset_index(drop=True)


def steady_speed(fronts: pd.DataFrame, c: float, half_width: float) -> dict:
    """Speed of each side's front (least squares over LO..HI of its path from the tip to the
    edge, on the breaks that advance it), and their mean; NaN where a side has fewer than
    MIN_POINTS such breaks."""
    lo, hi = c + LO * (half_width - c), c + HI * (half_width - c)
    out: dict = {}
    speeds = []
    for side, name in ((1, "right"), (-1, "left")):
        f = fronts[fronts.side == side]
        adv = f[(f.distance == f.front) & (f.front >= lo) & (f.front <= hi)]
        v = se = icpt = float("nan")
        if len(adv) >= MIN_POINTS and adv.time.nunique() >= 2:
            (v, icpt), cov = np.polyfit(adv.time, adv.front, 1, cov=True)
            v, se, icpt = float(v), float(math.sqrt(cov[0, 0])), float(icpt)
            speeds.append((v, se))
        out[f"crack_speed_{name}"] = v
        out[f"crack_speed_{name}_se"] = se
        out[f"crack_front_{name}_intercept"] = icpt
        out[f"crack_points_{name}"] = int(len(adv))
    out["crack_fit_range"] = [lo, hi]
    out["crack_speed"] = float(np.mean([v for v, _ in speeds])) if speeds else float("nan")
    # the mean's uncertainty: the fits' standard errors combined, or half the sides' spread if larger
    se = math.sqrt(sum(e * e for _, e in speeds)) / len(speeds) if speeds else float("nan")
    spread = 0.5 * abs(speeds[0][0] - speeds[1][0]) if len(speeds) == 2 else 0.0
    out["crack_speed_se"] = max(se, spread) if speeds else float("nan")
    return out


def plot_fronts(fronts: pd.DataFrame, fit: dict, c_R: float | None, path) -> None:
    """Front position against time per side, the fitted steady lines over their range, and the
    Rayleigh speed's slope for comparison (dotted, from the start of each fit)."""
    import matplotlib.pyplot as plt  # noqa: PLC0415

    from runfiles.atomic import atomic_save  # noqa: PLC0415

    fig, ax = plt.subplots(figsize=(5.0, 3.6), dpi=150)
    lo, hi = fit["crack_fit_range"]
    for side, name, mk in ((1, "right", "o"), (-1, "left", "s")):
        f = fronts[fronts.side == side]
        if not len(f):
            continue
        line, = ax.plot(f.time, f.front, mk, ms=2, label=f"{name} front")
        v, b = fit[f"crack_speed_{name}"], fit[f"crack_front_{name}_intercept"]
        if np.isfinite(v):
            t = (np.array([lo, hi]) - b) / v
            ax.plot(t, b + v * t, "-", color=line.get_color(), lw=1.5, label=f"{name}: {v:.3g}")
        if c_R and np.isfinite(v):  # from where the fit starts: the slope a front at c_R would have
            t0 = (lo - b) / v
            ax.plot([t0, t0 + (hi - lo) / c_R], [lo, hi], ":", color="k", lw=1)
    ax.set(xlabel=r"time ($\tau$)", ylabel="front distance from the void centre (a)",
           title="crack fronts" + (f" (dotted: Rayleigh speed {c_R:.3g})" if c_R else ""))
    ax.legend(fontsize=7)
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p))
    plt.close(fig)


def rayleigh_speed(B: float, G: float, rho: float, dimension: int) -> float:
    """Rayleigh wave speed of an isotropic medium of moduli B, G and density rho (see above)."""
    c_s2 = G / rho
    c_l2 = (B + G) / rho if dimension == 2 else (B + 4.0 * G / 3.0) / rho
    k = c_s2 / c_l2

    def f(xi: float) -> float:
        x2 = xi * xi
        return (2.0 - x2) ** 2 - 4.0 * math.sqrt(1.0 - x2) * math.sqrt(1.0 - x2 * k)

    # f < 0 just above the trivial root xi = 0 (f ~ -2 (1 - k) xi^2) and f(1) = 1 > 0
    return brentq(f, 1e-3, 1.0 - 1e-12) * math.sqrt(c_s2)
