"""Draws from a power law p(x) ~ x^-tau on [xmin, xmax], for the tests' synthetic grain masses
(tests/test_powerlaw.py checks it against the law's own probabilities)."""

from __future__ import annotations

import numpy as np

# the tail sums of analysis.powerlaw: the sampler inverts exactly the law the fitter fits
from analysis.powerlaw import _dtail, _g


def sample_power_law(n: int, tau: float, xmin: float, xmax: float | None = None, discrete: bool = False,
                     rng: np.random.Generator | int | None = None) -> np.ndarray:
    """n independent draws from the law (exact inverse transform, discrete ones included)."""
    rng = np.random.default_rng(rng)
    u = 1.0 - rng.random(n)  # (0, 1]: the survival probability to invert
    if not discrete:
        s = tau - 1.0
        if xmax is None:
            if s <= 0:
                raise ValueError("an untruncated law needs tau > 1")
            return xmin * u ** (-1.0 / s)
        # Truncated: F(x) = g(s, ln(x/xmin)) / g(s, ln(xmax/xmin)), g(s, y) = (1 - e^{-sy}) / s.
        target = (1.0 - u) * _g(s, np.log(xmax / xmin))
        y = np.log1p(-s * target) / -s if abs(s) > 1e-12 else target
        return np.minimum(xmin * np.exp(y), xmax)
    # Discrete: X = the largest k with P(X >= k) >= u, by vectorised bisection on integers.
    xmin = int(xmin)
    norm = _dtail(tau, np.array([xmin]), xmax)[0]
    lo = np.full(n, xmin, dtype=np.int64)  # P(X >= lo) = 1 >= u always
    approx = (xmin - 0.5) * u ** (-1.0 / max(tau - 1.0, 1e-3)) + 0.5
    cap = (xmax + 1) if xmax is not None else np.iinfo(np.int64).max // 4
    hi = np.minimum(np.maximum(np.ceil(2 * approx).astype(np.int64), xmin + 1), cap)
    while True:  # make P(X >= hi) < u
        grow = (hi < cap) & (_dtail(tau, hi, xmax) / norm >= u)
        if not grow.any():
            break
        hi[grow] = np.minimum(hi[grow] * 2, cap)
    while np.any(hi - lo > 1):
        mid = (lo + hi) // 2
        ok = _dtail(tau, mid, xmax) / norm >= u
        lo = np.where(ok, mid, lo)
        hi = np.where(ok, hi, mid)
    return lo.astype(float)
