"""`driver calibrate` (driver/calibration/): the inversion of a curve (reached, out of reach with
the nearest reachable value, never clipped silently), the material file's validation, and in
real LAMMPS the BPM round trip on small curves: calibrate, run the tests at the chosen
parameters, recover E and nu within 5 % and G_c within 10 %; the second call reads the cache.
Ctrl-C while a curve is measured stops `driver calibrate` and `driver compare` (the same path)
with one line and exit code 130, as `driver run` and `driver sweep`."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from driver.calibration import curves as cv
from driver.calibration.material import MaterialFile, Target, load_material
from driver.calibration.solve import BpmUnits, bpm_lambda_c, invert, through_zero_slope
from driver.cli import app
from driver.schema import ConfigError


# ------------------------------------------------------------------------------ inversion
def test_invert_reaches_a_target_inside_the_curve():
    inv = invert([0, 2, 4], [0.3, 0.2, 0.1], 0.15, "k_A", "nu")
    assert inv.reached and inv.x == pytest.approx(3.0) and inv.y == 0.15 and inv.note == ""
    # order of the points does not matter; a measured point is hit exactly
    assert invert([4, 0, 2], [0.1, 0.3, 0.2], 0.2, "k_A", "nu").x == pytest.approx(2.0)


def test_invert_out_of_reach_names_the_nearest_reachable_value():
    inv = invert([0, 2, 4], [0.3, 0.2, 0.1], 0.45, "k_A", "nu")
    assert not inv.reached
    assert (inv.x, inv.y) == (0.0, 0.3)  # the nearest the model gets, not the target
    assert "out of reach" in inv.note and "0.3" in inv.note and "k_A = 0" in inv.note


def test_invert_says_when_the_curve_is_not_monotonic():
    inv = invert([0, 1, 2, 3], [0.0, 1.0, 0.5, 2.0], 0.75, "x", "y")
    assert inv.reached and inv.x == pytest.approx(0.75) and "not monotonic" in inv.note


def test_lambda_c_from_a_power_law_curve_is_exact():
    """K* / E* = 50 (lambda_c - 1) / E* (what the network measured): the log-log inversion of the
    target ratio gives back the lambda_c that produces it."""
    lc = np.array([1.001, 1.01, 1.1])
    E_red, a = 80.0, 1e-4
    K_red = 50.0 * (lc - 1.0)
    E = 5e10
    want = 1.004
    K = 50.0 * (want - 1.0) / E_red * E * math.sqrt(a)
    inv = bpm_lambda_c(K, E, a, lc, K_red, E_red)
    assert inv.reached and inv.x == pytest.approx(want, rel=1e-12)
    far = bpm_lambda_c(K * 1e3, E, a, lc, K_red, E_red)
    assert not far.reached and far.x == pytest.approx(1.1) and "out of reach" in far.note


def test_units_and_slope():
    u = BpmUnits(a=2.0, m=3.0, u=12.0)
    assert u.tau == pytest.approx(1.0)
    s, se = through_zero_slope([1.0, 2.0], [2.0, 4.0])
    assert s == pytest.approx(2.0) and se == pytest.approx(0.0, abs=1e-12)


# ------------------------------------------------------------------------------ material file
def write(tmp_path, text: str):
    p = tmp_path / "material.yaml"
    p.write_text(text)
    return p


def test_material_needs_exactly_one_toughness(tmp_path):
    both = "material: {density: 1, E: 1, nu: 0.2, G_c: 1, K_IC: 1}\nbpm: {particles_across: 10}\n"
    with pytest.raises(ConfigError, match="material.*exactly one of G_c"):
        load_material(write(tmp_path, both))
    Target(density=1, E=1, nu=0.2, K_IC=2.0)  # one of them is enough
    with pytest.raises(ConfigError, match="material.nu"):
        load_material(write(tmp_path, "material: {density: 1, E: 1, nu: 0.6, G_c: 1}\nbpm: {particles_across: 10}\n"))


def test_material_names_a_model_and_known_curves(tmp_path):
    with pytest.raises(ConfigError, match="at least one model"):
        load_material(write(tmp_path, "material: {density: 1, E: 1, nu: 0.2, G_c: 1}\n"))
    with pytest.raises(ConfigError, match="unknown curve.*bpm_moduli"):
        load_material(write(tmp_path, "material: {density: 1, E: 1, nu: 0.2, G_c: 1}\nbpm: {particles_across: 10}\n"
                                      "curves: {bpm_modul: {seeds: 1}}\n"))
    with pytest.raises(ConfigError, match="unknown key 'rho'"):
        load_material(write(tmp_path, "material: {rho: 1, E: 1, nu: 0.2, G_c: 1}\nbpm: {particles_across: 10}\n"))


def test_material_file_unknown_keys_list_the_material_files_own_keys(tmp_path):
    """Unknown keys of a material file are named with the keys allowed where they are (not a
    run config's, and not an empty list under `material:`)."""
    (tmp_path / "m.yaml").write_text("name: m\nmaterial: {density: 1, E: 1, nu: 0.2, G_c: 1, colour: red}\n"
                                     "bcm: {diameter: 2.0e-3, shap: cube}\noutput: {}\n")
    with pytest.raises(ConfigError) as info:
        load_material(tmp_path / "m.yaml")
    assert sorted(str(info.value).splitlines()[1:]) == sorted([
        "  material.colour: unknown key 'colour'; allowed keys: density, E, nu, G_c, K_IC",
        "  bcm.shap: unknown key 'shap'; allowed keys: shape, diameter, diameter_kind, n_cells, cell_size",
        "  output: unknown key 'output'; allowed keys: name, material, bcm, bpm, curves"])


def test_toughness_conversions():
    t = Target(density=1, E=2.0, nu=0.3, G_c=4.0)
    assert t.toughness(2) == (4.0, pytest.approx(math.sqrt(8.0)))  # 2D: E' = E
    assert t.toughness(3)[1] == pytest.approx(math.sqrt(4.0 * 2.0 / (1 - 0.09)))  # plane strain


@pytest.mark.lammps
def test_a_changed_curve_is_another_cache_entry():
    spec = cv.bpm_moduli(2)
    mat = MaterialFile.model_validate({"material": {"density": 1, "E": 1, "nu": 0.2, "G_c": 1},
                                       "bpm": {"particles_across": 10},
                                       "curves": {"bpm_moduli": {"base": {"model.L": 12}, "seeds": 1}}})
    small = cv.changed(spec, mat.curves["bpm_moduli"])
    assert small.sweep["base"]["model"]["L"] == 12 and small.sweep["seeds"] == 1
    assert small.sweep["axes"] == spec.sweep["axes"]
    assert cv.curve_key(small) != cv.curve_key(spec)
    assert spec.sweep["base"]["model"]["L"] == 24  # the default spec is not changed


# ------------------------------------------------------------------------------ round trip (LAMMPS)
SMALL = """name: small2d
material: {density: 2500, E: 7.0e10, nu: 0.2, G_c: 8.0}
bpm: {dimension: 2, diameter: 2.0e-3, particles_across: 16}
curves:
  bpm_moduli: {base: {model.L: 12}, axes: {model.k_A: [0, 2, 4]}, seeds: 1}
  bpm_mode1: {base: {model.L: 16, scenario.void_axes: [8, 1]}, seeds: 1,
              zip: [{model.lambda_c: [1.001, 1.01], scenario.max_pull_strain: [0.0004, 0.004],
                     scenario.strain_rate: [2.0e-6, 2.0e-5]}]}
"""


@pytest.mark.slow
def test_bpm_round_trip_and_cache(tmp_path, monkeypatch, plugin_cache):
    """Calibrate a 2D BPM to a material, run the tests at the chosen k_A and lambda_c, and get
    back E, nu within 5 % and G_c within 10 %; then the same call from the cache in seconds, and
    a target out of reach said so, with the nearest reachable value in the table."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "m.yaml").write_text(SMALL)
    runner = CliRunner()
    res = runner.invoke(app, ["calibrate", "m.yaml", "--out", "cal", "--workers", "1", "--verify"])
    assert res.exit_code == 0, res.output
    cal = json.loads((tmp_path / "cal" / "calibration.json").read_text())["bpm"]
    assert 0.0 < cal["parameters"]["k_A"] < 4.0 and 1.001 < cal["parameters"]["lambda_c"] < 1.01
    for key, tol in (("E", 0.05), ("nu", 0.05), ("G_c", 0.10)):
        assert abs(cal["verify"][key]["relative_error"]) < tol, (key, cal["verify"][key])
    assert (tmp_path / "cal" / "calibration.md").read_text().count("| k_A |") == 1
    assert (tmp_path / "cal" / "plots" / "bpm_curves.png").stat().st_size > 0

    t0 = time.time()
    again = runner.invoke(app, ["calibrate", "m.yaml", "--out", "cal2", "--workers", "1"])
    assert again.exit_code == 0, again.output
    assert time.time() - t0 < 20
    cal2 = json.loads((tmp_path / "cal2" / "calibration.json").read_text())["bpm"]
    assert all(c["from_cache"] for c in cal2["curves"].values())
    assert cal2["parameters"] == cal["parameters"]

    (tmp_path / "far.yaml").write_text(SMALL.replace("nu: 0.2", "nu: 0.45"))
    far = runner.invoke(app, ["calibrate", "far.yaml", "--out", "cal3", "--workers", "1"])
    assert far.exit_code == 0, far.output
    cal3 = json.loads((tmp_path / "cal3" / "calibration.json").read_text())["bpm"]
    assert not cal3["reach"]["nu"]["reached"] and cal3["parameters"]["k_A"] == 0.0
    assert cal3["achieved"]["nu"] < 0.4 and cal3["target"]["nu"] == 0.45  # not clipped silently
    assert "out of reach" in (tmp_path / "cal3" / "calibration.md").read_text()


SMALL_BCM = """name: small_bcm
material: {density: 6000, E: 2.0e11, nu: 0.1, G_c: 3.0}
bcm: {diameter: 2.0e-3, n_cells: 1728}
curves:
  bcm_moduli: {base: {scenario.block.n_cells: 64}, axes: {model.interface.kt: [4.0e6, 8.0e6]}, seeds: 1}
  bcm_fracture: {base: {scenario.block.n_cells: 64}, axes: {model.interface.G_c: [0.5, 1.0]}, seeds: 1}
"""


@pytest.mark.slow
def test_bcm_round_trip(tmp_path, monkeypatch, plugin_cache):
    """Calibrate the BCM block to a material, run the block tests at the chosen k_n, k_t, G_c and
    cell size, and get back E, nu within 5 % and the fracture energy within 10 %."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "m.yaml").write_text(SMALL_BCM)
    res = CliRunner().invoke(app, ["calibrate", "m.yaml", "--out", "cal", "--workers", "1", "--verify"])
    assert res.exit_code == 0, res.output
    cal = json.loads((tmp_path / "cal" / "calibration.json").read_text())["bcm"]
    p = cal["parameters"]
    assert 0.4 < p["kt_over_kn"] < 0.8 and p["kt"] == pytest.approx(p["kt_over_kn"] * p["kn"], rel=1e-3)
    for key, tol in (("E", 0.05), ("nu", 0.05), ("G_c", 0.10)):
        assert abs(cal["verify"][key]["relative_error"]) < tol, (key, cal["verify"][key])


# ------------------------------------------------------------------------------ Ctrl-C (LAMMPS)
#: BPM only (the first curve is bpm_moduli), three runs of ~250 disks at a fifth of the default
#: rate, each running LAMMPS for several seconds.
SLOW_BPM = """name: slow2d
material: {density: 2500, E: 7.0e10, nu: 0.2, G_c: 8.0}
bpm: {dimension: 2, diameter: 2.0e-3, particles_across: 16}
curves:
  bpm_moduli: {base: {model.L: 12, scenario.strain_rate: 2.0e-5}, axes: {model.k_A: [0, 2, 4]}, seeds: 1}
"""
#: A compare file whose first curve (the BCM block's moduli) runs a 64-cell block for a while.
SLOW_COMPARE_MATERIAL = """name: slowcmp
material: {density: 6000, E: 2.21e11, nu: 0.05, G_c: 3.3}
bcm: {diameter: 2.0e-3, n_cells: 200}
curves:
  bcm_moduli: {base: {scenario.block.n_cells: 64, scenario.block.crossings: 40}, axes: {model.interface.kt: [5.0e6]},
               seeds: 1}
"""
SLOW_COMPARE = """name: slowcmp
material: m.yaml
grid: {velocity: [2.0], seeds: 1}
bpm: {particles_across: 7}
workers: 1
"""


def interrupt_while_a_curve_runs(args: list[str], cwd: Path, cache: Path) -> tuple[int, str, list[dict]]:
    """`driver ARGS` in cwd with `cache` (the plugin_cache fixture: the built plugins only), sent
    SIGINT once a run of a calibration curve runs LAMMPS; (exit code, stderr, the curve runs'
    status.json)."""

    def statuses() -> list[dict]:
        out = []
        for path in cache.glob("calibration/*/runs/*/status.json"):
            try:
                out.append(json.loads(path.read_text()))
            except (OSError, ValueError):  # being written
                pass
        return out

    # SIGINT at its default in the command (as from a terminal), whatever this test process holds:
    # a Python child keeps an inherited SIG_IGN and would run to its end (seen in .ci/run)
    proc = subprocess.Popen([sys.executable, "-m", "driver.cli", *args], cwd=cwd, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env={**os.environ, "BRITTLE_CACHE": str(cache)},
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    def in_lammps() -> bool:
        return any(s.get("state") == "running" and s.get("phase") == "lammps" for s in statuses())

    deadline = time.time() + 300
    while time.time() < deadline:
        assert proc.poll() is None, proc.communicate()[1][-3000:]
        if in_lammps():
            time.sleep(0.5)  # into the run's first chunks
            if in_lammps():  # still running (under load a short run can end within the wait): now
                break
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=300)
    return proc.returncode, err, statuses()


def assert_one_line_stop(code: int, err: str, command: str, runs: list[dict]) -> None:
    assert code == 130, (code, err[-3000:])
    assert "Traceback" not in err and "Interrupted" not in err, err[-3000:]
    last = [ln for ln in err.splitlines() if ln.strip()][-1]
    assert last.startswith(f"error: {command} interrupted; run the same command again to resume"), last
    assert any(r["state"] == "interrupted" and r.get("checkpoint_step") for r in runs), runs


@pytest.mark.slow
def test_ctrl_c_stops_calibrate_on_dask_with_one_line(tmp_path, plugin_cache):
    """Two Dask workers measure the moduli curve; Ctrl-C: the running runs write a checkpoint and
    stop, and the command says so in one line (no traceback ending in SweepInterrupted)."""
    (tmp_path / "m.yaml").write_text(SLOW_BPM)
    code, err, runs = interrupt_while_a_curve_runs(["calibrate", "m.yaml", "--out", "cal", "--workers", "2"],
                                                   tmp_path, plugin_cache)
    assert_one_line_stop(code, err, "calibrate", runs)


@pytest.mark.slow
def test_ctrl_c_stops_compare_in_process_with_one_line(tmp_path, plugin_cache):
    """`driver compare` (--workers 1: the runs in its own process) stopped while its first curve
    is measured: one line, exit code 130 (no traceback ending in RunInterrupted)."""
    (tmp_path / "m.yaml").write_text(SLOW_COMPARE_MATERIAL)
    (tmp_path / "c.yaml").write_text(SLOW_COMPARE)
    code, err, runs = interrupt_while_a_curve_runs(["compare", "c.yaml", "--out", "cmp"], tmp_path, plugin_cache)
    assert_one_line_stop(code, err, "compare", runs)
