"""SPEC 1.5 measures on hand-computed numbers."""

import math

from analysis.impact import impact_measures


def test_measures_by_hand():
    m = impact_measures(wk_minus=10.0, wk_plus=2.0, wk_plus_cm=1.5, broken_area=0.5, total_area=4.0, g_c=3.0,
                        elastic_end=0.25, dissipated_measured=4.75)
    assert m["W_f"] == 3.0 and m["W_s"] == 24.0
    assert m["D_w"] == 0.125 and m["eta"] == 0.3 and m["e_k2"] == 0.2
    assert math.isclose(m["omega"], 10 / 24) and math.isclose(m["chi"], 2 / 3)
    assert m["W_c"] == 5.0 and math.isclose(m["W_c_over_W_s"], 5 / 24)
    assert math.isclose(m["balance_residual"], 0.0, abs_tol=1e-15)


def test_no_fracture_chi_infinite():
    m = impact_measures(1.0, 0.5, 0.5, 0.0, 1.0, 1.0, 0.0)
    assert m["chi"] == math.inf and m["D_w"] == 0.0 and "balance_residual" not in m
