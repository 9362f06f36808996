"""BPM particle impact on a rigid plane (SPEC 1.4, 3): the unit of the (bpm, impact) pair.

The scenario section is the shared `impact` one (driver/scenarios/sections.py, ImpactScenario:
velocity, gap, times in SI, the same settle rule as the BCM's); the particle is model.particle
(driver/bpm/particle_section.py: parent shape and size, SI units, plane contact, G_c). Built by
driver/bpm/impact.py, analysed by analysis/bpm_impact.py, a set by analysis/runset.py (as the
BCM impact's)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

from driver.scenarios.api import Scenario
from driver.scenarios.sections import ImpactScenario

if TYPE_CHECKING:
    from analysis.completeness import RunCompleteness


def _build(cfg, rd, plugin):
    from driver.bpm.impact import run_impact  # noqa: PLC0415

    return run_impact(cfg, rd, plugin)


def _progress(cfg, system):
    from driver.bpm.impact import progress_spec  # noqa: PLC0415

    return progress_spec(cfg, system)


def _particles(cfg) -> int:
    """Expected particles: the packing's number density 6 phi / pi times the parent's volume in a^3."""
    from driver.bcm.particle import parent_shape  # noqa: PLC0415

    p = cfg.model.particle
    volume = parent_shape(p.shape, p.diameter / p.units.length_a_m, p.diameter_kind).volume
    return max(2, int(round(6.0 * cfg.model.packing_fraction / math.pi * volume)))


def _estimate(cfg, ranks):
    from driver.bpm.impact import lj_units, plane_law  # noqa: PLC0415
    from driver.size_model import (BPM_ANGLES_PER_PARTICLE, BPM_BONDS_PER_PARTICLE, BPM_MEMORY_BASE,  # noqa: PLC0415
                                 BPM_MEMORY_PER_PARTICLE, BPM_SECONDS_PER_PARTICLE, SizeEstimate, _ranks_memory)

    p, sc, m = cfg.model.particle, cfg.scenario, cfg.model
    n = _particles(cfg)
    un = lj_units(p.units)
    dt = min(m.timestep, plane_law(p.contact, un)["period"] / sc.steps_per_period)
    bonds, angles = int(round(BPM_BONDS_PER_PARTICLE[3] * n)), int(round(BPM_ANGLES_PER_PARTICLE[3] * n))
    return SizeEstimate(
        model="BPM 3D particle", elements=n, element_name="particles", bonds=bonds + angles,
        bond_name=f"bonds + angles ({bonds:,} + {angles:,})",
        memory_bytes=int(BPM_MEMORY_BASE[3] + _ranks_memory(ranks) + BPM_MEMORY_PER_PARTICLE[3] * n),
        seconds_per_1000_steps=BPM_SECONDS_PER_PARTICLE[3] * n / ranks,
        steps=int(math.ceil(sc.max_time / un["tau"] / dt)), ranks=ranks)


def _analyse(run_dir: Path, cfg: dict, plots: bool, completeness: RunCompleteness) -> dict:
    from analysis.bpm_impact import BpmImpactAnalysis  # noqa: PLC0415

    return BpmImpactAnalysis(run_dir, cfg, plots, completeness).run()


def _set_params(cfg: dict) -> dict:
    model, scen = cfg["model"], cfg["scenario"]
    return {"G_c": float(model["particle"]["G_c"]), "velocity": float(scen["velocity"]), "seed": cfg.get("seed"),
            "k_A": float(model["k_A"]), "lambda_c": float(model["lambda_c"])}


def _analyse_set(runs: list[dict], out: Path, plots: bool, left_out: list[dict], options: dict) -> dict:
    from analysis.runset import BREAKUP_FRACTION, analyse_impact_set  # noqa: PLC0415

    return analyse_impact_set(runs, out, plots, left_out=left_out, params=_set_params,
                              breakup_fraction=options.get("breakup_fraction") or BREAKUP_FRACTION)


def _frame(run_dir: Path, cfg: dict, step: int, png: Path) -> None:
    raise ValueError("animations of a BPM impact are not available yet")


def _check(cfg) -> None:
    from driver.bpm.particle_section import BPMParticle  # noqa: PLC0415

    if cfg.model.assembly is not None:
        raise ValueError("model.assembly: a bed of grains is for scenario compress; this scenario takes one "
                         "particle or sample (remove model.assembly)")
    if cfg.model.dimension != 3:
        raise ValueError("scenario impact with model bpm: a BPM particle is 3D only (model.dimension: 3)")
    if cfg.model.particle is None:
        cfg.model.particle = BPMParticle()  # config.resolved.yaml holds every value the run uses
    if cfg.output.animation:
        raise ValueError("output.animation: not available for a BPM impact")


def _work(cfg) -> float:
    return cfg.scenario.velocity ** 2 / cfg.model.particle.G_c


UNIT = Scenario(
    model="bpm", scenario="impact", section=ImpactScenario,
    description="a BPM particle (a packing clipped to the BCM parent) hits a rigid plane (SPEC 1.4, 3)",
    build=_build, progress=_progress, estimate=_estimate, analyse=_analyse, set_params=_set_params,
    analyse_set=_analyse_set, frame=("atoms", _frame), elements=_particles, result_tables=("fragments",),
    check=_check, work=_work)
