"""`driver compare` (driver/compare/): the side-by-side statistics on hand-made tables (the
difference of two models' means in units of their combined standard error, the verdicts, the
crossovers' brackets), the measures with the material's G_c, each model's parameter at a grid
G_c, the compare file's refusals; and in real LAMMPS a tiny grid (two velocities, one seed, a
few hundred elements per model) that writes the tables, plots and report, and resumes."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from driver.cli import app
from driver.compare import stats
from driver.compare.compare import agreement_words
from driver.compare.params import bcm_interface_gc, bpm_lambda_c
from driver.compare.schema import load_compare, material_of
from driver.schema import ConfigError


def runs(rows):
    return pd.DataFrame([{"state": "finished", **r} for r in rows])


# ------------------------------------------------------------------------------ statistics
def test_side_by_side_difference_in_combined_standard_errors():
    """BCM D_w 0.1, 0.3 (mean 0.2, s = sqrt(0.02)); BPM 0.5, 0.7, 0.9 (mean 0.7, s = 0.2):
    se = sqrt(0.02 / 2 + 0.04 / 3), z = 0.5 / se = 3.27 > 2: differ. e_k^2 equal means: z = 0."""
    t = runs([{"model": "bcm", "G_c": 1.0, "velocity": 2.0, "D_w": 0.1, "e_k2": 0.4},
              {"model": "bcm", "G_c": 1.0, "velocity": 2.0, "D_w": 0.3, "e_k2": 0.6},
              {"model": "bpm", "G_c": 1.0, "velocity": 2.0, "D_w": 0.5, "e_k2": 0.3},
              {"model": "bpm", "G_c": 1.0, "velocity": 2.0, "D_w": 0.7, "e_k2": 0.5},
              {"model": "bpm", "G_c": 1.0, "velocity": 2.0, "D_w": 0.9, "e_k2": 0.7}])
    p = stats.side_by_side(t, ["D_w", "e_k2"]).set_index("measure")
    se = math.sqrt(0.02 / 2 + 0.04 / 3)
    d = p.loc["D_w"]
    assert (d.n_bcm, d.n_bpm) == (2, 3)
    assert d.mean_bcm == pytest.approx(0.2) and d.std_bcm == pytest.approx(math.sqrt(0.02))
    assert d.mean_bpm == pytest.approx(0.7) and d.std_bpm == pytest.approx(0.2)
    assert d.difference == pytest.approx(0.5) and d.combined_se == pytest.approx(se)
    assert d.z == pytest.approx(0.5 / se) and d.verdict == "differ"
    e = p.loc["e_k2"]
    assert e.z == pytest.approx(0.0) and e.verdict == "agree"
    w = stats.wide(stats.side_by_side(t, ["D_w", "e_k2"]))
    assert len(w) == 1 and w.D_w_mean_bpm.iloc[0] == pytest.approx(0.7) and w.e_k2_verdict.iloc[0] == "agree"
    # a wider agreement band turns the difference into agreement
    assert stats.side_by_side(t, ["D_w"], z_agree=4.0).verdict.iloc[0] == "agree"


def test_verdicts_without_error_bars():
    assert stats.z_score(1.0, math.nan, 1, 2.0, 0.1, 3)[2] != stats.z_score(1.0, math.nan, 1, 2.0, 0.1, 3)[2]  # NaN
    assert stats.verdict(1.0, 2.0, math.nan, 2.0) == "undetermined"
    assert stats.z_score(1.0, 0.0, 2, 1.0, 0.0, 2) == (0.0, 0.0, 0.0)  # equal, no spread: agree
    diff, se, z = stats.z_score(1.0, 0.0, 2, 1.5, 0.0, 2)
    assert (diff, se, z) == (0.5, 0.0, math.inf) and stats.verdict(1.0, 1.5, z, 2.0) == "differ"
    assert stats.verdict(math.nan, 1.0, 0.0, 2.0) == "missing"
    # one run of a model: undetermined; failed runs do not count
    t = runs([{"model": "bcm", "G_c": 1.0, "velocity": 1.0, "D_w": 0.1},
              {"model": "bpm", "G_c": 1.0, "velocity": 1.0, "D_w": 0.2},
              {"model": "bpm", "G_c": 1.0, "velocity": 1.0, "D_w": 0.4}])
    t = pd.concat([t, pd.DataFrame([{"model": "bcm", "G_c": 1.0, "velocity": 1.0, "D_w": 9.0, "state": "failed"}])])
    p = stats.side_by_side(t, ["D_w"]).iloc[0]
    assert p.n_bcm == 1 and p.mean_bcm == pytest.approx(0.1) and p.verdict == "undetermined"


def test_common_measures_use_the_material_gc():
    """A = 1e-6 m^2, A0 = 4e-6 m^2, G_c = 2 J/m^2: W_f = 4e-6 J, W_s = 1.6e-5 J; W_k^- = 3.2e-5 J:
    omega = 2, eta = 0.125; W_k^+ = 8e-6: chi = 2, W_c = 2e-5, W_c / W_s = 1.25; W_f held 2e-6:
    eta_held = 0.0625. The model's own omega (another G_c) is kept as omega_model."""
    t = stats.common_measures(runs([{"model": "bcm", "G_c": 2.0, "A": 1e-6, "A0": 4e-6, "W_k_minus": 3.2e-5,
                                     "W_k_plus": 8e-6, "W_f_held": 2e-6, "omega": 6.0, "W_f": 1.3e-6},
                                    {"model": "bpm", "G_c": 2.0, "A": 0.0, "A0": 4e-6, "W_k_minus": 3.2e-5,
                                     "W_k_plus": 8e-6, "W_f_held": 0.0, "omega": 2.0, "W_f": 0.0}]))
    r = t.iloc[0]
    assert r.W_f == pytest.approx(4e-6) and r.W_s == pytest.approx(1.6e-5) and r.omega == pytest.approx(2.0)
    assert r.eta == pytest.approx(0.125) and r.chi == pytest.approx(2.0) and r.W_c == pytest.approx(2e-5)
    assert r.W_c_over_W_s == pytest.approx(1.25) and r.eta_held == pytest.approx(0.0625)
    assert r.omega_model == 6.0 and r.W_f_model == 1.3e-6
    assert np.isnan(t.iloc[1].chi)  # nothing broke: no chi


