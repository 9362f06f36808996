"""BCM particle impact on a rigid plane (SPEC 1.4): the unit of the (bcm, impact) pair. Its
section is the shared `impact` one (driver/scenarios/sections.py, ImpactScenario). The system
and input are built by driver/bcm/impact.py, the run analysed by analysis/bcm_impact.py, a set by
analysis/runset.py (imported when used: a config is validated without them)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from driver.scenarios.api import Scenario
from driver.scenarios.sections import ImpactScenario

if TYPE_CHECKING:
    from analysis.completeness import RunCompleteness


def _build(cfg, rd, plugin):
    from driver.bcm.impact import run_impact  # noqa: PLC0415

    return run_impact(cfg, rd, plugin)


def _progress(cfg, system):
    from driver.bcm.impact import progress_spec  # noqa: PLC0415

    return progress_spec(cfg, system)


def _estimate(cfg, ranks):
    from driver.size_model import bcm_impact  # noqa: PLC0415

    return bcm_impact(cfg, ranks)


def _analyse(run_dir: Path, cfg: dict, plots: bool, completeness: RunCompleteness) -> dict:
    from analysis.bcm_impact import BcmImpactAnalysis  # noqa: PLC0415

    return BcmImpactAnalysis(run_dir, cfg, plots, completeness).run()


def _set_params(cfg: dict) -> dict:
    model, scen = cfg["model"], cfg["scenario"]
    return {"G_c": float(model["interface"]["G_c"]), "velocity": float(scen["velocity"]), "seed": cfg.get("seed"),
            "n_cells": model.get("n_cells")}


def _analyse_set(runs: list[dict], out: Path, plots: bool, left_out: list[dict], options: dict) -> dict:
    from analysis.runset import BREAKUP_FRACTION, analyse_impact_set  # noqa: PLC0415

    return analyse_impact_set(runs, out, plots, left_out=left_out, params=_set_params,
                              breakup_fraction=options.get("breakup_fraction") or BREAKUP_FRACTION)


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
    # a particle that breaks more has more contacts and settles later: 3 s at 0.5 m/s to 42 s
    # at 6.5 m/s in the 300-cell study (runs/bcm_impact_study_small)
    return cfg.scenario.velocity ** 2 / cfg.model.interface.G_c


UNIT = Scenario(
    model="bcm", scenario="impact", section=ImpactScenario,
    description="a BCM particle hits a rigid plane (SPEC 1.4)",
    build=_build, progress=_progress, estimate=_estimate, analyse=_analyse, set_params=_set_params,
    analyse_set=_analyse_set, frame=("cells", _frame), elements=_elements, result_tables=("fragments",), check=_check, work=_work)
