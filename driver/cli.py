"""The `driver` command: run, validate, post, plugins."""

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
err = Console(stderr=True)


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
def post(run_dir: Path = typer.Argument(..., help="run directory of an earlier `driver run`")) -> None:
    """Recompute tables and plots of a run directory from its dumps (no LAMMPS)."""
    from driver.pipeline import analyse_run, load_resolved  # noqa: PLC0415

    if not (run_dir / "config.resolved.yaml").exists():
        _fail(f"{run_dir}: not a run directory (no config.resolved.yaml)", 2)
    summary = analyse_run(run_dir, load_resolved(run_dir))
    typer.echo(json.dumps(summary, indent=2))


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
        except LammpsError as exc:
            err.print(f"[red]failed[/] {values}: {exc}")
    table = sweep_table(runs)
    save_table(table, sweep_dir / "sweep")
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
