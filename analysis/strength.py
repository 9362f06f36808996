"""Single-particle crushing between platens (SPEC 4.1): the first peak of the platen force, the
work and loading stiffness up to it, sigma_c = F_c / d², and the statistics of sigma_c over
grains: Weibull fits per size and the size effect.

Conventions: one record per grain, in time order; `displacement` is the platen's travel from
first contact (closing positive), `force` the compressive platen force (positive), in SI
units. Pure functions on arrays; the figures are in analysis/strength_plots.py.

Rules, each stated once here and in the docstring of its function:

- peak (first_peak): F_c is the largest force before the force first falls below `drop`
  (0.8) times its running maximum;
- noise floor (first_peak): such a fall counts only once the running maximum has reached
  `floor` (0.05) of the record's largest force, so that chatter at first touch is no peak;
- loading stiffness (loading_stiffness): the slope of the least-squares line of force against
  displacement over the last unbroken run of samples before the peak with force between
  lo·F_c and hi·F_c (0.1 and 0.5);
- Weibull intervals (weibull_fit): pivotal (Thoman, Bain & Antle 1969; ASTM C1239), m_hat / m
  and m_hat ln(sigma_0_hat / sigma_0) simulated on n_boot standard Weibull samples of the
  data's size, so that the coverage is the nominal one at any n, up to Monte Carlo error.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike
from scipy import stats
from scipy.integrate import trapezoid

DROP = 0.8
"""A fall of the force below DROP times its running maximum ends the first peak (SPEC 4.1
leaves the rule to the tool): a 20 % fall is well above the force noise of a quasi-static
test and well below the fall at a splitting failure."""
NOISE_FLOOR = 0.05
"""A fall counts only once the running maximum has reached this fraction of the record's
largest force: the first touch of a platen can chatter (the force rises and falls back to
zero while the contact settles), at forces orders of magnitude below failure."""
MIN_WEIBULL_GRAINS = 10
"""Fewer grains than this and the Weibull fit is flagged as unreliable. Not for the intervals'
coverage: the pivotal intervals of weibull_fit cover at the nominal rate at any n, up to
Monte Carlo error. For the estimate and the width: the maximum-likelihood m is biased upwards,
its mean over 4000 standard samples 17 % high at n = 10 (4.4 % at n = 30, 0.6 % at n = 200;
WeibullFit.m_unbiased removes it on average), and the 95 % interval of m spans a factor of 2.9
at n = 10 (1.75 at n = 30)."""


def _series(name: str, values: ArrayLike) -> np.ndarray:
    """A finite, non-empty 1-D float array, or a ValueError naming the argument."""
    a = np.asarray(values, dtype=float)
    if a.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {a.shape}")
    if a.size == 0:
        raise ValueError(f"{name} is empty")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} holds {int(np.sum(~np.isfinite(a)))} non-finite values")
    return a


def _record(displacement: ArrayLike, force: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    u, f = _series("displacement", displacement), _series("force", force)
    if u.shape != f.shape:
        raise ValueError(f"displacement ({u.size} samples) and force ({f.size} samples) differ in length")
    return u, f


def _positive(name: str, values: ArrayLike) -> np.ndarray:
    a = _series(name, values)
    if np.any(a <= 0):
        bad = a[a <= 0]
        raise ValueError(f"{name} must be positive: {bad.size} values <= 0 (the first: {bad[0]:g})")
    return a


# ---------------------------------------------------------------------------------------
# One grain's record


@dataclass(frozen=True)
class Peak:
    """The first peak of a platen-force record (first_peak).

    index: sample of F_c (the first sample at that force); F_c: the peak force [N];
    displacement: the platen displacement at F_c [m]; dropped: whether the force fell below
    drop × its running maximum after the peak; drop_index: the first sample below it (None
    when dropped is False: F_c is then the largest force of the record, and the caller must
    flag the grain as not broken within the record).
    """

    index: int
    F_c: float
    displacement: float
    dropped: bool
    drop_index: int | None


def first_peak(displacement: ArrayLike, force: ArrayLike, drop: float = DROP, floor: float = NOISE_FLOOR) -> Peak:
    """F_c, the first peak of the platen force (SPEC 4.1).

    Rule: F_c is the largest force before the force first falls below `drop` (0.8) times its
    running maximum (the largest force so far); such a fall counts only once the running
    maximum has reached `floor` (0.05) of the largest force of the whole record, so that
    chatter at first touch is no peak. If the force never falls so, F_c is the largest force
    of the record and dropped is False. Of equal forces the first sample is taken.

    displacement, force: (n,) samples in time order (platen travel, compressive force). The
    floor is relative to the whole record, so the record should end soon after the failure
    (or be cut there): fragments compacted to 1/floor = 20 times F_c later would hide it.
    """
    u, f = _record(displacement, force)
    if not 0.0 < drop < 1.0:
        raise ValueError(f"drop = {drop:g}: must be in (0, 1)")
    if not 0.0 <= floor < 1.0:
        raise ValueError(f"floor = {floor:g}: must be in [0, 1)")
    f_max = float(f.max())
    if f_max <= 0:
        raise ValueError("force is never positive: the platens never touched the grain in this record")
    running = np.maximum.accumulate(f)
    falls = np.flatnonzero((f < drop * running) & (running >= floor * f_max))
    if falls.size == 0:
        i = int(np.argmax(f))
        return Peak(i, float(f[i]), float(u[i]), False, None)
    j = int(falls[0])
    i = int(np.argmax(f[:j]))  # the running maximum at j is the largest force before it
    return Peak(i, float(f[i]), float(u[i]), True, j)


def work_to(displacement: ArrayLike, force: ArrayLike, index: int, work: ArrayLike | None = None) -> float:
    """The platen's work from the first sample to sample `index` (e.g. Peak.index: the work at F_c).

    Without `work`: the trapezoid rule, integral of force d(displacement) over the samples.
    With `work`, a recorded series W_p = integral of F v_p dt (SPEC 4.1) at the same samples,
    its increment work[index] - work[0] is returned instead: the engine integrates it at
    every time step, where the trapezoid sees only the recorded samples. Both start at the
    first sample, so a record that starts before contact gives the same work either way.
    """
    u, f = _record(displacement, force)
    if not 0 <= index < u.size:
        raise ValueError(f"index = {index}: outside the record's {u.size} samples")
    if work is not None:
        w = _series("work", work)
        if w.shape != u.shape:
            raise ValueError(f"work ({w.size} samples) and force ({f.size} samples) differ in length")
        return float(w[index] - w[0])
    return float(trapezoid(f[: index + 1], u[: index + 1]))


@dataclass(frozen=True)
class Stiffness:
    """The loading stiffness (loading_stiffness): slope [N/m] and its standard error from the
    residuals, over the n samples start..stop-1 of the record."""

    slope: float
    sigma: float
    n: int
    start: int
    stop: int


def loading_stiffness(displacement: ArrayLike, force: ArrayLike, F_c: float, lo: float = 0.1,
                      hi: float = 0.5) -> Stiffness:
    """Slope of force against displacement while the grain is loaded towards F_c.

    Rule: the slope of the least-squares line of force against displacement over the last
    unbroken run of samples before the peak with force between lo·F_c and hi·F_c (0.1 and
    0.5): from just after the last sample below lo·F_c to just before the first sample at or
    above hi·F_c. The first sample at or above F_c marks the peak. The lower bound leaves out
    chatter at first touch and the soft start of a Hertzian contact (F ~ delta^1.5), the upper
    one the damage that softens the grain before the peak; the slope is a secant of the
    loading curve in that window, not an elastic constant.

    Needs 3 samples in the window (record more often otherwise).
    """
    u, f = _record(displacement, force)
    if not np.isfinite(F_c) or F_c <= 0:
        raise ValueError(f"F_c = {F_c:g}: must be finite and positive")
    if not 0.0 <= lo < hi <= 1.0:
        raise ValueError(f"lo = {lo:g}, hi = {hi:g}: need 0 <= lo < hi <= 1")
    # a relative tolerance of 1e-12: F_c may come from this very record, rounded on its way
    reached = np.flatnonzero(f >= F_c * (1.0 - 1e-12))
    if reached.size == 0:
        raise ValueError(f"force never reaches F_c = {F_c:g}")
    above = np.flatnonzero(f[: reached[0] + 1] >= hi * F_c)
    stop = int(above[0])  # there is one: the peak itself is above hi·F_c
    below = np.flatnonzero(f[:stop] < lo * F_c)
    start = int(below[-1]) + 1 if below.size else 0
    n = stop - start
    if n < 3:
        raise ValueError(f"{n} samples with force in [{lo:g}, {hi:g}) x F_c before the peak: a stiffness needs 3")
    r = stats.linregress(u[start:stop], f[start:stop])
    return Stiffness(float(r.slope), float(r.stderr), n, start, stop)


def characteristic_stress(F_c: ArrayLike, d: ArrayLike) -> np.ndarray | float:
    """sigma_c = F_c / d² (SPEC 4.1), d the grain's height between the platens at first contact."""
    f, dd = np.asarray(F_c, dtype=float), np.asarray(d, dtype=float)
    if np.any(~np.isfinite(dd)) or np.any(dd <= 0):
        raise ValueError("d must be finite and positive")
    if np.any(~np.isfinite(f)) or np.any(f < 0):
        raise ValueError("F_c must be finite and non-negative")
    out = f / dd ** 2
    return float(out) if out.ndim == 0 else out


