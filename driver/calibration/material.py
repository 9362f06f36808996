"""The input of `driver calibrate`: a target material (SI units) and, per model, the resolution
wanted (issue 12, point 3; SPEC 3: "Calibrate them to the same density, Young's modulus,
Poisson's ratio and fracture energy").

    name: glass
    material: {density: 2500, E: 7.0e10, nu: 0.22, G_c: 8.0}   # or K_IC instead of G_c
    bcm: {diameter: 2.0e-3, n_cells: 1728}                    # or cell_size (m)
    bpm: {dimension: 3, diameter: 2.0e-3, particles_across: 16} # or particle_size (m)
    curves: {bpm_moduli: {axes: {model.k_A: [0, 2, 4]}, seeds: 1}}   # optional

`curves:` changes the sweeps that measure a calibration curve (driver/calibration/curves.py;
the same keys as a sweep file's scales: `base` (dotted keys of the base config), `axes`, `zip`,
`seeds`); a changed curve is another cache entry.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Literal

from pydantic import Field, ValidationError, model_validator

from driver.config import format_validation_error, load_yaml, read_config_text
from driver.schema import ConfigError, _Strict


class Target(_Strict):
    """The material both models are calibrated to (SI units)."""

    density: float = Field(..., gt=0.0, le=1e5, description="solid density, kg/m^3")
    E: float = Field(..., gt=0.0, le=1e13, description="Young's modulus, Pa")
    nu: float = Field(..., gt=-1.0, lt=0.5, description="Poisson's ratio (-1 < nu < 1/2)")
    G_c: float | None = Field(None, gt=0.0, le=1e7, description="fracture energy, J/m^2 (or K_IC)")
    K_IC: float | None = Field(None, gt=0.0, le=1e9, description="mode-I fracture toughness, Pa m^(1/2) (or G_c)")

    @model_validator(mode="after")
    def _one_toughness(self) -> "Target":
        if (self.G_c is None) == (self.K_IC is None):
            raise ValueError("give exactly one of G_c (J/m^2) and K_IC (Pa m^(1/2))")
        return self

    def plane_modulus(self, dimension: int) -> float:
        """E' of G_c = K_IC^2 / E' (SPEC 3): E in 2D (the network's own 2D elasticity, plane
        stress), E / (1 - nu^2) in 3D (plane strain: the thin periodic slab of the mode-I test,
        and the interior of a particle)."""
        return self.E if dimension == 2 else self.E / (1.0 - self.nu ** 2)

    def toughness(self, dimension: int) -> tuple[float, float]:
        """(G_c, K_IC) of the target, one given and the other from G_c = K_IC^2 / E'."""
        ep = self.plane_modulus(dimension)
        if self.K_IC is not None:
            return self.K_IC ** 2 / ep, self.K_IC
        return self.G_c, math.sqrt(self.G_c * ep)


class BcmResolution(_Strict):
    """The BCM particle the parameters are for: its cells' size sets k_n (E ~ k_n / h)."""

    shape: Literal["truncated_pentakis_dodecahedron", "cube", "icosphere_like"] = Field(
        "truncated_pentakis_dodecahedron", description="parent shape, as the BCM's model.shape")
    diameter: float = Field(2e-3, gt=0.0, description="parent diameter, m")
    diameter_kind: Literal["circumscribed", "equal_volume"] = Field(
        "circumscribed", description="which diameter `diameter` is, as the BCM's model.diameter_kind")
    n_cells: int | None = Field(None, ge=2, le=200_000, description="cells in the particle (default 1728, or give "
                                                                    "cell_size)")
    cell_size: float | None = Field(None, gt=0.0, description="mean cell size h = (V / N_c)^(1/3), m (instead of "
                                                               "n_cells)")

    @model_validator(mode="after")
    def _one_size(self) -> "BcmResolution":
        if self.n_cells is not None and self.cell_size is not None:
            raise ValueError("give n_cells or cell_size, not both")
        if self.n_cells is None and self.cell_size is None:
            self.n_cells = 1728
        return self

    def h(self) -> float:
        """The mean cell size, m."""
        if self.cell_size is not None:
            return self.cell_size
        from driver.bcm.particle import parent_shape  # noqa: PLC0415

        return (parent_shape(self.shape, self.diameter, self.diameter_kind).volume / self.n_cells) ** (1.0 / 3.0)


