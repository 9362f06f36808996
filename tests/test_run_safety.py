"""Run directories that never lose a user's files: ownership, dangerous locations, the lock,
sweeps and set analyses into foreign folders, OS errors as one line (issue: safe run dirs)."""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from driver.cli import app
from driver.rundir import LOCK, MARKER, SWEEP_MARKER, RunDir, RunDirError, check_location, claim_dir, read_status
from driver.sweep_lock import sweep_lock

TINY = {"name": "tiny", "seed": 5, "model": {"kind": "bpm", "dimension": 2, "L": 8},
        "scenario": {"kind": "shear", "strain_rate": 0.02, "max_strain": 0.05, "measure_strains": [0.05],
                     "thermo_every": 100},
        "output": {"plots": False}}


def tree_digest(root: Path) -> dict[str, str]:
    """Every file and folder under root with the hash of its bytes (folders: 'dir')."""
    out = {}
    for p in sorted(root.rglob("*")):
        out[str(p.relative_to(root))] = "dir" if p.is_dir() else hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def foreign_folder(path: Path) -> Path:
    path.mkdir(parents=True)
    (path / "thesis.tex").write_text("\\chapter{Results}")
    (path / "data").mkdir()
    (path / "data" / "measurements.csv").write_text("v,D\n1,0.1\n")
    (path / "results").mkdir()  # a name the run layout also uses
    (path / "results" / "summary.json").write_text('{"mine": true}')
    return path


def write_config(tmp_path: Path, **over) -> Path:
    cfg = json.loads(json.dumps(TINY))
    for k, v in over.items():
        cfg[k].update(v) if isinstance(cfg.get(k), dict) else cfg.__setitem__(k, v)
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


def cli(*args: str, cwd: Path | None = None, env: dict | None = None) -> subprocess.CompletedProcess:
    """The real console entry (driver.cli:main), as a user runs it."""
    return subprocess.run([sys.executable, "-c", "from driver.cli import main; main()", *args], cwd=cwd,
                          capture_output=True, text=True, env={**os.environ, **(env or {})}, timeout=300)


# ----------------------------------------------------------------------- ownership
@pytest.mark.parametrize("force", [False, True])
def test_foreign_folder_never_cleared(tmp_path, force):
    """Observed: with --force a non-empty folder that is not a run directory was deleted whole."""
    target = foreign_folder(tmp_path / "project")
    before = tree_digest(target)
    cfg = write_config(tmp_path)
    res = CliRunner().invoke(app, ["run", str(cfg), "-o", str(target), *(["--force"] if force else [])])
    assert res.exit_code == 2
    assert "not made by this tool" in res.output and "nothing in it is touched" in res.output
    assert tree_digest(target) == before


def test_status_json_alone_does_not_make_a_run_directory(tmp_path):
    """Observed: any folder with a valid status.json was taken for a run directory and cleared."""
    target = foreign_folder(tmp_path / "other_tool_run")
    (target / "status.json").write_text(json.dumps({"state": "running"}))
    before = tree_digest(target)
    res = CliRunner().invoke(app, ["run", str(write_config(tmp_path)), "-o", str(target)])
    assert res.exit_code == 2 and tree_digest(target) == before


@pytest.mark.parametrize("where", [".", "", "..", "{cwd}", "{parent}", "/", "~", "$HOME"])
def test_dangerous_locations_refused(tmp_path, monkeypatch, where):
    """Observed: output.dir '.', '' or name '..' with --force emptied the current directory;
    '/' or the home directory reached rmtree. Refused before anything is touched (temporary HOME)."""
    home = tmp_path / "home"
    work = home / "project" / "work"
    work.mkdir(parents=True)
    (work / "keep.txt").write_text("precious")
    (home / ".bashrc").write_text("# mine")
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.chdir(work)
    cfg = write_config(home / "project")
    before = tree_digest(tmp_path)
    out = where.format(cwd=work, parent=work.parent)
    res = CliRunner().invoke(app, ["run", str(cfg), "-o", out, "--force"], env={"HOME": str(home)})
    assert res.exit_code == 2, res.output
    assert "cannot be a run directory" in res.output
    assert tree_digest(tmp_path) == before


@pytest.mark.parametrize("name", [".", "..", "a/b", "../x", ""])
def test_name_is_a_plain_file_name(tmp_path, name):
    res = CliRunner().invoke(app, ["validate", str(write_config(tmp_path, name=name))])
    assert res.exit_code == 2 and "name" in res.output


