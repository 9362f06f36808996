"""Stopping and resuming runs: SIGINT/SIGTERM stop a run at a chunk boundary with a checkpoint,
SIGKILL leaves a stale run that `driver status` names, `--resume` carries a run on and gives
the results of an uninterrupted run (identical on 1 rank), `driver post` analyses a partial
run, and a failed re-analysis keeps the previous summary."""

from __future__ import annotations

import filecmp
import io
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
import yaml
from rich.console import Console

from driver.config import ConfigError, load_config, parse_config
from driver.pipeline import check_resumable, execute
from driver.rundir import latest_checkpoint, read_status, run_state

# 2D shear of ~430 particles to strain 0.5: 100,000 steps in chunks of 1000 (~3 s of LAMMPS)
SHEAR = {"name": "shear", "seed": 3, "model": {"kind": "bpm", "dimension": 2, "L": 16},
         "scenario": {"kind": "shear", "strain_rate": 0.001, "max_strain": 0.5,
                      "measure_strains": [0.1, 0.25, 0.5], "thermo_every": 100},
         "execution": {"chunk_steps": 1000}, "output": {"plots": False}}
SHEAR_STEPS = 100_000
# BCM impact of 300 cells at 4.5 m/s, chunks of ~430 steps, settled near step 8,700; cell and
# interface dumps every 1000 steps (the resumed process writes its first step's again)
IMPACT = {"name": "impact", "seed": 1, "model": {"kind": "bcm", "n_cells": 300},
          "scenario": {"kind": "impact", "velocity": 4.5, "max_time": 4e-4, "thermo_every": 100,
                       "dump_every": 1000},
          "execution": {"chunk_steps": 500}, "output": {"plots": False}}
IMPACT_STEPS = 8000


def config_file(tmp_path: Path, base: dict, name: str, **execution) -> Path:
    cfg = json.loads(json.dumps(base))
    cfg["execution"].update(execution)
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


def driver(*args: str) -> subprocess.Popen:
    """`driver ARGS` with SIGINT at its default (as from a terminal), whatever this test process
    holds: a Python child keeps an inherited SIG_IGN, and the signals these tests send would not
    stop it."""
    return subprocess.Popen([sys.executable, "-m", "driver.cli", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def last_step(out: Path) -> int:
    try:
        lines = [ln for ln in (out / "thermo.dat").read_text().splitlines() if ln.strip() and ln[0] != "#"]
    except OSError:
        return -1
    return int(float(lines[-1].split()[0])) if lines else -1


def run_and_signal(cfg: Path, out: Path, at_step: int, sig: int, *extra: str,
                   wait_for_checkpoint: bool = False) -> tuple[int, float, str]:
    """Start `driver run`, send `sig` once the record passes `at_step`; (exit code, seconds from
    the signal to the exit, stderr)."""
    proc = driver("run", str(cfg), "-o", str(out), "--quiet", *extra)
    deadline = time.time() + 240
    while proc.poll() is None and time.time() < deadline:
        if last_step(out) > at_step and (not wait_for_checkpoint or latest_checkpoint(out) is not None):
            break
        time.sleep(0.02)
    assert proc.poll() is None, f"the run ended before step {at_step}: {proc.stderr.read()[-2000:]}"
    t0 = time.time()
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    return proc.returncode, time.time() - t0, err


def assert_same_results(a: Path, b: Path) -> None:
    """Tables, summary and dumps of two runs are identical."""
    tables = sorted(p.name for p in (a / "results").glob("*.parquet"))
    assert tables and tables == sorted(p.name for p in (b / "results").glob("*.parquet"))
    for name in tables:
        pd.testing.assert_frame_equal(pd.read_parquet(a / "results" / name), pd.read_parquet(b / "results" / name),
                                      check_exact=True)
    summaries = [json.loads((d / "results/summary.json").read_text()) for d in (a, b)]
    assert [{k: v for k, v in x.items() if k != "name"} for x in summaries][0] == \
        {k: v for k, v in summaries[1].items() if k != "name"}
    dumps = sorted(p.name for p in (a / "dumps").iterdir())
    assert dumps == sorted(p.name for p in (b / "dumps").iterdir())
    for name in dumps:
        assert filecmp.cmp(a / "dumps" / name, b / "dumps" / name, shallow=False), name


def cli_run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "driver.cli", "run", *args, "--quiet"], capture_output=True,
                          text=True)


