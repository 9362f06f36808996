"""BCM particle crushed between two platens (SPEC 4.1): the unit of the (bcm, crush) pair. Its
section is the shared `crush` one (driver/scenarios/sections.py, CrushScenario). The system and
input are built by driver/bcm/crush.py, the run analysed by analysis/crush.py."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from driver.scenarios.api import Scenario
from driver.scenarios.sections import CrushScenario

if TYPE_CHECKING:
    from analysis.completeness import RunCompleteness


def _build(cfg, rd, plugin):
    from driver.bcm.crush import run_crush  # noqa: PLC0415

    return run_crush(cfg, rd, plugin)


def _progress(cfg, system):
    from driver.bcm.crush import progress_spec  # noqa: PLC0415

    return progress_spec(cfg, system)


def _estimate(cfg, ranks):
    from driver.size_model import bcm_crush  # noqa: PLC0415

    return bcm_crush(cfg, ranks)


def _analyse(run_dir: Path, cfg: dict, plots: bool, completeness: RunCompleteness) -> dict:
    from analysis.crush import BcmCrushAnalysis  # noqa: PLC0415

    return BcmCrushAnalysis(run_dir, cfg, plots, completeness).run()


def _set_params(cfg: dict) -> dict:
    model, scen = cfg["model"], cfg["scenario"]
    return {"G_c": float(model["interface"]["G_c"]), "platen_speed": float(scen["platen_speed"]),
            "seed": cfg.get("seed"), "n_cells": model.get("n_cells"), "diameter": float(model["diameter"])}


def _analyse_set(runs: list[dict], out: Path, plots: bool, left_out: list[dict], options: dict) -> dict:
    from analysis.crush import analyse_crush_set  # noqa: PLC0415

    return analyse_crush_set(runs, out, plots, left_out=left_out, params=_set_params)


def _frame(run_dir: Path, cfg: dict, step: int, png: Path) -> None:
    from analysis.animation import cells_frame  # noqa: PLC0415

    cells_frame(run_dir, cfg, step, png)


def _elements(cfg) -> int:
    return cfg.model.n_cells


def _check(cfg) -> None:
    if cfg.model.assembly is not None:
        raise ValueError("model.assembly: a bed of grains is for scenario compress; this scenario takes one "
                         "particle (remove model.assembly)")
    if cfg.output.animation and cfg.scenario.dump_every == 0:
        raise ValueError("output.animation needs periodic dumps: set scenario.dump_every > 0 (steps between "
                         "dumps), or animation: false")


def _work(cfg) -> float:
    # the run lasts about the platen travel to the peak over its speed
    return 1.0 / cfg.scenario.platen_speed


UNIT = Scenario(
    model="bcm", scenario="crush", section=CrushScenario,
    description="a BCM particle crushed between a fixed and a moving platen (SPEC 4.1)",
    build=_build, progress=_progress, estimate=_estimate, analyse=_analyse, set_params=_set_params,
    analyse_set=_analyse_set, frame=("cells", _frame), elements=_elements, result_tables=("crush",),
    check=_check, work=_work)
