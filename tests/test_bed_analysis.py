"""The bed analysis (analysis/bed.py, issue 25) on hand-built tables and synthetic records whose
answers are worked out here from the definitions, never from the code's own output. No LAMMPS.

Hardin's B_r by hand, D_cut = 0.074 mm: 4 grains of equal mass, b = 2 mm; one of them split
into two halves of b = 1 mm.
  B_p = log10(2 / 0.074) = 0.301030 + 1.130768 = 1.431798 (every grain has b_p = log10(2/0.074));
  current potential = 3/4 log10(2/0.074) + 1/4 log10(1/0.074), so
  B_t = 1/4 (log10(2/0.074) - log10(1/0.074)) = log10(2) / 4 = 0.0752575 and
  B_r = log10(2) / (4 log10(2/0.074)) = 0.0752575 / 1.431798 = 0.0525615.

Einav's B by hand, d_M = 2 mm, d_m = 0.2 mm (one decade on the log10 axis), alpha = 2.5 (k = 0.5):
  area under the ultimate grading = integral over the decade of (d/d_M)^0.5 dlog10 d
    = (1 - 0.1^0.5) / (0.5 ln 10) = 0.683772 / 1.151293 = 0.593917;
  initial: all grains at 2 mm, area 0, so B_p = 0.593917;
  current: half the mass at 2 mm, half at 1 mm: passing 0.5 from 1 to 2 mm, area 0.5 log10(2) = 0.150515;
  B = 0.150515 / 0.593917 = 0.253428.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from analysis.bed import (HARDIN_CUT, K0, einav_breakage, energy_balance, fraction_broken, grading_curve,
                          grain_breakage, hardin_breakage, loading_branch, mean_K0, passing_at, ultimate_passing,
                          void_ratio, yield_stress)

MM = 1e-3
GRAIN_MASS = 1e-5  # kg, about a 2 mm grain of quartz


def fragments(rows):
    """A fragment table from (grain, mass, b) rows; a and c around b, as analysis/fragment_shapes.py's."""
    g, m, b = (np.array(v, dtype=float) for v in zip(*rows))
    return pd.DataFrame({"grain": g.astype(int), "mass": m, "a": 1.2 * b, "b": b, "c": 0.8 * b})


def intact_bed(n=4, b=2 * MM):
    return fragments([(i, GRAIN_MASS, b) for i in range(n)])


def one_split_bed():
    """4 grains of b = 2 mm, grain 0 split into two halves of b = 1 mm."""
    return fragments([(0, GRAIN_MASS / 2, 1 * MM), (0, GRAIN_MASS / 2, 1 * MM),
                      (1, GRAIN_MASS, 2 * MM), (2, GRAIN_MASS, 2 * MM), (3, GRAIN_MASS, 2 * MM)])


# ---------------------------------------------------------------------------------------
# void ratio, K0, loading branch


def test_void_ratio_by_hand():
    # a 10 mm cube holding 0.6 cm³ of solid: e = 1 / 0.6 - 1 = 2/3; 0.9 cm³ of box: 0.9/0.6 - 1 = 0.5
    assert void_ratio(1e-6, 0.6e-6) == pytest.approx(2 / 3, rel=1e-14)
    assert np.allclose(void_ratio(np.array([1e-6, 0.9e-6]), 0.6e-6), [2 / 3, 0.5], rtol=1e-14)
    with pytest.raises(ValueError):
        void_ratio(1e-6, 0.0)


def test_K0_and_window():
    assert np.allclose(K0([50.0, 60.0], [100.0, 200.0]), [0.5, 0.3])
    assert np.isnan(K0(1.0, 0.0))
    # the window keeps sigma_v in [100, 200]: ratios 0.5 and 0.3, mean 0.4
    assert mean_K0([1.0, 50.0, 60.0, 900.0], [10.0, 100.0, 200.0, 1000.0], 100.0, 200.0) == pytest.approx(0.4)
    with pytest.raises(ValueError):
        mean_K0([1.0], [10.0], 100.0, 200.0)


def test_loading_branch_keeps_up_to_the_maximum():
    rec = pd.DataFrame({"sigma_v": [0.0, 1.0, 3.0, 5.0, 4.0, 5.0, 2.0], "void_ratio": np.arange(7.0)})
    assert loading_branch(rec).void_ratio.tolist() == [1.0, 2.0, 3.0]  # the zero left out, the first 5 kept


