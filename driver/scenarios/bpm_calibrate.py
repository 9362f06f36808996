"""BPM calibration tests (SPEC 2.3): the unit of the (bpm, calibrate) pair; its section is the
shared `calibrate` one (driver/scenarios/sections.py, CalibrateScenario). Test `moduli`: B, G, E
and nu of the network (driver/bpm/moduli.py builds and deforms it, analysis/moduli.py fits); a
set of such runs over k_A gives the calibration curves. Test `mode1`: K_IC from the peak stress
of a free sample with an elliptic void pulled apart (driver/bpm/mode1.py builds it,
analysis/mode1.py measures). Test `mode2`: K_IIC from the peak shear stress of a periodic
sample with an elliptic void at 45 degrees under pure shear, breakable bonds only in a band
along the void (driver/bpm/mode2.py builds it, analysis/mode2.py measures). Test `crack_speed`:
the mode-I pull (2D, or the 3D slab), measured for its crack fronts from the break log, their
steady speed and its ratio to the Rayleigh speed of the network from B_reference and G_reference
(analysis/crack.py; a mode1 run reports the same when those are given)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from driver.scenarios.api import Scenario
from driver.scenarios.sections import CalibrateScenario

if TYPE_CHECKING:
    from analysis.completeness import RunCompleteness


def protocol(test: str | None) -> str:
    """The protocol a test runs: crack_speed is the mode-I pull, measured for its crack fronts."""
    return "mode1" if test == "crack_speed" else (test or "moduli")


def _build(cfg, rd, plugin):
    if cfg.scenario.test == "mode2":
        from driver.bpm.mode2 import run_mode2  # noqa: PLC0415

        return run_mode2(cfg, rd, plugin)
    if protocol(cfg.scenario.test) == "mode1":
        from driver.bpm.mode1 import run_mode1  # noqa: PLC0415

        return run_mode1(cfg, rd, plugin)
    from driver.bpm.moduli import run_moduli  # noqa: PLC0415

    return run_moduli(cfg, rd, plugin)


def _progress(cfg, system):
    if protocol(cfg.scenario.test) == "mode1":
        from driver.bpm.mode1 import progress_spec  # noqa: PLC0415
    elif cfg.scenario.test == "mode2":
        from driver.bpm.mode2 import progress_spec  # noqa: PLC0415
    else:
        from driver.bpm.moduli import progress_spec  # noqa: PLC0415
    return progress_spec(cfg, system)


def _estimate(cfg, ranks):
    from driver.moduli_protocol import phases  # noqa: PLC0415
    from driver.schedule import total_steps  # noqa: PLC0415
    from driver.size_model import bpm_size  # noqa: PLC0415

    sc, m = cfg.scenario, cfg.model
    if protocol(sc.test) == "mode1":
        return bpm_size(cfg, ranks, total_steps(sc.max_pull_strain, sc.strain_rate, m.timestep),
                        sc.thickness if m.dimension == 3 else None)
    if sc.test == "mode2":
        return bpm_size(cfg, ranks, total_steps(sc.max_shear_strain, sc.strain_rate, m.timestep),
                        sc.thickness if m.dimension == 3 else None)
    return bpm_size(cfg, ranks, phases(m.dimension, sc.strain_rate, sc.max_strain, m.timestep)[-1].end)


def _analyse(run_dir: Path, cfg: dict, plots: bool, completeness: RunCompleteness) -> dict:
    if cfg["scenario"].get("test") == "mode2":
        from analysis.mode2 import Mode2Analysis as analysis  # noqa: PLC0415
    elif protocol(cfg["scenario"].get("test")) == "mode1":  # mode1 and crack_speed
        from analysis.mode1 import Mode1Analysis as analysis  # noqa: PLC0415
    else:
        from analysis.moduli import ModuliAnalysis as analysis  # noqa: PLC0415
    return analysis(run_dir, cfg, plots, completeness).run()


def _set_params(cfg: dict) -> dict:
    m = cfg["model"]
    return {"dimension": m["dimension"], "L": float(m["L"]), "k_A": float(m["k_A"]), "seed": cfg.get("seed"),
            "strain_rate": float(cfg["scenario"]["strain_rate"]), "test": cfg["scenario"].get("test", "moduli"),
            "lambda_c": float(m["lambda_c"]), "theta_c_deg": float(m["theta_c_deg"])}


def _analyse_set(runs: list[dict], out: Path, plots: bool, left_out: list[dict], options: dict) -> dict:
    tests = {protocol(r["cfg"]["scenario"].get("test", "moduli")) for r in runs}
    if len(tests) > 1:
        raise ValueError(f"a set of calibration runs mixes the tests {sorted(tests)}: analyse each test apart")
    if tests == {"mode1"}:
        from analysis.mode1 import analyse_mode1_set  # noqa: PLC0415

        return analyse_mode1_set(runs, out, plots, left_out=left_out)
    if tests == {"mode2"}:
        from analysis.mode2 import analyse_mode2_set  # noqa: PLC0415

        return analyse_mode2_set(runs, out, plots, left_out=left_out)
    from analysis.moduli import analyse_moduli_set  # noqa: PLC0415

    return analyse_moduli_set(runs, out, plots, left_out=left_out)


def _result_tables(cfg: dict) -> tuple[str, ...]:
    """What a finished run of each test leaves for the set analysis."""
    return {"mode1": ("mode1",), "mode2": ("mode2",)}.get(protocol(cfg["scenario"].get("test")), ("moduli_phases",))


def _frame(run_dir: Path, cfg: dict, step: int, png: Path) -> None:
    raise ValueError("a calibration test writes no periodic dumps to animate")


def _elements(cfg) -> int:
    from driver.bpm.packing import particle_count  # noqa: PLC0415

    m, sc = cfg.model, cfg.scenario
    # the 3D toughness tests run on the slab of driver/bpm/slab.py
    slab = sc.thickness if m.dimension == 3 and protocol(sc.test) in ("mode1", "mode2") else None
    return particle_count(m.dimension, m.L, m.packing_fraction, slab, m.packing or "contact")


def _check(cfg) -> None:
    if cfg.model.assembly is not None:
        raise ValueError("model.assembly: a bed of grains is for scenario compress; this scenario takes one "
                         "particle or sample (remove model.assembly)")
    if cfg.model.particle is not None:
        raise ValueError("model.particle describes the particle of scenario impact; remove it here")
    if cfg.output.animation:
        raise ValueError("output.animation: a calibration test writes no periodic dumps")
    # the section is shared with the BCM block's tests (driver/scenarios/bcm_calibrate.py)
    if (cfg.scenario.test not in ("moduli", "mode1", "mode2", "crack_speed")
            or getattr(cfg.scenario, "block", None) is not None):
        raise ValueError("scenario: test = fracture and the block section are the BCM block's; a BPM calibration "
                         "run has the tests moduli, mode1, mode2 and crack_speed")
    if cfg.scenario.test == "crack_speed" and not (cfg.scenario.B_reference and cfg.scenario.G_reference):
        raise ValueError("scenario.test = crack_speed compares the crack's speed with the Rayleigh speed of the "
                         "network: give scenario.B_reference and scenario.G_reference (B and G of a moduli run of "
                         "the same model)")
    if protocol(cfg.scenario.test) == "mode1":
        _check_mode1(cfg)
        return
    if cfg.scenario.test == "mode2":
        _check_mode2(cfg)
        return
    if cfg.scenario.max_strain >= cfg.model.lambda_c - 1.0:
        raise ValueError(f"scenario.max_strain = {cfg.scenario.max_strain:g} reaches the bond break stretch "
                         f"lambda_c - 1 = {cfg.model.lambda_c - 1:g}: not an elastic test")


#: Largest ratio of the void's major axis to the sample width: the range of Feddersen's
#: finite-width factor sqrt(sec(pi c / W)) for a centre crack, within 0.3 % for 2c / W <= 0.7
#: (Tada, Paris & Irwin, The Stress Analysis of Cracks Handbook, 3rd ed., 2000: centre crack in a strip).
MAX_VOID_TO_WIDTH = 0.7


def _check_mode1(cfg) -> None:
    sc, m = cfg.scenario, cfg.model
    if not sc.void:
        raise ValueError("scenario.void = false: the mode1 test measures K_IC at the tips of the elliptic void; "
                         "a sample without it is refused")
    major, minor = sc.void_axes
    if minor > major:
        raise ValueError(f"scenario.void_axes = {list(sc.void_axes)}: the first (major, along x) must be the longer")
    if major > MAX_VOID_TO_WIDTH * m.L:
        raise ValueError(f"scenario.void_axes: a major axis {major:g} over model.L = {m.L:g} is above "
                         f"{MAX_VOID_TO_WIDTH:g}, where the finite-width factor no longer holds: model.L >= "
                         f"{major / MAX_VOID_TO_WIDTH:.4g}")
    if minor + 2 * sc.grip_width >= m.L:
        raise ValueError("scenario.grip_width: the grips and the void do not fit in model.L")


#: Largest ratio of the void's major axis to the period of the collinear cracks along the
#: diagonal, L sqrt(2) (analysis/mode2.py): the images of the void in the neighbouring rows of
#: the array, a perpendicular L / sqrt(2) away, stay over 1.4 major axes from it.
MAX_VOID_TO_PERIOD = 0.5


def _check_mode2(cfg) -> None:
    sc, m = cfg.scenario, cfg.model
    if not sc.void:
        raise ValueError("scenario.void = false: the mode2 test measures K_IIC at the tips of the elliptic void; "
                         "a sample without it is refused")
    major, minor = sc.void_axes
    if minor > major:
        raise ValueError(f"scenario.void_axes = {list(sc.void_axes)}: the first (major, at 45 degrees) must be "
                         "the longer")
    period = m.L * 2 ** 0.5
    if major > MAX_VOID_TO_PERIOD * period:
        raise ValueError(f"scenario.void_axes: a major axis {major:g} over the crack period L sqrt(2) = "
                         f"{period:.4g} is above {MAX_VOID_TO_PERIOD:g}, where the images of the void interact: "
                         f"model.L >= {major / (MAX_VOID_TO_PERIOD * 2 ** 0.5):.4g}")
    if not minor < sc.band_width < 0.5 * m.L / 2 ** 0.5:
        raise ValueError(f"scenario.band_width = {sc.band_width:g}: must be wider than the void's minor axis "
                         f"({minor:g}) and under half the spacing of the band's periodic images, "
                         f"L / (2 sqrt 2) = {0.5 * m.L / 2 ** 0.5:.4g}")


UNIT = Scenario(
    model="bpm", scenario="calibrate", section=CalibrateScenario,
    description="a BPM calibration test: moduli, mode1, mode2 (SPEC 2.3)",
    build=_build, progress=_progress, estimate=_estimate, analyse=_analyse, set_params=_set_params,
    analyse_set=_analyse_set, frame=("atoms", _frame), elements=_elements, result_tables=_result_tables,
    check=_check)
