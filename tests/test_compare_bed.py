"""`driver compare` with `test: compress` (driver/compare/bed.py, issue 25 point 6): the compare
file's bed and its refusals; the run configs of both models fill the same bed (grain count,
sizes, box, seeds) with the same scenario; the side-by-side table and its verdicts on hand-made
runs whose summaries are known, with the last dumped state's breakage carried into the table."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from driver.compare import bed, stats
from driver.compare.compare import _bed_analysis, agreement_words
from driver.compare.runs import grid_runs
from driver.compare.schema import load_compare, material_of
from driver.schema import ConfigError
from tests.test_compare_crush import BCM_CAL, BPM_CAL, MATERIAL, write

BED = """name: b
material: m.yaml
test: compress
grid: {seeds: 2}
assembly: {n_grains: 8, sizes: {kind: uniform, min: 1.6e-3, max: 2.4e-3}, box: [6.0e-3, 6.0e-3, 1.4e-2]}
bcm: {n_cells: 100}
bpm: {particles_across: 6}
scenario: {platen_speed: 0.5, target_stress: 2.0e6}
"""


def test_the_bed_compare_file_and_its_refusals(tmp_path):
    write(tmp_path, "m.yaml", MATERIAL)
    cmp = load_compare(write(tmp_path, "c.yaml", BED))
    assert cmp.test == "compress" and cmp.assembly["n_grains"] == 8
    for text, match in ((BED.replace("assembly: {n_grains: 8, sizes: {kind: uniform, min: 1.6e-3, max: 2.4e-3}, "
                                      "box: [6.0e-3, 6.0e-3, 1.4e-2]}\n", ""), "needs assembly"),
                        (BED.replace("grid: {seeds: 2}", "grid: {velocity: [1.0], seeds: 2}"),
                         "test: compress has no impact velocity"),
                        (BED.replace("grid: {seeds: 2}", "grid: {diameter: [2.0e-3], seeds: 2}"), "assembly.sizes"),
                        (BED.replace("test: compress", "test: crush"), "assembly: a bed of grains is for test: "
                                                                        "compress")):
        with pytest.raises(ConfigError, match=match):
            load_compare(write(tmp_path, "bad.yaml", text))


def test_both_models_fill_the_same_bed(tmp_path):
    """Two seeds x two models: every run is a compress test with the compare file's scenario and
    the same model.assembly (count, sizes, box), its seed the grid's, in runs/<model>/G_c<G_c>/
    seed<s>; the BCM at its resolution and calibrated interface G_c, the BPM at its units and
    lambda_c. Same seed, same grain sizes: both draw them from the seed's stream."""
    from driver.assembly import grain_sizes  # noqa: PLC0415

    write(tmp_path, "m.yaml", MATERIAL)
    cmp = load_compare(write(tmp_path, "c.yaml", BED))
    mat, _, _ = material_of(cmp, tmp_path / "c.yaml")
    runs = grid_runs(cmp, mat, BCM_CAL, BPM_CAL, tmp_path / "out", "c.yaml")
    assert len(runs) == 4
    assemblies = {(v["model"], v["seed"]): cfg.model.assembly.model_dump() for v, cfg in runs}
    for values, cfg in runs:
        assert cfg.scenario.kind == "compress" and cfg.scenario.platen_speed == 0.5
        assert cfg.scenario.target_stress == 2.0e6 and cfg.seed == values["seed"] and values["n_grains"] == 8
        assert assemblies[(values["model"], values["seed"])] == assemblies[("bcm", values["seed"])]
        assert cfg.run_dir() == tmp_path / "out" / "runs" / values["model"] / "G_c3.3" / f"seed{values['seed']}"
        if values["model"] == "bcm":
            assert cfg.model.n_cells == 100 and cfg.model.interface.G_c == pytest.approx(3.3 / 3.17, rel=1e-3)
        else:
            assert cfg.model.particle.units.length_a_m == 2.5e-4 and cfg.model.lambda_c == 1.00037
    a = assemblies[("bcm", 1)]
    spec = runs[0][1].model.assembly.sizes
    for seed in (1, 2):
        d = [grain_sizes(spec, a["n_grains"], np.random.default_rng([seed, 25])) for _ in range(2)]
        assert np.array_equal(d[0], d[1])


