"""Maximum-likelihood power-law fits p(x) ~ x^-tau (SPEC 1.5: p(m) exponent; SPEC 2.5: N(M)).

Following Clauset, Shalizi & Newman, SIAM Review 51, 661 (2009) ("CSN" below):

- continuous data, x >= xmin: tau_hat = 1 + n / sum ln(x / xmin)            (CSN Eq. 3.1)
- discrete data (integer masses), x >= xmin: p(x) = x^-tau / zeta(tau, xmin), with the
  Hurwitz zeta; tau_hat maximises L = -n ln zeta(tau, xmin) - tau sum ln x   (CSN Eq. 3.5)
- an upper cut xmax makes the law truncated: the normaliser runs over [xmin, xmax] and the
  MLE is numerical (the likelihood is concave in tau, so the maximum is unique).

Standard error: the law is an exponential family in tau with sufficient statistic ln x, so
the Fisher information is n Var(ln x) = n d^2 ln Z / dtau^2 under the fitted law and
sigma = 1 / sqrt(n Var(ln x)); for the continuous untruncated law this is CSN's
(tau - 1) / sqrt(n). The bootstrap (seeded) resamples the data given and repeats the whole
fit, xmin scan included (CSN section 3.4). KS distance between the data in [xmin, xmax]
and the fitted law; with xmin=None, xmin minimises it over the data's distinct values
(CSN section 3.3).

The `powerlaw` package (Alstott et al.) does much of this, but its discrete fits default to
approximations and its truncated laws are limited; these few functions do exactly what is
stated above and are tested against laws drawn independently.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.special import zeta

TAU_BOUNDS = (1.0 + 1e-6, 20.0)  # untruncated laws need tau > 1 to be normalisable
TAU_BOUNDS_TRUNCATED = (-10.0, 20.0)
_DIRECT_SUM_MAX = 1_000_000  # a truncated discrete normaliser is summed directly up to this range


@dataclass(frozen=True)
class PowerLawFit:
    """A fitted law p(x) ~ x^-tau on [xmin, xmax] (xmax None: no upper cut).

    sigma: asymptotic standard error (Fisher information); sigma_bootstrap: standard
    deviation of tau over n_bootstrap resamples (None when not asked); n: number of data in
    [xmin, xmax]; ks: Kolmogorov-Smirnov distance between those data and the law.
    """

    tau: float
    sigma: float
    xmin: float
    xmax: float | None
    n: int
    ks: float
    method: str
    discrete: bool = False
    loglik: float = float("nan")
    sigma_bootstrap: float | None = None
    n_bootstrap: int = 0


def fit_power_law(x: np.ndarray, xmin: float | None = None, xmax: float | None = None, discrete: bool = False,
                  n_bootstrap: int = 0, seed: int = 0, min_tail: int = 10, max_candidates: int = 1000) -> PowerLawFit:
    """Fit p(x) ~ x^-tau to the data x >= xmin (and <= xmax when given).

    x: (n,) positive samples (integers when discrete=True, e.g. grain masses in particles).
    xmin: lower end of the law; None scans the distinct values of x (each leaving at least
    min_tail data; beyond max_candidates of them, evenly spaced ranks) for the smallest KS
    distance.
    xmax: optional upper cut (a truncated law; data above it are left out).
    n_bootstrap: number of resamples for sigma_bootstrap (0: none), seeded by seed.
    """
    x = _check_data(x, discrete)
    if discrete and xmin is not None:
        xmin = float(np.ceil(xmin))  # integer data: a cut of 3.5 keeps M >= 4, and the law starts there
    if xmax is not None and xmin is not None and xmax <= xmin:
        raise ValueError(f"xmax = {xmax} must exceed xmin = {xmin}")
    if n_bootstrap < 0:
        raise ValueError("n_bootstrap must be >= 0")
    fit = _fit(x, xmin, xmax, discrete, min_tail, max_candidates)
    if n_bootstrap == 0:
        return fit
    rng = np.random.default_rng(seed)
    taus = []
    for _ in range(n_bootstrap):
        xb = rng.choice(x, size=len(x), replace=True)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # a degenerate resample may sit at a bound
                taus.append(_fit(xb, xmin, xmax, discrete, min_tail, max_candidates).tau)
        except ValueError:
            continue  # a resample with too few data in range: skip it
    sb = float(np.std(taus, ddof=1)) if len(taus) > 1 else float("nan")
    return PowerLawFit(fit.tau, fit.sigma, fit.xmin, fit.xmax, fit.n, fit.ks, fit.method + f"; bootstrap x{len(taus)}",
                       fit.discrete, fit.loglik, sb, len(taus))


# When a fitted exponent of the grain-mass distribution N(M) ~ M^-tau is a result.
TAU_RANGE = (1.0, 3.0)
"""Physical range of tau for N(M) ~ M^-tau, the open-closed interval (1, 3].