def test_crossovers_agree_when_their_brackets_overlap():
    rows = []
    for model, damage in (("bcm", [0.0, 0.1, 0.5]), ("bpm", [0.0, 0.0, 0.3])):
        for v, w, d in zip([1.0, 2.0, 4.0], [0.5, 2.0, 8.0], damage):
            rows.append({"model": model, "G_c": 1.0, "velocity": v, "omega": w, "D_w": d,
                         "largest_fragment_mass_fraction": 1.0 - d})
    cross = stats.crossovers(runs(rows), 0.9)
    c0 = cross[cross.threshold == "omega_0"].set_index("model")
    assert (c0.loc["bcm", "lo"], c0.loc["bcm", "hi"]) == (0.5, 2.0)
    assert (c0.loc["bpm", "lo"], c0.loc["bpm", "hi"]) == (2.0, 8.0)
    pairs = stats.crossover_pairs(cross).set_index("threshold")
    assert pairs.loc["omega_0", "verdict"] == "agree"  # [0.5, 2] and [2, 8] touch at 2
    # omega_1 (largest below 0.9): BCM between 2 and 8 (0.5 at omega 8), BPM between 2 and 8 (0.7)
    assert pairs.loc["omega_1", "verdict"] == "agree"
    far = cross.copy()
    far.loc[(far.model == "bpm") & (far.threshold == "omega_0"), ["lo", "hi"]] = [4.0, 8.0]
    assert stats.crossover_pairs(far).set_index("threshold").loc["omega_0", "verdict"] == "differ"


