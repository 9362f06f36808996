"""Scaling analysis (SPEC 2.5 for BPM, SPEC 1.5 sweep level for BCM): collapses, growth, thresholds.

Rescaling forms (SPEC 2.5), each in one function below:
- finite size:  N(M, L) = L^(gamma - alpha tau) f(M / L^alpha)
- finite rate:  N(M, edot, L) = L^d edot^(2 nu alpha) h(M edot^(nu alpha))
- second moment: <M^2> = L^(d + alpha) g(edot L^(1/nu))
- growth: N ~ eps^phi

Collapse quality (after Houdayer & Hartmann, PRB 70, 014418, 2004, on log scales): every
rescaled curve's points that fall inside another curve's range are compared with that
curve's linear interpolation in (ln X, ln Y); the cost is the mean of
(ln Y_i - ln Y_k(X_i))^2 / (s_i^2 + s_k^2) over all such comparisons, with s the standard
error of ln Y (e.g. 1/sqrt(count) for a histogram bin; 1/sqrt(2) each when no errors are
given, so the cost is then the mean squared log difference). With honest errors a good
collapse has a cost near 1. Exponents minimise it (Nelder-Mead).

Uncertainties: uncertainty="bootstrap" (default) refits on resampled data: each point's
ln Y is redrawn from N(ln Y, s) when errors are given (parametric bootstrap), otherwise the
points of each curve are resampled with replacement; "jackknife" leaves one run (curve) out
at a time (>= 3 curves; this measures how much the exponents depend on which runs are in,
i.e. corrections to scaling); "curvature" inverts the Hessian of the summed chi-square at
the minimum (Cov = 2 H^-1, doubled because each pair of curves is compared both ways, and
scaled by the cost when it exceeds 1): quick, but it treats interpolated comparisons as
independent.

Caveats, measured on synthetic data: linear interpolation in log-log biases the exponents
where the curves bend (an exponential cutoff sampled at 3 points per decade moved
nu_alpha by 0.4 %, at 7 per decade by < 0.1 %); points entering or leaving the overlap make
the cost step, so the landscape can have side minima (use bounds and n_grid). For binned
N(M), put each bin at the mean mass of its grains, not at its geometric centre: with integer
masses and tau = 2 the first bins' N is 20 % off the law at the centre, which does not
collapse. Binning itself (5 bins per decade) moved alpha by about 2 % on noise-free data.

Only the product nu * alpha enters the finite-rate form, so that collapse fits
nu_alpha = nu * alpha; alpha and nu separately come from the finite-size and the
second-moment collapses.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np
from scipy import stats
from scipy.optimize import least_squares, minimize

_BAD_COST = 1e6  # cost of parameters for which the curves barely overlap


@dataclass
class Curve:
    """One run's measure: y against x (both > 0; other points are dropped), with the run's
    parameters (e.g. {"L": 100, "edot": 1e-4}) and optionally the standard error of ln y."""

    x: np.ndarray
    y: np.ndarray
    params: dict[str, float]
    sigma_lny: np.ndarray | None = None

    def __post_init__(self):
        x, y = np.asarray(self.x, dtype=float), np.asarray(self.y, dtype=float)
        if x.shape != y.shape:
            raise ValueError(f"x {x.shape} and y {y.shape} differ")
        keep = (x > 0) & (y > 0) & np.isfinite(x) & np.isfinite(y)
        self.x, self.y = x[keep], y[keep]
        if self.sigma_lny is not None:
            s = np.broadcast_to(np.asarray(self.sigma_lny, dtype=float), keep.shape)[keep]
            if np.any(~np.isfinite(s)) or np.any(s <= 0):
                raise ValueError("sigma_lny must be finite and positive")
            self.sigma_lny = s


@dataclass
class CollapseFit:
    """Fitted exponents (params), their standard errors (sigma), the cost at the minimum and
    the number of point comparisons behind it; samples holds bootstrap/jackknife estimates."""

    params: dict[str, float]
    sigma: dict[str, float]
    cost: float
    n_terms: int
    method: str
    cov: np.ndarray | None = None
    samples: np.ndarray | None = field(default=None, repr=False)


# ---------------------------------------------------------------------------------------
# Rescaling forms (SPEC 2.5)


def finite_size_rescale(m, n, L, alpha, gamma, tau):
    """(M / L^alpha, N / L^(gamma - alpha tau)) of N(M, L) = L^(gamma - alpha tau) f(M / L^alpha)."""
    m, n = np.asarray(m, dtype=float), np.asarray(n, dtype=float)
    return m / L ** alpha, n / L ** (gamma - alpha * tau)


def finite_rate_rescale(m, n, L, edot, nu_alpha, d):
    """(M edot^(nu alpha), N / (L^d edot^(2 nu alpha))) of N ~ L^d edot^(2 nu alpha) h(M edot^(nu alpha))."""
    m, n = np.asarray(m, dtype=float), np.asarray(n, dtype=float)
    return m * edot ** nu_alpha, n / (L ** d * edot ** (2 * nu_alpha))


def moment_rescale(edot, m2, L, alpha, nu, d):
    """(edot L^(1/nu), <M^2> / L^(d + alpha)) of <M^2> ~ L^(d + alpha) g(edot L^(1/nu))."""
    edot, m2 = np.asarray(edot, dtype=float), np.asarray(m2, dtype=float)
    return edot * L ** (1.0 / nu), m2 / L ** (d + alpha)


# ---------------------------------------------------------------------------------------
# Collapse quality and fit


Rescale = Callable[[Curve, np.ndarray], tuple[np.ndarray, np.ndarray]]


def collapse_cost(curves: Sequence[Curve], rescale: Rescale, p: np.ndarray, min_terms: int = 4,
                  return_terms: bool = False):
    """Cost of the collapse of `curves` under rescale(curve, p) -> (X, Y) (see module doc)."""
    prepared = []
    for cv in curves:
        X, Y = rescale(cv, np.asarray(p, dtype=float))
        lx, ly = np.log(X), np.log(Y)
        s2 = np.full(len(lx), 0.5) if cv.sigma_lny is None else cv.sigma_lny ** 2
        order = np.argsort(lx)
        prepared.append((lx[order], ly[order], s2[order]))
    total, terms = 0.0, 0
    for i, (lxi, lyi, si) in enumerate(prepared):
        for k, (lxk, lyk, sk) in enumerate(prepared):
            if i == k or len(lxk) < 2:
                continue
            inside = (lxi >= lxk[0]) & (lxi <= lxk[-1])
            if not inside.any():
                continue
            x = lxi[inside]
            r2 = (lyi[inside] - np.interp(x, lxk, lyk)) ** 2 / (si[inside] + np.interp(x, lxk, sk))
            total += float(r2.sum())
            terms += int(inside.sum())
    cost = total / terms if terms >= min_terms and np.isfinite(total) else _BAD_COST
    return (cost, terms) if return_terms else cost


def fit_collapse(curves: Sequence[Curve], rescale: Rescale, p0: Sequence[float], names: Sequence[str],
                 bounds: Sequence[tuple[float, float]] | None = None, uncertainty: str = "bootstrap",
                 n_bootstrap: int = 100, seed: int = 0, min_terms: int = 4, n_grid: int = 0,
                 perturb: Callable[[np.random.Generator], Rescale] | None = None, n_starts: int = 5) -> CollapseFit:
    """Exponents minimising collapse_cost, with uncertainties (module doc).

    rescale(curve, p) -> (X, Y) with p in the order of names; p0 starting values;
    bounds optional (lo, hi) per parameter; n_grid > 0 (needs bounds) first evaluates the
    cost on an n_grid^k grid over the bounds and minimises from its n_starts best points,
    keeping the lowest, for landscapes with several minima. perturb(rng) may return a rescale function with fixed inputs
    redrawn (e.g. tau from its own error) for each bootstrap replicate.
    """
    if uncertainty not in ("bootstrap", "jackknife", "curvature"):
        raise ValueError(f"uncertainty must be bootstrap, jackknife or curvature, not {uncertainty!r}")
    curves = list(curves)
    if len(curves) < 2:
        raise ValueError("a collapse needs at least two curves")
    if len(p0) != len(names):
        raise ValueError("p0 and names differ in length")
    start = np.asarray(p0, dtype=float)
    if n_grid > 0:
        if bounds is None:
            raise ValueError("n_grid needs bounds")
        axes = [np.linspace(lo, hi, n_grid) for lo, hi in bounds]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, len(names))
        costs = np.array([collapse_cost(curves, rescale, g, min_terms) for g in grid])
        # a coarse grid can rank a flat side minimum first: descend from the best few points,
        # and from the caller's own start
        starts = [start, *grid[np.argsort(costs, kind="stable")[:n_starts]]]
    else:
        starts = [start]
    best = min((_minimise(curves, rescale, s0, bounds, min_terms) for s0 in starts),
               key=lambda q: collapse_cost(curves, rescale, q, min_terms))
    cost, terms = collapse_cost(curves, rescale, best, min_terms, return_terms=True)
    if cost >= _BAD_COST:
        raise ValueError("the curves do not overlap after rescaling: try other starting values")
    rng = np.random.default_rng(seed)
    samples, cov = None, None
    if uncertainty == "bootstrap":
        samples = np.array([_minimise(_resample(curves, rng), perturb(rng) if perturb else rescale, best, bounds,
                                      min_terms) for _ in range(n_bootstrap)])
        cov = np.atleast_2d(np.cov(samples.T, ddof=1))
        method = f"bootstrap x{n_bootstrap} ({'parametric' if curves[0].sigma_lny is not None else 'points resampled'})"
    elif uncertainty == "jackknife":
        if len(curves) < 3:
            raise ValueError("a jackknife over runs needs at least three curves")
        samples = np.array([_minimise(curves[:j] + curves[j + 1:], rescale, best, bounds, min_terms)
                            for j in range(len(curves))])
        n = len(curves)
        dev = samples - samples.mean(axis=0)
        cov = (n - 1) / n * dev.T @ dev
        method = f"jackknife over {n} runs"
    else:
        hess = _hessian(lambda q: collapse_cost(curves, rescale, q, min_terms) * terms, best)
        cov = 2.0 * 2.0 * np.linalg.inv(hess) * max(1.0, cost)
        method = "curvature of the cost"
    sig = np.sqrt(np.clip(np.diag(cov), 0, None))
    return CollapseFit(dict(zip(names, map(float, best))), dict(zip(names, map(float, sig))), float(cost), int(terms),
                       method, cov, samples)


def _minimise(curves, rescale, p0, bounds, min_terms) -> np.ndarray:
    def f(q):
        return collapse_cost(curves, rescale, q, min_terms)

    step = np.where(p0 != 0, 0.1 * np.abs(p0), 0.05)
    simplex = np.vstack([p0] + [p0 + np.eye(len(p0))[i] * step[i] for i in range(len(p0))])
    opts = {"xatol": 1e-7, "fatol": 1e-10, "maxiter": 4000, "initial_simplex": simplex}
    res = minimize(f, p0, method="Nelder-Mead", bounds=bounds, options=opts)
    opts.pop("initial_simplex")
    res = minimize(f, res.x, method="Nelder-Mead", bounds=bounds, options=opts)  # restart: NM can stall
    return np.asarray(res.x, dtype=float)


def _resample(curves: list[Curve], rng: np.random.Generator) -> list[Curve]:
    out = []
    for cv in curves:
        if cv.sigma_lny is not None:
            y = cv.y * np.exp(rng.normal(size=len(cv.y)) * cv.sigma_lny)
            out.append(Curve(cv.x, y, cv.params, cv.sigma_lny))
        else:
            idx = np.sort(rng.integers(0, len(cv.x), len(cv.x)))  # with replacement: duplicates kept
            out.append(Curve(cv.x[idx], cv.y[idx], cv.params))
    return out


def _hessian(f: Callable[[np.ndarray], float], p: np.ndarray) -> np.ndarray:
    k = len(p)
    h = 1e-3 * np.maximum(np.abs(p), 1e-2)
    H = np.empty((k, k))
    f0 = f(p)
    for i in range(k):
        ei = np.eye(k)[i] * h[i]
        H[i, i] = (f(p + ei) - 2 * f0 + f(p - ei)) / h[i] ** 2
        for j in range(i + 1, k):
            ej = np.eye(k)[j] * h[j]
            H[i, j] = H[j, i] = (f(p + ei + ej) - f(p + ei - ej) - f(p - ei + ej) + f(p - ei - ej)) / (4 * h[i] * h[j])
    return H


# Ready-made collapses of SPEC 2.5 ------------------------------------------------------


def fit_finite_size(curves: Sequence[Curve], tau: float, p0: tuple[float, float] = (1.0, 1.0),
                    sigma_tau: float = 0.0, bounds: Sequence[tuple[float, float]] | None = None,
                    **kw) -> CollapseFit:
    """alpha and gamma of N(M, L) = L^(gamma - alpha tau) f(M / L^alpha), curves of N against M
    with params["L"], tau fixed (from fit_power_law).

    The data fix the horizontal shift alpha and the vertical one kappa = gamma - alpha tau,
    whose cost valley is narrow along gamma; the collapse is fitted in (alpha, kappa), which do
    not involve tau, and gamma = kappa + alpha tau. Its standard error includes tau's:
    var(gamma) = var(kappa) + tau^2 var(alpha) + 2 tau cov(alpha, kappa) + alpha^2 sigma_tau^2
    (bootstrap replicates draw tau from N(tau, sigma_tau)). p0 and bounds are in (alpha, gamma).
    """

    def rescale(cv, p):
        return finite_size_rescale(cv.x, cv.y, cv.params["L"], p[0], p[1], 0.0)  # p = (alpha, kappa)

    start = (p0[0], p0[1] - p0[0] * tau)
    kb = None
    if bounds is not None:
        (alo, ahi), (glo, ghi) = bounds
        kb = [(alo, ahi), (min(glo - alo * tau, glo - ahi * tau), max(ghi - alo * tau, ghi - ahi * tau))]
    fit = fit_collapse(curves, rescale, start, ("alpha", "kappa"), bounds=kb, **kw)
    alpha, kappa = fit.params["alpha"], fit.params["kappa"]
    jac = np.array([[1.0, 0.0], [tau, 1.0]])  # (alpha, gamma) from (alpha, kappa)
    samples = None
    if fit.samples is not None:
        if "bootstrap" in fit.method and sigma_tau > 0:
            taus = np.random.default_rng(kw.get("seed", 0) + 1).normal(tau, sigma_tau, len(fit.samples))
        else:
            taus = np.full(len(fit.samples), tau)
        samples = np.column_stack([fit.samples[:, 0], fit.samples[:, 1] + fit.samples[:, 0] * taus])
    if samples is not None and "bootstrap" in fit.method:
        cov = np.atleast_2d(np.cov(samples.T, ddof=1))
    else:
        cov = jac @ fit.cov @ jac.T
        cov[1, 1] += (alpha * sigma_tau) ** 2
    sig = np.sqrt(np.clip(np.diag(cov), 0, None))
    return CollapseFit({"alpha": alpha, "gamma": kappa + alpha * tau}, {"alpha": float(sig[0]), "gamma": float(sig[1])},
                       fit.cost, fit.n_terms, fit.method + (f"; tau = {tau:.3g} +- {sigma_tau:.2g} propagated"
                                                            if sigma_tau > 0 else ""), cov, samples)


def fit_finite_rate(curves: Sequence[Curve], d: int, p0: float = 0.5, **kw) -> CollapseFit:
    """nu_alpha = nu * alpha of N(M, edot, L) ~ L^d edot^(2 nu alpha) h(M edot^(nu alpha)),
    curves of N against M with params["L"] and params["edot"]."""

    def rescale(cv, p):
        return finite_rate_rescale(cv.x, cv.y, cv.params["L"], cv.params["edot"], p[0], d)

    return fit_collapse(curves, rescale, [p0], ("nu_alpha",), **kw)


def moment_curves(L, edot, m2, sigma_lnm2=None) -> list[Curve]:
    """Curves <M^2> against edot, one per system size L, from flat arrays (one entry per run)."""
    L, edot, m2 = (np.asarray(v, dtype=float) for v in (L, edot, m2))
    s = None if sigma_lnm2 is None else np.broadcast_to(np.asarray(sigma_lnm2, dtype=float), L.shape)
    return [Curve(edot[L == size], m2[L == size], {"L": float(size)}, None if s is None else s[L == size])
            for size in np.unique(L)]


def fit_moment_collapse(curves: Sequence[Curve], d: int, p0: tuple[float, float] = (1.0, 1.0), **kw) -> CollapseFit:
    """alpha and nu of <M^2> ~ L^(d + alpha) g(edot L^(1/nu)), curves from moment_curves."""

    def rescale(cv, p):
        return moment_rescale(cv.x, cv.y, cv.params["L"], p[0], p[1], d)

    return fit_collapse(curves, rescale, p0, ("alpha", "nu"), **kw)


# ---------------------------------------------------------------------------------------
# Growth N ~ eps^phi


@dataclass(frozen=True)
class PowerFit:
    """y = prefactor x^exponent from a least-squares line in log-log, with standard errors."""

    exponent: float
    sigma_exponent: float
    prefactor: float
    sigma_log_prefactor: float
    n: int
    r2: float


def fit_loglog(x, y, x_min: float | None = None, x_max: float | None = None) -> PowerFit:
    """y = prefactor x^exponent by a linear fit of ln y against ln x over the points with
    x, y > 0 and x in [x_min, x_max]; standard errors from the fit's residuals."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    keep = (x > 0) & (y > 0)
    if x_min is not None:
        keep &= x >= x_min
    if x_max is not None:
        keep &= x <= x_max
    if keep.sum() < 3:
        raise ValueError(f"{keep.sum()} usable points: a power-law fit needs at least 3")
    r = stats.linregress(np.log(x[keep]), np.log(y[keep]))
    return PowerFit(float(r.slope), float(r.stderr), float(np.exp(r.intercept)), float(r.intercept_stderr),
                    int(keep.sum()), float(r.rvalue ** 2))


