"""Run configuration: the YAML schema, its defaults, and errors that name the field.

Every default of the tool lives in this file. A config is checked completely before anything
runs or is written: unknown keys, wrong types, out-of-range values and inconsistent choices
are refused with the field's path, the value given and what is allowed.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Literal, Union

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator


class ConfigError(ValueError):
    """An input file was refused; the message names file, field, value and what is allowed."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", validate_default=True)


# ---------------------------------------------------------------------------- BPM (SPEC 2)
class BPMModel(_Strict):
    """Clemmer-Robbins bonded particle model (SPEC 2.1-2.2), LJ reduced units (a = m = u = 1)."""

    kind: Literal["bpm"] = "bpm"
    dimension: Literal[2, 3] = Field(2, description="2: bidisperse disks; 3: monodisperse spheres")
    L: float = Field(24.0, ge=6.0, le=5000.0, description="periodic box side, in particle diameters a")
    packing_fraction: float | None = Field(
        None, gt=0.3, lt=0.95,
        description="area/volume fraction before relaxation; default just above jamming (see packing.py)")
    lambda_c: float = Field(1.05, gt=1.0, le=2.0, description="critical bond stretch r/r0 (Eq. 2)")
    theta_c_deg: float = Field(10.0, gt=0.0, lt=180.0, description="critical angle change (Eq. 3), degrees")
    k_A: float = Field(4.0, ge=0.0, le=100.0, description="angle stiffness (Eq. 3), units of u")
    gamma: float = Field(50.0, ge=0.0, description="damping (Eq. 5), units sqrt(m u)/a")
    timestep: float = Field(0.005, gt=0.0, le=0.02, description="velocity-Verlet step, units sqrt(m a^2/u)")
    bond_max_length: float | None = Field(
        None, gt=1.0, description="3D Delaunay edge cut; default 5/4 a (SPEC 2.1, see network.py); unused in 2D")
    skin: float = Field(0.3, gt=0.0, le=2.0, description="neighbour-list skin, units of a")


class ShearScenario(_Strict):
    """Constant-volume shear at a true strain rate (SPEC 2.4): 2D pure shear, 3D triaxial."""

    kind: Literal["shear"] = "shear"
    strain_rate: float = Field(1e-3, gt=0.0, le=0.1, description="true strain rate edot, units 1/tau")
    max_strain: float = Field(1.0, gt=0.0, le=3.0, description="final true strain eps = edot t")
    measure_strains: list[Annotated[float, Field(gt=0.0)]] = Field(
        default_factory=lambda: [0.1, 0.25, 0.5, 1.0],
        description="strains at which bond snapshots are written and grains counted")
    thermo_every: int = Field(200, ge=1, description="steps between stress/progress records")
    dump_every: int = Field(0, ge=0, description="steps between atom+bond dumps; 0 = only at measure strains")

    @model_validator(mode="after")
    def _strains_within_run(self) -> "ShearScenario":
        bad = [s for s in self.measure_strains if s > self.max_strain * (1 + 1e-12)]
        if bad:
            raise ValueError(f"measure_strains {bad} exceed max_strain = {self.max_strain}")
        if sorted(self.measure_strains) != self.measure_strains or len(set(self.measure_strains)) != len(
                self.measure_strains):
            raise ValueError("measure_strains must be strictly increasing")
        return self


# ---------------------------------------------------------------------------- BCM (SPEC 1)
class CohesiveInterface(_Strict):
    """Glued face between two cells (SPEC 1.2-1.3), whole-interface values, SI units."""

    kn: float = Field(1e7, gt=0.0, description="normal stiffness, N/m")
    kt: float = Field(0.8e7, gt=0.0, description="tangential stiffness, N/m")
    en2: float = Field(0.999, ge=0.0, le=1.0, description="squared normal restitution e_n^2")
    G_c: float = Field(1.0, gt=0.0, description="fracture energy, J/m^2")


class FrictionalContact(_Strict):
    """Cohesionless contact: broken interfaces, cell-cell and cell-plane contacts (SPEC 1.2-1.3)."""

    kn: float = Field(1e8, gt=0.0, description="normal stiffness, N/m")
    kt: float = Field(8e7, gt=0.0, description="tangential stiffness, N/m")
    en2: float = Field(0.001, ge=0.0, le=1.0, description="squared normal restitution e_n^2")
    mu: float = Field(0.3, ge=0.0, description="Coulomb friction coefficient mu_s")