def test_report_words_come_from_the_table():
    t = runs([{"model": m, "G_c": 1.0, "velocity": v, "D_w": d}
              for m, v, ds in (("bcm", 1.0, [0.1, 0.12]), ("bpm", 1.0, [0.11, 0.13]),
                               ("bcm", 2.0, [0.2, 0.21]), ("bpm", 2.0, [0.6, 0.62])) for d in ds])
    points = stats.side_by_side(t, ["D_w"])
    summary = stats.agreement_summary(points)
    assert summary.iloc[0][["agree", "differ", "undetermined"]].tolist() == [1, 1, 0]
    assert summary.iloc[0].at_velocity == 2.0
    words = agreement_words(points, summary, stats.crossover_pairs(stats.crossovers(t.assign(omega=t.velocity))), 2.0)
    assert words[0].startswith("D_w") and "agree within error bars at 1 point and differ at 1" in words[0]
    assert "v = 2 m/s" in words[0] and "v = 1 m/s" not in words[0]


# ------------------------------------------------------------------------------ parameters, schema
def test_parameters_at_a_grid_gc():
    """BCM: the interface G_c = G_c / slope of the one fracture curve; BPM: lambda_c - 1 grows as
    sqrt(G_c) (K_IC ~ lambda_c - 1, G_c ~ K_IC^2)."""
    assert bcm_interface_gc({"fracture_slope": {"slope": 2.5}}, 5.0) == pytest.approx(2.0)
    assert bpm_lambda_c(1.01, 1.0, 4.0) == pytest.approx(1.02)
    assert bpm_lambda_c(1.01, 1.0, 1.0) == pytest.approx(1.01)


def test_kept_runs_compare_floats_to_a_tolerance():
    from driver.compare.runs import same  # noqa: PLC0415

    assert same({"u": {"m": 7.44485294117647e-08}, "n": [1, 2]}, {"u": {"m": 7.444852940935607e-08}, "n": [1, 2]})
    assert not same({"u": {"m": 7.4e-08}}, {"u": {"m": 7.5e-08}})
    assert not same({"a": 1}, {"b": 1}) and not same({"s": "x"}, {"s": "y"})


def write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


MATERIAL = """name: m
material: {density: 6000, E: 2.21e11, nu: 0.05, G_c: 3.3}
bcm: {diameter: 2.0e-3, n_cells: 1728}
"""


def test_compare_file_refusals_and_resolutions(tmp_path):
    write(tmp_path, "m.yaml", MATERIAL)
    ok = ("name: c\nmaterial: m.yaml\ngrid: {velocity: [1, 2], seeds: 1}\nbcm: {n_cells: 200}\n"
          "bpm: {particles_across: 7}\n")
    cmp = load_compare(write(tmp_path, "c.yaml", ok))
    mat, reuse, _ = material_of(cmp, tmp_path / "c.yaml")
    assert mat.bcm.n_cells == 200 and mat.bpm.dimension == 3 and mat.bpm.a() == pytest.approx(2e-3 / 7)
    assert reuse is None
    on_omega = load_compare(write(tmp_path, "c2.yaml", ok.replace("velocity: [1, 2]", "omega: [1, 2]")))
    assert on_omega.grid.axis == "omega_target" and cmp.grid.axis == "velocity"
    for grid in ("velocity: [1, 2], omega: [1, 2]", "seeds: 2"):
        with pytest.raises(ConfigError, match="grid.velocity.*or grid.omega.*exactly one"):
            load_compare(write(tmp_path, "c2.yaml", ok.replace("velocity: [1, 2], seeds: 1", grid)))
    with pytest.raises(ConfigError, match="scenario: velocity comes from grid"):
        load_compare(write(tmp_path, "c3.yaml", ok + "scenario: {velocity: 3}\n"))
    with pytest.raises(ConfigError, match="unknown curve"):
        load_compare(write(tmp_path, "c4.yaml", ok + "curves: {bpm_modul: {seeds: 1}}\n"))
    with pytest.raises(ConfigError, match="test"):
        load_compare(write(tmp_path, "c5.yaml", ok + "test: shear\n"))
    with pytest.raises(ConfigError, match="does not exist"):
        material_of(load_compare(write(tmp_path, "c6.yaml", ok.replace("m.yaml", "nope.yaml"))), tmp_path / "c6.yaml")


