"""Scaling fits recover the exponents of synthetic data built from the SPEC 2.5 forms.

Curves are exact scaling functions times log-normal noise of known size (fixed seeds), so
each fit must land within its stated uncertainty of the truth.
"""

from __future__ import annotations

import numpy as np
import pytest

from analysis.scaling import (Curve, collapse_cost, finite_rate_rescale, finite_size_rescale,
                              fit_collapse, fit_finite_rate, fit_finite_size, fit_growth, fit_moment_collapse,
                              fit_threshold_power, locate_threshold, moment_curves, moment_rescale, omega_0, omega_1,
                              threshold_power)

TAU, ALPHA, GAMMA, NU, D = 2.0, 1.5, 2.0, 0.8, 2
NOISE = 0.05


def f_scaling(z):
    return z ** -TAU * np.exp(-z)


def finite_size_curves(rng, sizes=(25, 50, 100, 200), points=25):
    out = []
    for L in sizes:
        m = np.geomspace(3, 4 * L ** ALPHA, points)
        n = L ** (GAMMA - ALPHA * TAU) * f_scaling(m / L ** ALPHA)
        out.append(Curve(m, n * np.exp(rng.normal(size=points) * NOISE), {"L": L}, np.full(points, NOISE)))
    return out


def fs_rescale(cv, p):
    return finite_size_rescale(cv.x, cv.y, cv.params["L"], p[0], p[1], TAU)


def test_rescaling_forms():
    m, n = finite_size_rescale([8.0], [2.0], 4.0, 1.5, 2.0, 2.0)
    assert np.allclose([m[0], n[0]], [8 / 8, 2 * 4 ** 1.0])  # M/L^alpha, N/L^(gamma - alpha tau)
    m, n = finite_rate_rescale([10.0], [3.0], 2.0, 1e-2, 0.5, 2)
    assert np.allclose([m[0], n[0]], [1.0, 3 / (4 * 1e-2)])
    x, y = moment_rescale([1e-3], [5.0], 10.0, 1.0, 0.5, 2)
    assert np.allclose([x[0], y[0]], [1e-1, 5e-3])


def test_cost_near_one_at_the_truth_and_larger_off_it():
    curves = finite_size_curves(np.random.default_rng(0))
    c_true, terms = collapse_cost(curves, fs_rescale, [ALPHA, GAMMA], return_terms=True)
    assert 0.7 < c_true < 1.3 and terms > 100  # honest errors: a good collapse costs about 1
    assert collapse_cost(curves, fs_rescale, [ALPHA + 0.1, GAMMA]) > 3 * c_true
    assert collapse_cost(curves, fs_rescale, [ALPHA, GAMMA + 0.1]) > 3 * c_true


def test_finite_size_collapse_recovers_exponents():
    rng = np.random.default_rng(2)
    fit = fit_finite_size(finite_size_curves(rng), TAU, p0=(1.0, 1.0), n_bootstrap=60, seed=1)
    assert abs(fit.params["alpha"] - ALPHA) < 2 * fit.sigma["alpha"]
    assert abs(fit.params["gamma"] - GAMMA) < 2 * fit.sigma["gamma"]
    assert fit.sigma["alpha"] < 0.02 and "parametric" in fit.method and fit.samples.shape == (60, 2)
    # The bootstrap sigma is the spread of the estimate over independent data sets.
    est = np.array([list(fit_finite_size(finite_size_curves(rng), TAU, p0=(1.0, 1.0), uncertainty="curvature")
                         .params.values()) for _ in range(40)])
    spread = est.std(axis=0, ddof=1)
    assert 0.6 < fit.sigma["alpha"] / spread[0] < 1.6 and 0.6 < fit.sigma["gamma"] / spread[1] < 1.6
    assert np.all(np.abs(est.mean(axis=0) - [ALPHA, GAMMA]) < 3 * spread / np.sqrt(40) + 0.003)


def test_other_uncertainty_modes_and_tau_propagation():
    curves = finite_size_curves(np.random.default_rng(3))
    jack = fit_finite_size(curves, TAU, uncertainty="jackknife")
    curv = fit_finite_size(curves, TAU, uncertainty="curvature")
    assert jack.samples.shape == (4, 2) and "jackknife" in jack.method
    for fit in (jack, curv):
        assert abs(fit.params["alpha"] - ALPHA) < 3 * fit.sigma["alpha"] + 0.01
        assert all(0 < s < 0.1 for s in fit.sigma.values())
    with_tau = fit_finite_size(curves, TAU, sigma_tau=0.05, n_bootstrap=40, seed=1)
    plain = fit_finite_size(curves, TAU, n_bootstrap=40, seed=1)
    assert with_tau.sigma["gamma"] > 2 * plain.sigma["gamma"]  # gamma - alpha tau is what the data fix
    grid = fit_finite_size(curves, TAU, p0=(1.0, 1.0), uncertainty="curvature", bounds=[(0.5, 3), (0, 4)], n_grid=9)
    assert abs(grid.params["alpha"] - curv.params["alpha"]) < 1e-3
    with pytest.raises(ValueError, match="uncertainty"):
        fit_collapse(curves, fs_rescale, [1, 1], ["a", "g"], uncertainty="guess")