tau <= 1 is no fragmentation law: the number of grains per unit mass would not fall with M
(tau < 0: it rises), so the count above any mass is carried by the largest grains and the
fit describes the cut-off or a remnant, not a scale-free distribution. tau > 3 is steeper
than any fragment-mass exponent measured in brittle fragmentation, and than the Fisher
exponent of percolation clusters (187/91 = 2.05 in 2D, 2.19 in 3D) that bounds a network
breaking at random; such a value comes from a few grains piled at the cut.
"""
MIN_FIT_GRAINS = 10
"""Fewest grains a tau fit may rest on: 10 grains fitted, i.e. with M >= m_min, neither
percolating nor the largest finite grain (statistics.fit_grain_tau's `min_grains`). The
maximum-likelihood standard error is about (tau - 1) / sqrt(n), already +-0.25 at n = 10 for
tau = 1.8: fewer grains give no usable exponent."""


def grains_fitted(masses: np.ndarray, m_min: float, percolating: np.ndarray | None = None) -> int:
    """Number of grains a tau fit of N(M) rests on: M >= m_min, not percolating, the largest
    of them (the remnant) left out, as statistics.fit_grain_tau selects them."""
    keep = np.asarray(masses, dtype=float) >= m_min
    if percolating is not None:
        keep &= ~np.asarray(percolating, dtype=bool)
    return max(int(keep.sum()) - 1, 0)


def exponent_flag(tau: float | None, n: int, tau_range: tuple[float, float] = TAU_RANGE,
                  min_grains: int = MIN_FIT_GRAINS) -> str | None:
    """Why a fitted tau of N(M) is not a result, or None when it is one.

    Flagged: fewer than `min_grains` grains fitted (MIN_FIT_GRAINS), no fit (tau None), and
    tau outside (tau_range[0], tau_range[1]] (TAU_RANGE: (1, 3]; NaN is outside).
    """
    if n < min_grains:
        return f"too few grains: {n} to fit, a fit needs at least {min_grains}"
    if tau is None:
        return f"no fit: the {n} grains to fit span no range of masses"
    lo, hi = tau_range
    if not lo < tau <= hi:
        return f"tau = {tau:.3g} outside the physical range ({lo:g}, {hi:g}]"
    return None


# ---------------------------------------------------------------------------------------


def _check_data(x, discrete: bool) -> np.ndarray:
    x = np.asarray(x, dtype=float).ravel()
    if x.size == 0 or not np.all(np.isfinite(x)) or np.any(x <= 0):
        raise ValueError("power-law data must be finite and positive")
    if discrete and np.any(x != np.round(x)):
        raise ValueError("discrete=True needs integer data")
    return x


def _g(s: float, y):
    """(1 - exp(-s y)) / s, continuous at s = 0 (= y)."""
    y = np.asarray(y, dtype=float)
    if abs(s) < 1e-12:
        return y
    return -np.expm1(-s * y) / s


def _dtail(tau: float, k: np.ndarray, xmax: float | None) -> np.ndarray:
    """sum_{j=k}^{xmax} j^-tau for integer k (array), xmax None meaning infinity."""
    k = np.asarray(k, dtype=float)
    if xmax is None:
        return zeta(tau, k)
    xmax = int(xmax)
    kmin = int(k.min()) if k.size else xmax
    if tau > 1 and xmax - kmin > _DIRECT_SUM_MAX:
        return np.where(k <= xmax, zeta(tau, k) - zeta(tau, xmax + 1.0), 0.0)
    j = np.arange(kmin, xmax + 1, dtype=float)
    suffix = np.concatenate([np.cumsum((j ** -tau)[::-1])[::-1], [0.0]])
    idx = np.clip(k.astype(np.int64) - kmin, 0, len(j))
    return suffix[idx]


def _log_norm(tau: float, xmin: float, xmax: float | None, discrete: bool) -> float:
    """ln Z(tau): Z = integral (continuous) or sum (discrete) of x^-tau over [xmin, xmax]."""
    if discrete:
        return float(np.log(_dtail(tau, np.array([xmin]), xmax)[0]))
    s = tau - 1.0
    if xmax is None:
        return -s * np.log(xmin) - np.log(s)
    return float(-s * np.log(xmin) + np.log(_g(s, np.log(xmax / xmin))))


def _cdf(x: np.ndarray, tau: float, xmin: float, xmax: float | None, discrete: bool) -> np.ndarray:
    if discrete:
        # P(X <= x) = 1 - P(X >= floor(x) + 1)
        k = np.clip(np.floor(x) + 1.0, xmin, None if xmax is None else xmax + 1.0)
        c = 1.0 - _dtail(tau, k, xmax) / _dtail(tau, np.array([xmin]), xmax)[0]
    else:
        s = tau - 1.0
        y = np.log(np.clip(x, xmin, xmax) / xmin)
        c = -np.expm1(-s * y) if xmax is None else _g(s, y) / _g(s, np.log(xmax / xmin))
    c = np.where(x < xmin, 0.0, c)
    return c if xmax is None else np.where(x >= xmax, 1.0, c)


def _var_lnx(tau: float, xmin: float, xmax: float | None, discrete: bool) -> float:
    """Var(ln x) under the law = d^2 ln Z / dtau^2 (central difference; exact when closed)."""
    if not discrete and xmax is None:
        return 1.0 / (tau - 1.0) ** 2
    h = 1e-3 if xmax is not None else min(1e-3, (tau - 1.0) / 4)
    f = [_log_norm(tau + d, xmin, xmax, discrete) for d in (-h, 0.0, h)]
    return (f[0] - 2 * f[1] + f[2]) / h ** 2


def _tail(x: np.ndarray, xmin: float, xmax: float | None) -> np.ndarray:
    keep = x >= xmin
    if xmax is not None:
        keep &= x <= xmax
    return np.sort(x[keep])


def _mle(xs: np.ndarray, xmin: float, xmax: float | None, discrete: bool) -> tuple[float, float]:
    """(tau_hat, log-likelihood) on the sorted data in range."""
    n, slog = len(xs), float(np.sum(np.log(xs)))
    if not discrete and xmax is None:
        tau = 1.0 + n / (slog - n * np.log(xmin))  # CSN Eq. 3.1
    else:
        bounds = TAU_BOUNDS if xmax is None else TAU_BOUNDS_TRUNCATED
        if discrete and xmax is not None and xmax - xmin > _DIRECT_SUM_MAX:
            bounds = TAU_BOUNDS

        def nll(t: float) -> float:
            return t * slog + n * _log_norm(t, xmin, xmax, discrete)

        res = minimize_scalar(nll, bounds=bounds, method="bounded", options={"xatol": 1e-10})
        tau = float(res.x)
        if min(abs(tau - bounds[0]), abs(tau - bounds[1])) < 1e-6:
            warnings.warn(f"power-law MLE at the search bound tau = {tau:g}", RuntimeWarning, stacklevel=3)
    loglik = -tau * slog - n * _log_norm(tau, xmin, xmax, discrete)
    return tau, float(loglik)


def _ks(xs: np.ndarray, tau: float, xmin: float, xmax: float | None, discrete: bool) -> float:
    """KS distance between sorted data and the law (CSN Eq. 3.9)."""
    n = len(xs)
    if discrete:
        # Both CDFs step only at integers: compare at each distinct value u and at u - 1.
        u, counts = np.unique(xs, return_counts=True)
        emp = np.cumsum(counts) / n
        emp_before = np.concatenate([[0.0], emp[:-1]])
        return float(max(np.max(np.abs(emp - _cdf(u, tau, xmin, xmax, True))),
                         np.max(np.abs(emp_before - _cdf(u - 1.0, tau, xmin, xmax, True)))))
    f = _cdf(xs, tau, xmin, xmax, False)
    i = np.arange(1, n + 1)
    return float(max(np.max(i / n - f), np.max(f - (i - 1) / n)))


def _fit(x: np.ndarray, xmin: float | None, xmax: float | None, discrete: bool,
         min_tail: int, max_candidates: int) -> PowerLawFit:
    kind = "discrete MLE (Hurwitz zeta)" if discrete else "continuous MLE"
    if not discrete and xmax is None:
        kind += ", closed form"
    if xmax is not None:
        kind += f", truncated at xmax = {xmax:g}"
    if xmin is not None:
        xs = _tail(x, xmin, xmax)
        if len(xs) < 2:
            raise ValueError(f"{len(xs)} data in [{xmin}, {xmax}]: too few to fit")
        tau, ll = _mle(xs, xmin, xmax, discrete)
        ks = _ks(xs, tau, xmin, xmax, discrete)
        sigma = 1.0 / np.sqrt(len(xs) * _var_lnx(tau, xmin, xmax, discrete))
        return PowerLawFit(float(tau), float(sigma), float(xmin), _opt_float(xmax), len(xs), ks, kind, discrete, ll)
    # xmin scan (CSN section 3.3): the candidate with the smallest KS distance.
    xr = np.sort(x if xmax is None else x[x <= xmax])
    cands = np.unique(xr[: max(0, len(xr) - min_tail + 1)])
    if len(cands) == 0:
        raise ValueError(f"fewer than min_tail = {min_tail} data: cannot scan xmin")
    if len(cands) > max_candidates:
        cands = cands[np.unique(np.linspace(0, len(cands) - 1, max_candidates).round().astype(int))]
    best = None
    for xm in cands:
        if xmax is not None and xm >= xmax:
            continue
        xs = xr[np.searchsorted(xr, xm, side="left"):]
        if len(xs) < max(min_tail, 2):
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            tau, ll = _mle(xs, xm, xmax, discrete)
        ks = _ks(xs, tau, xm, xmax, discrete)
        if best is None or ks < best[0]:
            best = (ks, xm, tau, ll, len(xs))
    if best is None:
        raise ValueError("no xmin candidate leaves enough data")
    ks, xm, tau, ll, n = best
    sigma = 1.0 / np.sqrt(n * _var_lnx(tau, xm, xmax, discrete))
    return PowerLawFit(float(tau), float(sigma), float(xm), _opt_float(xmax), n, ks, kind + "; xmin by KS scan",
                       discrete, ll)


def _opt_float(v: float | None) -> float | None:
    return None if v is None else float(v)
