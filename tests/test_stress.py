"""Stress measures of SPEC 2.4 (analysis/stress.py) on hand-built pressure tensors: P, sqrt(J2)
and mu = sqrt(J2)/P against values worked out by hand, their invariance under rotation, and
the inertial number."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from analysis.stress import inertial_number, stress_measures

COLS = ["pxx", "pyy", "pzz", "pxy", "pxz", "pyz"]


def table(*rows) -> pd.DataFrame:
    return pd.DataFrame(rows, columns=COLS)


def test_3d_by_hand():
    # P = (3 + 1 + 2)/3 = 2; deviator diag(1, -1, 0); J2 = (1 + 1 + 0)/2 + 1^2 + 0^2 + 0.5^2 = 2.25
    t = stress_measures(table([3.0, 1.0, 2.0, 1.0, 0.0, 0.5]), dimension=3)
    assert t.P.iloc[0] == pytest.approx(2.0)
    assert t.sqrtJ2.iloc[0] == pytest.approx(1.5)
    assert t.mu.iloc[0] == pytest.approx(0.75)


def test_2d_pure_and_simple_shear_by_hand():
    # pure shear pxx = P + tau, pyy = P - tau and simple shear pxy = tau both have J2 = tau^2;
    # pzz and the out-of-plane components do not enter in 2D
    P, tau = 4.0, 1.2
    t = stress_measures(table([P + tau, P - tau, 99.0, 0.0, 7.0, 7.0], [P, P, -5.0, tau, 0.0, 0.0]), dimension=2)
    assert t.P.tolist() == pytest.approx([P, P])
    assert t.sqrtJ2.tolist() == pytest.approx([tau, tau])
    assert t.mu.tolist() == pytest.approx([tau / P, tau / P])


def test_invariant_under_rotation():
    rng = np.random.default_rng(3)
    a = rng.normal(size=(3, 3))
    sigma = a + a.T
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    rotated = q @ sigma @ q.T
    rows = [[m[0, 0], m[1, 1], m[2, 2], m[0, 1], m[0, 2], m[1, 2]] for m in (sigma, rotated)]
    t = stress_measures(table(*rows), dimension=3)
    dev = sigma - np.trace(sigma) / 3 * np.eye(3)
    assert t.sqrtJ2.tolist() == pytest.approx([np.sqrt(0.5 * np.sum(dev * dev))] * 2, rel=1e-12)
    assert t.P.tolist() == pytest.approx([np.trace(sigma) / 3] * 2, rel=1e-12)


def test_mu_undefined_without_compression():
    t = stress_measures(table([-1.0, -1.0, 0.0, 0.5, 0.0, 0.0], [0.0, 0.0, 0.0, 0.5, 0.0, 0.0]), dimension=2)
    assert t.sqrtJ2.tolist() == pytest.approx([0.5, 0.5])
    assert t.mu.isna().all()


def test_inertial_number():
    # I = edot <d> sqrt(rho / P) = 1e-3 * 0.8 * sqrt(2 / 0.5) = 1.6e-3; undefined where P <= 0
    got = inertial_number(1e-3, 0.8, np.array([2.0, 2.0, 2.0]), np.array([0.5, 0.0, -1.0]))
    assert got[0] == pytest.approx(1.6e-3) and np.isnan(got[1:]).all()