class BCMModel(_Strict):
    """Bonded cell method (SPEC 1): a particle tessellated into rigid Voronoi cells, SI units."""

    kind: Literal["bcm"] = "bcm"
    shape: Literal["truncated_pentakis_dodecahedron", "cube", "icosphere_like"] = "truncated_pentakis_dodecahedron"
    diameter: float = Field(2e-3, gt=0.0, description="parent diameter, m")
    diameter_kind: Literal["circumscribed", "equal_volume"] = "circumscribed"
    n_cells: int = Field(1728, ge=2, le=200_000, description="number of Voronoi cells N_c")
    density: float = Field(6000.0, gt=0.0, description="solid density rho_s, kg/m^3")
    rounding: float = Field(0.02, ge=0.0, lt=0.3,
                            description="rounding radius r_m as a fraction of the mean cell size h = (V/N_c)^(1/3)")
    interface: CohesiveInterface = Field(default_factory=CohesiveInterface)
    contact: FrictionalContact = Field(default_factory=FrictionalContact)
    griffith_energy: Literal["stored", "rockable", "literal"] = Field(
        "stored", description="energy in the Griffith criterion (SPEC 1.2): what the springs store (default), "
                              "Rockable's N_p-fold sum, or Eq. 5 read literally (1/N_p)")
    lloyd_tol: float = Field(2e-3, gt=0.0, lt=0.1, description="Lloyd stop: RMS seed step / h")
    lloyd_max_iter: int = Field(400, ge=0, le=10_000)


class ImpactScenario(_Strict):
    """One particle hits a rigid plane (SPEC 1.4)."""

    kind: Literal["impact"] = "impact"
    velocity: float = Field(4.5, gt=0.0, le=100.0, description="impact velocity v_0 normal to the plane, m/s")
    gap: float = Field(1e-3, ge=0.0, lt=1.0, description="initial gap to the plane, fraction of the diameter")
    steps_per_period: float = Field(50.0, ge=10.0, description="time step = shortest contact period / this")
    max_time: float = Field(5e-4, gt=0.0, description="hard stop on simulated time, s")
    settle_window: float = Field(5e-6, gt=0.0, description="window over which the outcome must not change, s")
    ke_tolerance: float = Field(1e-3, gt=0.0, lt=1.0,
                                description="settled when kinetic energy changes by less than this fraction "
                                            "over a window with no break and the plane unloaded")
    thermo_every: int = Field(100, ge=1, description="steps between energy records")
    dump_every: int = Field(0, ge=0, description="steps between cell dumps; 0 = start and end only")


class Output(_Strict):
    dir: Path | None = Field(None, description="run directory; default runs/<name>")
    plots: bool = True
    count_above: list[Annotated[float, Field(ge=1)]] = Field(
        [10, 100], description="grain masses (in particle masses) whose grain counts per frame the frame table "
                               "holds, besides SPEC 2.5's small-grain cut")
    animation: bool = Field(False, description="also write plots/fragmentation.gif from the periodic dumps "
                                               "(needs scenario.dump_every > 0)")


class Execution(_Strict):
    np: int = Field(1, ge=1, le=4096, description="MPI ranks for LAMMPS")


MODEL_KINDS = ("bpm", "bcm")
SCENARIO_KINDS = ("shear", "impact")


class RunConfig(_Strict):
    """A whole run: which model, which scenario, where and how."""

    name: str = Field("run", pattern=r"^[A-Za-z0-9_.\-]+$", description="run name (directory-safe)")
    seed: int = Field(1, ge=1, le=2**31 - 1, description="seeds the packing/tessellation and orientations")
    model: Annotated[Union[BPMModel, BCMModel], Field(discriminator="kind")] = Field(default_factory=BPMModel)
    scenario: Annotated[Union[ShearScenario, ImpactScenario], Field(discriminator="kind")] = Field(
        default_factory=ShearScenario)
    output: Output = Field(default_factory=Output)
    execution: Execution = Field(default_factory=Execution)

    @model_validator(mode="before")
    @classmethod
    def _require_kinds(cls, data: Any) -> Any:
        # A clear message when a section lacks its 'kind' (pydantic's is cryptic).
        if isinstance(data, dict):
            for section, kinds in (("model", MODEL_KINDS), ("scenario", SCENARIO_KINDS)):
                sub = data.get(section)
                if isinstance(sub, dict) and "kind" not in sub:
                    raise ValueError(f"{section}.kind is missing; allowed: {', '.join(kinds)}")
        return data

    @model_validator(mode="after")
    def _consistent(self) -> "RunConfig":
        if self.scenario.kind == "shear" and self.model.kind != "bpm":
            raise ValueError("scenario 'shear' needs model kind 'bpm' (BCM shear is not available yet)")
        if self.scenario.kind == "impact" and self.model.kind != "bcm":
            raise ValueError("scenario 'impact' needs model kind 'bcm' (BPM particle impact is not available yet)")
        if self.output.animation and self.scenario.dump_every == 0:
            raise ValueError("output.animation needs periodic dumps: set scenario.dump_every > 0 (steps between "
                             "dumps), or animation: false")
        if self.model.kind == "bpm" and self.scenario.kind == "shear":
            steps = self.scenario.max_strain / (self.scenario.strain_rate * self.model.timestep)
            if steps > 2e9:
                raise ValueError(f"max_strain / (strain_rate * timestep) = {steps:.3g} steps is beyond 2e9")
        return self

    def run_dir(self) -> Path:
        return self.output.dir if self.output.dir is not None else Path("runs") / self.name