def fit_growth(eps, n, eps_min: float | None = None, eps_max: float | None = None) -> PowerFit:
    """phi of N ~ eps^phi (SPEC 2.5): fit_loglog of N against eps over [eps_min, eps_max]."""
    return fit_loglog(eps, n, eps_min, eps_max)


# ---------------------------------------------------------------------------------------
# BCM thresholds against the damage potential omega (SPEC 1.5)


@dataclass(frozen=True)
class Threshold:
    """A crossover located between two sampled omegas: value (midpoint, or the linear
    interpolation of the run mean at the level) and the bracket [lo, hi] as its uncertainty."""

    value: float
    lo: float
    hi: float

    @property
    def half_width(self) -> float:
        return 0.5 * (self.hi - self.lo)


def locate_threshold(omega, y, level: float = 0.0, estimate: str = "midpoint", groups=None) -> Threshold:
    """The first parameter point at which some run has y > level, bracketed by the point
    below it.

    groups: the parameter point of each run (e.g. its impact velocity). The runs of one point
    (tessellations) have slightly different omegas (W_s and the mass vary with the
    tessellation), so the bracket runs between points, from the largest omega of the point
    below (no run there has y > level) to the smallest omega of a run with y > level at the
    point found; when the tessellation spread makes these overlap, the bracket is the
    overlap's span. groups None: every distinct omega is a point of its own.
    estimate="midpoint" (default; right for measures that are exactly 0 below, like D_w) or
    "linear" (the mean of y per point interpolated linearly to `level` inside the bracket).
    If the first point already has y > level, lo = -inf and value = NaN (only an upper bound);
    if none has, hi = +inf and value = NaN.
    """
    if estimate not in ("midpoint", "linear"):
        raise ValueError(f"estimate must be 'midpoint' or 'linear', not {estimate!r}")
    omega, y = np.asarray(omega, dtype=float), np.asarray(y, dtype=float)
    g = omega if groups is None else np.asarray(groups)
    if g.shape != omega.shape:
        raise ValueError(f"{g.size} group labels for {omega.size} runs")
    points = sorted(np.unique(g), key=lambda k: float(np.mean(omega[g == k])))
    above = np.array([np.any(y[g == k] > level) for k in points])
    if not above.any():
        return Threshold(float("nan"), float(omega.max()), float("inf"))
    k = int(np.argmax(above))
    at = (g == points[k]) & (y > level)
    hi = float(omega[at].min())
    if k == 0:
        return Threshold(float("nan"), float("-inf"), hi)
    below = g == points[k - 1]
    lo = float(omega[below].max())
    lo, hi = min(lo, hi), max(lo, hi)
    if estimate == "midpoint":
        return Threshold(0.5 * (lo + hi), lo, hi)
    y_lo, y_hi = float(np.mean(y[below])), float(np.mean(y[g == points[k]]))
    t = (level - y_lo) / (y_hi - y_lo) if y_hi != y_lo else 0.5
    return Threshold(lo + float(np.clip(t, 0.0, 1.0)) * (hi - lo), lo, hi)


