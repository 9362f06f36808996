"""Sweep files (`driver sweep sweep.yaml`): axes, zip groups, ranges, seeds, base, names, dry
run and its cost estimate; the sweep's table and progress where they are not written to a
terminal; and, in real LAMMPS, sweeps on a local Dask cluster (a failed run recorded, an
interrupted sweep resumed)."""

from __future__ import annotations

import io
import json
import os
from pathlib import Path

import pandas as pd
import pytest
import yaml
from rich.console import Console
from typer.testing import CliRunner

from driver.cli import app, print_runs
from driver.config import ConfigError, resolved_yaml
from driver.estimate import estimate
from driver.sweep import load_sweep, plan, short_keys, value_list

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
BASE = {"name": "sw", "seed": 2, "model": {"kind": "bpm", "dimension": 2, "L": 8},
        "scenario": {"kind": "shear", "strain_rate": 0.02, "max_strain": 0.1, "measure_strains": [0.1],
                     "thermo_every": 100}}


def write(path: Path, data) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def tree(root: Path) -> set[str]:
    return {str(Path(d, f).relative_to(root)) for d, dirs, files in os.walk(root) for f in files + dirs}


def dry_run(*args):
    return CliRunner().invoke(app, ["sweep", *map(str, args), "--dry-run"])


