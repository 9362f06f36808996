"""Config validation: malformed inputs are refused with the field named, nothing is written."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from driver.config import ConfigError, load_config, parse_config
from driver.schedule import steps_for_strain

GOOD = """
name: t
seed: 3
model: {kind: bpm, dimension: 2, L: 12}
scenario: {kind: shear, strain_rate: 0.01, max_strain: 0.2, measure_strains: [0.1, 0.2]}
output: {dir: OUT}
"""

# (yaml fragment replacing GOOD, words the message must contain)
BAD = [
    ("model: {kind: bpm, lamda_c: 1.1}", ["model.lamda_c", "unknown key", "lambda_c"]),
    ("model: {kind: bpm, lambda_c: 0.9}", ["model.lambda_c", "greater than 1", "0.9"]),
    ("model: {kind: bpm, dimension: 4}", ["model.dimension", "2 or 3", "4"]),
    ("model: {kind: bcmx}", ["model", "bcmx", "bpm"]),
    ("model: {dimension: 2}", ["model.kind", "missing", "bpm"]),
    ("seed: many", ["seed", "integer", "many"]),
    ("scenario: {kind: shear, max_strain: 0.5, measure_strains: [0.2, 1.0]}", ["scenario", "exceed max_strain"]),
    ("scenario: {kind: shear, measure_strains: [0.5, 0.2]}", ["scenario", "increasing"]),
    ("scenario: {kind: shear, strain_rate: -1}", ["scenario.strain_rate", "greater than 0", "-1"]),
    ("colour: red", ["colour", "unknown key", "scenario"]),
    ("name: 'bad name/x'", ["name", "pattern"]),
    ("model: {kind: bpm, L: 2}", ["model.L", "greater than or equal to 6"]),
]


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "input.yaml"
    p.write_text(textwrap.dedent(text).replace("OUT", str(tmp_path / "out")))
    return p


def test_good_config_parses(tmp_path):
    cfg = load_config(_write(tmp_path, GOOD))
    assert cfg.model.dimension == 2 and cfg.scenario.strain_rate == 0.01
    assert cfg.run_dir() == tmp_path / "out"


@pytest.mark.parametrize("fragment,words", BAD)
def test_bad_config_names_field(tmp_path, fragment, words):
    path = _write(tmp_path, fragment)
    with pytest.raises(ConfigError) as info:
        load_config(path)
    msg = str(info.value)
    assert str(path) in msg
    for w in words:
        assert w in msg, f"{w!r} not in message:\n{msg}"


def test_not_a_mapping():
    with pytest.raises(ConfigError, match="mapping"):
        parse_config([1, 2], "x.yaml")


def test_unreadable_and_unparsable(tmp_path):
    with pytest.raises(ConfigError, match="cannot read"):
        load_config(tmp_path / "missing.yaml")
    bad = tmp_path / "b.yaml"
    bad.write_text("model: {kind: bpm\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_config(bad)


def test_steps_for_strain():
    assert steps_for_strain(1.0, 1e-3, 0.005) == 200000
    assert steps_for_strain(0.1, 0.01, 0.005) == 2000


@pytest.mark.parametrize("text,field", [
    ("model: {kind: bpm, lambda_c: 0.9}\noutput: {dir: OUT}\n", "lambda_c"),
    (GOOD + "colour: red\n", "colour"),
])
@pytest.mark.lammps
def test_cli_refuses_and_writes_nothing(tmp_path, text, field):
    """`driver run` and `driver validate` exit non-zero, name the field, create no run dir."""
    path = _write(tmp_path, text)
    for cmd in ("run", "validate"):
        proc = subprocess.run([sys.executable, "-m", "driver.cli", cmd, str(path)], capture_output=True, text=True,
                              cwd=tmp_path)
        assert proc.returncode == 2, proc.stderr
        assert field in proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["input.yaml"]


# ------------------------------------------------------------------ non-finite numbers, name, output.dir
@pytest.mark.parametrize("fragment,field", [
    ("model: {kind: bpm, gamma: .inf}", "model.gamma"),
    ("model: {kind: bpm, L: .nan}", "model.L"),
    ("model: {kind: bpm, packing_fraction: .nan}", "model.packing_fraction"),
    ("model: {kind: bpm, bond_max_length: .inf}", "model.bond_max_length"),
    ("model: {kind: bcm, diameter: .inf}\nscenario: {kind: impact}", "model.diameter"),
    ("model: {kind: bcm, interface: {G_c: .inf}}\nscenario: {kind: impact}", "model.interface.G_c"),
    ("model: {kind: bcm, contact: {mu: .inf}}\nscenario: {kind: impact}", "model.contact.mu"),
    ("model: {kind: bcm}\nscenario: {kind: impact, max_time: .inf}", "scenario.max_time"),
    ("model: {kind: bcm, n_cells: .inf}\nscenario: {kind: impact}", "model.n_cells"),
    ("scenario: {kind: shear, measure_strains: [0.1, .nan]}", "scenario.measure_strains.1"),
    ("output: {count_above: [10, .inf]}", "output.count_above.1"),
    ("model: {kind: bpm, gamma: 1.0e400}", "model.gamma"),  # overflows to inf
    ("model: {kind: bpm, gamma: '-inf'}", "model.gamma"),
])
def test_non_finite_refused_with_field(tmp_path, fragment, field):
    with pytest.raises(ConfigError) as info:
        load_config(_write(tmp_path, fragment))
    msg = str(info.value)
    assert f"{field}:" in msg and "finite" in msg, msg


@pytest.mark.parametrize("name", [".", "..", "a/b", "../x", "/abs", "a\\b", ".hidden", "-rf", "a b", ""])
def test_name_must_be_plain_file_name(name):
    with pytest.raises(ConfigError, match="name"):
        parse_config({"name": name})


@pytest.mark.parametrize("name", ["run", "bcm_impact_1728", "_x", "3d.v2-final"])
def test_plain_names_accepted(name):
    assert parse_config({"name": name}).name == name


def test_output_dir_expands_home_and_variables(monkeypatch, tmp_path):
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setenv("BRITTLE_TEST_RUNS", "/scratch/runs")
    assert parse_config({"output": {"dir": "~/runs/a"}}).run_dir() == tmp_path / "runs" / "a"
    assert parse_config({"output": {"dir": "$BRITTLE_TEST_RUNS/a"}}).run_dir() == Path("/scratch/runs/a")
    assert parse_config({"output": {"dir": "${BRITTLE_TEST_RUNS}/b"}}).run_dir() == Path("/scratch/runs/b")
    assert parse_config({"output": {"dir": "plain/rel"}}).run_dir() == Path("plain/rel")


def test_output_dir_unset_variable_refused(monkeypatch):
    monkeypatch.delenv("BRITTLE_TEST_UNSET", raising=False)
    with pytest.raises(ConfigError, match="output.dir: environment variable BRITTLE_TEST_UNSET is not set"):
        parse_config({"output": {"dir": "$BRITTLE_TEST_UNSET/a"}})


def test_output_dir_empty_refused():
    with pytest.raises(ConfigError, match="output.dir: must not be empty"):
        parse_config({"output": {"dir": ""}})