# ---------------------------------------------------------------------------------------
# Weibull statistics over grains of one size (SPEC 4.1)


def median_rank_survival(sigma: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """(sigma sorted ascending, P_s): Benard's median rank, the i-th smallest of n (i = 1..n)
    failing with probability (i - 0.3) / (n + 0.4), so P_s = 1 - (i - 0.3) / (n + 0.4)."""
    s = np.sort(_positive("sigma", sigma))
    i = np.arange(1, s.size + 1)
    return s, 1.0 - (i - 0.3) / (s.size + 0.4)


@dataclass(frozen=True)
class WeibullFit:
    """P_s(sigma) = exp(-(sigma / sigma_0)^m) fitted by maximum likelihood (weibull_fit).

    m, sigma_0: the maximum-likelihood estimates; m_interval, sigma_0_interval: pivotal
    intervals at `confidence` from n_boot simulated standard samples (NaN with n_boot = 0);
    n: grains fitted; flag: why the fit is not to be trusted (fewer than MIN_WEIBULL_GRAINS
    grains: m biased upwards, wide intervals), None otherwise; method: how it was fitted.
    m_unbiased: m / mean(m_hat / m), the maximum-likelihood m divided by its bias factor at
    this n, simulated on the same standard samples (ASTM C1239's unbiasing factor, 1/mean:
    0.858 at n = 10, 0.958 at n = 30, 0.994 at n = 200); its mean over samples is m (to 1 %
    at n >= 10), where that of the MLE is 17 % high at n = 10. NaN with n_boot = 0.
    """

    m: float
    sigma_0: float
    m_interval: tuple[float, float]
    sigma_0_interval: tuple[float, float]
    n: int
    confidence: float
    n_boot: int
    flag: str | None = None
    method: str = ""
    m_unbiased: float = float("nan")

    def survival(self, sigma: ArrayLike) -> np.ndarray:
        """P_s at sigma under the fitted law."""
        return np.exp(-(np.asarray(sigma, dtype=float) / self.sigma_0) ** self.m)


def _weibull_mle(sigma: np.ndarray) -> tuple[float, float]:
    """(m, sigma_0) by maximum likelihood, location fixed at 0.

    ln sigma of a Weibull law is a Gumbel law of minima (scipy's gumbel_l) with location
    ln sigma_0 and scale 1/m, and the maximum of the likelihood does not move under the change
    of variable, so gumbel_l.fit on ln sigma is the Weibull MLE: scipy solves its score
    equation to 1e-14, where weibull_min.fit(sigma, floc=0) reaches the same point (to 1e-7,
    tests/test_strength.py) by a general minimiser, 20 times slower, too slow for a bootstrap.
    Data are centred on their mean logarithm first, so stresses in Pa or MPa fit alike.
    """
    ls = np.log(sigma)
    centre = float(ls.mean())
    loc, scale = stats.gumbel_l.fit(ls - centre)
    return float(1.0 / scale), float(np.exp(loc + centre))


@functools.lru_cache(maxsize=256)
def _weibull_pivots(n: int, n_boot: int, seed: int, confidence: float) -> tuple[float, float, float, float, float]:
    """Quantiles of the Weibull MLE's pivotal quantities for samples of n grains, by Monte Carlo.

    For a two-parameter Weibull sample, ln sigma = ln sigma_0 + w / m with w standard (a
    Gumbel law of minima), and the MLE is equivariant under that change of location and scale:
    m_hat = m t1 and ln sigma_0_hat = ln sigma_0 + u / m, where t1 and u are the MLE's m and
    ln sigma_0 of the standard sample w. So t1 = m_hat / m and t2 = t1 u = m_hat ln(sigma_0_hat
    / sigma_0) have laws that depend on n only (Thoman, Bain & Antle 1969). Here n_boot standard
    Weibull samples (m = 1, sigma_0 = 1) of size n, drawn by a numpy Generator seeded by `seed`,
    are fitted by _weibull_mle, and t1 = m_hat_i, t2 = m_hat_i ln sigma_0_hat_i taken.

    Returns (q_t1(alpha/2), q_t1(1 - alpha/2), q_t2(alpha/2), q_t2(1 - alpha/2), mean t1),
    alpha = 1 - confidence. Cached: they depend on (n, n_boot, seed, confidence) only, not on
    the data, so a second fit of n grains (another group of a set) costs one MLE.
    """
    rng = np.random.default_rng(seed)
    est = np.array([_weibull_mle(w) for w in rng.weibull(1.0, size=(n_boot, n))])
    t1 = est[:, 0]
    t2 = t1 * np.log(est[:, 1])
    q = [(1.0 - confidence) / 2, (1.0 + confidence) / 2]
    (a1, b1), (a2, b2) = np.quantile(t1, q), np.quantile(t2, q)
    return float(a1), float(b1), float(a2), float(b2), float(t1.mean())


def weibull_fit(sigma: ArrayLike, n_boot: int = 1000, seed: int = 0, confidence: float = 0.95) -> WeibullFit:
    """m and sigma_0 (the stress at P_s = 1/e) of P_s = exp(-(sigma / sigma_0)^m) (SPEC 4.1).

    Maximum likelihood with the location fixed at 0 (_weibull_mle). Intervals: pivotal
    (Thoman, Bain & Antle 1969, the method of ASTM C1239 for the strength of ceramics):
    m_hat / m and m_hat ln(sigma_0_hat / sigma_0) have laws that depend on n only, simulated
    on n_boot standard Weibull samples of n grains (numpy Generator seeded by `seed`, so the
    intervals are reproducible; _weibull_pivots, cached per (n, n_boot, seed, confidence)).
    With q_t1, q_t2 their quantiles and alpha = 1 - confidence,

        m in [m_hat / q_t1(1 - alpha/2), m_hat / q_t1(alpha/2)],
        sigma_0 in [sigma_0_hat exp(-q_t2(1 - alpha/2) / m_hat), sigma_0_hat exp(-q_t2(alpha/2) / m_hat)].

    Their coverage is the nominal one at any n, m and sigma_0, up to the Monte Carlo error of
    the quantiles, which shrinks as 1/sqrt(n_boot): at n = 30 and n_boot = 1000 the coverage of
    the 95 % interval of m is 94.6 % on average over seeds 0-19, with a standard deviation of
    0.6 % (seed 0: 93.4 %, the lowest of the 20); that of sigma_0 94.7 ± 0.8 %. With the
    defaults (n_boot = 1000, seed = 0), over 4000 samples each of m = 3 and 10, the 95 %
    intervals covered the true m in 93.1-93.5 % of samples of 30 grains and 95.7 % of 200,
    sigma_0 in 95.6-95.8 % and 93.9-94.9 % (400 samples each in tests/test_strength.py); the
    percentile bootstrap that came before covered m in 86 % and sigma_0 in 91.5 % at n = 30
    (400 samples, n_boot = 500; 94.5 and 93.8 % at n = 200). The m of the fit stays the MLE,
    biased upwards at small n (MIN_WEIBULL_GRAINS); m_unbiased divides out its mean bias.
    Fewer grains than MIN_WEIBULL_GRAINS are fitted but flagged.

    sigma: (n,) positive strengths of grains of one size, n >= 2 with two distinct values.
    """
    s = _positive("sigma", sigma)
    if np.unique(s).size < 2:
        raise ValueError(f"sigma holds {np.unique(s).size} distinct value of {s.size}: a Weibull fit needs 2 distinct "
                         "values")
    if n_boot < 0:
        raise ValueError(f"n_boot = {n_boot}: must be >= 0")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence = {confidence:g}: must be in (0, 1)")
    m, s0 = _weibull_mle(s)
    nan = float("nan")
    if n_boot:
        q1_lo, q1_hi, q2_lo, q2_hi, mean_t1 = _weibull_pivots(int(s.size), int(n_boot), int(seed), float(confidence))
        m_int = (m / q1_hi, m / q1_lo)
        s0_int = (s0 * float(np.exp(-q2_hi / m)), s0 * float(np.exp(-q2_lo / m)))
        m_unbiased = m / mean_t1
    else:
        m_int = s0_int = (nan, nan)
        m_unbiased = nan
    flag = (f"{s.size} grains, fewer than {MIN_WEIBULL_GRAINS}: the fit is unreliable (the maximum-likelihood m "
            "biased upwards, see m_unbiased; the intervals wide)" if s.size < MIN_WEIBULL_GRAINS else None)
    method = "maximum likelihood, location 0" + (
        f"; pivotal (Thoman-Bain-Antle), Monte Carlo x {n_boot}" if n_boot else "")
    return WeibullFit(m, s0, m_int, s0_int, int(s.size), float(confidence), int(n_boot), flag, method, m_unbiased)


# ---------------------------------------------------------------------------------------
# Size effect (SPEC 4.1)


@dataclass(frozen=True)
class SizeEffect:
    """median sigma_c = prefactor d^(-b) over sizes, with Weibull's 3/m beside it (size_effect).

    b_interval: percentile bootstrap interval at `confidence`; groups: one row per size,
    ascending: d, n, sigma_median (and its bootstrap interval sigma_median_lo/hi), the
    group's Weibull fit (m, m_lo, m_hi, sigma_0, sigma_0_lo, sigma_0_hi; NaN for a group with
    fewer than two distinct strengths) and b_weibull = 3/m with b_weibull_lo/hi (3/m of the
    interval's ends), flag (the Weibull fit's, or why there is none). reference: the row of
    the group with the most grains (the smallest size among equals), whose 3/m is
    b_weibull / b_weibull_interval, the value to compare b with. Missing values (NaN) where
    there is nothing to give: no interval with n_boot = 0, no flag.
    """

    b: float
    b_interval: tuple[float, float]
    prefactor: float
    confidence: float
    n_boot: int
    groups: pd.DataFrame = field(repr=False)
    reference: int
    b_weibull: float
    b_weibull_interval: tuple[float, float]

    def median(self, d: ArrayLike) -> np.ndarray:
        """The fitted median sigma_c at size d."""
        return self.prefactor * np.asarray(d, dtype=float) ** -self.b


def _slope(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Least-squares slopes of the rows of y against x (shared abscissa)."""
    xc = x - x.mean()
    return (y - y.mean(axis=-1, keepdims=True)) @ xc / (xc @ xc)


def size_effect(d: ArrayLike, sigma: ArrayLike, groups: ArrayLike | None = None, n_boot: int = 1000,
                seed: int = 0, confidence: float = 0.95) -> SizeEffect:
    """b of median sigma_c ~ d^(-b) over grain sizes, and the weakest-link value 3/m (SPEC 4.1).

    Weakest link: a grain survives when every volume element does, so for flaws spread
    through the volume P_s(sigma, V) = exp(-(V / V_0) (sigma / sigma_0)^m); at a fixed P_s
    (the median: P_s = 1/2) sigma scales as V^(-1/m), that is as d^(-3/m) for similar grains:
    b = 3/m (flaws on the surface would give 2/m). The test holds only if sigma_c = F_c / d²
    scales like the stress that breaks the grain (similar shapes) and m is the same at every
    size, which the per-size fits below let one check.

    d, sigma: (n,) per grain. Groups are the grains of equal d, or of equal `groups` label
    when given (then each group's size is the median d of its grains: d measured per grain,
    SPEC 4.1, varies within a nominal size). b: slope of the least-squares line of ln(median
    sigma_c) against ln d, one point per size. Its interval: percentile bootstrap, n_boot
    replicates that resample the grains within each group (seeded, reproducible). 3/m: of
    weibull_fit per group (same n_boot, seed + 1 + the group's row) and of the group with the
    most grains, whose m is best determined.
    """
    dd, s = _positive("d", d), _positive("sigma", sigma)
    if dd.shape != s.shape:
        raise ValueError(f"d ({dd.size} grains) and sigma ({s.size} grains) differ in length")
    labels = dd if groups is None else np.asarray(groups)
    if labels.shape != s.shape:
        raise ValueError(f"groups ({labels.size} labels) and sigma ({s.size} grains) differ in length")
    if n_boot < 0:
        raise ValueError(f"n_boot = {n_boot}: must be >= 0")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence = {confidence:g}: must be in (0, 1)")
    keys = list(np.unique(labels))
    if len(keys) < 2:
        raise ValueError(f"{'d' if groups is None else 'groups'}: grains of {len(keys)} size; a size effect needs "
                         "at least 2")
    members = sorted((np.flatnonzero(labels == k) for k in keys), key=lambda idx: float(np.median(dd[idx])))
    sizes = np.array([np.median(dd[idx]) for idx in members])
    if np.unique(sizes).size < len(sizes):
        raise ValueError("d: two groups have the same median size")
    med = np.array([np.median(s[idx]) for idx in members])
    lx = np.log(sizes)
    b = -float(_slope(lx, np.log(med)))
    prefactor = float(np.exp(np.mean(np.log(med)) + b * lx.mean()))

    rng = np.random.default_rng(seed)
    q = [(1.0 - confidence) / 2, (1.0 + confidence) / 2]
    nan2 = (float("nan"), float("nan"))
    if n_boot:
        boot_med = np.column_stack([np.median(rng.choice(s[idx], size=(n_boot, idx.size), replace=True), axis=1)
                                    for idx in members])
        b_int = tuple(map(float, np.quantile(-_slope(lx, np.log(boot_med)), q)))
        med_int = np.quantile(boot_med, q, axis=0)
    else:
        b_int, med_int = nan2, np.full((2, len(members)), np.nan)

    rows = []
    for k, idx in enumerate(members):
        row = {"d": sizes[k], "n": idx.size, "sigma_median": med[k], "sigma_median_lo": med_int[0, k],
               "sigma_median_hi": med_int[1, k]}
        if np.unique(s[idx]).size >= 2:
            w = weibull_fit(s[idx], n_boot=n_boot, seed=seed + 1 + k, confidence=confidence)
            row |= {"m": w.m, "m_lo": w.m_interval[0], "m_hi": w.m_interval[1], "sigma_0": w.sigma_0,
                    "sigma_0_lo": w.sigma_0_interval[0], "sigma_0_hi": w.sigma_0_interval[1], "b_weibull": 3 / w.m,
                    "b_weibull_lo": 3 / w.m_interval[1], "b_weibull_hi": 3 / w.m_interval[0], "flag": w.flag}
        else:
            row |= dict.fromkeys(("m", "m_lo", "m_hi", "sigma_0", "sigma_0_lo", "sigma_0_hi", "b_weibull",
                                  "b_weibull_lo", "b_weibull_hi"), float("nan"))
            row["flag"] = f"{idx.size} grains with {np.unique(s[idx]).size} distinct strengths: no Weibull fit"
        rows.append(row)
    table = pd.DataFrame(rows)
    ref = int(np.argmax(table["n"].to_numpy()))  # argmax: the first, i.e. smallest size, among equals
    r = table.iloc[ref]
    return SizeEffect(b, b_int, prefactor, float(confidence), int(n_boot), table, ref, float(r["b_weibull"]),
                      (float(r["b_weibull_lo"]), float(r["b_weibull_hi"])))
