"""BCM particle impact on a rigid plane (SPEC 1.4): the `impact` scenario section and the unit
of the (bcm, impact) pair. The system and input are built by driver/bcm/impact.py, the run
analysed by analysis/impact.py, a set by analysis/runset.py (imported when used: a config is
validated without them)."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import Field, field_validator

from driver.bcm.section import check_steps_per_period
from driver.registry import Scenario
from driver.schema import _Strict


class ImpactScenario(_Strict):
    """One particle hits a rigid plane (SPEC 1.4)."""

    kind: Literal["impact"] = Field("impact", description="impact: one particle hits a rigid plane")
    velocity: float = Field(4.5, gt=0.0, le=100.0, description="impact velocity v_0 normal to the plane, m/s")
    gap: float = Field(1e-3, ge=0.0, lt=1.0, description="initial gap to the plane, fraction of the diameter")
    # below 12 refused (check_steps_per_period). 50 by the time-step study (bench/timestep_study.py,
    # docs/models/bcm-timestep.md): the largest value whose run energy balance stays below 1e-4 with a
    # margin of 2 in every case measured (a 100-cell particle at 10 m/s: 1.1e-4 at 30, 8.6e-5 at
    # 40, 4.1e-5 at 50), the outcome within the 100-step reference's seed-to-seed spread
    steps_per_period: float = Field(50.0, gt=0.0, description="time step = shortest contact period / this")
    max_time: float = Field(5e-4, gt=0.0, description="hard stop on simulated time, s")
    settle_window: float = Field(5e-6, gt=0.0, description="window over which the outcome must not change, s")
    ke_tolerance: float = Field(1e-3, gt=0.0, lt=1.0,
                                description="settled when kinetic energy changes by less than this fraction "
                                            "over a window with no break and the plane unloaded")
    thermo_every: int = Field(10, ge=1, description="steps between energy records: 10 samples a 2 µs contact "
                                                   "at 50 points or more for time steps up to 4e-9 s")
    dump_every: int = Field(0, ge=0, description="steps between cell dumps; 0 = start and end only")

    _stable = field_validator("steps_per_period")(check_steps_per_period)


def _build(cfg, rd, plugin):
    from driver.bcm.impact import run_impact  # noqa: PLC0415

    return run_impact(cfg, rd, plugin)


def _progress(cfg, system):
    from driver.bcm.impact import progress_spec  # noqa: PLC0415

    return progress_spec(cfg, system)


def _estimate(cfg, ranks):
    from driver.estimate import bcm_impact  # noqa: PLC0415

    return bcm_impact(cfg, ranks)


def _analyse(run_dir: Path, cfg: dict, plots: bool, partial: bool) -> dict:
    from analysis.impact import analyse_impact  # noqa: PLC0415

    return analyse_impact(run_dir, cfg, plots=plots, partial=partial)


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