# ------------------------------------------------------------------------------ loading
def _describe_allowed(model_cls: type[BaseModel] | None) -> str:
    if model_cls is None:
        return ""
    return "allowed keys: " + ", ".join(model_cls.model_fields)


def _model_at(loc: tuple[Any, ...], data: Any) -> type[BaseModel] | None:
    """The pydantic class that owns the mapping at `loc` (for listing allowed keys)."""
    cls: type[BaseModel] | None = RunConfig
    for key in loc:
        if cls is None or not isinstance(key, str):
            return None
        if key not in cls.model_fields:
            # a discriminated-union tag such as 'bpm' appears in loc: resolve it
            return None
        ann = cls.model_fields[key].annotation
        candidates = [a for a in getattr(ann, "__args__", (ann,)) if isinstance(a, type) and issubclass(a, BaseModel)]
        if not candidates:
            return None
        if len(candidates) > 1 and isinstance(data, dict):
            kind = (data.get(key) or {}).get("kind") if isinstance(data.get(key), dict) else None
            candidates = [c for c in candidates if c.model_fields.get("kind") and c.model_fields["kind"].default == kind] or candidates
        cls = candidates[0]
        data = data.get(key) if isinstance(data, dict) else None
    return cls


def format_validation_error(exc: ValidationError, source: str, raw: Any) -> str:
    lines = [f"{source}: invalid configuration ({exc.error_count()} problem(s))"]
    for err in exc.errors():
        loc = tuple(p for p in err["loc"] if not (isinstance(p, str) and p in MODEL_KINDS + SCENARIO_KINDS))
        path = ".".join(str(p) for p in loc) or "<top level>"
        msg = err["msg"].removeprefix("Value error, ")
        if err["type"] == "extra_forbidden":
            owner = _model_at(loc[:-1], raw)
            msg = f"unknown key '{loc[-1]}'; {_describe_allowed(owner)}"
        elif err["type"] == "union_tag_invalid" or err["type"] == "literal_error":
            msg = f"{msg}"
        if not loc and " is missing; " in msg:  # the before-validator names its own field
            path, msg = msg.split(" is missing; ", 1)
            msg = "missing; " + msg
        value = err.get("input")
        shown = "" if err["type"] in {"extra_forbidden", "missing"} or isinstance(value, dict) else f" (got {value!r})"
        lines.append(f"  {path}: {msg}{shown}")
    return "\n".join(lines)


def parse_config(data: Any, source: str = "<config>") -> RunConfig:
    """Validate a mapping (from YAML) into a RunConfig, or raise ConfigError."""
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: the top level must be a mapping of keys, got {type(data).__name__}")
    try:
        return RunConfig.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(exc, source, data)) from None


def load_config(path: str | Path) -> RunConfig:
    """Read and validate an input YAML file."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read input file ({exc.strerror})") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {exc}") from None
    return parse_config(data, str(path))


def resolved_yaml(cfg: RunConfig) -> str:
    """The config with every default filled in, as YAML (what the run actually used)."""
    return yaml.safe_dump(cfg.model_dump(mode="json"), sort_keys=False)


def steps_for_strain(strain: float, strain_rate: float, timestep: float) -> int:
    """Number of steps to reach a true strain at a given rate (rounded to the nearest step)."""
    return int(math.floor(strain / (strain_rate * timestep) + 0.5))