def rate_curves(rng, points=45):
    kappa = NU * ALPHA
    curves = []
    for L in (100, 200):
        for edot in (1e-5, 1e-4, 1e-3):
            m = np.geomspace(3, 5 * edot ** -kappa, points)  # about 7 points per decade
            n = L ** D * edot ** (2 * kappa) * f_scaling(m * edot ** kappa)
            curves.append(Curve(m, n * np.exp(rng.normal(size=points) * NOISE), {"L": L, "edot": edot}, NOISE))
    return curves


def test_finite_rate_collapse():
    rng = np.random.default_rng(4)
    kappa = NU * ALPHA
    # With tau = 2 the power-law part collapses for any nu_alpha and the cost has side
    # minima: a coarse grid over the bounds finds the right basin.
    fit = fit_finite_rate(rate_curves(rng), D, p0=0.5, n_bootstrap=40, bounds=[(0.2, 2.0)], n_grid=19)
    assert abs(fit.params["nu_alpha"] - kappa) < 3 * fit.sigma["nu_alpha"] and fit.sigma["nu_alpha"] < 0.005
    # Over independent data sets: unbiased, and the bootstrap sigma is their spread.
    est = np.array([fit_finite_rate(rate_curves(rng), D, p0=kappa, uncertainty="curvature").params["nu_alpha"]
                    for _ in range(30)])
    assert abs(est.mean() - kappa) < 3 * est.std(ddof=1) / np.sqrt(30)
    assert 0.6 < fit.sigma["nu_alpha"] / est.std(ddof=1) < 1.6


def test_second_moment_collapse():
    rng = np.random.default_rng(5)
    L, edot, m2 = [], [], []
    for size in (25, 50, 100, 200):
        for e in np.geomspace(1e-5, 1.0, 11):
            L.append(size)
            edot.append(e)
            m2.append(size ** (D + ALPHA) / (1 + e * size ** (1 / NU)) * np.exp(rng.normal() * 0.03))
    fit = fit_moment_collapse(moment_curves(L, edot, m2, 0.03), D, p0=(1.0, 1.0), n_bootstrap=40)
    assert abs(fit.params["alpha"] - ALPHA) < 2 * fit.sigma["alpha"]
    assert abs(fit.params["nu"] - NU) < 2 * fit.sigma["nu"]


def test_growth_exponent():
    rng = np.random.default_rng(6)
    eps = np.geomspace(0.05, 2.0, 15)
    n = 40 * eps ** 1.7 * np.exp(rng.normal(size=15) * 0.05)
    fit = fit_growth(eps, n)
    assert abs(fit.exponent - 1.7) < 2 * fit.sigma_exponent and fit.n == 15
    assert abs(np.log(fit.prefactor / 40)) < 2 * fit.sigma_log_prefactor
    assert fit_growth(np.append(eps, 0.0), np.append(n, 5.0), eps_max=1.0).n == 12
    with pytest.raises(ValueError):
        fit_growth([1.0, 2.0], [1.0, 2.0])


# -- BCM thresholds against omega ---------------------------------------------------------

OMEGA0, BETA, PREF = 2.1, 0.7, 0.3


def damage_sweep(rng, runs=5, noise=0.05):
    omega = np.repeat(np.arange(1.0, 5.01, 0.25), runs)
    return omega, threshold_power(omega, OMEGA0, BETA, PREF) * np.exp(rng.normal(size=omega.size) * noise)


def test_locate_thresholds():
    omega, dw = damage_sweep(np.random.default_rng(7))
    t0 = omega_0(omega, dw)
    assert (t0.lo, t0.hi, t0.value) == (2.0, 2.25, 2.125) and t0.lo < OMEGA0 < t0.hi
    # Fragments: 1 up to omega = 3 (inclusive), then some runs break in two or more.
    frags = np.where(omega > 3.0, 1 + (omega > 3.2) + (omega > 3.6), 1)
    t1 = omega_1(omega, frags)
    assert (t1.lo, t1.hi) == (3.0, 3.25) and t1.half_width == 0.125
    lin = locate_threshold([1, 2, 3], [1.0, 1.0, 3.0], level=2.0, estimate="linear")
    assert lin.value == 2.5
    assert np.isnan(omega_0([1, 2], [0.1, 0.2]).value) and np.isnan(omega_0([1, 2], [0, 0]).value)


