"""Config validation: malformed inputs are refused with the field named, nothing is written."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from driver.config import ConfigError, load_config, parse_config, steps_for_strain

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
def test_cli_refuses_and_writes_nothing(tmp_path, text, field):
    """`driver run` and `driver validate` exit non-zero, name the field, create no run dir."""
    path = _write(tmp_path, text)
    for cmd in ("run", "validate"):
        proc = subprocess.run([sys.executable, "-m", "driver.cli", cmd, str(path)], capture_output=True, text=True,
                              cwd=tmp_path)
        assert proc.returncode == 2, proc.stderr
        assert field in proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["input.yaml"]