def test_compare_file_unknown_keys_list_the_compare_files_own_keys(tmp_path):
    """An unknown key is named where the file has it, with the keys allowed there: the compare
    file's (not a run config's), and those of its sections (bcm, bpm: not taken for the model
    kinds a run config's messages leave out)."""
    write(tmp_path, "m.yaml", MATERIAL)
    ok = "name: c\nmaterial: m.yaml\ngrid: {velocity: [1, 2], seeds: 1}\n"
    with pytest.raises(ConfigError) as info:
        load_compare(write(tmp_path, "c.yaml", ok + "output: {dir: x}\nbcm: {n_cellz: 200}\nbpm: {lambda: 1.01}\n"))
    lines = str(info.value).splitlines()[1:]
    assert sorted(lines) == sorted([
        "  output: unknown key 'output'; allowed keys: name, material, test, assembly, grid, bcm, bpm, scenario, base, "
        "curves, breakup_fraction, z_agree, workers",
        "  bcm.n_cellz: unknown key 'n_cellz'; allowed keys: n_cells, cell_size",
        "  bpm.lambda: unknown key 'lambda'; allowed keys: particles_across, particle_size, theta_c_deg, lambda_c"])
    with pytest.raises(ConfigError,
                       match=r"grid.step: unknown key 'step'; allowed keys: velocity, omega, G_c, diameter, seeds$"):
        load_compare(write(tmp_path, "c2.yaml", ok.replace("seeds: 1}", "seeds: 1, step: 2}")))


def test_a_calibration_json_as_the_material(tmp_path):
    """driver calibrate's calibration.json: its material, and its BCM result reused while the
    BCM resolution and curves stay the same (a changed n_cells calibrates again)."""
    from driver.calibration.material import load_material  # noqa: PLC0415

    mat = load_material(write(tmp_path, "m.yaml", MATERIAL))
    bcm = {"parameters": {"kn": 1e7, "kt": 8e6, "G_c": 1.0}, "fracture_slope": {"slope": 3.3}}
    (tmp_path / "calibration.json").write_text(json.dumps({"material": mat.model_dump(mode="json"), "bcm": bcm}))
    text = "name: c\nmaterial: calibration.json\ngrid: {velocity: [1]}\nbpm: {particles_across: 7}\n"
    cmp = load_compare(write(tmp_path, "c.yaml", text))
    got, reuse, _ = material_of(cmp, tmp_path / "c.yaml")
    assert reuse == bcm and got.bcm.n_cells == 1728 and got.material.G_c == 3.3
    other = load_compare(write(tmp_path, "c2.yaml", text + "bcm: {n_cells: 300}\n"))
    assert material_of(other, tmp_path / "c2.yaml")[1] is None
    (tmp_path / "bad.json").write_text("{}")
    with pytest.raises(ConfigError, match="not a calibration.json"):
        material_of(load_compare(write(tmp_path, "c3.yaml", text.replace("calibration.json", "bad.json"))),
                    tmp_path / "c3.yaml")


# ------------------------------------------------------------------------------ LAMMPS: a tiny grid
TINY_MATERIAL = """name: tiny
material: {density: 6000, E: 2.21e11, nu: 0.05, G_c: 3.3}
bcm: {diameter: 2.0e-3, n_cells: 200}
curves:
  bcm_moduli: {base: {scenario.block.n_cells: 64}, axes: {model.interface.kt: [5.0e6, 1.0e7]}, seeds: 1}
  bcm_fracture: {base: {scenario.block.n_cells: 64}, axes: {model.interface.G_c: [0.5, 1.0]}, seeds: 1}
  bpm_moduli: {base: {model.L: 6}, axes: {model.k_A: [0, 1, 2]}, seeds: 1}
  bpm_mode1: {base: {model.L: 12, scenario.void_axes: [8, 1]}, seeds: 1,
              zip: [{model.lambda_c: [1.003, 1.03], scenario.max_pull_strain: [0.0009, 0.009],
                     scenario.strain_rate: [1.2e-5, 1.2e-4]}]}
"""
TINY = """name: tiny
material: m.yaml
grid: {velocity: [2.0, 8.0], seeds: 1}
bcm: {n_cells: 200}
bpm: {particles_across: 7}
scenario: {max_time: 1.0e-4}
workers: 1
"""