# ---------------------------------------------------------------------------------------
# compression curve


def bilinear(s):
    """e = 0.8 - 0.02 log10 s up to 1 MPa, then 0.8 - 0.02 * 6 - 0.3 log10(s / 1 MPa): continuous at
    1 MPa, sigma_y = 1 MPa, C_s = 0.02, C_c = 0.3."""
    x = np.log10(s)
    return np.where(x <= 6, 0.8 - 0.02 * x, 0.8 - 0.02 * 6 - 0.3 * (x - 6))


def test_yield_stress_exact_bilinear():
    s = np.logspace(4, 8, 41)
    fit = yield_stress(s, bilinear(s))
    assert fit.flag is None
    assert fit.sigma_y == pytest.approx(1e6, rel=1e-9)
    assert fit.C_c == pytest.approx(0.3, rel=1e-9)
    assert fit.C_s == pytest.approx(0.02, rel=1e-9)
    assert np.allclose(fit.e_post([1e7, 1e8]), bilinear(np.array([1e7, 1e8])))


def test_yield_stress_noisy_bilinear():
    # noise 1e-3 in e on 21 points per line over 2 decades: the slopes' standard errors are about
    # 1e-3 / (sqrt(21) * 0.6) = 4e-4 (0.1 % of C_c), the lines' levels 2e-4, so log10 sigma_y moves
    # by about 3e-4 / (C_c - C_s) = 1e-3 (0.25 %): 1 % is four standard deviations
    s = np.logspace(4, 8, 41)
    rng = np.random.default_rng(25)
    e = bilinear(s) + rng.normal(0.0, 1e-3, s.size)
    order = rng.permutation(s.size)  # the fit sorts by stress: the order given does not matter
    fit = yield_stress(s[order], e[order])
    assert fit.flag is None
    assert fit.sigma_y == pytest.approx(1e6, rel=0.01)
    assert fit.C_c == pytest.approx(0.3, rel=0.01)
    assert fit.C_s == pytest.approx(0.02, abs=5 * 4e-4)
    assert fit.n == 41 and 19 <= fit.split <= 22


@pytest.mark.parametrize("noise", [0.0, 1e-3])
def test_yield_stress_flags_a_straight_line(noise):
    s = np.logspace(4, 8, 41)
    e = 0.8 - 0.1 * np.log10(s) + np.random.default_rng(3).normal(0.0, noise, s.size)
    fit = yield_stress(s, e)
    assert fit.flag is not None and "no knee" in fit.flag
    assert fit.C_c == pytest.approx(0.1, rel=0.2)


def test_yield_stress_flags_a_noisy_flat_line():
    # C_s ~ 0, so the ratio rule cannot reject it: the standard-error rule must
    s = np.logspace(4, 8, 41)
    fit = yield_stress(s, 0.7 + np.random.default_rng(1).normal(0.0, 1e-3, s.size))
    assert fit.flag is not None and "standard errors" in fit.flag


def test_yield_stress_flags_too_few_points():
    s = np.logspace(4, 8, 5)
    fit = yield_stress(s, bilinear(s))
    assert fit.flag is not None and np.isnan(fit.sigma_y)


def test_yield_stress_refuses_non_positive_stress():
    with pytest.raises(ValueError):
        yield_stress([0.0, 1.0, 2.0, 3.0, 4.0, 5.0], np.ones(6))


# ---------------------------------------------------------------------------------------
# grading


def test_grading_curve_by_hand():
    # b = 1, 2, 2, 3 mm with masses 1, 2, 3, 4: fractions 0.1 at 1 mm, 0.5 at 2 mm, 0.4 at 3 mm
    table = fragments([(0, 1.0, 1 * MM), (0, 2.0, 2 * MM), (1, 3.0, 2 * MM), (1, 4.0, 3 * MM)])
    curve = grading_curve(table)
    assert np.allclose(curve["size"], [1 * MM, 2 * MM, 3 * MM])
    assert np.allclose(curve.mass_fraction, [0.1, 0.5, 0.4])
    assert np.allclose(curve.passing, [0.1, 0.6, 1.0])
    d = np.array([0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 10.0]) * MM
    assert np.allclose(passing_at(curve, d), [0.0, 0.1, 0.1, 0.6, 0.6, 1.0, 1.0])
    # the sieve size is b, not a: by a the curve would start at 1.2 mm
    assert passing_at(curve, 1.1 * MM) == pytest.approx(0.1)