def reference_interrupted_resumed(cfg: Path, tmp_path: Path, at_step: int | None = None,
                                  at_fraction: float | None = None) -> tuple[Path, Path]:
    """An uninterrupted run of `cfg` (ref), and the same run stopped by SIGINT once its record
    passes `at_step` (or that fraction of the reference's steps) and resumed (run): checks the
    stop (exit 130 within 10 s, `interrupted`, a checkpoint) and the resume; returns both."""
    ref, out = tmp_path / "ref", tmp_path / "run"
    done = cli_run(str(cfg), "-o", str(ref))
    assert done.returncode == 0, done.stderr[-2000:]
    at = at_step if at_step is not None else int(at_fraction * last_step(ref))
    code, seconds, err = run_and_signal(cfg, out, at, signal.SIGINT)
    assert code == 130 and seconds < 10, err[-2000:]
    assert read_status(out)["state"] == "interrupted" and latest_checkpoint(out) is not None
    resumed = cli_run(str(cfg), "-o", str(out), "--resume")
    assert resumed.returncode == 0, resumed.stderr[-3000:]
    return ref, out


@pytest.fixture(scope="module")
def shear_reference(shared_runs, plugin_path) -> Path:
    """Read only (built once per session): a test that changes it copies it."""
    return shared_runs.get("bpm_shear_resume_reference", lambda out: execute(
        parse_config({**SHEAR, "output": {**SHEAR["output"], "dir": str(out)}}), show_progress=False))


