"""`driver run`: config -> run directory -> LAMMPS -> results, with provenance and status."""

from __future__ import annotations

import shutil
import time
from pathlib import Path

import yaml
from rich.console import Console

from driver.config import RunConfig, resolved_yaml
from driver.plugin_build import plugin_library
from driver.rundir import RunDir, atomic_write_json, atomic_write_text, provenance


def execute(cfg: RunConfig, source: Path | None = None, force: bool = False, np_ranks: int | None = None,
            show_progress: bool = True, console: Console | None = None) -> Path:
    """Run one validated config to completion; returns the run directory."""
    console = console or Console(stderr=True)
    ranks = np_ranks or cfg.execution.np
    plugin = plugin_library()  # before touching the run dir: a build failure leaves nothing behind
    rd = RunDir(cfg.run_dir())
    action = rd.prepare(force=force)
    if action == "cleared":
        console.print(f"[yellow]{rd.root}: previous contents removed, starting clean")
    if source is not None:
        shutil.copy2(source, rd.root / "input.yaml")
    atomic_write_text(rd.root / "config.resolved.yaml", resolved_yaml(cfg))
    t0 = time.time()
    prov = provenance({"config_name": cfg.name, "seed": cfg.seed, "mpi_ranks": ranks,
                       "plugin_library": str(plugin), "plugin_build_hash": plugin.parent.name,
                       "started": time.strftime("%Y-%m-%dT%H:%M:%S")})
    atomic_write_json(rd.root / "provenance.json", prov)
    try:
        if cfg.scenario.kind == "shear":
            from driver.scenarios.shear import run_shear as run_scenario  # noqa: PLC0415
        else:
            from driver.scenarios.impact import run_impact as run_scenario  # noqa: PLC0415
        facts = run_scenario(cfg, rd, plugin, ranks, show_progress)
        analyse_run(rd.root, cfg.model_dump(mode="json"))
    except BaseException as exc:
        rd.set_state("failed", error=f"{type(exc).__name__}: {exc}")
        raise
    prov["wall_seconds"] = time.time() - t0
    prov["lammps_wall_seconds"] = facts.get("lammps_wall_seconds")
    atomic_write_json(rd.root / "provenance.json", prov)
    rd.set_state("finished")
    return rd.root


def load_resolved(run_dir: Path) -> dict:
    return yaml.safe_load((Path(run_dir) / "config.resolved.yaml").read_text())


def analyse_run(run_dir: Path, cfg: dict, partial: bool = False) -> dict:
    """The analysis of a run directory for its scenario: what `driver run` ends with and
    `driver post` repeats; writes results/summary.json and returns the summary. partial: the
    run did not finish; analyse the snapshots it left (shear runs)."""
    # The summary is what a set analysis reads of a run: removed first and written last, so
    # that an analysis that fails half way leaves no summary beside its new tables.
    (Path(run_dir) / "results" / "summary.json").unlink(missing_ok=True)
    if cfg["scenario"]["kind"] == "shear":
        from analysis.shear import analyse_shear  # noqa: PLC0415

        summary = analyse_shear(run_dir, cfg, plots=cfg["output"]["plots"], partial=partial)
    else:
        from analysis.impact import analyse_impact  # noqa: PLC0415

        summary = analyse_impact(run_dir, cfg, plots=cfg["output"]["plots"])
    if cfg["output"].get("animation"):
        from analysis.animation import animate_run  # noqa: PLC0415

        animate_run(run_dir)
    # written here, so that `driver post` refreshes the summary a set analysis reads
    atomic_write_json(Path(run_dir) / "results" / "summary.json", {"name": cfg["name"], **summary})
    return summary