# ---------------------------------------------------------------------------------------
# Hardin's B_r


def test_hardin_intact_bed_is_zero():
    curve = grading_curve(intact_bed())
    br = hardin_breakage(curve, curve)
    assert br.relative == 0.0 and br.total == 0.0
    assert br.potential == pytest.approx(np.log10(2 / 0.074), rel=1e-14)


def test_hardin_hand_value():
    assert HARDIN_CUT == 0.074 * MM
    br = hardin_breakage(grading_curve(intact_bed()), grading_curve(one_split_bed()))
    assert br.potential == pytest.approx(np.log10(2 / 0.074), abs=1e-12)
    assert br.total == pytest.approx(np.log10(2) / 4, abs=1e-12)
    assert br.relative == pytest.approx(np.log10(2) / (4 * np.log10(2 / 0.074)), abs=1e-12)
    assert br.relative == pytest.approx(0.0525615, abs=1e-7)


def test_hardin_all_below_cut_is_one():
    dust = fragments([(g, GRAIN_MASS / 8, 0.05 * MM) for g in range(4) for _ in range(8)])
    br = hardin_breakage(grading_curve(intact_bed()), grading_curve(dust))
    assert br.relative == 1.0


def test_hardin_cut_is_a_parameter():
    # with the cut at 0.5 mm: B_p = log10(2/0.5) = log10 4, B_t = log10(2)/4, B_r = 1/8
    br = hardin_breakage(grading_curve(intact_bed()), grading_curve(one_split_bed()), d_cut=0.5 * MM)
    assert br.relative == pytest.approx(0.125, abs=1e-12)


# ---------------------------------------------------------------------------------------
# Einav's B


D_M, D_m, ALPHA = 2 * MM, 0.2 * MM, 2.5


def ultimate_fragments(n, total_mass=1.0, exact=True):
    """Fragments following F_u(d) = (d/D_M)^(3 - ALPHA) between D_m and D_M.

    The mass below D_m, F_u(D_m), sits at D_m (Einav's measure counts it as passing at d_m). The rest
    is cut into n equal-mass bins [F_{j-1}, F_j]. exact: each bin's fragment at the mass-mean of
    log10 d over the bin, so that its step adds exactly the bin's area (the area under a grading on a
    log10 axis is the mass-mean of log10(d_M) - log10(max(d, d_m))). With x(F) = log10 D_M + log10(F)/k,
    k = 3 - alpha, the integral of x dF over the bin is x_M dF + [F ln F - F] / (k ln 10).
    Otherwise each fragment at the bin's mid-quantile.
    """
    k = 3 - ALPHA
    f_m = (D_m / D_M) ** k
    f = np.linspace(f_m, 1.0, n + 1)
    if exact:
        g = f * np.log(f) - f
        x = np.log10(D_M) + np.diff(g) / (np.diff(f) * k * np.log(10))
    else:
        x = np.log10(D_M) + np.log10((f[:-1] + f[1:]) / 2) / k
    rows = [(0, total_mass * f_m, D_m)] + [(0, total_mass * (1 - f_m) / n, 10 ** xi) for xi in x]
    return rows


def test_einav_intact_bed_is_zero():
    curve = grading_curve(intact_bed())
    assert einav_breakage(curve, curve, d_m=D_m).relative == 0.0


def test_einav_hand_value():
    current = fragments([(0, 0.5, 2 * MM), (1, 0.5, 1 * MM)])
    b = einav_breakage(grading_curve(intact_bed()), grading_curve(current), d_m=D_m, alpha=ALPHA)
    assert b.potential == pytest.approx((1 - 0.1 ** 0.5) / (0.5 * np.log(10)), abs=1e-12)
    assert b.total == pytest.approx(0.5 * np.log10(2), abs=1e-12)
    assert b.relative == pytest.approx(0.253428, abs=1e-6)