def test_thresholds_bracket_between_parameter_points():
    """Two tessellations per velocity, each with its own omega: the bracket runs from the point
    below to the first run that broke, whichever tessellation it is, never between two
    tessellations of one point."""
    omega = np.array([0.452, 0.453, 2.034, 2.040, 8.14, 8.16])
    velocity = np.array([1, 1, 3, 3, 6, 6])
    for frags, hi in (([1, 1, 1, 3, 9, 12], 2.040), ([1, 1, 3, 1, 9, 12], 2.034)):
        t = omega_1(omega, np.array(frags), groups=velocity)
        assert (t.lo, t.hi) == (0.453, hi)
    # spreads that overlap: the bracket is the overlap's span
    t = omega_0([1.0, 1.3, 1.2, 1.5], [0, 0, 0.1, 0], groups=[1, 1, 2, 2])
    assert (t.lo, t.hi) == (1.2, 1.3)
    assert np.isnan(omega_0([1.0, 1.1], [0.2, 0.0], groups=[1, 1]).value)
    with pytest.raises(ValueError, match="group labels"):
        omega_0([1.0, 2.0], [0, 1], groups=[1])


def test_fit_threshold_power_recovers_and_covers():
    rng = np.random.default_rng(8)
    omega, dw = damage_sweep(rng)
    fit = fit_threshold_power(omega, dw)
    assert abs(fit.omega0 - OMEGA0) < 2 * fit.sigma_omega0
    assert abs(fit.beta - BETA) < 2 * fit.sigma_beta
    assert abs(fit.prefactor - PREF) < 2 * fit.sigma_prefactor
    assert 2.0 <= fit.omega0 < 2.25  # inside the bracket where D_w first becomes positive
    # Coverage over repeated sweeps (omega0 fitted; omega0 fixed with known errors): the
    # stated sigmas are honest (about 95 % within 2 sigma; 400 sweeps gave 93-96 %).
    hits = []
    for _ in range(60):
        om, y = damage_sweep(rng)
        f = fit_threshold_power(om, y)
        g = fit_threshold_power(om, y, omega0=OMEGA0, sigma_lny=0.05)
        hits.append([abs(f.omega0 - OMEGA0) < 2 * f.sigma_omega0, abs(f.beta - BETA) < 2 * f.sigma_beta,
                     abs(g.beta - BETA) < 2 * g.sigma_beta])
    assert np.all(np.mean(hits, axis=0) > 0.85)
    assert g.sigma_omega0 == 0.0 and "fixed" in g.method
    with pytest.raises(ValueError, match="at or below"):
        fit_threshold_power(omega, dw, omega0=3.0)
    assert "extrapolated" not in fit.method
    assert "extrapolated" in fit_threshold_power(omega[omega > 2.5], dw[omega > 2.5]).method


def test_threshold_fit_stays_physical_and_flags_a_bound():
    """D_w from a law whose threshold lies below zero (omega0 = -0.5), sampled where every run
    has cracks: the unconstrained fit returned a negative omega_0. omega0 is now held in its
    physical range (>= 0) and the fit that ends on that bound says so; a fit inside its range
    carries no flag."""
    omega = np.repeat(np.linspace(0.5, 3.0, 11), 3)
    dw = threshold_power(omega, -0.5, 0.7, 0.3) * np.exp(np.random.default_rng(4).normal(size=omega.size) * 0.01)
    fit = fit_threshold_power(omega, dw)
    assert fit.omega0 >= 0.0 and fit.omega0 == pytest.approx(0.0, abs=1e-9)
    assert fit.flag is not None and "lower bound 0" in fit.flag and "physical" in fit.flag
    assert "not constrained" in fit.flag and "lower bound" in fit.method and fit.beta > 0
    good = fit_threshold_power(*damage_sweep(np.random.default_rng(8)))
    assert good.flag is None


def test_omega_1_largest_fragment_rule():
    """SPEC 1.5's break-up: the first point where a run's largest fragment holds less than the
    fraction (default 0.9) of the parent; a 2-cell chip (largest 0.995) is not break-up."""
    from analysis.scaling import BREAKUP_FRACTION, omega_1_largest

    omega = np.array([1.0, 1.1, 2.0, 2.1, 3.0, 3.1])
    largest = np.array([1.0, 1.0, 0.995, 0.93, 0.6, 0.95])
    velocity = np.array([1, 1, 2, 2, 3, 3])
    t = omega_1_largest(omega, largest, groups=velocity)
    assert (t.lo, t.hi, t.value) == (2.1, 3.0, 2.55) and BREAKUP_FRACTION == 0.9
    t = omega_1_largest(omega, largest, 0.94, groups=velocity)
    assert (t.lo, t.hi) == (1.1, 2.1)
    with pytest.raises(ValueError, match="break-up fraction"):
        omega_1_largest(omega, largest, 1.5)
