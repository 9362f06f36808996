"""BCM calibration tests on a periodic block of cells (SPEC 3): the unit of the (bcm, calibrate)
pair. Test `moduli`: B, G, E and nu of the block by compression and simple shear; test
`fracture`: a notched block pulled in mode I, the energy released per unit new crack area
against G_c and the tensile strength. driver/bcm/calibrate.py builds and deforms the block,
analysis/bcm_calibrate.py measures (with the fits of analysis/moduli.py).

Both models' calibration runs share the `calibrate` section (a config holds one section per
kind): `BlockCalibrateScenario` extends the BPM one with the BCM tests and a `block:`
subsection, which a BPM run must leave out and a BCM run gets filled in with its defaults.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Literal

from pydantic import Field, field_validator

from driver.bcm.section import check_steps_per_period
from driver.scenarios.api import Scenario
from driver.scenarios.sections import CalibrateScenario
from driver.schema import _Strict

if TYPE_CHECKING:
    from analysis.completeness import RunCompleteness

#: Keys of the `calibrate` section that only a BPM run reads (a BCM run refuses them when set).
BPM_ONLY = ("strain_rate", "void", "void_axes", "grip_width", "max_pull_strain", "B_reference", "G_reference",
            "E_reference", "band_width", "max_shear_strain", "K_IC_reference", "thickness")


class BlockSection(_Strict):
    """The periodic block of a BCM calibration test (SPEC 3), SI units."""

    n_cells: int = Field(300, ge=27, le=20_000, description="cells in the cubic periodic block (at least about "
                                                            "2 cells across in every direction for LAMMPS)")
    cell_size: float | None = Field(None, gt=0.0, description="mean cell size h, m (box side h n_cells^(1/3)); "
                                                              "none: the particle's, (V_particle / N_c)^(1/3) "
                                                              "from the model section (filled in when the "
                                                              "config is read)")
    steps_per_period: float = Field(50.0, gt=0.0, description="time step = shortest contact period (stiffest "
                                                               "spring, lightest cells) / this")
    crossings: float = Field(4.0, gt=0.0, description="moduli: the fast compression phase lasts this many "
                                                       "sound-crossing times T = L / c_0, c_0 = sqrt(k_n / "
                                                       "(rho_s h)) (shear phases 3 T per crossing; half-rate "
                                                       "phases twice as long)")
    notch: float = Field(0.5, ge=0.0, lt=1.0, description="fracture: fraction of the width x over which the "
                                                          "interfaces crossing the plane z = L/2 are left "
                                                          "unbonded")
    pull_rate: float = Field(2e-5, gt=0.0, le=1e-2, description="fracture: engineering strain (z) per "
                                                                "sound-crossing time T")
    pull_strain: float = Field(2e-3, gt=0.0, le=0.05, description="fracture: engineering strain (z) at which "
                                                                  "the pull ends")

    _stable = field_validator("steps_per_period")(check_steps_per_period)


class BlockCalibrateScenario(CalibrateScenario):
    """A calibration test (SPEC 2.3 for BPM, SPEC 3 for the BCM block)."""

    test: Literal["moduli", "mode1", "mode2", "crack_speed", "fracture"] = Field(
        "moduli", description="moduli: B, G, E, nu by compression and simple shear at a rate, then at half of it "
                              "(the rate check); mode1 (BPM): K_IC of a free sample with an elliptic void; "
                              "mode2 (BPM): K_IIC under pure shear; crack_speed (BPM): the mode1 pull's crack speed; "
                              "fracture (BCM): a notched periodic block pulled in mode I")
    block: BlockSection | None = Field(None, description="BCM: the periodic block (filled in with its defaults "
                                                         "for a BCM run; a BPM run leaves it out)")


def _build(cfg, rd, plugin):
    from driver.bcm.calibrate import run_fracture, run_moduli  # noqa: PLC0415

    return (run_fracture if cfg.scenario.test == "fracture" else run_moduli)(cfg, rd, plugin)


def _progress(cfg, system):
    from driver.bcm.calibrate import progress_spec  # noqa: PLC0415

    return progress_spec(cfg, system)


def _estimate(cfg, ranks):
    import math  # noqa: PLC0415

    from driver.size_model import BCM_SECONDS_PER_CELL, SizeEstimate, bcm_interfaces  # noqa: PLC0415

    blk, m = cfg.scenario.block, cfg.model
    n = blk.n_cells
    # steps per crossing time without building (driver/bcm/calibrate.py): T / dt = n^(1/3)
    # steps_per_period / (2 pi) sqrt(2 k_max / (r k_n)), r = lightest cell / mean cell ~ 0.6
    k_max = max(m.contact.kn, m.contact.kt, m.interface.kn, m.interface.kt)
    per_crossing = n ** (1 / 3) * blk.steps_per_period / (2 * math.pi) * math.sqrt(2 * k_max / (0.6 * m.interface.kn))
    steps = (30 * blk.crossings * per_crossing if cfg.scenario.test == "moduli"
             else blk.pull_strain / blk.pull_rate * per_crossing)
    return SizeEstimate(model="BCM", elements=n, element_name="cells", bonds=bcm_interfaces(n), bond_name="interfaces",
                        memory_bytes=int(3e8 + 2e5 * n), seconds_per_1000_steps=BCM_SECONDS_PER_CELL * n / ranks,
                        steps=int(math.ceil(steps)), ranks=ranks)


def _analyse(run_dir: Path, cfg: dict, plots: bool, completeness: RunCompleteness) -> dict:
    from analysis.bcm_calibrate import BlockFractureAnalysis, BlockModuliAnalysis  # noqa: PLC0415

    analysis = BlockFractureAnalysis if cfg["scenario"].get("test") == "fracture" else BlockModuliAnalysis
    return analysis(run_dir, cfg, plots, completeness).run()


def _set_params(cfg: dict) -> dict:
    m, blk = cfg["model"], cfg["scenario"]["block"] or {}
    return {"test": cfg["scenario"].get("test", "moduli"), "kn": float(m["interface"]["kn"]),
            "kt": float(m["interface"]["kt"]), "kt_over_kn": float(m["interface"]["kt"]) / float(m["interface"]["kn"]),
            "G_c": float(m["interface"]["G_c"]), "n_cells": blk.get("n_cells"), "cell_size": blk.get("cell_size"),
            "seed": cfg.get("seed")}


def _analyse_set(runs: list[dict], out: Path, plots: bool, left_out: list[dict], options: dict) -> dict:
    from analysis.bcm_calibrate import analyse_block_set  # noqa: PLC0415

    return analyse_block_set(runs, out, plots, left_out=left_out)


def _result_tables(cfg: dict) -> tuple[str, ...]:
    return ("fracture",) if cfg["scenario"].get("test") == "fracture" else ("moduli_phases",)


def _frame(run_dir: Path, cfg: dict, step: int, png: Path) -> None:
    raise ValueError("a calibration test writes no periodic dumps to animate")


def _elements(cfg) -> int:
    return (cfg.scenario.block or BlockSection()).n_cells


def _check(cfg) -> None:
    if cfg.model.assembly is not None:
        raise ValueError("model.assembly: a bed of grains is for scenario compress; this scenario takes one "
                         "particle (remove model.assembly)")
    sc = cfg.scenario
    if cfg.output.animation:
        raise ValueError("output.animation: a calibration test writes no periodic dumps")
    if sc.test in ("mode1", "mode2", "crack_speed"):
        raise ValueError(f"scenario.test = {sc.test} is a BPM toughness test; the BCM block has moduli and fracture")
    # set to something else than their defaults: a resolved config (config.resolved.yaml, a
    # Dask task's config) holds every key at its default, and must read back
    given = sorted(k for k in BPM_ONLY if getattr(sc, k) != CalibrateScenario.model_fields[k].default)
    if given:
        raise ValueError(f"scenario: {', '.join(given)} only apply to BPM calibration runs; the BCM block's rates "
                         "are set in scenario.block (crossings, pull_rate, pull_strain)")
    # the resolved config holds every value the run uses: the block and its cell size
    if sc.block is None:
        sc.block = BlockSection()
    if sc.block.cell_size is None:
        from driver.bcm.calibrate import particle_cell_size  # noqa: PLC0415 (builds the parent shape)

        sc.block.cell_size = particle_cell_size(cfg.model)


UNIT = Scenario(
    model="bcm", scenario="calibrate", section=BlockCalibrateScenario,
    description="a BCM calibration test on a periodic block: moduli, fracture (SPEC 3)",
    build=_build, progress=_progress, estimate=_estimate, analyse=_analyse, set_params=_set_params,
    analyse_set=_analyse_set, frame=("cells", _frame), elements=_elements, result_tables=_result_tables,
    check=_check)
