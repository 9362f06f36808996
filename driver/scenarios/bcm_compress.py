"""A bed of BCM grains in confined compression (issue 25): the unit of the (bcm, compress) pair.
Its section is the shared `compress` one (driver/scenarios/sections.py, CompressScenario); the
grains come from model.assembly. The system and input are built by driver/bcm/compress.py, the
run analysed by analysis/bed_run.py."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from driver.scenarios.api import Scenario
from driver.scenarios.sections import CompressScenario

if TYPE_CHECKING:
    from analysis.completeness import RunCompleteness


def _build(cfg, rd, plugin):
    from driver.bcm.compress import run_compress  # noqa: PLC0415

    return run_compress(cfg, rd, plugin)


def _progress(cfg, system):
    from driver.bcm.compress import progress_spec  # noqa: PLC0415

    return progress_spec(cfg, system)


def _estimate(cfg, ranks):
    from driver.size_model import bcm_compress  # noqa: PLC0415

    return bcm_compress(cfg, ranks)


def _analyse(run_dir: Path, cfg: dict, plots: bool, completeness: RunCompleteness) -> dict:
    from analysis.bed_run import BcmBedAnalysis  # noqa: PLC0415

    return BcmBedAnalysis(run_dir, cfg, plots, completeness).run()


def _set_params(cfg: dict) -> dict:
    model, scen = cfg["model"], cfg["scenario"]
    return {"G_c": float(model["interface"]["G_c"]), "platen_speed": float(scen["platen_speed"]),
            "seed": cfg.get("seed"), "n_cells": model.get("n_cells"), "n_grains": model["assembly"]["n_grains"]}


def _analyse_set(runs: list[dict], out: Path, plots: bool, left_out: list[dict], options: dict) -> dict:
    from analysis.bed_run import analyse_bed_set  # noqa: PLC0415

    return analyse_bed_set(runs, out, plots, left_out=left_out)


def _frame(run_dir: Path, cfg: dict, step: int, png: Path) -> None:
    from analysis.animation import cells_frame  # noqa: PLC0415

    cells_frame(run_dir, cfg, step, png)


def _elements(cfg) -> int:
    return cfg.model.n_cells * cfg.model.assembly.n_grains


def _check(cfg) -> None:
    if cfg.model.assembly is None:
        raise ValueError("scenario compress needs model.assembly (the bed: n_grains, sizes, box)")
    if cfg.scenario.target_stress <= cfg.scenario.start_stress:
        raise ValueError(f"scenario.target_stress = {cfg.scenario.target_stress:g} Pa must exceed "
                         f"scenario.start_stress = {cfg.scenario.start_stress:g} Pa")
    if cfg.output.animation and cfg.scenario.dump_every == 0:
        raise ValueError("output.animation needs periodic dumps: set scenario.dump_every > 0 (steps between "
                         "dumps), or animation: false")


def _work(cfg) -> float:
    return cfg.model.assembly.n_grains / cfg.scenario.platen_speed


UNIT = Scenario(
    model="bcm", scenario="compress", section=CompressScenario,
    description="a bed of BCM grains in a rigid box, compressed by its top platen (issue 25)",
    build=_build, progress=_progress, estimate=_estimate, analyse=_analyse, set_params=_set_params,
    analyse_set=_analyse_set, frame=("cells", _frame), elements=_elements, result_tables=("compress",),
    check=_check, work=_work)