class BpmResolution(_Strict):
    """The BPM solid the parameters are for: its particle diameter a is the length unit."""

    dimension: Literal[2, 3] = Field(3, description="2: bidisperse disks (a slab of thickness a); 3: spheres")
    diameter: float = Field(2e-3, gt=0.0, description="particle (grain) diameter, m")
    particles_across: float | None = Field(None, ge=2.0, le=1e4, description="particles across the diameter: a = "
                                                                            "diameter / particles_across")
    particle_size: float | None = Field(None, gt=0.0, description="the particle diameter a, m (instead of "
                                                                   "particles_across)")
    theta_c_deg: float = Field(10.0, gt=0.0, lt=180.0, description="critical angle change, degrees (SPEC 2.2 "
                                                                   "default; kept as given)")
    packing: Literal["contact", "lj_minimum"] | None = Field(
        None, description="3D: the preparation of the solid (model.packing); default lj_minimum here: its bonded "
                          "neighbours lie beyond the repulsion's diameter a, so no bond breaks inside the "
                          "repulsion at the small lambda_c a brittle material needs (on contact, 60 % of the bonds "
                          "overlap, and below lambda_c = 1.026 breaks create energy); 2D: leave out")

    @model_validator(mode="after")
    def _one_size(self) -> "BpmResolution":
        if (self.particles_across is None) == (self.particle_size is None):
            raise ValueError("give exactly one of particles_across and particle_size (m)")
        if self.packing is not None and self.dimension == 2:
            raise ValueError("packing: a 3D option (the 2D solid has one preparation)")
        if self.packing is None and self.dimension == 3:
            self.packing = "lj_minimum"
        return self

    def a(self) -> float:
        """The length unit a (particle diameter), m."""
        return self.particle_size if self.particle_size is not None else self.diameter / self.particles_across


class CurveChange(_Strict):
    """Changes to the sweep of one calibration curve (as a sweep file's scales entry)."""

    base: dict[str, Any] = Field(default_factory=dict, description="dotted keys of the base run config")
    axes: dict[str, Any] | None = Field(None, description="the varied keys and their values, as a sweep file's "
                                                          "axes (replace the curve's own)")
    zip: list[Any] | None = Field(None, description="groups of keys varied together, as a sweep file's zip")
    seeds: Any = Field(None, description="seeds 1..n, or a list of seeds (replace the curve's own)")


class MaterialFile(_Strict):
    """A `driver calibrate` input (module docstring)."""

    name: str = Field("material", min_length=1, max_length=100, pattern=r"^[A-Za-z0-9_.-]+$",
                      description="the material's name: the output directory is runs/calibrate_<name>")
    material: Target = Field(..., description="the target material, SI units")
    bcm: BcmResolution | None = Field(None, description="calibrate the BCM, for this particle and cell size")
    bpm: BpmResolution | None = Field(None, description="calibrate the BPM, for this solid and particle size")
    curves: dict[str, CurveChange] = Field(default_factory=dict,
                                           description="changes to the sweeps of the calibration curves, by curve "
                                                       "name (bpm_moduli, bpm_mode1, bcm_moduli, bcm_fracture)")

    @model_validator(mode="after")
    def _some_model(self) -> "MaterialFile":
        if self.bcm is None and self.bpm is None:
            raise ValueError("name at least one model to calibrate: a bcm: and/or a bpm: section")
        return self


def read_input(path: str | Path, cls, keys: str):
    """Read a YAML input file into the pydantic model `cls` (keys: its top-level keys, for the
    message), then check its `curves:` names; ConfigError naming the file, field and what is
    allowed."""
    path = Path(path)
    source = str(path)
    data = load_yaml(read_config_text(path), source)
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: the top level must be a mapping ({keys})")
    try:
        out = cls.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(exc, source, data, cls)) from None
    from driver.calibration.curves import CURVES  # noqa: PLC0415

    unknown = sorted(set(out.curves) - set(CURVES))
    if unknown:
        raise ConfigError(f"{source}: curves: unknown curve(s) {', '.join(unknown)}; the curves are "
                          f"{', '.join(sorted(CURVES))}")
    return out


def load_material(path: str | Path) -> MaterialFile:
    """Read and validate a material file (read_input)."""
    return read_input(path, MaterialFile, "name, material, bcm, bpm, curves")