def test_force_clears_only_the_run_layout(tmp_path, plugin_path):
    """--force on a finished run of this tool removes what the run wrote, never a file the
    user added to the folder; the marker and its id stay."""
    out = tmp_path / "run"
    cfg = write_config(tmp_path)
    assert CliRunner().invoke(app, ["run", str(cfg), "-o", str(out), "--quiet"]).exit_code == 0
    marker = (out / MARKER).read_text()
    (out / "my_notes.md").write_text("observations")
    (out / "results" / "my_fit.py").write_text("print(1)")
    (out / "dumps" / "atoms.777777.lammpstrj").write_text("stale")  # the tool's kind of file
    refused = CliRunner().invoke(app, ["run", str(cfg), "-o", str(out), "--quiet"])
    assert refused.exit_code == 2 and "--force" in refused.output
    res = CliRunner().invoke(app, ["run", str(cfg), "-o", str(out), "--force", "--quiet"])
    assert res.exit_code == 0, res.output
    assert (out / "my_notes.md").read_text() == "observations"
    assert (out / "results" / "my_fit.py").read_text() == "print(1)"
    assert not (out / "dumps" / "atoms.777777.lammpstrj").exists()
    assert (out / MARKER).read_text() == marker
    assert read_status(out)["state"] == "finished"


# ------------------------------------------------------------------------------ lock
@pytest.mark.lammps
def test_second_run_into_busy_directory_fails_naming_the_holder(tmp_path):
    out = tmp_path / "busy"
    holder = RunDir(out)
    holder.acquire()
    holder.set_running(phase="lammps")
    try:
        res = CliRunner().invoke(app, ["run", str(write_config(tmp_path)), "-o", str(out), "--force"])
        assert res.exit_code == 2
        assert f"pid {os.getpid()}" in res.output and "busy" in res.output
        with pytest.raises(RunDirError, match="busy"):
            RunDir(out).acquire()
    finally:
        holder.release()
    assert read_status(out)["state"] == "running"  # the holder's status was not touched


def test_a_sweep_into_a_directory_another_sweep_holds_is_refused_naming_it(tmp_path):
    """The sweep lock: while a sweep holds its directory, `driver sweep` into it is refused at
    once (exit 2), naming the holder's pid and command, and writes nothing; released, it is free."""
    out = claim_dir(tmp_path / "sw", SWEEP_MARKER, "sweep directory")
    config = write_config(tmp_path)
    with sweep_lock(out, ["driver", "sweep", "first.yaml"]):
        res = CliRunner().invoke(app, ["sweep", str(config), "--set", "model.k_A=1,2", "--out", str(out)])
        assert res.exit_code == 2, res.output
        assert "busy, a sweep is running there" in res.output and f"pid {os.getpid()}" in res.output
        assert "driver sweep first.yaml" in res.output
        with pytest.raises(RunDirError, match="busy"):
            with sweep_lock(out, ["driver", "sweep", "second.yaml"]):
                pass
    assert sorted(p.name for p in out.iterdir()) == sorted([SWEEP_MARKER, ".brittle-sweep.lock"])
    with sweep_lock(out, ["driver", "sweep", "again.yaml"]):  # released when the holder ended
        pass


