"""`driver run`: config -> run directory -> LAMMPS session -> results, with provenance and status.

A run is `running` (pid, host, heartbeat, phase) while it lives, then `finished`, `failed`
(with the error) or `interrupted` (with the step of its last checkpoint). `resume` carries an
interrupted or stale run on from its last checkpoint; a run whose LAMMPS part had ended is
only analysed again.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import time
from pathlib import Path
from typing import Any

import yaml
from rich.console import Console

from analysis.completeness import RunCompleteness
from driver.bed_phases import CHECK_LOG_FILE
from driver.config import RunConfig, resolved_yaml
from driver.mpi_launch import settings as mpi_settings
from driver.plugin_build import plugin_library
from driver.registry import unit_of
from driver.rundir import (LOCK, MARKER, STAGING, STAGING_MARKER, STATUS, RunDir, RunDirError, check_claimable,
                           latest_checkpoint, provenance, read_status)
from driver.runner import RunInterrupted, deferred_signals, interruptible, run_session
from runfiles.atomic import atomic_write_json, atomic_write_text

# Keys that may change between an interrupted run and its resumption: how it runs, not what.
RESUMABLE_CHANGES = ("execution.", "output.plots", "output.animation", "output.count_above", "output.dir")


def execute(cfg: RunConfig, source: Path | None = None, force: bool = False, np_ranks: int | None = None,
            show_progress: bool = True, console: Console | None = None, resume: bool = False) -> Path:
    """Run one validated config to completion; returns the run directory.

    Raises RunDirError (folder refused, busy, finished), RunInterrupted (stopped by a signal),
    LammpsError, ConfigError (resume with a changed config)."""
    console = console or Console(stderr=True)
    ranks = np_ranks or cfg.execution.np
    rd = RunDir(cfg.run_dir())  # its location is checked here, before anything is built or written
    check_claimable(rd.root, MARKER, "run directory")
    plugin = plugin_library()  # before touching the run dir: a build failure leaves nothing behind
    action = rd.prepare(force=force, resume=resume)  # takes the run's lock
    try:
        with interruptible():
            return _execute_locked(cfg, rd, action, source, plugin, ranks, show_progress, console)
    finally:
        rd.release()


def _execute_locked(cfg: RunConfig, rd: RunDir, action: str, source: Path | None, plugin: Path, ranks: int,
                    show_progress: bool, console: Console) -> Path:
    checkpoint = None
    lammps_done = False
    if action == "resume":
        previous = read_status(rd.root) or {}
        check_resumable(cfg, rd.root)
        prov = json.loads((rd.root / "provenance.json").read_text())
        if not previous.get("lammps_done"):
            check_same_plugins(prov, plugin, rd.root)
        system = json.loads((rd.root / "system.json").read_text())
        lammps_done = bool(previous.get("lammps_done"))
        if not lammps_done:
            checkpoint = latest_checkpoint(rd.root)
            trim_after(rd.root, checkpoint["step"])
        prov.setdefault("resumed", []).append({"at": time.strftime("%Y-%m-%dT%H:%M:%S"), "mpi_ranks": ranks,
                                               "mpi_settings": mpi_settings(),
                                               "from_step": None if lammps_done else checkpoint["step"]})
        console.print(f"[yellow]{rd.root}: resuming " + (
            "the analysis (its LAMMPS part had ended)" if lammps_done else f"from the checkpoint at step "
                                                                            f"{checkpoint['step']}"))
        spec = unit_of(cfg).progress(cfg, system)
    else:
        if action == "cleared":
            console.print(f"[yellow]{rd.root}: the earlier run's files were removed, starting clean")
        foreign = rd.foreign_entries()
        if foreign:
            console.print(f"[yellow]{rd.root}: left alone, not made by this tool: {', '.join(foreign)}")
        rd.set_running(phase="build")
        if source is not None:
            shutil.copy2(source, rd.root / "input.yaml")
        atomic_write_text(rd.root / "config.resolved.yaml", resolved_yaml(cfg))
        prov = provenance({"config_name": cfg.name, "seed": cfg.seed, "mpi_ranks": ranks,
                           "mpi_settings": mpi_settings(),
                           "plugin_library": str(plugin), "plugin_build_hash": plugin.parent.name,
                           "started": time.strftime("%Y-%m-%dT%H:%M:%S")})
        atomic_write_json(rd.root / "provenance.json", prov)
        t_build = time.time()
        try:
            system, spec = unit_of(cfg).build(cfg, rd, plugin)
            prov["build_seconds"] = time.time() - t_build  # wall_seconds (below) is LAMMPS + analysis
        except RunInterrupted as exc:
            rd.set_state("interrupted", error=str(exc), phase="build", signal=exc.signum)
            raise
        except BaseException as exc:
            rd.set_state("failed", error=f"{type(exc).__name__}: {exc}", phase="build")
            raise
    t0 = time.time()
    if not lammps_done:
        rd.set_running(phase="lammps", mpi_ranks=ranks)
        try:
            run_session(rd.root, np=ranks, checkpoint=checkpoint, progress=spec, show_progress=show_progress,
                        console=console, heartbeat=lambda last: rd.heartbeat(**last),
                        checkpoint_seconds=cfg.execution.checkpoint_seconds())
        except RunInterrupted as exc:
            if exc.lammps_done:
                rd.set_state("interrupted", error=str(exc), phase="analysis", lammps_done=True, signal=exc.signum)
                raise
            last = latest_checkpoint(rd.root)
            rd.set_state("interrupted", error=str(exc), phase="lammps", signal=exc.signum,
                         checkpoint_step=last["step"] if last else None)
            raise RunInterrupted(exc.signum, last["step"] if last else None) from None
        except BaseException as exc:
            rd.set_state("failed", error=f"{type(exc).__name__}: {exc}", phase="lammps")
            raise
        prov["lammps_wall_seconds"] = prov.get("lammps_wall_seconds", 0.0) + (time.time() - t0)
    rd.set_running(phase="analysis", lammps_done=True)
    try:
        analyse_run(rd.root, cfg.model_dump(mode="json"))
    except RunInterrupted as exc:
        rd.set_state("interrupted", error=str(exc), phase="analysis", lammps_done=True, signal=exc.signum)
        raise
    except BaseException as exc:
        rd.set_state("failed", error=f"{type(exc).__name__}: {exc}", phase="analysis", lammps_done=True)
        raise
    prov["wall_seconds"] = prov.get("wall_seconds", 0.0) + (time.time() - t0)
    atomic_write_json(rd.root / "provenance.json", prov)
    rd.set_state("finished")
    return rd.root


# ----------------------------------------------------------------------------- resume
def _flat(d: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(d, dict):
        out: dict[str, Any] = {}
        for k, v in d.items():
            out.update(_flat(v, f"{prefix}{k}."))
        return out
    return {prefix[:-1]: d}


def check_resumable(cfg: RunConfig, run_dir: Path) -> None:
    """Refuse a resume whose config differs from the run's in what it simulates. The run's
    config is read through today's schema first, so a run made before a default was filled in
    when the config is read (its config.resolved.yaml holds null there) compares equal."""
    from driver.config import ConfigError, parse_config  # noqa: PLC0415

    resolved = load_resolved(run_dir)
    try:
        resolved = parse_config(resolved, str(run_dir / "config.resolved.yaml")).model_dump(mode="json")
    except ConfigError:
        pass  # a key this version no longer knows: compared as it stands, so the change is named
    old = _flat(resolved)
    new = _flat(cfg.model_dump(mode="json"))
    changed = sorted(k for k in set(old) | set(new) if old.get(k) != new.get(k)
                     and not any(k == p or k.startswith(p) for p in RESUMABLE_CHANGES))
    if changed:
        detail = ", ".join(f"{k}: {old.get(k)!r} -> {new.get(k)!r}" for k in changed[:8])
        raise ConfigError(f"{run_dir}: cannot resume, the config changed since the run started ({detail}); "
                          "run it under another output directory, or use --force to start it again")


def check_same_plugins(prov: dict, plugin: Path, run_dir: Path) -> None:
    """Refuse to resume LAMMPS from a checkpoint written by another build of the plugins: a
    checkpoint holds the styles' own state (interface tables, per-atom stores, counters) in
    the layout of the build that wrote it, and another build may read it back wrong or not
    at all. ConfigError naming both builds and the ways out."""
    from driver.config import ConfigError  # noqa: PLC0415

    made = prov.get("plugin_build_hash")
    if made is not None and made != plugin.parent.name:
        raise ConfigError(f"{run_dir}: cannot resume, its checkpoints were written by plugin build {made} and the "
                          f"plugins are now build {plugin.parent.name} (their sources changed since the run started); "
                          "finish it with the version that started it, or use --force to start it again")


# the dumps a run writes: periodic and snapshot dumps by step, the impact's start and end state
_DUMP_NAME = re.compile(r"^(atoms|bonds|cells|interfaces)\.(?P<step>\d+|start|end)\.lammpstrj$")


def trim_after(run_dir: Path, step: int) -> None:
    """Before resuming from `step`: drop the records and dumps the interrupted run wrote after it
    (the resumed run writes them again), so no file mixes two attempts."""
    # the record and the break log: a step's lines are kept up to the checkpoint's step (the
    # breaks of that step are in the checkpoint already), a line cut by the interruption dropped
    for name in ("thermo.dat", "breaks.dat", CHECK_LOG_FILE):
        _trim_lines(run_dir / name, step)
    for dump in (run_dir / "dumps").glob("*.lammpstrj*"):
        m = _DUMP_NAME.match(dump.name)  # only the tool's own dump names, never a user's file
        if m and (m["step"] == "end" or (m["step"].isdigit() and int(m["step"]) > step)):
            dump.unlink()


def _trim_lines(path: Path, step: int) -> None:
    """Keep the '#' lines of a record whose first column is the step, and its records up to
    `step`; a last line without its newline (cut by the interruption) goes."""
    if not path.exists():
        return
    kept = []
    for line in path.read_text().splitlines(keepends=True):
        fields = line.split()
        if not line.endswith("\n"):
            break
        if line.startswith("#") or not fields:
            kept.append(line)
            continue
        try:
            if int(float(fields[0])) <= step:
                kept.append(line)
        except ValueError:
            continue
    atomic_write_text(path, "".join(kept))


# --------------------------------------------------------------------------- analysis
def load_resolved(run_dir: Path) -> dict:
    return yaml.safe_load((Path(run_dir) / "config.resolved.yaml").read_text())


_STAGED = ("results", "plots")
_REPORTS = ("report.md", "report.html")


def analyse_run(run_dir: Path, cfg: dict, completeness: RunCompleteness = RunCompleteness.FINISHED) -> dict:
    """The analysis of a run directory for its scenario: what `driver run` ends with and
    `driver post` repeats; returns the summary. completeness: CUT_SHORT for a run that did not
    finish, which its analysis measures on what it left (flagged) or refuses (RunRefused):
    analysis/completeness.py.

    The analysis works in a staging folder (links to the run's inputs, copies of its earlier
    results) and its results replace the earlier ones only when it has finished, summary.json
    last: an analysis that fails leaves the previous results, summary included, untouched."""
    run_dir = Path(run_dir).resolve()
    staging = run_dir / STAGING
    if staging.exists():  # left by an analysis that was killed: removed only when it is ours
        if not (staging / STAGING_MARKER).is_file():
            raise RunDirError(f"{staging}: exists and was not made by this tool; move it away to analyse the run")
        shutil.rmtree(staging)
    staging.mkdir()
    (staging / STAGING_MARKER).write_text("brittle-driver analysis staging\n")
    try:
        for entry in run_dir.iterdir():
            if entry.name in (*_STAGED, *_REPORTS, STAGING, MARKER, LOCK, STATUS):
                continue
            (staging / entry.name).symlink_to(entry)
        for name in _STAGED:
            (staging / name).mkdir()
            if (run_dir / name).is_dir():  # earlier results, and anything a user put there
                for f in (run_dir / name).iterdir():
                    if f.is_dir() and not f.is_symlink():
                        shutil.copytree(f, staging / name / f.name, symlinks=True)
                    elif f.name != "summary.json":
                        shutil.copy2(f, staging / name / f.name, follow_symlinks=False)
        summary = _analyse(staging, cfg, completeness)
        atomic_write_json(staging / "results" / "summary.json", {"name": cfg["name"], **summary})
        # swap in: plots and reports first, the results (holding summary.json) last; a stop
        # signal waits for the end of the swap, so it never leaves a run without results
        with deferred_signals():
            for name in ("plots", *_REPORTS, "results"):
                new, old = staging / name, run_dir / name
                if old.is_dir():
                    os.replace(old, staging / f"{name}.old")
                elif not new.exists():
                    old.unlink(missing_ok=True)
                if new.exists():
                    os.replace(new, old)
        return summary
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _analyse(run_dir: Path, cfg: dict, completeness: RunCompleteness) -> dict:
    scenario = unit_of(cfg)
    summary = scenario.analyse(run_dir, cfg, cfg["output"]["plots"], completeness)
    if (run_dir / "breaks.dat").exists():  # runs made before the break log have none
        from analysis.breaks import write_break_table  # noqa: PLC0415

        events = write_break_table(run_dir)
        summary["break_events"] = {kind: int(n) for kind, n in events["kind"].value_counts().sort_index().items()}
    if cfg["output"].get("animation"):
        animate(run_dir, cfg)
    return summary


def animate(run_dir: Path, cfg: dict) -> Path | None:
    """plots/fragmentation.gif of a run from its periodic dumps, drawn by its unit's frames
    (None when it has fewer than two periodic dumps)."""
    from analysis.animation import animate_run  # noqa: PLC0415

    prefix, draw = unit_of(cfg).frame
    return animate_run(run_dir, cfg, prefix, draw)