# ---------------------------------------------------------------------- SIGINT/TERM
@pytest.mark.parametrize("sig", [signal.SIGINT, pytest.param(signal.SIGTERM, marks=pytest.mark.slow)])
def test_signal_stops_one_rank_shear_and_resume_is_identical(tmp_path, shear_reference, sig):
    cfg = config_file(tmp_path, SHEAR, "shear")
    out = tmp_path / "run"
    code, seconds, err = run_and_signal(cfg, out, SHEAR_STEPS // 2, sig)
    assert code == 128 + sig, err
    assert seconds < 10
    st = read_status(out)
    assert st["state"] == "interrupted" and st["phase"] == "lammps"
    ckpt = latest_checkpoint(out)
    assert ckpt is not None and ckpt["step"] == st["checkpoint_step"] and 0 < ckpt["step"] < SHEAR_STEPS
    assert "--resume" in err
    # a plain re-run does not throw the checkpoint away
    again = subprocess.run([sys.executable, "-m", "driver.cli", "run", str(cfg), "-o", str(out), "--quiet"],
                           capture_output=True, text=True)
    assert again.returncode == 2 and "--resume" in again.stderr
    resumed = subprocess.run([sys.executable, "-m", "driver.cli", "run", str(cfg), "-o", str(out), "--resume",
                              "--quiet"], capture_output=True, text=True)
    assert resumed.returncode == 0, resumed.stderr[-3000:]
    assert read_status(out)["state"] == "finished"
    assert_same_results(shear_reference, out)
    prov = json.loads((out / "provenance.json").read_text())
    assert prov["resumed"][0]["from_step"] == ckpt["step"]


@pytest.mark.slow
def test_sigint_stops_bcm_impact_and_resume_is_identical(tmp_path, plugin_path):
    ref, out = reference_interrupted_resumed(config_file(tmp_path, IMPACT, "impact"), tmp_path, IMPACT_STEPS // 2)
    assert_same_results(ref, out)


@pytest.mark.slow
@pytest.mark.mpi
def test_sigint_stops_two_rank_run_and_resume_completes(tmp_path, plugin_path):
    """2 ranks: the stop request reaches every rank through rank 0 (include control.lmp); the
    resumed run matches an uninterrupted 2-rank run."""
    ref, out = reference_interrupted_resumed(config_file(tmp_path, SHEAR, "shear2", np=2), tmp_path,
                                             SHEAR_STEPS // 2)
    one = json.loads((ref / "results/summary.json").read_text())
    two = json.loads((out / "results/summary.json").read_text())
    assert two["bonds_broken"] == one["bonds_broken"] and two["grains_at_strain"] == one["grains_at_strain"]


# -------------------------------------------------------------------------- SIGKILL
@pytest.mark.slow
def test_sigkill_leaves_a_stale_run_that_post_reads_and_resume_completes(tmp_path, shear_reference):
    cfg = config_file(tmp_path, SHEAR, "shear", checkpoint_every="20000steps")
    out = tmp_path / "run"
    code, _, _ = run_and_signal(cfg, out, int(SHEAR_STEPS * 0.6), signal.SIGKILL, wait_for_checkpoint=True)
    assert code == -signal.SIGKILL
    assert read_status(out)["state"] == "running"  # what the killed process left
    assert run_state(out)["state"] == "stale"
    status = subprocess.run([sys.executable, "-m", "driver.cli", "status", str(out)], capture_output=True, text=True)
    assert status.returncode == 0 and "stale" in status.stdout
    # checkpoints every 20,000 steps, killed past 60,000: the last two kept, 20,000 apart
    kept = sorted(json.loads(p.read_text())["step"] for p in (out / "checkpoints").glob("step*.json"))
    assert len(kept) == 2 and kept[1] - kept[0] == 20_000 and kept[1] % 20_000 == 0 and kept[1] >= 60_000
    # the snapshots it dumped are data: post analyses them and says what is missing
    post = subprocess.run([sys.executable, "-m", "driver.cli", "post", str(out), "--no-plots"], capture_output=True,
                          text=True)
    assert post.returncode == 0, post.stderr[-3000:]
    assert "did not finish" in post.stderr
    summary = json.loads((out / "results/summary.json").read_text())
    assert "0.1" in summary["grains_at_strain"] and "0.5" not in summary["grains_at_strain"]
    resumed = subprocess.run([sys.executable, "-m", "driver.cli", "run", str(cfg), "-o", str(out), "--resume",
                              "--quiet"], capture_output=True, text=True)
    assert resumed.returncode == 0, resumed.stderr[-3000:]
    assert_same_results(shear_reference, out)


def test_resume_refused_when_the_config_changed(tmp_path, plugin_path):
    cfg = config_file(tmp_path, SHEAR, "shear")
    out = tmp_path / "run"
    run_and_signal(cfg, out, SHEAR_STEPS // 4, signal.SIGINT)
    changed = {**SHEAR, "model": {**SHEAR["model"], "k_A": 2.0}, "output": {"dir": str(out)}}
    with pytest.raises(ConfigError, match=r"model.k_A: 4.0 -> 2.0"):
        execute(parse_config(changed), resume=True, show_progress=False)
    assert read_status(out)["state"] == "interrupted"
    # a run made before defaults were filled in when the config is read holds null there: the
    # same config resumes it (the check reads the old record through today's schema)
    old = yaml.safe_load((out / "config.resolved.yaml").read_text())
    old["model"]["packing_fraction"], old["execution"]["chunk_steps"] = None, None
    (out / "config.resolved.yaml").write_text(yaml.safe_dump(old, sort_keys=False))
    check_resumable(load_config(cfg), out)
    # checkpoints written by another build of the plugins are not read back
    prov = json.loads((out / "provenance.json").read_text())
    (out / "provenance.json").write_text(json.dumps({**prov, "plugin_build_hash": "an-older-build"}))
    with pytest.raises(ConfigError, match="written by plugin build an-older-build"):
        execute(parse_config({**SHEAR, "output": {"dir": str(out)}}), resume=True, show_progress=False)
    assert read_status(out)["state"] == "interrupted"


# ------------------------------------------------------------------ progress, post
def test_progress_follows_a_relative_output_dir(tmp_path, monkeypatch, plugin_path):
    """Observed: with a relative output.dir on 1 rank the bar stayed at step 0 (the monitor
    polled a relative path after the run changed directory)."""
    monkeypatch.chdir(tmp_path)
    buf = io.StringIO()
    cfg = {**SHEAR, "scenario": {**SHEAR["scenario"], "max_strain": 0.1, "measure_strains": [0.1]},
           "output": {"plots": False, "dir": "rel/run"}}
    execute(parse_config(cfg), console=Console(file=buf, width=200), show_progress=True)
    assert "step 20,000/20,000" in buf.getvalue()


def test_failed_reanalysis_keeps_the_previous_summary(shear_reference, tmp_path):
    import shutil

    run = tmp_path / "copy"
    shutil.copytree(shear_reference, run)
    summary = (run / "results/summary.json").read_bytes()
    tables = {p.name: p.read_bytes() for p in (run / "results").iterdir()}
    last = sorted((run / "dumps").glob("bonds.*.lammpstrj"), key=lambda p: int(p.name.split(".")[1]))[-1]
    last.write_text(last.read_text()[:200])  # truncated: the analysis fails on it
    post = subprocess.run([sys.executable, "-m", "driver.cli", "post", str(run), "--no-plots"], capture_output=True,
                          text=True)
    assert post.returncode == 2
    assert (run / "results/summary.json").read_bytes() == summary
    assert {p.name: p.read_bytes() for p in (run / "results").iterdir()} == tables
    assert read_status(run)["state"] == "finished" and not (run / ".post-staging").exists()


def test_checkpoints_every_steps_keep_the_last_two(tmp_path, plugin_path):
    out = tmp_path / "run"
    cfg = {**SHEAR, "scenario": {**SHEAR["scenario"], "max_strain": 0.2, "measure_strains": [0.2]},
           "execution": {"chunk_steps": 1000, "checkpoint_every": "5000steps"}, "output": {"dir": str(out)}}
    execute(parse_config(cfg), show_progress=False)
    records = sorted(p.name for p in (out / "checkpoints").glob("step*.json"))
    assert records == ["step000000030000.json", "step000000035000.json"]
    assert sorted(p.name for p in (out / "checkpoints").glob("*.restart")) == [
        "step000000030000.restart", "step000000035000.restart"]
    assert os.path.getsize(out / "checkpoints" / "step000000035000.restart") > 0


def test_resume_after_an_interrupted_analysis_only_analyses(shear_reference, tmp_path):
    """A run stopped after its LAMMPS part (during the analysis) resumes with the analysis
    alone: LAMMPS is not run again."""
    import shutil

    run = tmp_path / "copy"
    shutil.copytree(shear_reference, run)
    log = (run / "log.lammps").read_bytes()
    (run / "results" / "summary.json").unlink()
    (run / "status.json").write_text(json.dumps({"state": "interrupted", "phase": "analysis", "lammps_done": True}))
    cfg = {**SHEAR, "output": {**SHEAR["output"], "dir": str(run)}}
    execute(parse_config(cfg), resume=True, show_progress=False)
    assert read_status(run)["state"] == "finished"
    assert (run / "log.lammps").read_bytes() == log
    assert_same_results(shear_reference, run)


@pytest.mark.slow
def test_interrupted_sweep_resumes_its_interrupted_run(tmp_path, shear_reference):
    """SIGINT stops a sweep run one after the other in the driver's process (--workers 1) inside
    its first run (checkpoint written, exit 130); running the same sweep again resumes that run
    from its checkpoint and runs the rest. (On Dask workers: tests/test_sweep_files.py.)"""
    base = config_file(tmp_path, SHEAR, "base")
    out = tmp_path / "sweep"
    cmd = ["sweep", str(base), "--set", "seed=3,4", "--out", str(out), "--workers", "1"]
    proc = driver(*cmd)
    first = out / "seed3"
    deadline = time.time() + 240
    while proc.poll() is None and time.time() < deadline and last_step(first) <= SHEAR_STEPS // 2:
        time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err[-2000:]
    assert read_status(first)["state"] == "interrupted" and not (out / "seed4").exists()
    again = subprocess.run([sys.executable, "-m", "driver.cli", *cmd], capture_output=True, text=True)
    assert again.returncode == 0, again.stderr[-3000:]
    prov = json.loads((first / "provenance.json").read_text())
    assert prov["resumed"] and prov["resumed"][0]["from_step"] > 0
    assert read_status(first)["state"] == read_status(out / "seed4")["state"] == "finished"
    assert_same_results(shear_reference, first)


@pytest.mark.slow
def test_stop_during_the_last_chunk_keeps_the_finished_simulation(tmp_path, shear_reference):
    """A stop asked during the last chunk is not lost: the simulation is complete, the run is
    `interrupted` with its LAMMPS part done, and --resume only analyses it."""
    one_chunk = {**SHEAR, "scenario": {**SHEAR["scenario"], "measure_strains": [0.5]}}
    cfg = config_file(tmp_path, one_chunk, "one_chunk", chunk_steps=SHEAR_STEPS)
    out = tmp_path / "run"
    code, _, err = run_and_signal(cfg, out, SHEAR_STEPS // 4, signal.SIGINT)
    assert code == 130, err[-2000:]
    st = read_status(out)
    assert st["state"] == "interrupted" and st["lammps_done"] and latest_checkpoint(out) is None
    log = (out / "log.lammps").read_bytes()
    resumed = subprocess.run([sys.executable, "-m", "driver.cli", "run", str(cfg), "-o", str(out), "--resume",
                              "--quiet"], capture_output=True, text=True)
    assert resumed.returncode == 0, resumed.stderr[-3000:]
    assert (out / "log.lammps").read_bytes() == log and read_status(out)["state"] == "finished"


@pytest.mark.slow
@pytest.mark.mpi
def test_sigint_stops_two_rank_bcm_impact_and_resume_completes(tmp_path, plugin_path):
    ref, out = reference_interrupted_resumed(config_file(tmp_path, IMPACT, "impact2", np=2), tmp_path,
                                             IMPACT_STEPS // 2)
    one = json.loads((ref / "results/summary.json").read_text())
    two = json.loads((out / "results/summary.json").read_text())
    # same decomposition on both: the resumed run repeats the uninterrupted one
    for key in ("broken_interfaces", "n_fragments", "end_step"):
        assert two[key] == one[key], key
    assert two["e_k2"] == pytest.approx(one["e_k2"], rel=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize("example,at", [
    # the example's copy of test_sigint_stops_bcm_impact_and_resume_is_identical (46 s), which CI
    # runs on its smaller BCM impact; extended to keep .ci/run under 15 minutes
    pytest.param("bcm_impact_quick.yaml", 0.5, marks=pytest.mark.extended),
    # another model's copy (59 s): the BPM's resume also runs in CI through the crush's
    # (tests/test_bpm_crush.py); extended to keep .ci/run under 15 minutes with the beds' tests
    pytest.param("bpm_shear_2d.yaml", 0.5, marks=pytest.mark.extended)])
def test_examples_interrupted_and_resumed_are_identical(tmp_path, plugin_path, example, at):
    """The issue's check on the examples themselves: interrupt at ~50 %, resume, compare."""
    cfg = Path(__file__).resolve().parent.parent / "examples" / example
    ref, out = reference_interrupted_resumed(cfg, tmp_path, at_fraction=at)
    assert_same_results(ref, out)