def omega_0(omega, damage, groups=None) -> Threshold:
    """omega_0: first omega with cracks (D_w > 0) (SPEC 1.5); groups as in locate_threshold."""
    return locate_threshold(omega, damage, level=0.0, groups=groups)


BREAKUP_FRACTION = 0.9  # SPEC 1.5: broken up when the largest fragment holds less of the parent's mass


def breakup_definitions(fraction: float = BREAKUP_FRACTION) -> dict[str, str]:
    """The break-up definitions a set analysis reports omega_1 under, name -> meaning (SPEC 1.5)."""
    return {f"largest_below_{fraction:g}": f"the largest fragment holds less than {fraction:g} of the parent's mass",
            "two_multicell_fragments": "two or more fragments of two or more cells (chip-based count)"}


def omega_1(omega, n_fragments, groups=None) -> Threshold:
    """omega_1 by the chip-based count (`two_multicell_fragments`): first omega where a particle
    breaks into two or more fragments. Pass the count of fragments of two or more cells to
    leave single chipped cells out; groups as in locate_threshold. A two-cell chip knocked off
    a particle that keeps 99 % of its mass passes this test: omega_1_largest is SPEC 1.5's rule."""
    return locate_threshold(omega, n_fragments, level=1.0, groups=groups)


def omega_1_largest(omega, largest_fraction, fraction: float = BREAKUP_FRACTION, groups=None) -> Threshold:
    """omega_1 by SPEC 1.5's break-up rule (`largest_below_<fraction>`): the first parameter
    point where some run's largest fragment holds less than `fraction` of the parent's mass
    (largest_fraction: largest fragment mass / parent mass per run); groups as in
    locate_threshold."""
    if not 0 < fraction <= 1:
        raise ValueError(f"break-up fraction {fraction:g}: must be in (0, 1]")
    return locate_threshold(omega, fraction - np.asarray(largest_fraction, dtype=float), level=0.0, groups=groups)