# ----------------------------------------------------------------------------- grids
def test_three_axis_dry_run_lists_the_product_and_names(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    sweep = write(tmp_path / "grid.yaml", {"base": BASE, "axes": {
        "scenario.strain_rate": [0.01, 0.02], "model.k_A": {"linspace": [1, 3, 3]}, "model.gamma": [10.5, 50]}})
    loaded = load_sweep(sweep, [])
    assert loaded.directory == Path("runs/grid")
    assert loaded.keys == ["scenario.strain_rate", "model.k_A", "model.gamma"]
    names = [cfg.run_dir().name for _, cfg in loaded.runs]
    expected = [f"strain_rate{r}_k_A{k}_gamma{g}" for r in ("0.01", "0.02") for k in (1, 2, 3) for g in ("10.5", 50)]
    assert names == expected  # the first axis varies slowest
    values, cfg = loaded.runs[9]  # 0.02, 2, 50
    assert values == {"scenario.strain_rate": 0.02, "model.k_A": 2, "model.gamma": 50}
    assert (cfg.scenario.strain_rate, cfg.model.k_A, cfg.model.gamma) == (0.02, 2, 50)
    assert cfg.run_dir() == Path("runs/grid") / expected[9] and cfg.name == f"sw_{expected[9]}"
    result = dry_run(sweep)
    assert result.exit_code == 0, result.output
    assert all(name in result.output for name in expected)
    assert result.output.count("pending") == 12 and "12 runs in runs/grid" in result.output


def test_zip_pairs_keys_and_refuses_unequal_lengths(tmp_path):
    sweep = write(tmp_path / "z.yaml", {"base": BASE, "axes": {"model.k_A": [1, 2]},
                                        "zip": [{"model.L": [8, 12, 16], "scenario.strain_rate": [0.04, 0.02, 0.01]}]})
    runs = load_sweep(sweep, []).runs
    pairs = [(v["model.k_A"], v["model.L"], v["scenario.strain_rate"]) for v, _ in runs]
    assert pairs == [(k, L, r) for k in (1, 2) for L, r in ((8, 0.04), (12, 0.02), (16, 0.01))]
    assert runs[1][1].run_dir().name == "k_A1_L12_strain_rate0.02"
    write(sweep, {"base": BASE, "zip": [{"model.k_A": [1, 2]}, {"model.L": [8, 12, 16],
                                                                "scenario.strain_rate": [0.04, 0.02]}]})
    with pytest.raises(ConfigError, match=r"(?s)z\.yaml: zip group 2 \(model\.L, scenario\.strain_rate\).*equal lengths"):
        load_sweep(sweep, [])
    write(sweep, {"base": BASE, "zip": {"model.L": [8, 12]}})
    with pytest.raises(ConfigError, match="zip: expected a list of groups"):
        load_sweep(sweep, [])


def test_log_and_lin_ranges():
    log = value_list({"logspace": [0.5, 10, 12]}, "v")
    assert len(log) == 12 and log[0] == 0.5 and log[-1] == 10
    ratios = [b / a for a, b in zip(log, log[1:])]
    assert ratios == pytest.approx([20 ** (1 / 11)] * 11, rel=1e-10)  # geometric, between the values given
    assert value_list({"logspace": [1, 1000, 4]}, "v") == [1, 10, 100, 1000]
    assert value_list({"linspace": [0.0, 1.0, 5]}, "v") == [0.0, 0.25, 0.5, 0.75, 1.0]
    assert value_list({"linspace": [0, 0.3, 4]}, "v") == [0, 0.1, 0.2, 0.3]  # no 0.30000000000000004
    ints = value_list({"linspace": [300, 1700, 3]}, "v")
    assert ints == [300, 1000, 1700] and all(isinstance(v, int) for v in ints)
    assert value_list({"linspace": [2.5, 2.5, 1]}, "v") == [2.5]
    for bad in ({"logspace": [0, 10, 3]}, {"linspace": [0, 1, 2.5]}, {"linspace": [0, 1]}, {"range": [0, 1, 2]},
                [], 3.0):
        with pytest.raises(ConfigError, match="^v: "):
            value_list(bad, "v")


def test_seeds_as_count_and_list(tmp_path):
    sweep = write(tmp_path / "s.yaml", {"base": BASE, "axes": {"model.k_A": [1, 2]}, "seeds": 3})
    runs = load_sweep(sweep, []).runs
    assert [(v["model.k_A"], cfg.seed) for v, cfg in runs] == [(k, s) for k in (1, 2) for s in (1, 2, 3)]
    assert runs[0][1].run_dir().name == "k_A1_seed1"
    write(sweep, {"base": BASE, "seeds": [7, 11]})
    assert [cfg.run_dir().name for _, cfg in load_sweep(sweep, []).runs] == ["seed7", "seed11"]
    for bad in (0, [], [1.5], "3"):
        write(sweep, {"base": BASE, "seeds": bad})
        with pytest.raises(ConfigError, match=r"s\.yaml: seeds"):
            load_sweep(sweep, [])
    write(sweep, {"base": BASE, "axes": {"seed": [1, 2]}, "seeds": 2})
    with pytest.raises(ConfigError, match="varied more than once: seed"):
        load_sweep(sweep, [])


def test_base_as_relative_path_and_inline(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write(tmp_path / "configs" / "base.yaml", {**BASE, "name": "from_file"})
    sweep = write(tmp_path / "configs" / "studies" / "rel.yaml", {"base": "../base.yaml", "seeds": 1})
    (values, cfg), = load_sweep(sweep, []).runs  # found beside the sweep file, not the working directory
    assert cfg.name == "from_file_seed1" and cfg.model.L == 8
    inline = write(tmp_path / "inline.yaml", {"base": {**BASE, "name": "inline"}, "seeds": 1})
    assert load_sweep(inline, []).runs[0][1].name == "inline_seed1"
    write(sweep, {"base": "../missing.yaml"})
    with pytest.raises(ConfigError, match=r"rel\.yaml: base: .*missing\.yaml: cannot read"):
        load_sweep(sweep, [])
    write(sweep, {"base": {**BASE, "model": {"kind": "bpm", "L": -1}}})
    with pytest.raises(ConfigError, match=r"(?s)rel\.yaml \(base\).*model\.L"):
        load_sweep(sweep, [])
    write(sweep, {"base": BASE, "model": {"L": 8}})
    with pytest.raises(ConfigError, match="unknown key.*model.*under base"):
        load_sweep(sweep, [])


def test_example_velocity_sweep():
    loaded = load_sweep(EXAMPLES / "studies" / "bcm_velocity_sweep.yaml", [])
    assert loaded.directory == Path("runs/bcm_velocity_sweep")
    names = [cfg.run_dir().name for _, cfg in loaded.runs]
    assert names[:3] == ["velocity0.2_seed1", "velocity0.2_seed2", "velocity0.5_seed1"] and len(names) == 18
    assert [cfg.scenario.velocity for _, cfg in loaded.runs[::2]] == [0.2, 0.5, 1, 2, 3, 4, 5, 6, 8]
    assert all(cfg.model.n_cells == 1728 for _, cfg in loaded.runs)


# ----------------------------------------------------------------------------- names
def test_names_distinguish_keys_and_close_values(tmp_path):
    assert short_keys(["model.interface.kn", "model.contact.kn", "seed"]) == ["interface.kn", "contact.kn", "seed"]
    assert short_keys(["a.b", "b"]) == ["a.b", "b"]
    bcm = yaml.safe_load((EXAMPLES / "bcm_impact_quick.yaml").read_text())
    sweep = write(tmp_path / "k.yaml", {"base": bcm, "axes": {
        "model.interface.kn": [1.0e7, 2.0e7], "model.contact.kn": [1.0e8],
        "scenario.velocity": [1.0000001, 1.0000002, 1.5]}})
    names = [cfg.run_dir().name for _, cfg in load_sweep(sweep, []).runs]
    assert names[:3] == ["interface.kn1e07_contact.kn1e08_velocity1.0000001",
                         "interface.kn1e07_contact.kn1e08_velocity1.0000002",
                         "interface.kn1e07_contact.kn1e08_velocity1.5"]
    assert len(set(names)) == 6
    write(sweep, {"base": BASE, "axes": {"model.k_A": [1, 1.0]}})
    with pytest.raises(ConfigError, match="two runs would share the directory 'k_A1'"):
        load_sweep(sweep, [])


def test_set_is_a_shortcut(tmp_path):
    config = write(tmp_path / "plain.yaml", BASE)
    loaded = load_sweep(config, ["model.k_A=1,2"])
    assert loaded.directory == Path("runs/sw_sweep") and [c.run_dir().name for _, c in loaded.runs] == ["k_A1", "k_A2"]
    with pytest.raises(ConfigError, match="a run config; vary keys with --set"):
        load_sweep(config, [])
    sweep = write(tmp_path / "s.yaml", {"base": BASE, "axes": {"model.k_A": [1, 2]}, "seeds": 2})
    names = [c.run_dir().name for _, c in load_sweep(sweep, ["model.gamma=10,20"]).runs]
    assert len(names) == 8 and names[0] == "k_A1_gamma10_seed1"  # --set axes come before the seeds
    with pytest.raises(ConfigError, match="varied more than once: model.k_A"):
        load_sweep(sweep, ["model.k_A=3"])


# ------------------------------------------------------------------- refused, writes
def test_bad_combination_refused_before_anything_runs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    sweep = write(tmp_path / "bad.yaml", {"base": BASE, "axes": {"model.lambda_c": [1.05, 0.5]}, "seeds": 2})
    with pytest.raises(ConfigError) as info:
        load_sweep(sweep, [])
    message = str(info.value)
    assert "bad.yaml, run lambda_c0.5_seed1 (model.lambda_c=0.5, seed=1)" in message and "lambda_c" in message
    for args in ([sweep], [sweep, "--dry-run"]):
        result = CliRunner().invoke(app, ["sweep", *map(str, args), "--out", str(tmp_path / "out")])
        assert result.exit_code == 2 and "lambda_c0.5_seed1" in result.output
        assert tree(tmp_path) == {"bad.yaml"}  # no sweep directory, no run directory


def test_dry_run_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    sweep = write(tmp_path / "d.yaml", {"base": BASE, "axes": {"model.k_A": [1, 2]}, "seeds": 2})
    before = tree(tmp_path)
    for args in ([sweep], [sweep, "--out", tmp_path / "elsewhere"]):
        result = dry_run(*args)
        assert result.exit_code == 0, result.output
    assert tree(tmp_path) == before == {"d.yaml"}


# ------------------------------------------------------------------------------ cost
def test_cost_unknown_when_no_estimate(tmp_path, monkeypatch):
    def no_estimate(cfg, np_ranks=None):
        raise ValueError("not covered")

    monkeypatch.setattr("driver.estimate.estimate", no_estimate)
    sweep = write(tmp_path / "u.yaml", {"base": BASE, "seeds": 2})
    result = dry_run(sweep, "--out", tmp_path / "out")
    assert result.exit_code == 0, result.output
    assert result.output.count("unknown") >= 3  # both rows and the total
    assert "total: unknown for the 2 runs to do" in result.output


def fake_finished(run_dir: Path, cfg, wall: float) -> None:
    """A run directory as a finished run leaves it, as far as the dry run reads it."""
    run_dir.mkdir(parents=True)
    (run_dir / ".brittle-run").write_text("{}")
    (run_dir / "status.json").write_text(json.dumps({"state": "finished"}))
    (run_dir / "provenance.json").write_text(json.dumps({"wall_seconds": wall, "mpi_ranks": 1}))
    (run_dir / "config.resolved.yaml").write_text(resolved_yaml(cfg))


def test_cost_bound_then_scaled_by_finished_runs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    bcm = yaml.safe_load((EXAMPLES / "bcm_impact_quick.yaml").read_text())
    sweep = write(tmp_path / "v.yaml", {"base": bcm, "axes": {"scenario.velocity": [1, 2, 4]}})
    loaded = load_sweep(sweep, [])
    seconds = [estimate(cfg).seconds for _, cfg in loaded.runs]
    result = dry_run(sweep)
    assert result.exit_code == 0, result.output
    assert result.output.count("≤") >= 4 and "not scaled" in result.output  # BCM: an upper bound

    # two runs finished, in a quarter and a half of their estimate: scale (0.25 + 0.5) / 2 ...
    write(tmp_path / "runs" / "v" / ".brittle-sweep", {})
    for (_, cfg), est, fraction in zip(loaded.runs, seconds, (0.25, 0.5)):
        fake_finished(cfg.run_dir(), cfg, fraction * est)
    before = tree(tmp_path)
    result = dry_run(sweep)
    assert result.exit_code == 0, result.output
    scale = (0.25 * seconds[0] + 0.5 * seconds[1]) / (seconds[0] + seconds[1])
    assert f"scaled by {scale:.3g}" in result.output and "of 2 runs finished in runs/v" in result.output
    assert result.output.count("finished") >= 2 and result.output.count("pending") == 1
    assert "for the 1 run to do" in result.output and "2 finished" in result.output
    assert tree(tmp_path) == before
    p = plan(loaded)
    assert p.scale == pytest.approx(scale) and p.scaled_runs == 2
    assert p.cost(p.runs[2]) == pytest.approx(scale * seconds[2])
    assert [r.state for r in p.runs] == ["finished", "finished", "pending"]
    assert p.runs[0].measured == pytest.approx(0.25 * seconds[0])


def test_sweep_on_a_local_dask_cluster_records_a_failed_run(tmp_path, plugin_path):
    """Four BCM impacts on a LocalCluster of 2 workers: one is given a parameter LAMMPS refuses
    (2 cells: their one interface has more contact points than bond_style bcm/griffith
    supports); its LAMMPS error is recorded in sweep.csv and its status, the other three
    finish, and the exit code says the sweep had a failure."""
    import json
    import subprocess
    import sys

    base = tmp_path / "base.yaml"
    base.write_text(yaml.safe_dump({"name": "dk", "seed": 1, "model": {"kind": "bcm", "n_cells": 20},
                                    "scenario": {"kind": "impact", "velocity": 1.0}, "output": {"plots": False}}))
    sweep = tmp_path / "sw.yaml"
    sweep.write_text(yaml.safe_dump({"base": "base.yaml", "axes": {"model.n_cells": [2, 16, 20, 24]}}))
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "driver.cli", "sweep", str(sweep), "--out", str(out),
                           "--workers", "2"], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 1, proc.stderr[-3000:]
    assert "1 of 4 runs failed" in proc.stderr and "n_cells2" in proc.stderr
    assert "more than the 16 that bond_style bcm/griffith supports" in proc.stderr  # LAMMPS's own message
    status = {d.name: json.loads((d / "status.json").read_text())
              for d in out.iterdir() if (d / "status.json").exists()}
    assert sorted(n for n, st in status.items() if st["state"] == "finished") == ["n_cells16", "n_cells20",
                                                                                  "n_cells24"]
    assert status["n_cells2"]["state"] == "failed" and "LammpsError" in status["n_cells2"]["error"]
    # written to pipes, the progress and the table are lines (not a live bar, not a squeezed grid)
    assert "sweep: 4/4 done, 0 running, 1 failed, 0 pending" in proc.stderr, proc.stderr[-3000:]
    assert "━" not in proc.stderr
    header, *rows = [ln.split("\t") for ln in proc.stdout.splitlines()]
    assert "state" in header and "run_dir" in header and "…" not in proc.stdout and "┃" not in proc.stdout
    assert sorted(dict(zip(header, r))["run_dir"] for r in rows) == [str(out / n) for n in
                                                                      ("n_cells16", "n_cells20", "n_cells24")]
    table = pd.read_csv(out / "sweep.csv").set_index("model.n_cells")
    assert table.loc[2, "state"] == "failed" and "bcm/griffith" in table.loc[2, "error"]
    assert (table.loc[[16, 20, 24], "state"] == "finished").all() and table.loc[[16, 20, 24], "D_w"].notna().all()
    points = pd.read_csv(out / "sweep_points.csv")
    assert sorted(points["model.n_cells"]) == [16, 20, 24] and (points.n_runs == 1).all()


@pytest.mark.slow
def test_interrupting_a_dask_sweep_and_running_it_again_resumes_it(tmp_path, plugin_path):
    """Four runs on 3 Dask workers; the client is interrupted (SIGINT) once the two short runs
    finished and the two long ones run: those write a checkpoint and stop. Running the same
    command again keeps the first two (their records untouched) and resumes the other two
    from their checkpoints (provenance 'resumed'), which then finish."""
    import json
    import signal
    import subprocess
    import sys
    import time

    base = tmp_path / "base.yaml"
    base.write_text(yaml.safe_dump({"name": "ir", "seed": 2, "model": {"kind": "bpm", "dimension": 2, "L": 16},
                                    "scenario": {"kind": "shear", "strain_rate": 0.002, "max_strain": 0.01,
                                                 "measure_strains": [0.01], "thermo_every": 200},
                                    "execution": {"chunk_steps": 500}, "output": {"plots": False}}))
    sweep = tmp_path / "sw.yaml"
    sweep.write_text(yaml.safe_dump({"base": "base.yaml", "zip": [{"scenario.max_strain": [0.01, 2.0],
                                                                   "scenario.measure_strains": [[0.01], [2.0]]}],
                                     "seeds": 2}))
    out = tmp_path / "out"
    # 3 workers: the two long runs start first (longest first), the short ones one after the other beside them
    cmd = [sys.executable, "-m", "driver.cli", "sweep", str(sweep), "--out", str(out), "--workers", "3"]
    short = ["max_strain0.01_measure_strains0.01_seed1", "max_strain0.01_measure_strains0.01_seed2"]
    long = ["max_strain2_measure_strains2_seed1", "max_strain2_measure_strains2_seed2"]

    def status(name):
        try:
            return json.loads((out / name / "status.json").read_text())
        except (OSError, ValueError):
            return {}

    # SIGINT at its default in the command (as from a terminal), whatever this test process holds:
    # a Python child keeps an inherited SIG_IGN and would finish its runs (seen twice in .ci/run)
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.time() + 300
    while time.time() < deadline and not (all(status(n).get("state") == "finished" for n in short)
                                          and all(status(n).get("phase") == "lammps" for n in long)):
        assert proc.poll() is None, proc.communicate()[1][-3000:]
        time.sleep(0.2)
    time.sleep(1.0)
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 130, (proc.returncode, stderr[-3000:], {n: status(n) for n in short + long})
    assert "run the same command again" in stderr
    for name in long:
        st = status(name)
        assert st["state"] == "interrupted" and st.get("checkpoint_step"), (st, stderr[-3000:])
    kept = {n: ((out / n / "status.json").read_bytes(), (out / n / "provenance.json").read_bytes()) for n in short}

    again = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr[-3000:]
    assert "4 runs, 2 already finished" in again.stderr
    for n in short:  # not run again: their records are byte for byte those of the first invocation
        assert ((out / n / "status.json").read_bytes(), (out / n / "provenance.json").read_bytes()) == kept[n]
        assert "resumed" not in json.loads((out / n / "provenance.json").read_text())
    for n in long:
        assert status(n)["state"] == "finished"
        resumed = json.loads((out / n / "provenance.json").read_text())["resumed"]
        assert len(resumed) == 1 and resumed[0]["from_step"] > 0
    table = pd.read_csv(out / "sweep.csv")
    assert sorted(table.state) == ["finished"] * 4


def test_the_runs_table_is_lines_where_it_is_not_written_to_a_terminal():
    """Many columns and long values: to a file or a pipe, a header line and one tab-separated
    line per run with every value whole; on a terminal, the table."""
    runs = pd.DataFrame([{"seed": s, "run_dir": f"/a/long/path/to/the/sweep/run_seed{s}", "state": "finished",
                          **{f"measure_{k}": 0.123456789 * k for k in range(25)},
                          "rule": "records with strain in (0.8, 1], the last 20% of the strain reached"}
                         for s in (1, 2)])
    shown = list(runs.columns)
    piped = io.StringIO()
    print_runs(runs, shown, Console(file=piped, width=120))
    lines = piped.getvalue().splitlines()
    assert lines[0].split("\t") == shown and len(lines) == 3
    assert lines[2].split("\t")[:3] == ["2", "/a/long/path/to/the/sweep/run_seed2", "finished"]
    assert lines[2].split("\t")[-2:] == ["2.963", "records with strain in (0.8, 1], the last 20% of the strain reached"]
    assert "…" not in piped.getvalue() and "┃" not in piped.getvalue()
    terminal = io.StringIO()
    print_runs(runs, ["seed", "state"], Console(file=terminal, width=120, force_terminal=True))
    assert "┃" in terminal.getvalue()


# ------------------------------------------------------------------------- aggregation
def test_seed_points_on_synthetic_summaries():
    """Means and standard deviations over seeds, per combination of the other keys; runs not
    finished are left out of the figures and counted out of n_runs."""
    from driver.sweep import seed_points

    rows = []
    for G, v, seed, D, e2 in [(0.5, 1, 1, 0.10, 0.30), (0.5, 1, 2, 0.20, 0.50), (0.5, 1, 3, 0.60, 0.40),
                              (0.5, 2, 1, 0.40, 0.20), (0.5, 2, 2, 0.50, 0.10),
                              (1.0, 1, 1, 0.05, 0.70)]:
        rows.append({"G_c": G, "velocity": v, "seed": seed, "run_dir": f"r{G}{v}{seed}", "state": "finished",
                     "error": None, "D_w": D, "e_k2": e2, "fragments": 3, "breakup": True})
    rows.append({"G_c": 1.0, "velocity": 1, "seed": 2, "run_dir": "x", "state": "failed", "error": "LammpsError"})
    points = seed_points(pd.DataFrame(rows), ["G_c", "velocity", "seed"])
    assert list(points[["G_c", "velocity"]].itertuples(index=False, name=None)) == [(0.5, 1), (0.5, 2), (1.0, 1)]
    assert list(points.n_runs) == [3, 2, 1]
    assert points.D_w_mean.tolist() == pytest.approx([0.3, 0.45, 0.05])
    assert points.D_w_std.iloc[0] == pytest.approx(((0.2 ** 2 + 0.1 ** 2 + 0.3 ** 2) / 2) ** 0.5)  # ddof 1
    assert points.e_k2_std.iloc[1] == pytest.approx(0.1 / 2 ** 0.5) and pd.isna(points.D_w_std.iloc[2])
    assert points.fragments_std.iloc[0] == 0 and "breakup_mean" not in points and "seed_mean" not in points
    # no key but the seed: one point over all finished runs
    one = seed_points(pd.DataFrame(rows), ["seed"])
    assert len(one) == 1 and one.n_runs.iloc[0] == 6 and one.D_w_mean.iloc[0] == pytest.approx(1.85 / 6)


def test_scales_of_a_sweep_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    sweep = write(tmp_path / "study.yaml", {
        "base": BASE, "axes": {"model.k_A": [1, 2, 3], "scenario.strain_rate": [0.01, 0.02]}, "seeds": 5,
        "scales": {"small": {"base": {"model.L": 12, "name": "st_small"}, "axes": {"model.k_A": [2]},
                             "seeds": 2}}})
    full = load_sweep(sweep, [])
    assert len(full.runs) == 30 and full.directory == Path("runs/study")
    small = load_sweep(sweep, [], scale="small")
    assert small.directory == Path("runs/study_small") and len(small.runs) == 4
    assert {cfg.model.L for _, cfg in small.runs} == {12} and {v["model.k_A"] for v, _ in small.runs} == {2}
    assert small.runs[0][1].name.startswith("st_small_")
    with pytest.raises(ConfigError, match=r"--scale big: no such scale under scales: \(defined: small\)"):
        load_sweep(sweep, [], scale="big")
    write(sweep, {"base": BASE, "scales": {"small": {"seeds": 2, "axis": {}}}})
    with pytest.raises(ConfigError, match=r"scales\.small: unknown key\(s\) axis"):
        load_sweep(sweep, [], scale="small")


def test_study_files_expand(tmp_path, monkeypatch):
    """The published studies: the full grid and the small scale validate, with their sizes."""
    monkeypatch.chdir(tmp_path)
    bcm = EXAMPLES / "studies" / "bcm_impact_study.yaml"
    full, small = load_sweep(bcm, []), load_sweep(bcm, [], scale="small")
    assert len(full.runs) == 240 and {cfg.model.n_cells for _, cfg in full.runs} == {1728}
    velocities = sorted({v["scenario.velocity"] for v, _ in full.runs})
    assert velocities[0] == 0.5 and velocities[-1] == 10 and len(velocities) == 12
    assert {v["model.interface.G_c"] for v, _ in full.runs} == {0.2, 0.5, 1.0, 2.0}
    assert len(small.runs) < len(full.runs) and {cfg.model.n_cells for _, cfg in small.runs} == {300}
    bpm = EXAMPLES / "studies" / "bpm_shear_study.yaml"
    full, small = load_sweep(bpm, []), load_sweep(bpm, [], scale="small")
    assert len(small.runs) < len(full.runs)
    assert {cfg.model.dimension for _, cfg in full.runs} == {2}
    assert len({v["model.L"] for v, _ in full.runs}) >= 3 and len({v["model.k_A"] for v, _ in full.runs}) >= 2
    moduli = EXAMPLES / "studies" / "bpm_moduli.yaml"
    two, three = load_sweep(moduli, []), load_sweep(moduli, [], scale="3d")
    assert sorted({v["model.k_A"] for v, _ in two.runs}) == [0, 2, 4, 6, 8, 10, 12] and len(two.runs) == 21
    assert {cfg.model.dimension for _, cfg in three.runs} == {3} and max(v["model.k_A"] for v, _ in three.runs) == 5


def test_sweeps_start_the_longest_runs_first():
    """Runs are submitted by estimated LAMMPS time, then by their unit's work (impacts: v0^2 /
    G_c), longest first: the bigger particle, then the fastest impact on the weakest material."""
    from driver.config import parse_config
    from driver.distributed import longest_first

    def impact(n_cells, v, g_c):
        return ({}, parse_config({"name": f"n{n_cells}v{v}g{g_c}", "model": {"kind": "bcm", "n_cells": n_cells,
                                                                           "interface": {"G_c": g_c}},
                                  "scenario": {"kind": "impact", "velocity": v}}))

    todo = [impact(300, 1.0, 1.0), impact(300, 5.0, 1.0), impact(1000, 1.0, 1.0), impact(300, 3.0, 0.5),
            impact(300, 0.5, 2.0)]
    assert [c.name for _, c in longest_first(todo)] == ["n1000v1.0g1.0", "n300v5.0g1.0", "n300v3.0g0.5",
                                                        "n300v1.0g1.0", "n300v0.5g2.0"]