@pytest.mark.slow
def test_tiny_grid_writes_tables_plots_report_and_resumes(tmp_path, monkeypatch, plugin_cache):
    """Two velocities, one seed, about 200 cells and 220 particles: calibration (small curves),
    4 runs, the tidy and side-by-side tables, the plots and the report; the second call finds
    every run finished and the curves cached; then an omega grid and a crush grid
    (check_tiny_crush_grid) on the same cached curves."""
    monkeypatch.chdir(tmp_path)
    write(tmp_path, "m.yaml", TINY_MATERIAL)
    write(tmp_path, "c.yaml", TINY)
    res = CliRunner().invoke(app, ["compare", "c.yaml", "--out", "cmp"])
    assert res.exit_code == 0, res.output
    out = tmp_path / "cmp"
    table = pd.read_csv(out / "runs.csv")
    assert len(table) == 4 and set(table.model) == {"bcm", "bpm"} and (table.state == "finished").all()
    assert {"omega", "omega_model", "D_w", "e_k2", "eta", "eta_held", "chi", "W_c_over_W_s", "W_f", "W_f_held",
            "wall_seconds"} <= set(table.columns)
    # both models at one velocity see about the same omega: the same parent, mass and G_c
    w = table.pivot(index="velocity", columns="model", values="omega")
    assert np.allclose(w.bcm, w.bpm, rtol=0.3)
    points = pd.read_csv(out / "points.csv")
    assert len(points) == 2 * points.measure.nunique() and {"mean_bcm", "std_bpm", "z", "verdict"} <= set(points)
    assert set(points.verdict) <= {"undetermined", "missing"}  # one seed: no error bars
    for f in ("agreement.csv", "crossovers.csv", "fragment_masses.csv", "calibration.json", "report.md",
              "report.html"):
        assert (out / f).stat().st_size > 0, f
    for f in ("measures_vs_omega", "shapes_vs_omega", "crossovers", "fragment_masses"):
        assert (out / "plots" / f"{f}.png").stat().st_size > 0, f
    report = (out / "report.md").read_text()
    assert "Where the models agree" in report and "wall time per run" in report
    assert "No verdict at any point for omega, D_w" in report  # one seed: no error bars
    # W_f twice in the BCM too (issue 13, point 2): W_f_held, the interfaces' energy at break, is
    # the break log's energy (results/breaks), and 2 A G_c beside it
    for r in table[(table.model == "bcm") & (table.D_w > 0)].itertuples():
        log = pd.read_parquet(f"{r.run_dir}/results/breaks.parquet")
        assert r.W_f_held == pytest.approx(log.energy.sum(), rel=1e-6) and r.W_f_held > 0
    cal = json.loads((out / "calibration.json").read_text())
    assert cal["bcm"]["parameters"]["G_c"] > 0 and cal["bpm"]["parameters"]["lambda_c_at_material_G_c"] > 1.0
    # lambda_c from the 3D mode-I curve, at the material's packing (lj_minimum by default)
    assert "bpm_mode1" in cal["bpm"]["curves"] and cal["material"]["bpm"]["packing"] == "lj_minimum"

    summaries = sorted(out.glob("runs/*/*/*/results/summary.json"))
    stamps = [p.stat().st_mtime_ns for p in summaries]
    t0 = time.time()
    again = CliRunner().invoke(app, ["compare", "c.yaml", "--out", "cmp"])
    assert again.exit_code == 0, again.output
    assert time.time() - t0 < 30  # curves from the cache, every run kept
    assert len(summaries) == 4 and [p.stat().st_mtime_ns for p in summaries] == stamps
    assert len(pd.read_csv(out / "runs.csv")) == 4

    # an omega grid (the curves cached): each particle hit at its own v_0, and each run's
    # omega with the material's G_c (W_k^- / (2 A_0 G_c), from its own analysis) is the target
    write(tmp_path, "w.yaml", TINY.replace("velocity: [2.0, 8.0]", "omega: [0.3]"))
    res = CliRunner().invoke(app, ["compare", "w.yaml", "--out", "cmpw"])
    assert res.exit_code == 0, res.output
    table = pd.read_csv(tmp_path / "cmpw" / "runs.csv")
    assert len(table) == 2 and (table.state == "finished").all()
    assert table.omega.to_numpy() == pytest.approx([0.3, 0.3], rel=1e-9)
    assert table.omega_target.tolist() == [0.3, 0.3] and table.velocity.nunique() == 2
    assert all(Path(d).name == "omega0.3_seed1" for d in table.run_dir)
    points = pd.read_csv(tmp_path / "cmpw" / "points.csv")
    assert "omega_target" in points and len(points) == points.measure.nunique() and "omega" not in set(points.measure)
    assert "same damage potential omega" in (tmp_path / "cmpw" / "report.md").read_text()

    # the crush (issue 24, point 5) on the same calibration, read from the cache
    check_tiny_crush_grid(tmp_path)