@pytest.mark.slow
def test_two_sweeps_of_one_file_into_one_directory_do_not_run_side_by_side(tmp_path, plugin_path):
    """Observed: a second `driver sweep` of the same file into the same directory ran beside the
    first, each reported the other's runs as failed (busy), both exited 1 and both rewrote the
    set tables. Now the second is refused at once naming the first, which finishes untouched."""
    config = write_config(tmp_path, model={"L": 16}, scenario={"strain_rate": 0.001, "max_strain": 0.5,
                                                               "measure_strains": [0.5]})
    out = tmp_path / "sw"
    args = ["sweep", str(config), "--set", "seed=1,2", "--out", str(out), "--workers", "1"]
    first = subprocess.Popen([sys.executable, "-c", "from driver.cli import main; main()", *args],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.time() + 300
        while time.time() < deadline and (read_status(out / "seed1") or {}).get("phase") != "lammps":
            assert first.poll() is None, first.communicate()[1][-3000:]
            time.sleep(0.05)
        second = cli(*args)
        assert second.returncode == 2, second.stderr[-3000:]
        assert "busy, a sweep is running there" in second.stderr and f"pid {first.pid}" in second.stderr
        _, err = first.communicate(timeout=600)
    finally:
        if first.poll() is None:
            first.send_signal(signal.SIGINT)
            first.communicate(timeout=120)
    assert first.returncode == 0 and "failed" not in err, err[-3000:]
    assert read_status(out / "seed1")["state"] == read_status(out / "seed2")["state"] == "finished"
    lines = [json.loads(ln) for ln in (out / "sweep_log.jsonl").read_text().splitlines()]
    assert [ln["outcome"] for ln in lines] == ["complete"]  # one sweep wrote the tables


# ------------------------------------------------------------------ sweeps and sets
def test_sweep_into_foreign_folder_refused(tmp_path):
    """Observed: `sweep --out` into a foreign folder overwrote a report.md there."""
    target = tmp_path / "paper"
    target.mkdir()
    (target / "report.md").write_text("# my report")
    res = CliRunner().invoke(app, ["sweep", str(write_config(tmp_path)), "--set", "model.k_A=1,2",
                                   "--out", str(target)])
    assert res.exit_code == 2 and (target / "report.md").read_text() == "# my report"
    assert sorted(p.name for p in target.iterdir()) == ["report.md"]


def test_set_analysis_into_foreign_folder_refused(tmp_path):
    target = foreign_folder(tmp_path / "figs")
    before = tree_digest(target)
    res = CliRunner().invoke(app, ["scaling", str(tmp_path), "--out", str(target)])
    assert res.exit_code == 2 and tree_digest(target) == before


# ------------------------------------------------------------------------ OS errors
@pytest.mark.lammps
def test_output_path_that_is_a_file(tmp_path):
    (tmp_path / "afile").write_text("x")
    proc = cli("run", str(write_config(tmp_path)), "-o", str(tmp_path / "afile"))
    assert proc.returncode == 2 and "not a folder" in proc.stderr and "Traceback" not in proc.stderr


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_read_only_location(tmp_path):  # pragma: no cover - CI runs as root
    ro = tmp_path / "ro"
    ro.mkdir(mode=0o555)
    proc = cli("run", str(write_config(tmp_path)), "-o", str(ro / "run"))
    assert proc.returncode == 2 and "Traceback" not in proc.stderr


@pytest.mark.lammps
def test_os_error_is_one_line_and_debug_shows_the_traceback(tmp_path):
    """An OS error anywhere (here: a file where the sweep's parent folder should be) is one line
    naming the path with exit code 2; --debug shows the traceback."""
    (tmp_path / "blocker").write_text("x")
    args = ("sweep", str(write_config(tmp_path)), "--set", "model.k_A=1", "--out", str(tmp_path / "blocker" / "s"))
    proc = cli(*args)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr and "blocker" in proc.stderr
    assert len([line for line in proc.stderr.splitlines() if line.strip()]) <= 2
    debug = cli(*args, "--debug")
    assert debug.returncode != 0 and "Traceback" in debug.stderr


def test_tilde_and_variables_expanded_in_output(tmp_path, monkeypatch):
    from driver.cli import with_output_dir
    from driver.config import parse_config

    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setenv("STUDY", "s1")
    cfg = parse_config({**TINY, "output": {"dir": "~/runs/a"}})
    assert cfg.run_dir() == tmp_path / "runs" / "a"
    assert with_output_dir(cfg, Path("$HOME/runs/$STUDY")).run_dir() == tmp_path / "runs" / "s1"


def test_check_location_accepts_a_new_folder(tmp_path):
    assert check_location(tmp_path / "new" / "run") == tmp_path / "new" / "run"
    assert not (tmp_path / "new").exists()  # checking creates nothing
    assert LOCK.startswith(".brittle")


def test_a_run_on_another_host_is_busy_while_its_heartbeat_is_fresh(tmp_path):
    """Locks may be local to a node: a `running` status from another host counts as alive while
    its heartbeat is younger than STALE_AFTER_S, and as stale after."""
    import time

    from driver.rundir import STALE_AFTER_S, run_state

    out = tmp_path / "run"
    rd = RunDir(out)
    rd.acquire()
    rd.release()
    status = {"state": "running", "pid": 1, "host": "node-that-is-not-this-one", "started": "earlier"}
    (out / "status.json").write_text(json.dumps({**status, "heartbeat_epoch": time.time()}))
    assert run_state(out)["state"] == "running"
    with pytest.raises(RunDirError, match="busy.*node-that-is-not-this-one"):
        RunDir(out).prepare(force=True)
    (out / "status.json").write_text(json.dumps({**status, "heartbeat_epoch": time.time() - 2 * STALE_AFTER_S}))
    assert run_state(out)["state"] == "stale"


def test_a_foreign_staging_folder_and_dump_names_are_left_alone(tmp_path):
    """Names the tool uses are only removed when the tool made them: a `.post-staging` folder
    without the tool's marker stops the analysis instead of being deleted, and a resume drops
    only dumps the tool itself names."""
    from driver.pipeline import analyse_run, trim_after

    run = tmp_path / "run"
    (run / "dumps").mkdir(parents=True)
    (run / ".post-staging").mkdir()
    (run / ".post-staging" / "notes.txt").write_text("mine")
    with pytest.raises(RunDirError, match="not made by this tool"):
        analyse_run(run, {"name": "x", "scenario": {"kind": "shear"}, "output": {"plots": False}})
    assert (run / ".post-staging" / "notes.txt").read_text() == "mine"
    for name in ("atoms.500.lammpstrj", "cells.end.lammpstrj", "my.end.notes.lammpstrj", "atoms.100.lammpstrj",
                 "trial.900.lammpstrj"):
        (run / "dumps" / name).write_text("x")
    trim_after(run, 200)
    assert sorted(p.name for p in (run / "dumps").iterdir()) == [
        "atoms.100.lammpstrj", "my.end.notes.lammpstrj", "trial.900.lammpstrj"]
