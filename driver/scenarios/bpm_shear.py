"""BPM shear fragmentation (SPEC 2.4): the `shear` scenario section and the unit of the
(bpm, shear) pair. The system and input are built by driver/bpm/shear.py, the run analysed
by analysis/shear.py, a set by analysis/runset.py (imported when used: a config is validated
without them)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Literal

from pydantic import Field, model_validator

from driver.scenarios.api import Scenario
from driver.schema import _Strict

if TYPE_CHECKING:
    from analysis.completeness import RunCompleteness

#: Most steps a shear run may take.
MAX_STEPS = 2e9


class ShearScenario(_Strict):
    """Constant-volume shear at a true strain rate (SPEC 2.4): 2D pure shear, 3D triaxial."""

    kind: Literal["shear"] = Field("shear", description="shear: constant-volume shear of a periodic solid")
    strain_rate: float = Field(1e-3, gt=0.0, le=0.1, description="true strain rate edot, units 1/tau")
    max_strain: float = Field(1.0, gt=0.0, le=3.0, description="final true strain eps = edot t")
    measure_strains: list[Annotated[float, Field(gt=0.0)]] = Field(
        default_factory=lambda: [0.1, 0.25, 0.5, 1.0],
        description="strains at which bond snapshots are written and grains counted")
    thermo_every: int = Field(200, ge=1, description="steps between stress/progress records")
    dump_every: int = Field(0, ge=0, description="steps between atom+bond dumps; 0 = only at measure strains")

    @model_validator(mode="after")
    def _strains_within_run(self) -> "ShearScenario":
        bad = [s for s in self.measure_strains if s > self.max_strain * (1 + 1e-12)]
        if bad:
            raise ValueError(f"measure_strains {bad} exceed max_strain = {self.max_strain}")
        if sorted(self.measure_strains) != self.measure_strains or len(set(self.measure_strains)) != len(
                self.measure_strains):
            raise ValueError("measure_strains must be strictly increasing")
        return self


def _build(cfg, rd, plugin):
    from driver.bpm.shear import run_shear  # noqa: PLC0415

    return run_shear(cfg, rd, plugin)


def _progress(cfg, system):
    from driver.bpm.shear import progress_spec  # noqa: PLC0415

    return progress_spec(cfg, system)


def _estimate(cfg, ranks):
    from driver.size_model import bpm_shear  # noqa: PLC0415

    return bpm_shear(cfg, ranks)


def _analyse(run_dir: Path, cfg: dict, plots: bool, completeness: RunCompleteness) -> dict:
    from analysis.shear import ShearAnalysis  # noqa: PLC0415

    return ShearAnalysis(run_dir, cfg, plots, completeness).run()


def _set_params(cfg: dict) -> dict:
    model, scen = cfg["model"], cfg["scenario"]
    return {"L": float(model["L"]), "edot": float(scen["strain_rate"]), "k_A": model.get("k_A"),
            "lambda_c": model.get("lambda_c"), "seed": cfg.get("seed")}


def _analyse_set(runs: list[dict], out: Path, plots: bool, left_out: list[dict], options: dict) -> dict:
    from analysis.runset import analyse_shear_set  # noqa: PLC0415

    return analyse_shear_set(runs, out, plots, options.get("strain"), options.get("n_bootstrap", 100),
                             left_out=left_out, params=_set_params)


def _frame(run_dir: Path, cfg: dict, step: int, png: Path) -> None:
    from analysis.animation import particles_frame  # noqa: PLC0415

    particles_frame(run_dir, cfg, step, png)


def _elements(cfg) -> int:
    from driver.bpm.packing import particle_count  # noqa: PLC0415

    return particle_count(cfg.model.dimension, cfg.model.L, cfg.model.packing_fraction)


def _check(cfg) -> None:
    if cfg.model.assembly is not None:
        raise ValueError("model.assembly: a bed of grains is for scenario compress; this scenario takes one "
                         "particle or sample (remove model.assembly)")
    if cfg.model.particle is not None:
        raise ValueError("model.particle describes the particle of scenario impact; remove it here")
    if cfg.output.animation and cfg.scenario.dump_every == 0:
        raise ValueError("output.animation needs periodic dumps: set scenario.dump_every > 0 (steps between "
                         "dumps), or animation: false")
    steps = cfg.scenario.max_strain / (cfg.scenario.strain_rate * cfg.model.timestep)
    if steps > MAX_STEPS:
        raise ValueError(f"max_strain / (strain_rate * timestep) = {steps:.3g} steps is beyond {MAX_STEPS:g}")


UNIT = Scenario(
    model="bpm", scenario="shear", section=ShearScenario,
    description="a periodic BPM solid sheared at constant volume until it fragments (SPEC 2.4)",
    build=_build, progress=_progress, estimate=_estimate, analyse=_analyse, set_params=_set_params,
    analyse_set=_analyse_set, frame=("atoms", _frame), elements=_elements, result_tables=("frames", "nm", "grains"), check=_check)