def threshold_power(omega, omega0: float, beta: float, prefactor: float):
    """prefactor (omega - omega0)^beta above omega0, 0 at and below it (e.g. D_w above omega_0)."""
    omega = np.asarray(omega, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(omega > omega0, prefactor * np.abs(omega - omega0) ** beta, 0.0)


def power_law(x, prefactor: float, exponent: float):
    """prefactor x^exponent (the regime fits far above a threshold, e.g. eta or e_k^2 against omega)."""
    return prefactor * np.asarray(x, dtype=float) ** exponent


@dataclass(frozen=True)
class ThresholdFit:
    """y = prefactor (omega - omega0)^beta above omega0, with standard errors and covariance
    (order omega0, beta, ln prefactor)."""

    omega0: float
    beta: float
    prefactor: float
    sigma_omega0: float
    sigma_beta: float
    sigma_prefactor: float
    n: int
    cov: np.ndarray = field(repr=False)
    method: str = ""
    flag: str | None = None  # why a parameter sits at a bound of its physical range (not constrained)


BETA_MAX = 10.0  # largest threshold exponent a fit may return (D_w grows as a power of omega - omega0)


def fit_threshold_power(omega, y, omega0: float | None = None, sigma_lny=None,
                        omega0_bounds: tuple[float, float] | None = None) -> ThresholdFit:
    """Fit y = A (omega - omega0)^beta to the points with y > 0 (least squares in ln y).

    omega0 None: fitted, bounded below by the largest omega where every run has y <= 0
    (the measure is still zero there) and above by the smallest omega with y > 0, unless
    omega0_bounds is given, and never below 0; beta in (0, BETA_MAX]. A parameter that ends
    at a bound is named in `flag` (and the method): the data do not constrain it.
    sigma_lny: standard error of ln y per point (None: estimated from the residuals). Errors
    from the Jacobian at the optimum, Cov = s^2 (J^T J)^-1.
    """
    omega, y = np.asarray(omega, dtype=float), np.asarray(y, dtype=float)
    pos = y > 0
    w, ly = omega[pos], np.log(y[pos])
    sig = None if sigma_lny is None else np.broadcast_to(np.asarray(sigma_lny, dtype=float), omega.shape)[pos]
    n_par = 2 if omega0 is not None else 3
    if len(w) <= n_par:
        raise ValueError(f"{len(w)} points with y > 0: too few for {n_par} parameters")
    wt = np.ones_like(ly) if sig is None else 1.0 / sig

    if omega0 is not None:
        if np.any(w <= omega0):
            raise ValueError("points with y > 0 at or below the given omega0")
        X = np.column_stack([np.ones_like(w), np.log(w - omega0)]) * wt[:, None]
        coef, *_ = np.linalg.lstsq(X, ly * wt, rcond=None)
        res = ly * wt - X @ coef
        s2 = (res @ res) / (len(w) - 2) if sig is None else 1.0
        c2 = s2 * np.linalg.inv(X.T @ X)
        cov = np.zeros((3, 3))
        cov[1:, 1:] = c2[[1, 0]][:, [1, 0]]
        lnA, beta = coef
        return ThresholdFit(float(omega0), float(beta), float(np.exp(lnA)), 0.0, float(np.sqrt(cov[1, 1])),
                            float(np.exp(lnA) * np.sqrt(cov[2, 2])), int(len(w)), cov,
                            "log-log least squares, omega0 fixed")

    # physical ranges: omega0 >= 0 (omega = W_k^- / W_s > 0: no crack threshold below zero
    # impact energy), at or above the largest omega where every run has y = 0, below the first
    # omega with y > 0; beta in (0, BETA_MAX] (the measure grows from zero at omega0)
    zero_below = [v for v in np.unique(omega) if v < w.min() and np.all(y[omega == v] <= 0)]
    span = w.max() - w.min()
    lo, hi = omega0_bounds if omega0_bounds is not None else (
        max(zero_below) if zero_below else w.min() - 10 * span, w.min())
    lo = max(lo, 0.0)
    hi_eff = min(hi, w.min()) - 1e-9 * max(span, 1.0)
    if not lo < hi_eff:
        raise ValueError(f"empty omega0 range [{lo}, {hi}]")
    beta_lo, beta_hi = 1e-6, BETA_MAX

    def resid(p):
        o0, beta, lnA = p
        return (ly - lnA - beta * np.log(w - o0)) * wt

    best = None
    for o0 in np.linspace(lo, hi_eff, 7)[1:-1]:
        X = np.column_stack([np.ones_like(w), np.log(w - o0)])
        (lnA, beta), *_ = np.linalg.lstsq(X * wt[:, None], ly * wt, rcond=None)
        r = least_squares(resid, [o0, float(np.clip(beta, 2 * beta_lo, 0.5 * beta_hi)), lnA],
                          bounds=([lo, beta_lo, -np.inf], [hi_eff, beta_hi, np.inf]),
                          x_scale="jac", xtol=1e-12, ftol=1e-12)
        if best is None or r.cost < best.cost:
            best = r
    J = best.jac
    s2 = 2 * best.cost / (len(w) - 3) if sig is None else 1.0
    cov = s2 * np.linalg.pinv(J.T @ J)
    o0, beta, lnA = best.x
    flags = []
    tol = 1e-3 * (hi_eff - lo)  # at a bound: within 0.1 % of the range (as the collapses' edges)
    if abs(o0 - lo) < tol:
        flags.append(f"omega0 at the lower bound {lo:.4g} of its range "
                     + ("(physical: omega0 >= 0)" if lo == 0.0 else "(the largest omega with y = 0 in every run)"))
    if abs(o0 - hi_eff) < tol:
        flags.append(f"omega0 at the upper bound {hi:.4g} of its range (the first omega with y > 0)")
    for edge in (beta_lo, beta_hi):
        if abs(beta - edge) < 1e-3 * (beta_hi - beta_lo):
            flags.append(f"beta at the bound {edge:g} of its range ({beta_lo:g}, {beta_hi:g}]")
    note = "".join(f"; {f}" for f in flags)
    if omega0_bounds is None and not zero_below:
        note += "; no sampled omega has y = 0 in every run: omega0 is extrapolated below the data"
    flag = "; ".join(flags) + ": not constrained by the data" if flags else None
    return ThresholdFit(float(o0), float(beta), float(np.exp(lnA)), float(np.sqrt(cov[0, 0])),
                        float(np.sqrt(cov[1, 1])), float(np.exp(lnA) * np.sqrt(cov[2, 2])), int(len(w)), cov,
                        "least squares in ln y, omega0 fitted in its physical range" + note, flag)
