"""Inputs that used to hang, exhaust memory or print tracebacks are refused quickly and briefly:
YAML size, alias and nesting limits, file encoding, and the size estimate of a run."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from driver import estimate as est
from driver.size_model import bcm_interfaces
from driver.config import MAX_CONFIG_BYTES, ConfigError, RunConfig, load_config, parse_config

HEAD = "name: t\nmodel: {kind: bpm}\nscenario:\n  kind: shear\n"


def _billion_laughs(levels: int = 9) -> str:
    """A valid key whose value nests 9 levels of 9 aliases: 9^9 (~4e8) leaves once expanded."""
    anchors = ", ".join(f"&a{i} [" + ", ".join([f"*a{i - 1}"] * 9) + "]" for i in range(1, levels + 1))
    return HEAD + f"  measure_strains: [&a0 [0.1], {anchors}]\n"


def _load(tmp_path: Path, text: str | bytes) -> RunConfig:
    p = tmp_path / "in.yaml"
    if isinstance(text, bytes):
        p.write_bytes(text)
    else:
        p.write_text(text)
    return load_config(p)


# --------------------------------------------------------------------------------- YAML limits
def test_alias_bomb_refused_fast_and_short(tmp_path):
    t0 = time.perf_counter()
    with pytest.raises(ConfigError) as info:
        _load(tmp_path, _billion_laughs())
    assert time.perf_counter() - t0 < 0.5
    msg = str(info.value)
    assert len(msg) < 300 and "aliases" in msg and "in.yaml" in msg, msg


def test_merge_key_bomb_refused(tmp_path):
    text = "a0: &a0 {k: 1}\n" + "".join(
        f"a{i}: &a{i} {{<<: [" + ", ".join([f"*a{i - 1}"] * 9) + "]}\n" for i in range(1, 10))
    t0 = time.perf_counter()
    with pytest.raises(ConfigError, match="aliases"):
        _load(tmp_path, text)
    assert time.perf_counter() - t0 < 0.5


def test_recursive_alias_refused(tmp_path):
    with pytest.raises(ConfigError, match="contains it"):
        _load(tmp_path, HEAD + "  measure_strains: &m [0.1, *m]\n")


def test_deep_nesting_refused_without_traceback(tmp_path):
    with pytest.raises(ConfigError, match="nested deeper"):
        _load(tmp_path, "model: " + "[" * 5000 + "]" * 5000 + "\n")


def test_few_aliases_still_allowed(tmp_path):
    cfg = _load(tmp_path, "name: t\nmodel: {kind: bpm}\nscenario:\n  kind: shear\n  max_strain: &s 0.5\n"
                          "  measure_strains: [0.1, *s]\n")
    assert cfg.scenario.measure_strains == [0.1, 0.5]


def test_file_too_large_refused_with_size(tmp_path):
    text = HEAD + "#" + "x" * MAX_CONFIG_BYTES + "\n"
    with pytest.raises(ConfigError) as info:
        _load(tmp_path, text)
    msg = str(info.value)
    assert f"{len(text):,} bytes" in msg and "at most" in msg and len(msg) < 300


def test_non_utf8_names_file_and_offset(tmp_path):
    raw = b"name: t\nmodel: {kind: bpm}\n# caf\xe9\n"
    with pytest.raises(ConfigError) as info:
        _load(tmp_path, raw)
    msg = str(info.value)
    offset = raw.index(b"\xe9")
    assert "in.yaml" in msg and "UTF-8" in msg and f"byte offset {offset}" in msg and "line 3" in msg


def test_utf8_bom_and_text_accepted(tmp_path):
    cfg = _load(tmp_path, "\ufeffname: t\n# café\nmodel: {kind: bpm}\n".encode())
    assert cfg.name == "t"


def test_control_character_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError, match="not valid YAML"):
        _load(tmp_path, "name: a\x00b\n")


def test_directory_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError, match="cannot read"):
        load_config(tmp_path)


# --------------------------------------------------------------------------- short messages
def test_huge_value_is_truncated(tmp_path):
    with pytest.raises(ConfigError) as info:
        _load(tmp_path, HEAD + "  strain_rate: '" + "9" * 200_000 + "'\n")
    msg = str(info.value)
    assert "scenario.strain_rate" in msg and len(msg) < 400, msg[:500]


def test_huge_list_value_is_truncated_and_problems_counted(tmp_path):
    items = ", ".join(["x"] * 5000)
    with pytest.raises(ConfigError) as info:
        _load(tmp_path, HEAD + f"  measure_strains: [{items}]\n")
    msg = str(info.value)
    assert "... and 4980 more" in msg and len(msg) < 4000, msg[:500]
    assert max(len(line) for line in msg.splitlines()) < 200


def test_huge_unknown_key_is_truncated():
    with pytest.raises(ConfigError) as info:
        parse_config({"k" * 100_000: 1})
    assert "unknown key" in str(info.value) and len(str(info.value)) < 400


# ------------------------------------------------------------------------------ size estimate
EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def _bcm(n_cells: int, **scenario) -> RunConfig:
    return parse_config({"model": {"kind": "bcm", "n_cells": n_cells}, "scenario": {"kind": "impact", **scenario}})


def _bpm(L: float, dimension: int = 2) -> RunConfig:
    return parse_config({"model": {"kind": "bpm", "L": L, "dimension": dimension}})


def test_bpm_counts_follow_packing_and_network_rules():
    e = est.estimate(_bpm(24))
    # particle_count: 0.86 L^2 / mean disk area, mean over the (1+sqrt5)/4 mixture; 976 in the example run
    assert e.elements == 976 and e.element_name == "particles"
    assert e.bonds == 9 * 976  # periodic 2D triangulation: exactly 3 bonds and 6 angles per particle
    assert e.steps == 200_000  # max_strain 1 / (1e-3 * 0.005)
    e3 = est.estimate(_bpm(16, 3))
    assert e3.elements == 5163  # 0.66 L^3 / (pi/6), the measured run's count
    assert abs(e3.bonds - (29136 + 131886)) < 0.02 * e3.bonds  # measured network of that run


@pytest.mark.parametrize("n_cells,interfaces", [(300, 1716), (1728, 10854), (8000, 52652)])
def test_bcm_interfaces_match_measured_tessellations(n_cells, interfaces):
    assert abs(bcm_interfaces(n_cells) - interfaces) < 0.02 * interfaces


def test_bcm_steps_bound_the_measured_run():
    # examples/bcm_impact.yaml at 50 steps per period: dt = 9.449e-10 s measured, so max_time
    # 4e-4 s is 423,320 steps
    e = est.estimate(_bcm(1728, max_time=4e-4, steps_per_period=50))
    assert 423_320 <= e.steps < 1.15 * 423_320


# peak RSS of `driver run` measured for driver/estimate.py (kB); the fits stay within 15 %
MEASURED_PEAK_KB = [
    (lambda: _bcm(300), 549_124), (lambda: _bcm(1728), 603_968), (lambda: _bcm(8000), 766_932),
    (lambda: _bcm(27000), 1_768_540), (lambda: _bpm(24), 248_564), (lambda: _bpm(192), 372_208),
    (lambda: _bpm(16, 3), 271_484), (lambda: _bpm(32, 3), 725_148),
]


@pytest.mark.parametrize("make,peak_kb", MEASURED_PEAK_KB)
def test_memory_fits_the_measured_runs(make, peak_kb):
    assert est.estimate(make()).memory_bytes == pytest.approx(peak_kb * 1024, rel=0.15)


def test_estimate_does_not_build_the_system():
    t0 = time.perf_counter()
    e = est.estimate(_bcm(200_000))
    assert time.perf_counter() - t0 < 5.0 and e.elements == 200_000


def test_ranks_add_memory_and_divide_time():
    one, four = est.estimate(_bpm(48)), est.estimate(_bpm(48), np_ranks=4)
    assert four.memory_bytes > one.memory_bytes and four.ranks == 4
    assert four.seconds_per_1000_steps == pytest.approx(one.seconds_per_1000_steps / 4)


def test_describe_is_one_line():
    text = est.estimate(_bcm(300)).describe()
    assert "\n" not in text and "300 cells" in text and "GiB" in text and "per 1000 steps" in text


@pytest.mark.parametrize("cfg,what", [(_bcm(200_000), "200,000 cells"), (_bpm(5000), "particles")])
def test_check_size_refuses_above_available_memory(cfg, what):
    with pytest.raises(ConfigError) as info:
        est.check_size(cfg, allow_large=False, available=4 * est.GIB, source="big.yaml")
    msg = str(info.value)
    assert msg.startswith("big.yaml: this run needs about ") and "4 GiB available" in msg, msg
    assert "--yes" in msg and what in msg


def test_check_size_uses_available_memory_by_default(monkeypatch):
    monkeypatch.setattr(est, "available_memory_bytes", lambda: 16 * est.GIB)
    with pytest.raises(ConfigError, match="16 GiB available"):
        est.check_size(_bpm(5000))  # ~4e7 particles


def test_check_size_allow_large_and_unknown_memory(monkeypatch):
    big = _bcm(200_000)
    assert est.check_size(big, allow_large=True, available=1 * est.GIB).elements == 200_000
    monkeypatch.setattr(est, "available_memory_bytes", lambda: None)
    assert est.check_size(big).elements == 200_000  # nothing to compare with: no refusal


@pytest.mark.parametrize("example", ["bcm_impact_quick.yaml", "bcm_impact.yaml", "bpm_shear_2d.yaml", "calibrate_moduli.yaml"])
def test_examples_fit_in_a_small_machine(example):
    e = est.check_size(load_config(EXAMPLES / example), available=2 * est.GIB)
    assert e.memory_bytes < est.GIB


def test_available_memory_from_meminfo(tmp_path):
    meminfo = tmp_path / "meminfo"
    meminfo.write_text("MemTotal:       32000000 kB\nMemFree:  1000 kB\nMemAvailable:   2048 kB\n")
    no_cgroup = tmp_path / "no_cgroup"
    assert est.available_memory_bytes(meminfo, no_cgroup) == 2048 * 1024
    assert est.available_memory_bytes(tmp_path / "absent", no_cgroup) is None
    cgroup = tmp_path / "cgroup"
    cgroup.mkdir()
    (cgroup / "memory.max").write_text("1048576\n")
    (cgroup / "memory.current").write_text("524288\n")
    assert est.available_memory_bytes(meminfo, cgroup) == 524288  # the container's limit is lower
    (cgroup / "memory.max").write_text("max\n")
    assert est.available_memory_bytes(meminfo, cgroup) == 2048 * 1024
    meminfo.write_text("MemTotal: 1 kB\n")
    assert est.available_memory_bytes(meminfo, no_cgroup) is None
