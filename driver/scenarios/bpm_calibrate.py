"""BPM calibration tests (SPEC 2.3): the `calibrate` scenario section and the unit of the
(bpm, calibrate) pair. Test `moduli`: B, G, E and nu of the network (driver/bpm/moduli.py
builds and deforms it, analysis/moduli.py fits); a set of such runs over k_A gives the
calibration curves. The fracture tests (mode1, mode2, crack_speed) are not available yet."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import Field

from driver.registry import Scenario
from driver.schema import _Strict


class CalibrateScenario(_Strict):
    """A calibration test of the model's material (SPEC 2.3)."""

    kind: Literal["calibrate"] = "calibrate"
    test: Literal["moduli"] = Field("moduli", description="moduli: B, G, E, nu by compression and simple shear "
                                                          "at strain_rate, then at half of it (the rate check)")
    strain_rate: float = Field(1e-4, gt=0.0, le=0.1, description="true strain rate of the compression, shear "
                                                                 "rate of the shear phases, units 1/tau")
    max_strain: float = Field(0.005, gt=0.0, le=0.02, description="largest volumetric (compression) or shear "
                                                                  "strain of a phase; the fit range")
    thermo_every: int = Field(50, ge=1, description="steps between stress records")
    dump_every: Literal[0] = Field(0, description="no periodic dumps in a calibration test")


def _build(cfg, rd, plugin):
    from driver.bpm.moduli import run_moduli  # noqa: PLC0415

    return run_moduli(cfg, rd, plugin)


def _progress(cfg, system):
    from driver.bpm.moduli import progress_spec  # noqa: PLC0415

    return progress_spec(cfg, system)


def _estimate(cfg, ranks):
    from driver.bpm.moduli import phases  # noqa: PLC0415
    from driver.estimate import bpm_size  # noqa: PLC0415

    steps = phases(cfg.model.dimension, cfg.scenario.strain_rate, cfg.scenario.max_strain, cfg.model.timestep)[-1].end
    return bpm_size(cfg, ranks, steps)


def _analyse(run_dir: Path, cfg: dict, plots: bool, partial: bool) -> dict:
    from analysis.moduli import analyse_moduli  # noqa: PLC0415

    return analyse_moduli(run_dir, cfg, plots=plots, partial=partial)


def _set_params(cfg: dict) -> dict:
    m = cfg["model"]
    return {"dimension": m["dimension"], "L": float(m["L"]), "k_A": float(m["k_A"]), "seed": cfg.get("seed"),
            "strain_rate": float(cfg["scenario"]["strain_rate"])}


def _analyse_set(runs: list[dict], out: Path, plots: bool, left_out: list[dict], options: dict) -> dict:
    from analysis.moduli import analyse_moduli_set  # noqa: PLC0415

    return analyse_moduli_set(runs, out, plots, left_out=left_out)


def _frame(run_dir: Path, cfg: dict, step: int, png: Path) -> None:
    raise ValueError("a calibration test writes no periodic dumps to animate")


def _elements(cfg) -> int:
    from driver.bpm.packing import particle_count  # noqa: PLC0415

    return particle_count(cfg.model.dimension, cfg.model.L, cfg.model.packing_fraction)


def _check(cfg) -> None:
    if cfg.output.animation:
        raise ValueError("output.animation: a calibration test writes no periodic dumps")
    if cfg.scenario.max_strain >= cfg.model.lambda_c - 1.0:
        raise ValueError(f"scenario.max_strain = {cfg.scenario.max_strain:g} reaches the bond break stretch "
                         f"lambda_c - 1 = {cfg.model.lambda_c - 1:g}: not an elastic test")


UNIT = Scenario(
    model="bpm", scenario="calibrate", section=CalibrateScenario,
    description="a BPM calibration test: moduli (SPEC 2.3)",
    build=_build, progress=_progress, estimate=_estimate, analyse=_analyse, set_params=_set_params,
    analyse_set=_analyse_set, frame=("atoms", _frame), elements=_elements, result_tables=("moduli_phases",),
    check=_check)
