"""The `driver` command: run, validate, post, scaling, sweep, plugins."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Optional

import typer
from rich.console import Console

from driver.config import ConfigError, load_config
from driver.engine import LammpsError
from driver.plugin_build import PluginBuildError
from driver.rundir import RunDirError

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="Brittle particle fracture on LAMMPS (BCM and BPM models).")
err = Console(stderr=True, soft_wrap=True)  # paths in messages stay on one line


def _fail(msg: str, code: int) -> None:
    err.print(f"[bold red]error:[/] {msg}", highlight=False, markup=True, soft_wrap=True)
    raise typer.Exit(code)


@app.command()
def run(input_yaml: Path = typer.Argument(..., help="run configuration (YAML)"),
        np: Optional[int] = typer.Option(None, "--np", min=1, help="MPI ranks (overrides execution.np)"),
        force: bool = typer.Option(False, "--force", help="overwrite a finished run directory"),
        quiet: bool = typer.Option(False, "--quiet", help="no progress bar")) -> None:
    """Build the system, run it in LAMMPS, and write results to the run directory."""
    from driver.pipeline import execute  # noqa: PLC0415

    try:
        cfg = load_config(input_yaml)
        out = execute(cfg, source=input_yaml, force=force, np_ranks=np, show_progress=not quiet, console=err)
    except ConfigError as exc:
        _fail(str(exc), 2)
    except RunDirError as exc:
        _fail(str(exc), 2)
    except PluginBuildError as exc:
        _fail(str(exc), 3)
    except LammpsError as exc:
        _fail(f"LAMMPS: {exc}", 1)
    summary = json.loads((out / "results" / "summary.json").read_text())
    err.print(f"[green]finished:[/] {out}")
    typer.echo(json.dumps(summary, indent=2))


@app.command()
def validate(input_yaml: Path = typer.Argument(..., help="run configuration (YAML)")) -> None:
    """Check a configuration without running or writing anything."""
    try:
        cfg = load_config(input_yaml)
    except ConfigError as exc:
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
            cfg = load_resolved(run_dir)
            cfg["output"]["plots"] = plots
            if thresholds is not None:
                cfg["output"]["count_above"] = thresholds
            animate = animate or cfg["output"].get("animation", False)
            cfg["output"]["animation"] = False  # made below, with a message
            from driver.rundir import is_finished  # noqa: PLC0415

            unfinished = not is_finished(run_dir)
            if unfinished:
                err.print(f"[yellow]{run_dir} did not finish (status.json): analysing the snapshots it has")
            summary = analyse_run(run_dir, cfg, partial=unfinished)
            for msg in summary.get("warnings", []):
                err.print(f"[yellow]warning:[/] {msg}")
            if animate:
                from analysis.animation import animate_run  # noqa: PLC0415

                gif = animate_run(run_dir)
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
            plots: bool = typer.Option(True, "--plots/--no-plots")) -> None:
    """Scaling analysis of a set of finished runs: exponents, collapses, crossovers, report."""
    from analysis.runset import RunSetError, analyse_set  # noqa: PLC0415

    if out is None:
        if len(paths) == 1 and not (paths[0] / "config.resolved.yaml").exists():
            out = paths[0]
        else:
            _fail("--out is needed unless one directory of runs is named", 2)
    try:
        result = analyse_set(paths, out, plots=plots, strain=strain, n_bootstrap=bootstrap)
    except RunSetError as exc:
        _fail(str(exc), 2)
    err.print(f"[green]set analysed:[/] {out}/report.html")
    typer.echo(json.dumps(result, indent=2, default=str))


@app.command()
def sweep(input_yaml: Path = typer.Argument(..., help="base configuration (YAML)"),
          set_: list[str] = typer.Option(..., "--set", help="KEY.PATH=V1,V2,... (repeat for a grid)"),
          out: Optional[Path] = typer.Option(None, "--out", help="sweep directory (default runs/<name>_sweep)"),
          np: Optional[int] = typer.Option(None, "--np", min=1, help="MPI ranks per run"),
          columns: str = typer.Option("", "--columns", help="comma-separated summary columns to print")) -> None:
    """Run a config over a grid of values; finished runs are kept (a re-run resumes)."""
    import yaml  # noqa: PLC0415
    from rich.table import Table  # noqa: PLC0415

    from analysis.tables import save_table  # noqa: PLC0415
    from driver.pipeline import execute  # noqa: PLC0415
    from driver.sweep import expand, parse_assignment, pending, sweep_table  # noqa: PLC0415

    try:
        base_cfg = load_config(input_yaml)  # the base itself must be valid
        base = yaml.safe_load(input_yaml.read_text())
        sweep_dir = out or Path("runs") / f"{base_cfg.name}_sweep"
        runs = expand(base, [parse_assignment(a) for a in set_], sweep_dir, str(input_yaml))
    except ConfigError as exc:
        _fail(str(exc), 2)
    todo = pending(runs)
    err.print(f"sweep: {len(runs)} runs, {len(runs) - len(todo)} already finished, in {sweep_dir}")
    for values, cfg in todo:
        err.print(f"[bold]run[/] {values}")
        try:
            execute(cfg, np_ranks=np, show_progress=True, console=err)
        except Exception as exc:  # noqa: BLE001 - one failed run must not stop the sweep
            err.print(f"[red]failed[/] {values}: {type(exc).__name__}: {exc} (see {cfg.run_dir()}/status.json)")
    table = sweep_table(runs)
    save_table(table, sweep_dir / "sweep")
    if len(table):
        from analysis.runset import RunSetError, analyse_set  # noqa: PLC0415

        try:
            analyse_set([cfg.run_dir() for _, cfg in runs if cfg.run_dir().exists()], sweep_dir)
            err.print(f"set report: {sweep_dir}/report.html")
        except (RunSetError, ValueError) as exc:
            err.print(f"[yellow]no set analysis: {exc}")
    shown = [c for c in columns.split(",") if c] or list(table.columns)
    rt = Table(*shown)
    for _, row in table.iterrows():
        rt.add_row(*(f"{row[c]:.4g}" if isinstance(row[c], float) else str(row[c]) for c in shown))
    Console(width=max(120, Console().width)).print(rt)


@app.command()
def plugins(verbose: bool = typer.Option(False, "--verbose")) -> None:
    """Build (if needed) the LAMMPS plugin library and print its path."""
    from driver.plugin_build import plugin_library  # noqa: PLC0415

    try:
        typer.echo(str(plugin_library(verbose=verbose)))
    except PluginBuildError as exc:
        _fail(str(exc), 3)


def main() -> None:  # pragma: no cover
    app(prog_name="driver")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
