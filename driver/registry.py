"""The scenario registry: which (model, scenario) pairs exist, and the unit that runs each.

A unit (driver/scenarios/<model>_<scenario>.py) knows how to build its system, write its
LAMMPS input, name its progress fields, estimate its cost, analyse a run, draw an animation
frame and analyse a set of its runs. Everything that differs between scenarios goes through
here: `driver run`, `driver post`, `driver scaling`, sweeps and animations look up the unit of
a run's (model.kind, scenario.kind) and call it. The config's `model:` and `scenario:`
sections are the unions of the sections registered below.

Adding a scenario: write its unit module (its scenario section, if new, and a `UNIT`) and add
the module to UNITS.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

from driver.bcm.section import BCMModel
from driver.bpm.section import BPMModel
from driver.schema import ConfigError

if TYPE_CHECKING:
    from driver.config import RunConfig
    from driver.estimate import SizeEstimate
    from driver.rundir import RunDir
    from driver.runner import ProgressSpec


@dataclass(frozen=True)
class Scenario:
    """What a (model, scenario) pair does; every callable takes the run's config.

    build(cfg, run_dir: RunDir, plugin) -> (system facts, ProgressSpec): the system, its
        inputs and schedule written into the run directory.
    progress(cfg, system) -> ProgressSpec: the progress fields of a run (again on resume).
    estimate(cfg, ranks) -> SizeEstimate: size, memory and time without building.
    analyse(run_dir, cfg: dict, plots, partial) -> summary: the run's tables and figures.
    set_params(cfg: dict) -> the parameters a set compares runs by (runs table columns).
    result_tables: result tables (results/<name>.parquet) a set analysis reads; or a function of
        the run's config (dict) giving them, for a unit whose runs differ (calibrate: by test).
    analyse_set(runs, out, plots, left_out, options) -> figures: a set of runs of this pair.
    frame: (dump prefix, draw(run_dir, cfg: dict, step, png)) of an animation frame.
    elements(cfg) -> particles or cells the system will hold (sizes the default chunk).
    check(cfg) -> None: consistency checks across sections (ValueError with the message).
    work(cfg) -> a number growing with a run's expected length among runs of equal estimate
        (sweeps start the longest first).
    """

    model: str
    scenario: str
    section: type
    description: str
    build: Callable[[RunConfig, RunDir, Path], tuple[dict, ProgressSpec]]
    progress: Callable[[RunConfig, dict], ProgressSpec]
    estimate: Callable[[RunConfig, int], SizeEstimate]
    analyse: Callable[[Path, dict, bool, bool], dict]
    set_params: Callable[[dict], dict]
    analyse_set: Callable[..., dict]
    frame: tuple[str, Callable[[Path, dict, int, Path], None]]
    elements: Callable[[RunConfig], int]
    result_tables: tuple[str, ...] | Callable[[dict], tuple[str, ...]] = ()
    check: Callable[[RunConfig], None] = field(default=lambda cfg: None)
    work: Callable[[RunConfig], float] = field(default=lambda cfg: 0.0)

    @property
    def key(self) -> tuple[str, str]:
        return (self.model, self.scenario)


def _units() -> list[Scenario]:
    # the registry: one line per unit
    from driver.scenarios import bcm_calibrate, bcm_impact, bpm_calibrate, bpm_impact, bpm_shear  # noqa: PLC0415

    return [bpm_shear.UNIT, bcm_impact.UNIT, bpm_calibrate.UNIT, bcm_calibrate.UNIT, bpm_impact.UNIT]


#: The `model:` sections, by their `kind`.
MODELS: dict[str, type] = {"bpm": BPMModel, "bcm": BCMModel}
#: Every registered unit, by (model kind, scenario kind).
UNITS: dict[tuple[str, str], Scenario] = {u.key: u for u in _units()}


def _sections() -> dict[str, type]:
    # Units of one scenario kind share one section (a config holds one section per kind): the
    # most derived of theirs, which must extend every other (bcm calibrate extends bpm's).
    out: dict[str, type] = {}
    for u in UNITS.values():
        have = out.get(u.scenario)
        if have is None or issubclass(u.section, have):
            out[u.scenario] = u.section
        elif not issubclass(have, u.section):
            raise TypeError(f"the units of scenario '{u.scenario}' have unrelated sections {have.__name__} and "
                            f"{u.section.__name__}: one must extend the other")
    return out


#: The `scenario:` sections, by their `kind` (a section may serve several models).
SCENARIOS: dict[str, type] = _sections()


def pairs_text() -> str:
    """The registered pairs, e.g. 'bpm + shear, bcm + impact'."""
    return ", ".join(f"{m} + {s}" for m, s in UNITS)


def unit(model: str, scenario: str) -> Scenario:
    """The unit of a (model kind, scenario kind) pair; ConfigError naming the pairs that exist."""
    try:
        return UNITS[(model, scenario)]
    except KeyError:
        raise ConfigError(f"scenario '{scenario}' is not available for model '{model}'; the pairs that exist "
                          f"(model.kind + scenario.kind): {pairs_text()}") from None


def unit_of(cfg: RunConfig | dict[str, Any]) -> Scenario:
    """The unit of a RunConfig or of a config mapping (config.resolved.yaml)."""
    if isinstance(cfg, dict):
        return unit(cfg["model"]["kind"], cfg["scenario"]["kind"])
    return unit(cfg.model.kind, cfg.scenario.kind)
