"""Crack speed (SPEC 2.3, analysis/crack.py): the Rayleigh speed against its classical value,
the front and its steady speed on a hand-built break log, and in LAMMPS a mode-I crack that
runs slower than the Rayleigh speed of the same network."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
import yaml

from analysis.crack import crack_fronts, rayleigh_speed, steady_speed
from driver.config import parse_config
from driver.pipeline import execute
from driver.schema import ConfigError


def test_rayleigh_speed_of_a_poisson_solid():
    """lambda = mu (nu = 1/4): c_R = 0.919402 c_s, the root of xi^6 - 8 xi^4 + (56/3) xi^2 - 32/3
    (Rayleigh's classical case). In 3D B = lambda + 2 mu / 3 = 5/3 mu; in 2D the same ratio
    c_s^2 / c_l^2 = 1/3 comes from B = 2 G."""
    xi = math.sqrt(2 - 2 / math.sqrt(3))  # the root of that cubic in xi^2 below 1
    assert rayleigh_speed(5 / 3, 1.0, 1.0, 3) == pytest.approx(xi, rel=1e-9)
    assert xi == pytest.approx(0.919402, abs=1e-6)
    assert rayleigh_speed(2.0 * 4.0, 4.0, 2.0, 2) == pytest.approx(xi * math.sqrt(4.0 / 2.0), rel=1e-9)


def test_front_and_steady_speed_on_a_hand_built_log():
    """Breaks at x = c + v t on both sides (v = 2 right, 3 left) of a void of half-length 10 in
    a sample 80 wide: each front's speed is v exactly; a break behind the front, one off the
    void's plane and one between the tips change nothing."""
    t = np.arange(0.5, 10.0, 0.5)
    right = pd.DataFrame({"time": t, "x": 40 + 10 + 2 * t, "y": 40.0})
    left = pd.DataFrame({"time": t, "x": 40 - 10 - 3 * t, "y": 40.2})
    stray = pd.DataFrame({"time": [5.2, 6.1, 7.3], "x": [40 + 12.0, 40 + 20.0, 40 + 1.0], "y": [40.0, 55.0, 40.0]})
    bonds = pd.concat([right, left, stray], ignore_index=True)
    fronts = crack_fronts(bonds, np.array([40.0, 40.0]), 10.0, band=4.0)
    assert len(fronts) == 2 * len(t) + 1  # the break 15 a off the plane and the one between the tips are out
    behind = fronts[fronts.time == 5.2].iloc[0]
    assert behind.distance == 12.0 and behind.front > 12.0  # behind the front: it does not move back
    speed = steady_speed(fronts, 10.0, 40.0)
    assert speed["crack_speed_right"] == pytest.approx(2.0) and speed["crack_speed_left"] == pytest.approx(3.0)
    assert speed["crack_speed"] == pytest.approx(2.5)
    # exact lines: the fits' errors vanish, the two sides' half spread is the mean's uncertainty
    assert speed["crack_speed_right_se"] == pytest.approx(0.0, abs=1e-9)
    assert speed["crack_speed_se"] == pytest.approx(0.5)
    none = steady_speed(fronts[fronts.time < 1.0], 10.0, 40.0)
    assert math.isnan(none["crack_speed"])


@pytest.mark.slow
def test_mode1_crack_runs_below_the_rayleigh_speed(tmp_path, plugin_path):
    """2D, L = 40, k_A = 4: B and G from a moduli run of the same network, then the mode-I pull;
    the crack front's steady speed is positive and below the Rayleigh speed (measured: 0.43 c_R)."""
    base = {"seed": 1, "model": {"kind": "bpm", "dimension": 2, "L": 40, "k_A": 4}, "output": {"plots": True}}
    mod = {**base, "name": "mod", "scenario": {"kind": "calibrate", "test": "moduli"}}
    mod["output"] = {**base["output"], "dir": str(tmp_path / "mod")}
    execute(parse_config(mod), show_progress=False)
    m = json.loads((tmp_path / "mod" / "results" / "summary.json").read_text())
    pull = {**base, "name": "pull", "scenario": {"kind": "calibrate", "test": "crack_speed", "max_pull_strain": 0.02,
                                                 "B_reference": m["B"], "G_reference": m["G"]}}
    pull["output"] = {**base["output"], "dir": str(tmp_path / "pull")}
    execute(parse_config(pull), show_progress=False)
    s = json.loads((tmp_path / "pull" / "results" / "summary.json").read_text())
    assert s["failed"] and s["crack_points_right"] >= 4 and s["crack_points_left"] >= 4
    assert 0 < s["crack_speed"] < s["rayleigh_speed"]
    assert 0.1 < s["crack_speed_over_rayleigh"] < 1.0
    assert (tmp_path / "pull" / "results" / "crack_front.parquet").exists()
    assert (tmp_path / "pull" / "plots" / "crack_front.png").stat().st_size > 0
    assert s["crack_speed_over_rayleigh_se"] > 0
    yaml.safe_dump(s)  # the summary is plain data


def test_crack_speed_test_needs_the_reference_moduli(tmp_path):
    cfg = {"name": "cs", "model": {"kind": "bpm", "dimension": 2, "L": 40},
           "scenario": {"kind": "calibrate", "test": "crack_speed"}, "output": {"dir": str(tmp_path / "cs")}}
    with pytest.raises(ConfigError, match="B_reference and scenario.G_reference"):
        parse_config(cfg)
    cfg["scenario"].update(B_reference=51.9, G_reference=40.0)
    assert parse_config(cfg).scenario.test == "crack_speed"
