"""The input of `driver compare` (issue 13, point 3):

    name: compare_impact_small
    material: material_bcm_default.yaml   # a material file, or a calibration.json (driver calibrate);
                                          # a path relative to this file
    test: impact                          # impact, crush (SPEC 4.1: between two platens), or compress (a bed
                                          # of grains in a box; then assembly: {n_grains, sizes, box}, issue 25)
    grid:
      omega: [0.05, 0.2, 0.8, 3.0]        # damage potentials (or {logspace: [a, b, n]}): both models
                                          # at equal omega, v_0 = sqrt(4 omega A_0 G_c / M) per particle;
                                          # or velocity: [...] (m/s), both at equal v_0
      G_c: [3.3]                          # J/m^2, the material's fracture energy (default: the material's)
      seeds: 2                            # seeds 1..2, or a list
      # test: crush: no velocity or omega; diameter: [1.5e-3, 2e-3, 3e-3] (m, optional) crushes
      # grains of these sizes at the element sizes of the resolutions below (the BCM's cell count
      # grows with d^3, the BPM's particle size stays); default: the material's diameter
    bcm: {n_cells: 300}                   # resolution: replaces the material file's (or cell_size)
    bpm: {particles_across: 8}            # lambda_c: calibrated, or given (below)
    scenario: {max_time: 2.0e-4}          # the shared impact section (velocity comes from the grid)
    curves: {bpm_moduli: {seeds: 1}}      # as a material file's curves: (replace its entries)
    base: {bcm: {}, bpm: {}}              # further dotted keys of either model's run config
    workers: 2                            # runs at a time (default: cores)

The BPM's lambda_c is calibrated in 3D (the mode-I curve of the thin periodic slab at the chosen
k_A, driver/calibration/curves.py) and read off that curve at each G_c of the grid
(params.py); `bpm.lambda_c` overrides it at the material's G_c (scaled to the grid's other G_c
as lambda_c - 1 ~ K_IC ~ sqrt(G_c)). Its k_A and units come from the 3D moduli curve.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Literal

from pydantic import Field, ValidationError, model_validator

from driver.calibration.material import BcmResolution, MaterialFile, load_material, read_input
from driver.config import format_validation_error
from driver.schema import ConfigError, _Strict


class Grid(_Strict):
    """The parameter points: velocities (impact) or particle sizes (crush) x G_c values x seeds."""

    velocity: Any = Field(None, description="impact velocities v_0, m/s: a list or {linspace|logspace: [a, b, n]}")
    omega: Any = Field(None, description="damage potentials omega = W_k^- / (2 A_0 G_c) instead of velocities "
                                         "(G_c the material's): a list or a range; each run's v_0 is set from its "
                                         "own particle's A_0 and mass")
    G_c: list[float] | None = Field(None, description="the material's fracture energy, J/m^2 (default: the "
                                                      "material's own)")
    diameter: list[float] | None = Field(None, description="crush: particle sizes d, m (the parent's diameter as "
                                                           "the material's diameter_kind), at the resolutions' "
                                                           "element sizes (default: the material's diameter)")
    seeds: Any = Field(2, description="seeds 1..n, or a list of seeds (tessellations / packings per point)")

    @model_validator(mode="after")
    def _values(self) -> "Grid":
        if self.G_c is not None and (not self.G_c or any(g <= 0 for g in self.G_c)):
            raise ValueError("grid.G_c: a non-empty list of positive fracture energies (J/m^2)")
        if self.diameter is not None and (not self.diameter or any(not d > 0 for d in self.diameter)
                                          or len(set(self.diameter)) != len(self.diameter)):
            raise ValueError("grid.diameter: a non-empty list of distinct positive particle sizes (m)")
        return self

    @property
    def axis(self) -> str:
        """The column that pairs the two models' runs: `velocity` or `omega_target` (impact),
        `diameter` (crush)."""
        if self.velocity is not None:
            return "velocity"
        return "omega_target" if self.omega is not None else "diameter"


class BpmCompare(_Strict):
    """The BPM particle of the comparison: its resolution and its break stretch."""

    particles_across: float | None = Field(None, ge=2.0, le=1e4, description="particles across the parent "
                                                                               "diameter (a = d / this)")
    particle_size: float | None = Field(None, gt=0.0, description="particle diameter a, m (instead)")
    theta_c_deg: float | None = Field(None, gt=0.0, lt=180.0, description="critical angle change, degrees")
    lambda_c: float | None = Field(None, gt=1.0, le=2.0, description="break stretch at the material's G_c "
                                                                     "(default: calibrated on the 3D mode-I curve)")

    @model_validator(mode="after")
    def _size(self) -> "BpmCompare":
        if self.particles_across is not None and self.particle_size is not None:
            raise ValueError("give particles_across or particle_size, not both")
        return self


class BcmCompare(_Strict):
    """The BCM particle's resolution (replaces the material file's)."""

    n_cells: int | None = Field(None, ge=2, le=200_000, description="cells in the BCM particle")
    cell_size: float | None = Field(None, gt=0.0, description="mean cell size h, m (instead of n_cells)")

    @model_validator(mode="after")
    def _size(self) -> "BcmCompare":
        if self.n_cells is not None and self.cell_size is not None:
            raise ValueError("give n_cells or cell_size, not both")
        return self


class Bases(_Strict):
    bcm: dict[str, Any] = Field(default_factory=dict, description="dotted keys of the BCM run config")
    bpm: dict[str, Any] = Field(default_factory=dict, description="dotted keys of the BPM run config")


class CompareFile(_Strict):
    """A `driver compare` input (module docstring)."""

    name: str = Field("compare", min_length=1, max_length=80, pattern=r"^[A-Za-z0-9_.-]+$",
                      description="the comparison's name: the directory is runs/compare_<name> by default")
    material: str = Field(..., min_length=1, description="a material file or a calibration.json, relative to "
                                                         "the compare file")
    test: Literal["impact", "crush", "compress"] = Field(
        "impact", description="the test both models run: impact (on a rigid plane, SPEC 1.3), crush (between two "
                              "platens, SPEC 4.1) or compress (a bed of grains in a rigid box, issue 25)")
    assembly: dict[str, Any] | None = Field(
        None, description="compress: the bed both models fill, as model.assembly (n_grains, sizes, box, "
                          "tessellations; driver/assembly.py): the same grain count, sizes and box, the same seeds")
    grid: Grid = Field(..., description="the parameter points both models run")
    bcm: BcmCompare = Field(default_factory=BcmCompare,
                            description="the BCM particle's resolution (replaces the material file's)")
    bpm: BpmCompare = Field(default_factory=BpmCompare,
                            description="the BPM particle's resolution and break stretch")
    scenario: dict[str, Any] = Field(default_factory=dict, description="keys of the shared scenario section "
                                                                       "of the test (impact: not velocity, the "
                                                                       "grid's)")
    base: Bases = Field(default_factory=Bases, description="further dotted keys of either model's run config")
    curves: dict[str, Any] = Field(default_factory=dict, description="changes to the calibration curves, as a "
                                                                     "material file's curves: (replace its entries)")
    breakup_fraction: float = Field(0.9, gt=0.0, lt=1.0, description="break-up: largest fragment below this "
                                                                     "fraction of the parent's mass (SPEC 1.5)")
    z_agree: float = Field(2.0, gt=0.0, description="|difference| / combined standard error at or below which "
                                                    "the models agree within error bars")
    workers: int | None = Field(None, ge=1, description="runs at a time (default: cores)")

    @model_validator(mode="after")
    def _scenario(self) -> "CompareFile":
        if "kind" in self.scenario:
            raise ValueError("scenario: kind comes from test; leave it out")
        if self.test == "impact":
            if "velocity" in self.scenario:
                raise ValueError("scenario: velocity comes from grid.velocity and kind from test; leave them out")
            if (self.grid.velocity is None) == (self.grid.omega is None):
                raise ValueError("give grid.velocity (impact velocities, m/s: both models at equal v_0) or grid.omega "
                                 "(damage potentials: both models at equal omega), exactly one")
            if self.grid.diameter is not None:
                raise ValueError("grid.diameter: particle sizes are a grid of test: crush; the impact's particle is "
                                 "the material's")
        elif self.grid.velocity is not None or self.grid.omega is not None:
            raise ValueError(f"test: {self.test} has no impact velocity: leave out grid.velocity and grid.omega (the "
                             "grid is " + ("grid.diameter, " if self.test == "crush" else "") + "grid.G_c and "
                             "grid.seeds; the platen's speed is scenario.platen_speed)")
        if self.test == "compress":
            if self.assembly is None:
                raise ValueError("test: compress needs assembly (the bed both models fill: n_grains, sizes, box, as "
                                 "model.assembly)")
            if self.grid.diameter is not None:
                raise ValueError("grid.diameter: particle sizes are a grid of test: crush; a bed's sizes are "
                                 "assembly.sizes")
        elif self.assembly is not None:
            raise ValueError(f"assembly: a bed of grains is for test: compress, not {self.test}")
        return self


def load_compare(path: str | Path) -> CompareFile:
    """Read and validate a compare file (driver/calibration/material.py read_input)."""
    return read_input(path, CompareFile, "name, material, test, grid, bcm, bpm, ...")


def material_of(cmp: CompareFile, compare_path: Path) -> tuple[MaterialFile, dict[str, Any] | None, Path]:
    """The material both models are calibrated to, with the compare file's resolutions: from a
    material file, or from a calibration.json (its material; its BCM result is returned too,
    reused when the BCM resolution is unchanged). The BPM is always 3D (the impact's particle)."""
    where = (Path(compare_path).parent / cmp.material).expanduser()
    if not where.exists():
        raise ConfigError(f"{compare_path}: material: {where} does not exist (a material file or a calibration.json)")
    calibration = None
    if where.suffix == ".json":
        try:
            calibration = json.loads(where.read_text())
            mat = MaterialFile.model_validate(calibration["material"])
        except (ValueError, KeyError, TypeError, ValidationError) as exc:
            raise ConfigError(f"{where}: not a calibration.json of driver calibrate ({type(exc).__name__}: "
                              f"{exc})") from None
    else:
        mat = load_material(where)
    data = mat.model_dump()
    bcm = dict(data.get("bcm") or {})
    if cmp.bcm.n_cells is not None or cmp.bcm.cell_size is not None:
        bcm.update({"n_cells": cmp.bcm.n_cells, "cell_size": cmp.bcm.cell_size})
    bpm = dict(data.get("bpm") or {"diameter": bcm.get("diameter", 2e-3)})
    bpm["dimension"] = 3
    if cmp.bpm.particles_across is not None or cmp.bpm.particle_size is not None:
        bpm.update({"particles_across": cmp.bpm.particles_across, "particle_size": cmp.bpm.particle_size})
    if cmp.bpm.theta_c_deg is not None:
        bpm["theta_c_deg"] = cmp.bpm.theta_c_deg
    if not bcm:
        bcm = BcmResolution(diameter=bpm["diameter"]).model_dump()
    data.update({"bcm": bcm, "bpm": bpm, "curves": {**data.get("curves", {}), **cmp.curves}})
    try:
        out = MaterialFile.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(exc, f"{compare_path} (material {where} with the compare "
                                                       f"file's resolutions)", data, MaterialFile)) from None
    reuse = None
    bcm_curves = lambda m: {k: v for k, v in m.curves.items() if k.startswith("bcm_")}  # noqa: E731
    if calibration is not None and calibration.get("bcm") and out.bcm == mat.bcm and bcm_curves(out) == bcm_curves(mat):
        reuse = calibration["bcm"]
    return out, reuse, where
