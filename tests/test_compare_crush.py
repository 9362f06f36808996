"""`driver compare` with `test: crush` (driver/compare/crush.py, issue 24 point 5): the Weibull
fits per model and grain size, the size effect per model, the interval verdicts and the flags
on hand-made tables of grains drawn from known Weibull laws; the compare file's crush grid and
its refusals; the run configs of both models at one element size over the sizes (the BCM's cell
count grows with d³, the BPM's particle size stays)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from analysis.strength import weibull_fit
from driver.compare import crush, stats
from driver.compare.compare import agreement_words
from driver.compare.runs import grid_runs, n_cells_at
from driver.compare.schema import load_compare, material_of
from driver.schema import ConfigError


def write(tmp: Path, name: str, text: str) -> Path:
    p = tmp / name
    p.write_text(text)
    return p


def grains(model: str, m: float, sigma_0: float, sizes: list[float], n: int, b: float = 0.0, seed: int = 0,
           G_c: float = 3.3) -> list[dict]:
    """n grains per size whose sigma_c follows P_s = exp(-(sigma / (sigma_0 (d / 2 mm)^-b))^m)."""
    rng = np.random.default_rng(seed)
    rows = []
    for d in sizes:
        for s in range(1, n + 1):
            sigma = sigma_0 * (d / 2e-3) ** -b * rng.weibull(m)
            rows.append({"model": model, "G_c": G_c, "diameter": d, "seed": s, "state": "finished", "dropped": True,
                         "sigma_c": sigma, "height": d, "F_c": sigma * d * d, "F_max": 2 * sigma * d * d,
                         "F_max_over_F_c": 1.0,
                         "force_mismatch_loading": 0.01, "run_dir": f"/nowhere/{model}/{d}/{s}"})
    return rows


def test_weibull_per_model_and_size_is_analysis_strengths_fit():
    """Each (model, G_c, size) is fitted over its grains that dropped, exactly as
    analysis.strength.weibull_fit does; a grain that never dropped, or a failed run, is left out."""
    rows = grains("bcm", 5.0, 20e6, [2e-3], 12) + grains("bpm", 10.0, 40e6, [2e-3], 12, seed=1)
    rows[3]["dropped"] = False
    rows.append({**rows[0], "state": "failed", "sigma_c": 1.0})
    table = pd.DataFrame(rows)
    both = crush.weibull_table(table)
    assert set(both.strength) == {"sigma_c", "sigma_max"}
    # sigma_max = F_max / d² where the summary has none: twice sigma_c here, the same m
    w_max = both[both.strength == "sigma_max"].set_index("model")
    w = both[both.strength == "sigma_c"].set_index("model")
    assert w_max.loc["bcm", "m"] == pytest.approx(w.loc["bcm", "m"], rel=1e-6)
    assert w_max.loc["bcm", "sigma_0"] == pytest.approx(2 * w.loc["bcm", "sigma_0"], rel=1e-6)
    assert w.loc["bcm", "n"] == 12 and w.loc["bcm", "n_dropped"] == 11 and w.loc["bpm", "n_dropped"] == 12
    s = np.array([r["sigma_c"] for r in rows[:12]])
    fit = weibull_fit(np.delete(s, 3))
    assert w.loc["bcm", "m"] == pytest.approx(fit.m) and w.loc["bcm", "sigma_0"] == pytest.approx(fit.sigma_0)
    assert (w.loc["bcm", "m_lo"], w.loc["bcm", "m_hi"]) == pytest.approx(fit.m_interval)
    assert w.loc["bcm", "flag"] is None
    # sigma_0 20 MPa against 40 MPa: their intervals do not overlap; m 5 against 10 over 12
    # grains: the intervals are wide
    pairs = crush.interval_pairs(crush.weibull_table(table), crush.size_effect_table(table)[0])
    pairs = pairs[pairs.strength == "sigma_c"].set_index("quantity")
    assert pairs.loc["sigma_0", "verdict"] == "differ"
    assert pairs.loc["sigma_0", "lo_bcm"] < 20e6 * 1.2 and pairs.loc["sigma_0", "hi_bpm"] > 40e6 * 0.8
    assert set(pairs.index) == {"m", "sigma_0"}  # one size: no size effect


def test_size_effect_per_model_recovers_its_exponent_and_verdicts_follow_intervals():
    """Grains of three sizes with b = 0.6 (BCM) and 0.2 (BPM), 40 per size: each model's fitted
    b lies in its own interval around the truth, and the two intervals are told apart."""
    sizes = [1.5e-3, 2e-3, 3e-3]
    table = pd.DataFrame(grains("bcm", 5.0, 20e6, sizes, 40, b=0.6)
                         + grains("bpm", 5.0, 20e6, sizes, 40, b=0.2, seed=3))
    sizes_table, effects = crush.size_effect_table(table)
    got = sizes_table[sizes_table.strength == "sigma_c"].set_index("model")
    for model, b in (("bcm", 0.6), ("bpm", 0.2)):
        assert got.loc[model, "b_lo"] < b < got.loc[model, "b_hi"]
        assert got.loc[model, "sizes"] == 3 and got.loc[model, "grains"] == 120
        assert effects[model, 3.3, "sigma_c"].b == pytest.approx(got.loc[model, "b"])
    pairs = crush.interval_pairs(crush.weibull_table(table), sizes_table)
    pairs = pairs[pairs.strength == "sigma_c"]
    b_row = pairs[pairs.quantity == "b"].iloc[0]
    assert math.isnan(b_row.diameter) and b_row.verdict == "differ"
    # m = 5 at every size in both: 3/m agrees
    assert pairs[pairs.quantity == "3/m"].iloc[0].verdict == "agree"
    words = crush.strength_words(pairs, crush.weibull_table(table))
    assert any(w.startswith("b (size effect") and "(differ)" in w for w in words)


def test_interval_verdicts():
    assert crush.interval_verdict(1.0, 2.0, 2.0, 3.0) == "agree"  # touching
    assert crush.interval_verdict(1.0, 2.0, 2.5, 3.0) == "differ"
    assert crush.interval_verdict(1.0, math.nan, 0.0, 3.0) == "undetermined"
    one = pd.DataFrame(grains("bcm", 5.0, 20e6, [2e-3], 1) + grains("bpm", 5.0, 20e6, [2e-3], 6))
    w = crush.weibull_table(one)
    w = w[w.strength == "sigma_c"].set_index("model")
    assert math.isnan(w.loc["bcm", "m"]) and "no Weibull fit" in w.loc["bcm", "flag"]
    assert "unreliable" in w.loc["bpm", "flag"]  # 6 grains
    pairs = crush.interval_pairs(crush.weibull_table(one), crush.size_effect_table(one)[0])
    assert set(pairs.verdict) == {"missing"}


def test_point_measures_side_by_side_and_flags():
    """The point measures go through the impact's side-by-side statistics on (G_c, diameter);
    the flags name the grains that never dropped, failed locally first or were not quasi-static."""
    rows = grains("bcm", 5.0, 20e6, [2e-3], 4) + grains("bpm", 5.0, 20e6, [2e-3], 4, seed=9)
    rows[0]["dropped"] = False
    rows[1]["F_max_over_F_c"] = 4.0
    rows[5]["force_mismatch_loading"] = 0.2
    table = pd.DataFrame(rows)
    points = stats.side_by_side(table, ["F_c", "sigma_c"], keys=("G_c", "diameter"))
    assert len(points) == 2 and set(points.columns) >= {"diameter", "mean_bcm", "mean_bpm", "verdict"}
    summary = stats.agreement_summary(points, "diameter")
    words = agreement_words(points, summary, pd.DataFrame(columns=["threshold"]), 2.0, "diameter",
                            crush.CRUSH_MEASURES)
    assert words[0].startswith("F_c (first-peak force F_c, N)")
    flags = crush.crush_flags(table)
    assert len(flags) == 3
    assert flags[0].startswith("1 grain never dropped") and "BCM d = 2 mm seed 1" in flags[0]
    assert "BCM d = 2 mm seed 2" in flags[1] and "BPM d = 2 mm seed 2" in flags[2]


MATERIAL = """name: m
material: {density: 6000, E: 2.21e11, nu: 0.05, G_c: 3.3}
bcm: {diameter: 2.0e-3, n_cells: 1728}
"""
CRUSH = """name: c
material: m.yaml
test: crush
grid: {diameter: [1.5e-3, 2.0e-3, 3.0e-3], seeds: 2}
bcm: {n_cells: 200}
bpm: {particles_across: 8}
scenario: {platen_speed: 0.02}
"""


def test_the_crush_compare_file_and_its_refusals(tmp_path):
    write(tmp_path, "m.yaml", MATERIAL)
    cmp = load_compare(write(tmp_path, "c.yaml", CRUSH))
    assert cmp.test == "crush" and cmp.grid.axis == "diameter"
    for bad, match in (("grid: {diameter: [1.5e-3, 2.0e-3, 3.0e-3], seeds: 2}",
                        "grid: {velocity: [1.0], seeds: 2}"),):
        with pytest.raises(ConfigError, match="test: crush has no impact velocity"):
            load_compare(write(tmp_path, "c2.yaml", CRUSH.replace(bad, match)))
    with pytest.raises(ConfigError, match="grid.diameter: a non-empty list of distinct positive"):
        load_compare(write(tmp_path, "c3.yaml", CRUSH.replace("1.5e-3, 2.0e-3, 3.0e-3", "2e-3, 2e-3")))
    with pytest.raises(ConfigError, match="scenario: kind comes from test"):
        load_compare(write(tmp_path, "c4.yaml", CRUSH.replace("{platen_speed: 0.02}", "{kind: crush}")))
    impact = CRUSH.replace("test: crush", "test: impact")
    with pytest.raises(ConfigError, match="grid.velocity.*or grid.omega.*exactly one"):
        load_compare(write(tmp_path, "c5.yaml", impact))
    with pytest.raises(ConfigError, match="grid.diameter: particle sizes are a grid of test: crush"):
        load_compare(write(tmp_path, "c6.yaml", impact.replace("seeds: 2}", "seeds: 2, velocity: [1.0]}")))
    with pytest.raises(ConfigError, match="scenario.platen_sped: unknown key"):
        # a crush key misspelt is refused by the run config of each model, naming it
        cmp7 = load_compare(write(tmp_path, "c7.yaml", CRUSH.replace("platen_speed", "platen_sped")))
        mat, _, _ = material_of(cmp7, tmp_path / "c7.yaml")
        grid_runs(cmp7, mat, BCM_CAL, BPM_CAL, tmp_path / "out", "c7.yaml")


BCM_CAL = {"parameters": {"kn": 1.8e7, "kt": 1.44e7, "G_c": 1.04}, "fracture_slope": {"slope": 3.17}}
BPM_CAL = {"parameters": {"k_A": 8.75, "theta_c_deg": 10.0},
           "units": {"length_a_m": 2.5e-4, "mass_m_kg": 9.8e-8, "energy_u_J": 0.0292},
           "lambda_c_by_G_c": [{"G_c": 3.3, "lambda_c": 1.00037}]}


def test_crush_runs_keep_the_element_size_over_the_grain_sizes(tmp_path):
    """Three sizes x two seeds x two models: the BCM's cell count is the material's resolution
    scaled by (d / 2 mm)³, the BPM's particle size a (its length unit) stays; every run is a
    crush at the compare file's platen speed, in runs/<model>/G_c<G_c>/diameter<d>..._seed<s>."""
    write(tmp_path, "m.yaml", MATERIAL)
    cmp = load_compare(write(tmp_path, "c.yaml", CRUSH))
    mat, _, _ = material_of(cmp, tmp_path / "c.yaml")
    runs = grid_runs(cmp, mat, BCM_CAL, BPM_CAL, tmp_path / "out", "c.yaml")
    assert len(runs) == 12
    assert [n_cells_at(mat, d) for d in (1.5e-3, 2e-3, 3e-3)] == [84, 200, 675]
    for values, cfg in runs:
        assert cfg.scenario.kind == "crush" and cfg.scenario.platen_speed == 0.02
        assert values["diameter"] in (1.5e-3, 2e-3, 3e-3) and values["seed"] in (1, 2) and cfg.seed == values["seed"]
        if values["model"] == "bcm":
            assert cfg.model.diameter == values["diameter"]
            assert cfg.model.n_cells == n_cells_at(mat, values["diameter"])
            assert cfg.model.interface.G_c == pytest.approx(3.3 / 3.17, rel=1e-3)
        else:
            assert cfg.model.particle.diameter == values["diameter"]
            assert cfg.model.particle.units.length_a_m == 2.5e-4 and cfg.model.lambda_c == 1.00037
        assert cfg.run_dir().parent == tmp_path / "out" / "runs" / values["model"] / "G_c3.3"
    names = sorted(cfg.run_dir().name for v, cfg in runs if v["model"] == "bcm")
    assert names[0] == "diameter0.0015_n_cells84_seed1"
    assert sorted(cfg.run_dir().name for v, cfg in runs if v["model"] == "bpm")[0] == "diameter0.0015_seed1"