def fake_bed(root: Path, model: str, seed: int, **summary) -> dict:
    """A finished run directory with its summary (states: the last dumped state's breakage)."""
    run_dir = root / model / f"seed{seed}"
    (run_dir / "results").mkdir(parents=True)
    states = [{"state": "load", "sigma_v": 5e4, "B_r": 0.0, "B_r_star": 0.0, "fraction_broken": 0.0,
               "fragments_per_grain": 1.0},
              {"state": "end", "sigma_v": 2e6, "B_r": summary.pop("B_r"), "B_r_star": 0.1, "fraction_broken": 0.5,
               "fragments_per_grain": 3.0}]
    (run_dir / "results" / "summary.json").write_text(json.dumps({**summary, "states": states}))
    return {"model": model, "G_c": 3.3, "n_grains": 8, "seed": seed, "state": "finished", "run_dir": str(run_dir),
            **summary}


def test_side_by_side_verdicts_on_known_beds(tmp_path):
    """Three seeds a model: sigma_y 1.0, 1.1, 0.9 MPa (BCM) against 3.0, 3.2, 2.8 MPa (BPM) differ
    (z = 15.5); e_start 1.50, 1.52, 1.48 against 1.51, 1.49, 1.50 agree; B_r of the last state is
    carried from the summaries' states (0.02-0.04 against 0.10-0.12: differ); a failed run is
    left out and the report says so."""
    rows = []
    for k, seed in enumerate((1, 2, 3)):
        rows.append(fake_bed(tmp_path, "bcm", seed, sigma_y=[1.0e6, 1.1e6, 0.9e6][k], e_start=[1.50, 1.52, 1.48][k],
                             B_r=[0.02, 0.03, 0.04][k], inertial_max=5e-4, balance_residual=1e-5))
        rows.append(fake_bed(tmp_path, "bpm", seed, sigma_y=[3.0e6, 3.2e6, 2.8e6][k], e_start=[1.51, 1.49, 1.50][k],
                             B_r=[0.10, 0.11, 0.12][k], inertial_max=5e-3, balance_residual=1e-5))
    rows.append({"model": "bpm", "G_c": 3.3, "n_grains": 8, "seed": 4, "state": "failed", "run_dir": "/nowhere",
                 "error": "boom"})
    table = bed.with_last_state(pd.DataFrame(rows))
    assert table.loc[table.model == "bpm", "B_r_last"].dropna().tolist() == [0.10, 0.11, 0.12]
    points = stats.side_by_side(table, list(bed.BED_MEASURES), keys=("G_c", "n_grains"))
    verdict = points.set_index("measure").verdict
    assert verdict["sigma_y"] == "differ" and verdict["e_start"] == "agree" and verdict["B_r_last"] == "differ"
    z = points.set_index("measure").z["sigma_y"]
    assert z == pytest.approx((3.0e6 - 1.0e6) / np.sqrt((0.1e6 ** 2 + 0.2e6 ** 2) / 3), rel=1e-9)
    words = agreement_words(points, stats.agreement_summary(points, "n_grains"), pd.DataFrame(columns=["threshold"]),
                            2.0, "n_grains", bed.BED_MEASURES)
    assert any(w.startswith("sigma_y") and "8 grains" in w and "differ" in w for w in words)
    flags = bed.bed_flags(table)
    assert len(flags) == 1 and flags[0].startswith("BPM: 3 of 3 beds loaded faster than quasi-static")


def test_bed_analysis_writes_its_tables(tmp_path):
    """The comparison's bed section on known runs: points, agreement and beds tables written, the
    verdicts in the report's words (no figures: no record tables in the fake runs)."""
    from analysis.plots import PlotGuard  # noqa: PLC0415
    from analysis.report import Report  # noqa: PLC0415

    write(tmp_path, "m.yaml", MATERIAL)
    cmp = load_compare(write(tmp_path, "c.yaml", BED))
    rows = [fake_bed(tmp_path / "runs", m, s, sigma_y=v, e_start=1.5, B_r=0.01 * s, inertial_max=1e-4,
                     balance_residual=1e-6)
            for m, vals in (("bcm", (1e6, 1.2e6)), ("bpm", (1.1e6, 1.3e6))) for s, v in zip((1, 2), vals)]
    rep = Report("t", "")
    result, figures = _bed_analysis(cmp, pd.DataFrame(rows), tmp_path, False, PlotGuard(), "t", rep)
    for name in ("points", "agreement", "beds"):
        assert (tmp_path / f"{name}.csv").exists()
    agreement = {r["measure"]: r for r in result["agreement"]}
    assert agreement["sigma_y"]["agree"] == 1 and figures == {}
