"""The base of every YAML section (strict: unknown keys, non-finite numbers refused) and the
error a refused input raises. Below driver/config.py, the model sections (driver/bcm/section.py,
driver/bpm/section.py) and the scenario units (driver/scenarios/), so that each can declare its
own section without importing the whole configuration."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict


class ConfigError(ValueError):
    """An input file was refused; the message names file, field, value and what is allowed."""


class _Strict(BaseModel):
    # allow_inf_nan=False: .inf/.nan are refused in every float field of every section, list
    # items included (a non-finite damping or time hangs LAMMPS; tested in test_validation.py)
    model_config = ConfigDict(extra="forbid", validate_default=True, allow_inf_nan=False)
