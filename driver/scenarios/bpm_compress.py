"""A bed of BPM grains in confined compression (issue 25): the unit of the (bpm, compress) pair.
Its section is the shared `compress` one (driver/scenarios/sections.py, CompressScenario); the
grains come from model.assembly, each a particle of model.particle (shape, units, the walls'
contact) at its own diameter. Built by driver/bpm/compress.py, analysed by analysis/bed_run.py
(`BpmBedAnalysis`)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from driver.scenarios.api import Scenario
from driver.scenarios.sections import CompressScenario

if TYPE_CHECKING:
    from analysis.completeness import RunCompleteness


def _build(cfg, rd, plugin):
    from driver.bpm.compress import run_compress  # noqa: PLC0415

    return run_compress(cfg, rd, plugin)


def _progress(cfg, system):
    from driver.bpm.compress import progress_spec  # noqa: PLC0415

    return progress_spec(cfg, system)


def _particles(cfg) -> int:
    """Particles of the bed: each grain's as the BPM particle's (driver/scenarios/bpm_crush.py),
    at the mean of the sizes' law (a list's mean, or the bounds' midpoint)."""
    import math  # noqa: PLC0415

    from driver.bcm.particle import parent_shape  # noqa: PLC0415

    p, sizes = cfg.model.particle, cfg.model.assembly.sizes
    d = sum(sizes.values) / len(sizes.values) if sizes.kind == "list" else 0.5 * (sizes.min + sizes.max)
    volume = parent_shape(p.shape, d / p.units.length_a_m, p.diameter_kind).volume
    return max(2, int(round(6.0 * cfg.model.packing_fraction / math.pi * volume))) * cfg.model.assembly.n_grains


def _estimate(cfg, ranks):
    from driver.size_model import bpm_compress  # noqa: PLC0415

    return bpm_compress(cfg, ranks, _particles(cfg))


def _analyse(run_dir: Path, cfg: dict, plots: bool, completeness: RunCompleteness) -> dict:
    from analysis.bed_run import BpmBedAnalysis  # noqa: PLC0415

    return BpmBedAnalysis(run_dir, cfg, plots, completeness).run()


def _set_params(cfg: dict) -> dict:
    model, scen = cfg["model"], cfg["scenario"]
    return {"k_A": float(model["k_A"]), "lambda_c": float(model["lambda_c"]),
            "platen_speed": float(scen["platen_speed"]), "seed": cfg.get("seed"),
            "n_grains": model["assembly"]["n_grains"]}


def _analyse_set(runs: list[dict], out: Path, plots: bool, left_out: list[dict], options: dict) -> dict:
    from analysis.bed_run import analyse_bed_set  # noqa: PLC0415

    return analyse_bed_set(runs, out, plots, left_out=left_out)


def _frame(run_dir: Path, cfg: dict, step: int, png: Path) -> None:
    raise ValueError("animations of a BPM bed are not available yet")


def _check(cfg) -> None:
    from driver.bpm.particle_section import BPMParticle  # noqa: PLC0415

    if cfg.model.dimension != 3:
        raise ValueError("scenario compress with model bpm: a BPM grain is 3D only (model.dimension: 3)")
    if cfg.model.assembly is None:
        raise ValueError("scenario compress needs model.assembly (the bed: n_grains, sizes, box)")
    if cfg.model.particle is None:
        cfg.model.particle = BPMParticle()  # config.resolved.yaml holds every value the run uses
    if cfg.scenario.target_stress <= cfg.scenario.start_stress:
        raise ValueError(f"scenario.target_stress = {cfg.scenario.target_stress:g} Pa must exceed "
                         f"scenario.start_stress = {cfg.scenario.start_stress:g} Pa")
    if cfg.scenario.fill_friction != 0.0:
        raise ValueError(f"scenario.fill_friction = {cfg.scenario.fill_friction:g}: the BCM's cell-contact friction; "
                         "BPM particles meet through the frictionless repulsion (leave it out, or 0)")
    if cfg.output.animation:
        raise ValueError("output.animation: not available for a BPM bed")


def _work(cfg) -> float:
    return cfg.model.assembly.n_grains / cfg.scenario.platen_speed


UNIT = Scenario(
    model="bpm", scenario="compress", section=CompressScenario,
    description="a bed of BPM grains (packings clipped to the parent, bonded inside each grain) in a rigid box, "
                "compressed by its top platen (issue 25)",
    build=_build, progress=_progress, estimate=_estimate, analyse=_analyse, set_params=_set_params,
    analyse_set=_analyse_set, frame=("atoms", _frame), elements=_particles, result_tables=("compress",),
    check=_check, work=_work)
