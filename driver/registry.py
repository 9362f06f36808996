"""The scenario registry: which (model, scenario) pairs exist, and the unit that runs each.

A unit (driver/scenarios/<model>_<scenario>.py, a `Scenario` of driver/scenarios/api.py) knows
how to build its system, write its LAMMPS input, name its progress fields, estimate its cost,
analyse a run, draw an animation frame and analyse a set of its runs. Everything that differs
between scenarios goes through here: `driver run`, `driver post`, `driver scaling`, sweeps and
animations look up the unit of a run's (model.kind, scenario.kind) and call it. The config's
`model:` and `scenario:` sections are the unions of the sections registered here.

The units are the modules listed in driver/scenarios/__init__.py (UNITS), imported the first
time a pair or a section is asked for, not when this module is imported.
"""

from __future__ import annotations

import functools
import importlib
from typing import TYPE_CHECKING, Any

from driver.bcm.section import BCMModel
from driver.bpm.section import BPMModel
from driver.schema import ConfigError
from driver.scenarios import UNITS as UNIT_MODULES

if TYPE_CHECKING:  # for readers and checkers only
    from driver.config import RunConfig
    from driver.scenarios.api import Scenario

#: The `model:` sections, by their `kind`.
MODELS: dict[str, type] = {"bpm": BPMModel, "bcm": BCMModel}


@functools.cache
def units() -> dict[tuple[str, str], Scenario]:
    """Every registered unit, by (model kind, scenario kind), in the order of UNIT_MODULES."""
    found = [importlib.import_module(f"driver.scenarios.{name}").UNIT for name in UNIT_MODULES]
    return {u.key: u for u in found}


@functools.cache
def scenario_sections() -> dict[str, type]:
    """The `scenario:` sections, by their `kind` (a section may serve several models)."""
    # Units of one scenario kind share one section (a config holds one section per kind): the
    # most derived of theirs, which must extend every other (bcm calibrate extends bpm's).
    out: dict[str, type] = {}
    for u in units().values():
        have = out.get(u.scenario)
        if have is None or issubclass(u.section, have):
            out[u.scenario] = u.section
        elif not issubclass(have, u.section):
            raise TypeError(f"the units of scenario '{u.scenario}' have unrelated sections {have.__name__} and "
                            f"{u.section.__name__}: one must extend the other")
    return out


def pairs_text() -> str:
    """The registered pairs, e.g. 'bpm + shear, bcm + impact'."""
    return ", ".join(f"{m} + {s}" for m, s in units())


def unit(model: str, scenario: str) -> Scenario:
    """The unit of a (model kind, scenario kind) pair; ConfigError naming the pairs that exist."""
    try:
        return units()[(model, scenario)]
    except KeyError:
        raise ConfigError(f"scenario '{scenario}' is not available for model '{model}'; the pairs that exist "
                          f"(model.kind + scenario.kind): {pairs_text()}") from None


def unit_of(cfg: RunConfig | dict[str, Any]) -> Scenario:
    """The unit of a RunConfig or of a config mapping (config.resolved.yaml)."""
    if isinstance(cfg, dict):
        return unit(cfg["model"]["kind"], cfg["scenario"]["kind"])
    return unit(cfg.model.kind, cfg.scenario.kind)
