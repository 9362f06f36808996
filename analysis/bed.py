"""Confined compression of a bed of breakable grains (issue 25): the compression curve, the
lateral stress ratio, the grading of the fragments and how far the bed has broken, and the
energy account. Pure functions on arrays and tables; no LAMMPS.

Conventions: stresses compressive positive, Pa; sizes in m; masses in kg; energies in J.
The time record is one row per record step (columns read by name: `sigma_v`, `sigma_h`,
`void_ratio`, `W_p`, the energy channels); a fragment table is one row per fragment, with
`grain` (the intact grain it is a part of), `mass` and the box a >= b >= c of
analysis/fragment_shapes.py; a grain table is one row per intact grain (`grain`, `mass`,
`diameter`).

Rules, each stated once here and in the docstring of its function:

- yield stress (yield_stress): two least-squares lines of e against log10 sigma_v, fitted
  independently (not forced to meet), split at the data point that minimises their total
  squared residual; sigma_y at their intersection, clamped to the data; C_c and C_s the
  negated slopes after and before; the knee flagged as not resolved unless C_c > 0 and
  C_c >= KNEE_RATIO C_s, with their difference above KNEE_Z standard errors;
- sieve size (grading_curve): a fragment passes a sieve of opening d when its intermediate
  box dimension b <= d (a sieve sorts by the second-largest dimension);
- Hardin's B_r (hardin_breakage): Hardin (1985), cut D_cut = 0.074 mm (the No. 200 sieve,
  HARDIN_CUT) unless given;
- Einav's B (einav_breakage): Einav (2007), ultimate grading (d / d_M)^(3 - alpha),
  alpha = 2.5 (EINAV_ALPHA) unless given, d_m given by the caller;
- broken grain (grain_breakage): its largest fragment holds less than 0.9 (BROKEN_BELOW) of
  its mass.

The gradings are step functions (each fragment's mass sits at its size), integrated exactly
on a log10 size axis: the area of a step is its mass fraction times a difference of log10
sizes, so no sampling of the curves enters any measure.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

KNEE_RATIO = 2.0
"""A knee is resolved only when the post-yield slope C_c is at least KNEE_RATIO times the
pre-yield slope C_s. On a straight line (no knee) the best split returns two equal slopes,
ratio 1; on the compression curve of a crushable sand C_c is typically 5 to 50 times C_s,
so a factor of 2 rejects the first and keeps the second with a wide margin."""
KNEE_Z = 5.0
"""and only when C_c - C_s exceeds KNEE_Z times its standard error (the two slopes' standard
errors from their residuals, added in quadrature): noise on a flat or straight curve makes the
post-yield line steeper by chance, and the split chosen as the best of many picks the largest
such chance. Measured on straight and flat lines of 41 and 401 points with Gaussian noise in e,
1000 seeds each, the knee was wrongly resolved in 4-8 % of them at 3 standard errors, 2-4 % at
4 and 1.5-2 % at 5; the knee of the tests' synthetic curve (C_c = 15 C_s, noise 1e-3 in e)
stands out by about 500."""
MIN_SIDE = 3
"""Points needed on each side of the knee: a line through 2 points has no residual, so any
split would fit them perfectly."""
HARDIN_CUT = 0.074e-3
"""Hardin's (1985) cut size D_cut, m: the No. 200 sieve, 0.074 mm, below which Hardin takes
a soil's particles to break no further. Our grains are 1 to 3 mm and their cells ~0.3 mm, so a
bed of single cells already reaches the smallest fragment the models can make, far above
this cut: with the default, B_r stays well below 1 however much the bed breaks (a bed of
single cells of b = 0.3 mm from grains of b = 2 mm gives B_r = log10(2/0.3)/log10(2/0.074) = 0.58).
Pass the cell size as d_cut for a measure that reaches 1 when every grain is dust of
single cells."""
EINAV_ALPHA = 2.5
"""The fractal dimension alpha of Einav's (2007) ultimate grading F_u(d) = (d / d_M)^(3 - alpha):
values of about 2.5 to 2.9 are measured on crushed granular materials (2.58 in fault gouge,
Sammis et al. 1987); the lower end by default, a parameter everywhere it enters."""
BROKEN_BELOW = 0.9
"""A grain is broken when its largest fragment holds less than this fraction of its mass:
chipping of a few cells at the contacts (a few % of the mass) is not breaking the grain."""


def _series(name: str, values: ArrayLike) -> np.ndarray:
    """A finite 1-D float array, or a ValueError naming the argument."""
    a = np.asarray(values, dtype=float)
    if a.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} holds {int(np.sum(~np.isfinite(a)))} non-finite values")
    return a


# ---------------------------------------------------------------------------------------
# State of the bed


def void_ratio(box_volume: ArrayLike, solid_volume: ArrayLike) -> np.ndarray | float:
    """e = V_box / V_solid - 1: the volume of the voids over that of the solid (arrays broadcast).

    box_volume: the volume between the platens and walls; solid_volume: the grains' (the sum of
    their cells' volumes, constant while they break), both m³ and positive.
    """
    vb, vs = np.asarray(box_volume, dtype=float), np.asarray(solid_volume, dtype=float)
    if np.any(~np.isfinite(vs)) or np.any(vs <= 0):
        raise ValueError("solid_volume must be finite and positive")
    if np.any(~np.isfinite(vb)) or np.any(vb <= 0):
        raise ValueError("box_volume must be finite and positive")
    out = vb / vs - 1.0
    return float(out) if out.ndim == 0 else out


def K0(sigma_h: ArrayLike, sigma_v: ArrayLike) -> np.ndarray | float:
    """K_0 = sigma_h / sigma_v, the ratio of the lateral (mean side-wall) to the vertical stress
    under no lateral strain; NaN where sigma_v <= 0 (the bed not loaded)."""
    h, v = np.asarray(sigma_h, dtype=float), np.asarray(sigma_v, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(v > 0, h / np.where(v > 0, v, 1.0), np.nan)
    return float(out) if out.ndim == 0 else out


def mean_K0(sigma_h: ArrayLike, sigma_v: ArrayLike, lo: float, hi: float) -> float:
    """The mean of K_0 = sigma_h / sigma_v over the records with lo <= sigma_v <= hi (Pa).

    A window, because K_0 is not constant through the test: at low stress it reflects how the
    bed was deposited, and on normal compression it settles to a constant (Jaky's
    1 - sin(phi') for sand)."""
    h, v = _series("sigma_h", sigma_h), _series("sigma_v", sigma_v)
    if h.shape != v.shape:
        raise ValueError(f"sigma_h ({h.size} records) and sigma_v ({v.size} records) differ in length")
    if not 0 < lo <= hi:
        raise ValueError(f"lo = {lo:g}, hi = {hi:g}: need 0 < lo <= hi")
    inside = (v >= lo) & (v <= hi)
    if not inside.any():
        raise ValueError(f"no record with sigma_v in [{lo:g}, {hi:g}] Pa")
    return float(np.mean(h[inside] / v[inside]))


# ---------------------------------------------------------------------------------------
# Compression curve


def loading_branch(record: pd.DataFrame, column: str = "sigma_v") -> pd.DataFrame:
    """The rows of `record` up to and including the first largest `column` (the monotonic
    loading part of a load-unload test), of those with column > 0 (a logarithm needs them)."""
    s = record[column].to_numpy(dtype=float)
    if s.size == 0 or not np.any(s > 0):
        raise ValueError(f"{column} is never positive: the bed was not loaded in this record")
    head = record.iloc[: int(np.nanargmax(s)) + 1]
    return head[head[column].to_numpy(dtype=float) > 0]


@dataclass(frozen=True)
class CompressionFit:
    """The bilinear fit of a compression curve e(log10 sigma_v) (yield_stress).

    sigma_y: the yield stress, Pa (NaN when the two lines are parallel or the fit impossible);
    C_c: compression index, -de/dlog10(sigma_v) of the post-yield line; C_s: the same of the
    pre-yield line (the recompression / swelling-like index); pre, post: (slope, intercept) of
    e = slope log10(sigma_v) + intercept of the two lines; split: how many of the points
    (sorted by sigma_v) are on the pre-yield line, the rest on the post-yield one; ssr: the
    total squared residual of the two lines; C_c_stderr, C_s_stderr: the slopes' standard
    errors; flag: why the knee is not resolved (None when it is); rule: the rule, in words.
    """

    sigma_y: float
    C_c: float
    C_s: float
    pre: tuple[float, float]
    post: tuple[float, float]
    split: int
    n: int
    ssr: float
    C_c_stderr: float
    C_s_stderr: float
    flag: str | None
    rule: str

    def e_pre(self, sigma_v: ArrayLike) -> np.ndarray:
        """e on the pre-yield line at sigma_v (Pa)."""
        return self.pre[0] * np.log10(np.asarray(sigma_v, dtype=float)) + self.pre[1]

    def e_post(self, sigma_v: ArrayLike) -> np.ndarray:
        """e on the post-yield line at sigma_v (Pa)."""
        return self.post[0] * np.log10(np.asarray(sigma_v, dtype=float)) + self.post[1]


YIELD_RULE = ("two least-squares lines of e against log10(sigma_v), fitted independently (not forced to meet), "
              "the points sorted by sigma_v and split where the two lines' total squared residual is least, "
              f"at least {MIN_SIDE} points on each side; sigma_y where the lines intersect, clamped to the data's "
              "stress range; C_c = -slope after the split, C_s = -slope before; the knee is resolved when "
              f"C_c > 0, C_c >= {KNEE_RATIO:g} C_s and C_c - C_s > {KNEE_Z:g} standard errors")


def _line(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float, float]:
    """(slope, intercept, squared residual, slope standard error) of the least-squares line."""
    xm, ym = x.mean(), y.mean()
    dx, dy = x - xm, y - ym
    sxx = float(dx @ dx)
    slope = float(dx @ dy) / sxx
    ssr = float(np.sum((dy - slope * dx) ** 2))
    se = float(np.sqrt(ssr / (x.size - 2) / sxx)) if x.size > 2 else float("nan")
    return slope, float(ym - slope * xm), ssr, se


def _split_residuals(x: np.ndarray, y: np.ndarray, m: int) -> np.ndarray:
    """Total squared residual of the two lines for each split k = m..n-m (the first k points
    on one line, the rest on the other), from prefix sums: O(n) for all splits. inf where a
    side's x are all equal (no line)."""
    x, y = x - x.mean(), y - y.mean()  # centred, so the sums below do not cancel badly
    sums = [np.concatenate([[0.0], np.cumsum(v)]) for v in (np.ones_like(x), x, y, x * x, x * y, y * y)]
    k = np.arange(m, x.size - m + 1)

    def ssr(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        n, sx, sy, sxx, sxy, syy = (s[hi] - s[lo] for s in sums)
        vxx, vxy, vyy = sxx - sx * sx / n, sxy - sx * sy / n, syy - sy * sy / n
        with np.errstate(divide="ignore", invalid="ignore"):
            out = vyy - vxy * vxy / vxx
        scale = np.maximum(sxx, 1e-300)
        return np.where(vxx > 1e-12 * scale, np.maximum(out, 0.0), np.inf)

    return ssr(np.zeros_like(k), k) + ssr(k, np.full_like(k, x.size))


def yield_stress(sigma_v: ArrayLike, e: ArrayLike, knee_ratio: float = KNEE_RATIO, knee_z: float = KNEE_Z,
                 min_side: int = MIN_SIDE) -> CompressionFit:
    """The yield stress sigma_y and compression index C_c of a compression curve by a bilinear fit.

    Rule (YIELD_RULE): with x = log10(sigma_v), points sorted by x, for every split k with at
    least `min_side` points on each side the first k points and the others are fitted each by
    its own least-squares line (the two lines are not forced to meet), and the split of least
    total squared residual is kept (the first among equals). sigma_y = 10^x* at the lines'
    intersection x* = (b_post - b_pre) / (a_pre - a_post), clamped to the data's range of x.
    C_c = -a_post and C_s = -a_pre (de / dlog10 sigma_v, positive when e falls with stress).
    The yield stress is where the two straight parts of the e-log10 sigma curve meet (the
    bilinear construction; Casagrande's needs the point of largest curvature, which noise in a
    record moves about); choosing the breakpoint by least squares makes it reproducible.

    The knee is flagged as not resolved (flag, a sentence) when there are fewer than
    2 min_side points, e is constant, C_c <= 0, C_c < knee_ratio C_s (a straight line gives 1),
    C_c - C_s <= knee_z times its standard error (sqrt(se_pre² + se_post²)), the lines are
    parallel (sigma_y NaN) or their intersection falls outside the data (clamped).

    sigma_v: (n,) positive vertical stresses, Pa; e: (n,) void ratios; of the loading branch
    only (loading_branch). Points at very low stress (first touch) spread over decades of
    log10 sigma_v and weigh on the pre-yield line: leave them out before the fit if they are
    not part of the compression.
    """
    s, ee = _series("sigma_v", sigma_v), _series("e", e)
    if s.shape != ee.shape:
        raise ValueError(f"sigma_v ({s.size} points) and e ({ee.size} points) differ in length")
    if np.any(s <= 0):
        raise ValueError(f"sigma_v must be positive: {int(np.sum(s <= 0))} values <= 0 (use loading_branch)")
    if min_side < 3:
        raise ValueError(f"min_side = {min_side}: needs 3 or more (2 points fit any line exactly)")
    order = np.argsort(s, kind="stable")
    x, y = np.log10(s[order]), ee[order]
    nan = float("nan")
    if x.size < 2 * min_side:
        return CompressionFit(nan, nan, nan, (nan, nan), (nan, nan), 0, int(x.size), nan, nan, nan,
                              f"{x.size} points, fewer than {2 * min_side}: no knee can be resolved "
                              f"({min_side} on each side)", YIELD_RULE)
    total = _split_residuals(x, y, min_side)
    if not np.any(np.isfinite(total)):
        return CompressionFit(nan, nan, nan, (nan, nan), (nan, nan), 0, int(x.size), nan, nan, nan,
                              "sigma_v does not vary on either side of any split: no line to fit", YIELD_RULE)
    k = min_side + int(np.argmin(total))
    a1, b1, r1, se1 = _line(x[:k], y[:k])
    a2, b2, r2, se2 = _line(x[k:], y[k:])
    c_c, c_s = -a2, -a1
    flags = []
    if np.ptp(y) == 0:
        flags.append("e is constant")
    if a1 == a2:
        sigma_y = nan
        flags.append("the two lines are parallel")
    else:
        xs = (b2 - b1) / (a1 - a2)
        if not x[0] <= xs <= x[-1]:
            # in log10: lines nearly parallel meet far away, beyond a float's range in Pa
            flags.append(f"the lines meet at log10(sigma_v / Pa) = {xs:.4g}, outside the data's "
                         f"[{x[0]:.4g}, {x[-1]:.4g}] (clamped)")
        sigma_y = float(10 ** np.clip(xs, x[0], x[-1]))
    if not c_c > 0:
        flags.append(f"the post-yield line does not fall (C_c = {c_c:.3g})")
    elif not c_c >= knee_ratio * c_s:
        flags.append(f"the post-yield line is not {knee_ratio:g} times as steep as the pre-yield one "
                     f"(C_c = {c_c:.3g}, C_s = {c_s:.3g})")
    se = float(np.hypot(se1, se2))
    if c_c > 0 and not c_c - c_s > knee_z * se:
        flags.append(f"C_c - C_s = {c_c - c_s:.3g} is within {knee_z:g} standard errors ({se:.3g})")
    flag = "; ".join(flags) + ": no knee resolved" if flags else None
    return CompressionFit(sigma_y, float(c_c), float(c_s), (a1, b1), (a2, b2), k, int(x.size), r1 + r2, se2, se1,
                          flag, YIELD_RULE)


# ---------------------------------------------------------------------------------------
# Grading


def grading_curve(fragments: pd.DataFrame, size: str = "b", mass: str = "mass") -> pd.DataFrame:
    """The grading curve of a fragment table: one row per distinct size, ascending, with
    size (m), mass_fraction (the mass at that size over the total) and passing (the fraction
    of the mass at that size or below).

    A fragment's sieve size is its intermediate box dimension b (a >= b >= c of
    analysis/fragment_shapes.py): a fragment passes a square opening when its two smaller
    dimensions do, whatever its length a. Pass size="diameter" for a grain table.
    The curve is a step function: passing_at reads it so.
    """
    d = _series(size, fragments[size])
    m = _series(mass, fragments[mass])
    if d.size == 0:
        raise ValueError("no fragments")
    if np.any(d < 0) or np.any(m < 0):
        raise ValueError(f"{size} and {mass} must be non-negative")
    total = m.sum()
    if total <= 0:
        raise ValueError("the fragments have no mass")
    sizes, inverse = np.unique(d, return_inverse=True)
    fraction = np.bincount(inverse, weights=m, minlength=sizes.size) / total
    passing = np.cumsum(fraction)
    passing[-1] = 1.0  # the whole mass passes the largest size; no rounding left
    return pd.DataFrame({"size": sizes, "mass_fraction": fraction, "passing": passing})


def passing_at(curve: pd.DataFrame, sizes: ArrayLike) -> np.ndarray | float:
    """The fraction of the mass passing sieves of opening `sizes` (m): the step function of
    the curve, the mass of fragments of size <= d (0 below the smallest fragment, 1 from the
    largest on)."""
    d = np.asarray(sizes, dtype=float)
    i = np.searchsorted(curve["size"].to_numpy(dtype=float), d, side="right")
    out = np.concatenate([[0.0], curve["passing"].to_numpy(dtype=float)])[i]
    return float(out) if out.ndim == 0 else out


def _steps(curve: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """(sizes, mass fraction at each) of a grading curve, checked: ascending sizes, passing
    non-decreasing from >= 0 to 1."""
    d = _series("size", curve["size"])
    p = _series("passing", curve["passing"])
    if d.size == 0:
        raise ValueError("empty grading curve")
    if np.any(np.diff(d) <= 0) or d[0] < 0:
        raise ValueError("grading curve sizes must be non-negative and strictly ascending")
    w = np.diff(p, prepend=0.0)
    if np.any(w < -1e-12) or abs(p[-1] - 1.0) > 1e-9:
        raise ValueError("grading curve passing must rise from >= 0 to 1")
    return d, w


@dataclass(frozen=True)
class Breakage:
    """A relative breakage: total (the area the grading has moved), potential (the area it
    can move), relative = total / potential; the areas on a log10 size axis."""

    total: float
    potential: float
    relative: float


def hardin_potential(curve: pd.DataFrame, d_cut: float = HARDIN_CUT) -> float:
    """Hardin's (1985) breakage potential of a grading, B_p = integral over the mass of b_p,
    with b_p(D) = log10(D / D_cut) for D > D_cut and 0 below.

    Equivalently the area, on a log10 D axis, between the line D = D_cut and the grading
    curve, above D_cut: swapping the integrals, B_p = integral from log10 D_cut up of
    (1 - F(D)) dlog10 D. Exact for the step curve: the sum of each step's mass fraction times
    its b_p.
    """
    if not d_cut > 0:
        raise ValueError(f"d_cut = {d_cut:g}: must be positive")
    d, w = _steps(curve)
    bp = np.log10(np.maximum(d, d_cut) / d_cut)  # b_p = 0 at and below the cut
    return float(w @ bp)


def hardin_breakage(original: pd.DataFrame, current: pd.DataFrame, d_cut: float = HARDIN_CUT) -> Breakage:
    """Hardin's (1985, J. Geotech. Eng. 111(10)) relative breakage B_r = B_t / B_p.

    B_p = hardin_potential(original): the area between the original grading curve and
    the vertical line D = d_cut on a log10 D axis, above d_cut; B_t = B_p(original) -
    B_p(current): the area between the original and current curves above d_cut (signed:
    negative if the current grading were coarser). B_r = 0 for the original grading, 1 when
    all the mass has passed below d_cut.

    original, current: grading curves (grading_curve) on the same size measure, e.g. the
    fragment table of the intact bed and that at a stress, both by b: taking the original
    from the grains' diameters instead would count the difference between a grain's
    diameter and its b as breakage. d_cut: Hardin's 0.074 mm (the No. 200 sieve,
    HARDIN_CUT) by default; see HARDIN_CUT for why the cell size may be the better cut here.
    """
    bp = hardin_potential(original, d_cut)
    if bp <= 0:
        raise ValueError(f"the original grading lies below d_cut = {d_cut:g} m: no breakage potential")
    bt = bp - hardin_potential(current, d_cut)
    return Breakage(bt, bp, bt / bp)


def ultimate_passing(d: ArrayLike, d_M: float, alpha: float = EINAV_ALPHA) -> np.ndarray | float:
    """Einav's (2007) ultimate grading F_u(d) = (d / d_M)^(3 - alpha) for d <= d_M, 1 above:
    the fractal grading of a fully crushed material (fractal dimension alpha < 3)."""
    if not alpha < 3:
        raise ValueError(f"alpha = {alpha:g}: must be below 3")
    dd = np.asarray(d, dtype=float)
    out = np.minimum(dd / d_M, 1.0) ** (3.0 - alpha)
    return float(out) if out.ndim == 0 else out


def _step_area(d: np.ndarray, w: np.ndarray, lo: float, hi: float) -> float:
    """integral of the step curve's passing F over log10 d in [lo, hi] (lo, hi as log10 of
    sizes): a step of mass w at size d passes from log10 d on, so it adds w times the length
    of [max(lo, log10 d), hi]."""
    with np.errstate(divide="ignore"):
        x = np.log10(d)
    return float(w @ np.clip(hi - np.maximum(x, lo), 0.0, None))


def einav_breakage(initial: pd.DataFrame, current: pd.DataFrame, d_m: float, d_M: float | None = None,
                   alpha: float = EINAV_ALPHA) -> Breakage:
    """Einav's (2007, "Breakage mechanics - Part I", JMPS 55) relative breakage B.

        B = integral [F(d) - F_0(d)] dlog10 d / integral [F_u(d) - F_0(d)] dlog10 d,

    both from d_m to d_M: the area between the current and initial grading curves over the
    area between the ultimate and initial ones, on a log10 d axis (Hardin's B_r with the
    ultimate grading in place of the vertical line at the cut). F_u(d) = (d / d_M)^(3 - alpha)
    (ultimate_passing), integrated in closed form: with k = 3 - alpha,
    integral of (d / d_M)^k dlog10 d from d_m to d_M = (1 - (d_m / d_M)^k) / (k ln 10)
    (log10(d_M / d_m) when k = 0). The step curves are integrated exactly (_step_area).
    B = 0 for the initial grading, 1 for the ultimate one, and a current grading
    (1 - B) F_0 + B F_u has breakage B.

    initial, current: grading curves (grading_curve) on the same size measure. d_m: the
    smallest size, given by the caller: the smallest fragment the model can make (a single
    cell's size), so that B measures the way to the finest grading the bed can reach (Einav's
    d_m is the smallest grain of the ultimate grading); mass below d_m counts as passing at
    d_m. d_M: the largest size of the initial grading by default. alpha: EINAV_ALPHA (2.5).
    """
    if not alpha < 3:
        raise ValueError(f"alpha = {alpha:g}: must be below 3")
    d0, w0 = _steps(initial)
    d1, w1 = _steps(current)
    d_M = float(d0[-1]) if d_M is None else float(d_M)
    if not 0 < d_m < d_M:
        raise ValueError(f"d_m = {d_m:g}, d_M = {d_M:g}: need 0 < d_m < d_M")
    lo, hi = np.log10(d_m), np.log10(d_M)
    k = 3.0 - alpha
    ultimate = (1.0 - (d_m / d_M) ** k) / (k * np.log(10.0)) if k != 0 else hi - lo
    a0 = _step_area(d0, w0, lo, hi)
    potential = ultimate - a0
    if potential <= 0:
        raise ValueError("the initial grading is not coarser than the ultimate one: no breakage potential")
    total = _step_area(d1, w1, lo, hi) - a0
    return Breakage(float(total), float(potential), float(total / potential))


# ---------------------------------------------------------------------------------------
# Grains


def grain_breakage(fragments: pd.DataFrame, grains: pd.DataFrame, broken_below: float = BROKEN_BELOW) -> pd.DataFrame:
    """Per intact grain: grain, mass (the intact grain's, kg), n_fragments, largest_fraction
    (its largest fragment's mass over its mass) and broken (largest_fraction < broken_below,
    0.9 by default, BROKEN_BELOW), ordered by grain.

    fragments: one row per fragment with `grain` and `mass` (a fragment is always a part of one
    grain); grains: one row per grain with `grain` and `mass`. Every grain must have a
    fragment (an intact grain is one) and every fragment a grain.
    """
    if not 0 < broken_below <= 1:
        raise ValueError(f"broken_below = {broken_below:g}: must be in (0, 1]")
    g = grains[["grain", "mass"]].sort_values("grain", kind="stable").reset_index(drop=True)
    if g.grain.duplicated().any():
        raise ValueError("grains: a grain id appears twice")
    if not np.all(g["mass"].to_numpy(dtype=float) > 0):
        raise ValueError("grains: masses must be positive")
    unknown = set(fragments.grain) - set(g.grain)
    if unknown:
        raise ValueError(f"fragments of {len(unknown)} grains not in the grain table (e.g. {min(unknown)})")
    per = fragments.groupby("grain")["mass"].agg(n_fragments="size", largest="max")
    missing = set(g.grain) - set(per.index)
    if missing:
        raise ValueError(f"{len(missing)} grains have no fragment (e.g. {min(missing)})")
    per = per.reindex(g.grain)
    out = g.assign(n_fragments=per.n_fragments.to_numpy(dtype=np.int64),
                   largest_fraction=per.largest.to_numpy(dtype=float) / g["mass"].to_numpy(dtype=float))
    out["broken"] = out.largest_fraction < broken_below
    return out


def fraction_broken(table: pd.DataFrame) -> float:
    """The fraction of the grains that are broken, by number, of a grain_breakage table."""
    if len(table) == 0:
        raise ValueError("no grains")
    return float(table.broken.to_numpy(dtype=bool).mean())


# ---------------------------------------------------------------------------------------
# Energy account


def energy_balance(record: pd.DataFrame, channels: Sequence[str], stored: Sequence[str] = ("kinetic", "elastic"),
                   work: str = "W_p") -> pd.DataFrame:
    """The energy account of the bed at each record: the platen work against what became of it,

        residual = W_p - (stored + sum of channels), every term counted from the first record,

    where `stored` are the energies held in the bed (kinetic, elastic: their change since the
    first record) and `channels` the cumulative works taken out (damping, friction, the
    fracture work W_f, ...): zero to the time integrator's error when no channel is missing
    (as analysis/crush.py energy_residual for one grain). Everything is counted from the first
    record, so a record that starts after a restart closes as well as one from the start.

    Returns a DataFrame on the record's index: residual (J) and relative = residual / W_p
    (NaN where the platen work since the first record is not positive).
    """
    names = [work, *stored, *channels]
    missing = [c for c in names if c not in record]
    if missing:
        raise ValueError(f"record has no column {', '.join(missing)}")
    if len(record) == 0:
        raise ValueError("empty record")
    delta = record[names] - record[names].iloc[0]
    residual = delta[work] - delta[list(stored)].sum(axis=1) - delta[list(channels)].sum(axis=1)
    wp = delta[work].to_numpy(dtype=float)
    relative = np.full(wp.shape, np.nan)
    np.divide(residual.to_numpy(dtype=float), wp, out=relative, where=wp > 0)
    return pd.DataFrame({"residual": residual, "relative": relative}, index=record.index)