# ------------------------------------------------------- LAMMPS: a tiny crush grid (run by the tiny grid test, on its curves)
TINY_CRUSH = """name: tiny_crush
material: m.yaml
test: crush
grid: {diameter: [1.6e-3, 2.0e-3], seeds: 1}
bcm: {n_cells: 80}
bpm: {particles_across: 6}
scenario: {platen_speed: 0.02}
workers: 1
"""


def check_tiny_crush_grid(tmp_path: Path) -> None:
    """test: crush on the tiny material (its curves cached by the impact grid before): two
    sizes, one seed, both models (80 and 41 BCM cells, 6 and 4.8 BPM particles across): 4
    crushes that drop, the crush measures side by side per size, the Weibull table (no fit: one
    grain a size), a size effect per model and strength, the plots and the report
    (driver/compare/crush.py)."""
    write(tmp_path, "k.yaml", TINY_CRUSH)
    res = CliRunner().invoke(app, ["compare", "k.yaml", "--out", "cmpk"])
    assert res.exit_code == 0, res.output
    out = tmp_path / "cmpk"
    table = pd.read_csv(out / "runs.csv")
    assert len(table) == 4 and (table.state == "finished").all() and table.dropped.all()
    assert sorted(table.diameter.unique()) == [1.6e-3, 2.0e-3] and set(table.model) == {"bcm", "bpm"}
    assert (table.F_c > 0).all() and (table.F_max >= table.F_c).all()
    assert table.sigma_max.to_numpy() == pytest.approx((table.F_max / table.height ** 2).to_numpy(), rel=1e-9)
    bcm = table[table.model == "bcm"].sort_values("diameter")
    assert [Path(d).name for d in bcm.run_dir] == ["diameter0.0016_n_cells41_seed1", "diameter0.002_n_cells80_seed1"]
    points = pd.read_csv(out / "points.csv")
    assert len(points) == 2 * points.measure.nunique() and {"F_c", "sigma_c", "sigma_max"} <= set(points.measure)
    weibull = pd.read_csv(out / "weibull.csv")
    assert len(weibull) == 8 and weibull.m.isna().all()  # 2 models x 2 sizes x 2 strengths, one grain each
    sizes = pd.read_csv(out / "size_effect.csv")
    assert len(sizes) == 4 and np.isfinite(sizes.b).all()  # per model and strength, over the two sizes
    pairs = pd.read_csv(out / "strength_pairs.csv")
    assert set(pairs.quantity) == {"m", "sigma_0", "b", "3/m"}
    for f in ("force_displacement", "measures_vs_size", "fragments_vs_size", "size_effect"):
        assert (out / "plots" / f"{f}.png").stat().st_size > 0, f
    report = (out / "report.md").read_text()
    assert "BCM and BPM, crush" in report and "wall time per run" in report and "size effect" in report


@pytest.mark.parametrize("name", ["compare_impact_small.yaml", "compare_impact.yaml", "compare_crush_small.yaml"])
def test_the_compare_examples_load_with_their_material(name):
    path = Path(__file__).resolve().parent.parent / "examples" / name
    cmp = load_compare(path)
    mat, _, _ = material_of(cmp, path)
    assert cmp.grid.axis == ("diameter" if cmp.test == "crush" else "omega_target") and mat.bpm.dimension == 3