def test_einav_ultimate_grading_is_one():
    initial = grading_curve(intact_bed())
    exact = einav_breakage(initial, grading_curve(fragments(ultimate_fragments(50))), d_m=D_m, alpha=ALPHA)
    assert exact.relative == pytest.approx(1.0, abs=1e-12)
    # mid-quantile fragments: between them the step curve is within dF/2 of F_u, dF = (1 - F_u(d_m))/n,
    # so the areas differ by at most dF/2 times the decade's length, 1
    n = 200
    mid = einav_breakage(initial, grading_curve(fragments(ultimate_fragments(n, exact=False))), d_m=D_m, alpha=ALPHA)
    bound = (1 - 0.1 ** 0.5) / n / 2 / mid.potential
    assert abs(mid.relative - 1.0) <= bound
    # the step curve of the exact construction against F_u itself, at the fragments' sizes
    curve = grading_curve(fragments(ultimate_fragments(n)))
    assert np.max(np.abs(curve.passing.to_numpy()[:-1] - ultimate_passing(curve["size"].to_numpy()[:-1], D_M)
                         )) <= (1 - 0.1 ** 0.5) / n


def test_einav_mixture_has_its_weight():
    # F = (1 - B) F_0 + B F_u has breakage B: the areas are linear in the grading
    weight = 0.3
    rows = [(i, (1 - weight) / 4, D_M) for i in range(4)] + ultimate_fragments(50, total_mass=weight)
    b = einav_breakage(grading_curve(intact_bed()), grading_curve(fragments(rows)), d_m=D_m, alpha=ALPHA)
    assert b.relative == pytest.approx(weight, abs=1e-12)


# ---------------------------------------------------------------------------------------
# grains


def test_grain_breakage_by_hand():
    grains = pd.DataFrame({"grain": [2, 0, 1], "mass": [GRAIN_MASS] * 3, "diameter": [2 * MM] * 3})
    frags = fragments([(0, 0.89 * GRAIN_MASS, 1.8 * MM), (0, 0.11 * GRAIN_MASS, 0.8 * MM),  # 89 %: broken
                       (1, 0.91 * GRAIN_MASS, 1.9 * MM), (1, 0.05 * GRAIN_MASS, 0.5 * MM),  # 91 %: chipped only
                       (1, 0.04 * GRAIN_MASS, 0.4 * MM),
                       (2, GRAIN_MASS, 2 * MM)])  # intact
    table = grain_breakage(frags, grains)
    assert table.grain.tolist() == [0, 1, 2]
    assert table.n_fragments.tolist() == [2, 3, 1]
    assert np.allclose(table.largest_fraction, [0.89, 0.91, 1.0])
    assert table.broken.tolist() == [True, False, False]
    assert fraction_broken(table) == pytest.approx(1 / 3)
    with pytest.raises(ValueError):
        grain_breakage(frags.assign(grain=frags.grain.replace(2, 7)), grains)


# ---------------------------------------------------------------------------------------
# energy account


def energy_record():
    """Kinetic and elastic energies that start non-zero, three cumulative works, and the platen work
    that closes the account exactly: W_p = change of (kinetic + elastic) + W_damp + W_friction + W_f."""
    t = np.linspace(0.0, 1.0, 6)
    rec = pd.DataFrame({"kinetic": 1e-6 + 1e-7 * np.sin(3 * t), "elastic": 2e-6 + 5e-6 * t ** 2,
                        "W_damp": 1e-6 * t, "W_friction": 3e-6 * t ** 1.5, "W_f": 2e-6 * t ** 3})
    stored = rec.kinetic + rec.elastic
    rec["W_p"] = stored - stored.iloc[0] + rec.W_damp + rec.W_friction + rec.W_f
    return rec


def test_energy_balance_closes():
    rec = energy_record()
    out = energy_balance(rec, ["W_damp", "W_friction", "W_f"])
    assert np.isnan(out.relative.iloc[0])  # no work yet
    assert np.all(np.abs(out.relative.iloc[1:]) < 1e-12)
    assert np.all(np.abs(out.residual) < 1e-12 * rec.W_p.max())


def test_energy_balance_missing_channel():
    rec = energy_record()
    out = energy_balance(rec, ["W_damp", "W_friction"])  # W_f dropped: the residual is W_f itself
    assert np.allclose(out.residual, rec.W_f, rtol=1e-12, atol=1e-20)
    assert np.allclose(out.relative.iloc[1:], (rec.W_f / rec.W_p).iloc[1:], rtol=1e-10)
    assert out.relative.iloc[-1] > 0.1
    with pytest.raises(ValueError):
        energy_balance(rec, ["W_nothing"])
