"""`driver sweep`: grid expansion, validation before running, resume, sweep table."""

from __future__ import annotations

import subprocess
import sys

import pandas as pd
import pytest
import yaml

from driver.config import ConfigError
from driver.sweep import load_sweep, parse_assignment

BASE = {"name": "sw", "seed": 2, "model": {"kind": "bpm", "dimension": 2, "L": 8},
        "scenario": {"kind": "shear", "strain_rate": 0.02, "max_strain": 0.1, "measure_strains": [0.1],
                     "thermo_every": 100}}


def expand(tmp_path, *assignments: str):
    """The runs of `driver sweep b.yaml --set A --set B ...` into tmp_path/sweep."""
    base = tmp_path / "b.yaml"
    base.write_text(yaml.safe_dump(BASE))
    return load_sweep(base, list(assignments), out=tmp_path / "sweep").runs


def test_parse_and_expand(tmp_path):
    assert parse_assignment("scenario.strain_rate=0.01,0.02") == ("scenario.strain_rate", [0.01, 0.02])
    runs = expand(tmp_path, "model.k_A=1,2", "seed=3,4")
    assert len(runs) == 4
    assert {(v["model.k_A"], v["seed"]) for v, _ in runs} == {(1, 3), (1, 4), (2, 3), (2, 4)}
    assert all(c.run_dir().parent == tmp_path / "sweep" for _, c in runs)
    assert runs[0][1].model.k_A == 1 and runs[0][1].seed == 3


def test_bad_value_refused_before_running(tmp_path):
    with pytest.raises(ConfigError, match="lambda_c"):
        expand(tmp_path, "model.lambda_c=1.05,0.5")
    with pytest.raises(ConfigError):
        parse_assignment("model.k_A")


@pytest.mark.slow
def test_cli_sweep_runs_and_resumes(tmp_path, plugin_path):
    base = tmp_path / "base.yaml"
    base.write_text(yaml.safe_dump(BASE))
    out = tmp_path / "sweep"
    cmd = [sys.executable, "-m", "driver.cli", "sweep", str(base), "--set", "model.k_A=0,4", "--out", str(out),
           "--columns", "model.k_A,bonds_broken"]
    first = subprocess.run(cmd, capture_output=True, text=True)
    assert first.returncode == 0, first.stderr[-3000:]
    table = pd.read_csv(out / "sweep.csv")
    assert sorted(table["model.k_A"]) == [0, 4] and len(table) == 2
    # the set analysis runs at the end of a sweep: growth exponents of both runs, one report
    fits = pd.read_csv(out / "fits.csv")
    assert set(fits.parameter) >= {"phi"} or "not fitted" in " ".join(fits.method.astype(str))
    assert (out / "report.html").exists() and (out / "runs.csv").exists()
    again = subprocess.run(cmd, capture_output=True, text=True)
    assert "2 already finished" in again.stderr
    pd.testing.assert_frame_equal(table, pd.read_csv(out / "sweep.csv"))
