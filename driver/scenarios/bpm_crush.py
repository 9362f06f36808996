"""BPM particle crushed between two platens (SPEC 4.1, 3): the unit of the (bpm, crush) pair.
Its section is the shared `crush` one (driver/scenarios/sections.py, CrushScenario: speeds and
times in SI); the particle is model.particle, as for the BPM impact (driver/scenarios/
bpm_impact.py, whose size, estimate and checks this unit shares). Built by driver/bpm/crush.py,
analysed by analysis/crush.py (`BpmCrushAnalysis`)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

from driver.scenarios.api import Scenario
from driver.scenarios.sections import CrushScenario

if TYPE_CHECKING:
    from analysis.completeness import RunCompleteness


def _build(cfg, rd, plugin):
    from driver.bpm.crush import run_crush  # noqa: PLC0415

    return run_crush(cfg, rd, plugin)


def _progress(cfg, system):
    from driver.bpm.crush import progress_spec  # noqa: PLC0415

    return progress_spec(cfg, system)


def _particles(cfg) -> int:
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
    t_end = min(sc.max_time, sc.max_strain * p.diameter / sc.platen_speed)
    bonds, angles = int(round(BPM_BONDS_PER_PARTICLE[3] * n)), int(round(BPM_ANGLES_PER_PARTICLE[3] * n))
    return SizeEstimate(
        model="BPM 3D particle", elements=n, element_name="particles", bonds=bonds + angles,
        bond_name=f"bonds + angles ({bonds:,} + {angles:,})",
        memory_bytes=int(BPM_MEMORY_BASE[3] + _ranks_memory(ranks) + BPM_MEMORY_PER_PARTICLE[3] * n),
        seconds_per_1000_steps=BPM_SECONDS_PER_PARTICLE[3] * n / ranks,
        steps=int(math.ceil(t_end / un["tau"] / dt)), ranks=ranks)


def _analyse(run_dir: Path, cfg: dict, plots: bool, completeness: RunCompleteness) -> dict:
    from analysis.crush import BpmCrushAnalysis  # noqa: PLC0415

    return BpmCrushAnalysis(run_dir, cfg, plots, completeness).run()


def _set_params(cfg: dict) -> dict:
    model, scen = cfg["model"], cfg["scenario"]
    return {"platen_speed": float(scen["platen_speed"]), "seed": cfg.get("seed"), "k_A": float(model["k_A"]),
            "lambda_c": float(model["lambda_c"]), "diameter": float(model["particle"]["diameter"])}


def _analyse_set(runs: list[dict], out: Path, plots: bool, left_out: list[dict], options: dict) -> dict:
    from analysis.crush import analyse_crush_set  # noqa: PLC0415

    return analyse_crush_set(runs, out, plots, left_out=left_out, params=_set_params)


def _frame(run_dir: Path, cfg: dict, step: int, png: Path) -> None:
    raise ValueError("animations of a BPM crush are not available yet")


def _check(cfg) -> None:
    from driver.bpm.particle_section import BPMParticle  # noqa: PLC0415

    if cfg.model.assembly is not None:
        raise ValueError("model.assembly: a bed of grains is for scenario compress; this scenario takes one "
                         "particle or sample (remove model.assembly)")
    if cfg.model.dimension != 3:
        raise ValueError("scenario crush with model bpm: a BPM particle is 3D only (model.dimension: 3)")
    if cfg.model.particle is None:
        cfg.model.particle = BPMParticle()  # config.resolved.yaml holds every value the run uses
    if cfg.output.animation:
        raise ValueError("output.animation: not available for a BPM crush")


def _work(cfg) -> float:
    return 1.0 / cfg.scenario.platen_speed


UNIT = Scenario(
    model="bpm", scenario="crush", section=CrushScenario,
    description="a BPM particle (a packing clipped to the BCM parent) crushed between a fixed and a moving platen "
                "(SPEC 4.1, 3)",
    build=_build, progress=_progress, estimate=_estimate, analyse=_analyse, set_params=_set_params,
    analyse_set=_analyse_set, frame=("atoms", _frame), elements=_particles, result_tables=("crush",),
    check=_check, work=_work)
