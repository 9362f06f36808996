"""Run configuration: the YAML schema, its defaults, and errors that name the field.

Every default of the tool lives in this file. A config is checked completely before anything
runs or is written: unknown keys, wrong types, out-of-range values and inconsistent choices
are refused with the field's path, the value given and what is allowed.
"""

from __future__ import annotations

import math
import os
import re
import reprlib
from pathlib import Path
from typing import Annotated, Any, Literal, Union

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator


class ConfigError(ValueError):
    """An input file was refused; the message names file, field, value and what is allowed."""


class _Strict(BaseModel):
    # allow_inf_nan=False: .inf/.nan are refused in every float field of every section, list
    # items included (a non-finite damping or time hangs LAMMPS; tested in test_validation.py)
    model_config = ConfigDict(extra="forbid", validate_default=True, allow_inf_nan=False)


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
    interface_stiffness: Literal["per_interface", "per_area"] = Field(
        "per_interface", description="per_interface: every interface has the configured k_n, k_t (the published "
                                     "model); per_area: k_n, k_t times S / <S>, the interface's area over the mean "
                                     "bonded area, so the Griffith threshold is a stress criterion")
    min_interface_area: float = Field(
        0.0, ge=0.0, lt=1.0, description="shared faces smaller than this fraction of the median face area are not "
                                         "bonded (their cells only touch as contacts); 0 = every face bonded, the "
                                         "published model. A_0 and D_w count bonded interfaces only")
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
    thermo_every: int = Field(10, ge=1, description="steps between energy records: 10 samples a 2 µs contact "
                                                   "at 50 points or more for time steps up to 4e-9 s")
    dump_every: int = Field(0, ge=0, description="steps between cell dumps; 0 = start and end only")


class Output(_Strict):
    dir: Path | None = Field(None, description="run directory; default runs/<name>")
    plots: bool = True
    count_above: list[Annotated[float, Field(ge=1)]] = Field(
        [10, 100], description="grain masses (in particle masses) whose grain counts per frame the frame table "
                               "holds, besides SPEC 2.5's small-grain cut")
    animation: bool = Field(False, description="also write plots/fragmentation.gif from the periodic dumps "
                                               "(needs scenario.dump_every > 0)")

    @field_validator("dir", mode="before")
    @classmethod
    def _expand(cls, value: Any) -> Any:
        """`~`, `~user`, `$VAR` and `${VAR}` expanded; an unset variable or unknown user is refused
        rather than becoming a directory literally named `$VAR`."""
        if not isinstance(value, (str, os.PathLike)):
            return value
        raw = os.fspath(value)
        if not raw.strip():
            raise ValueError("must not be empty (leave it out for runs/<name>)")
        names = re.findall(r"\$(?:\{([^}]*)\}|([A-Za-z_][A-Za-z0-9_]*))", raw)
        unset = [a or b for a, b in names if (a or b) not in os.environ]
        if unset:
            raise ValueError(f"environment variable {unset[0]} is not set")
        expanded = os.path.expandvars(os.path.expanduser(raw))
        if expanded.startswith("~"):
            raise ValueError(f"cannot expand {expanded.split('/', 1)[0]} (no such user)")
        return expanded


class Execution(_Strict):
    np: int = Field(1, ge=1, le=4096, description="MPI ranks for LAMMPS")
    checkpoint_every: str = Field(
        "10min", pattern=r"^\s*\d+(\.\d*)?\s*(s|min|h|steps)\s*$",
        description="how often a running run writes a checkpoint (restart file + the driver's records), as wall "
                    "time ('90s', '10min', '2h') or steps ('50000steps'); the last two are kept, and one is "
                    "always written when a run is stopped (SIGINT, SIGTERM)")
    chunk_steps: int | None = Field(
        None, ge=1, description="steps per `run` command between which a stop or checkpoint can happen; default "
                                "about one second of one core (driver/schedule.py)")

    def _checkpoint(self) -> tuple[float, str]:
        text = self.checkpoint_every.strip()
        unit = next(u for u in ("steps", "min", "s", "h") if text.endswith(u))
        return float(text[: -len(unit)]), unit

    def checkpoint_steps(self) -> int | None:
        """Steps between checkpoints when given in steps, else None."""
        value, unit = self._checkpoint()
        return max(1, int(value)) if unit == "steps" else None

    def checkpoint_seconds(self) -> float | None:
        """Wall seconds between checkpoints when given as a time, else None."""
        value, unit = self._checkpoint()
        return None if unit == "steps" else value * {"s": 1.0, "min": 60.0, "h": 3600.0}[unit]


MODEL_KINDS = ("bpm", "bcm")
SCENARIO_KINDS = ("shear", "impact")


class RunConfig(_Strict):
    """A whole run: which model, which scenario, where and how."""

    name: str = Field("run", pattern=r"^[A-Za-z0-9_][A-Za-z0-9_.\-]*$", max_length=100,
                      description="run name: a plain file name (letters, digits, _ . -; starts with a letter, "
                                  "digit or _, so never . or ..)")
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


#: Longest `(got ...)` value and field path shown in a message.
SHOWN_CHARS = 80
#: Problems listed in one message; the rest are counted.
SHOWN_PROBLEMS = 20

_repr = reprlib.Repr()
_repr.maxlevel, _repr.maxlist, _repr.maxdict, _repr.maxtuple = 2, 6, 4, 6
_repr.maxstring, _repr.maxother, _repr.maxlong = SHOWN_CHARS, SHOWN_CHARS, SHOWN_CHARS


def clip(text: str, limit: int = SHOWN_CHARS) -> str:
    """`text` cut to at most `limit` characters, an ellipsis marking the cut."""
    return text if len(text) <= limit else text[: limit - 3] + "..."


def short_repr(value: Any, limit: int = SHOWN_CHARS) -> str:
    """repr of a value, never longer than `limit` characters (reprlib stops inside big or
    self-referencing containers before the whole repr is built)."""
    return clip(_repr.repr(value), limit)


def format_validation_error(exc: ValidationError, source: str, raw: Any) -> str:
    errors = exc.errors()
    lines = [f"{source}: invalid configuration ({len(errors)} problem(s))"]
    for err in errors[:SHOWN_PROBLEMS]:
        loc = tuple(p for p in err["loc"] if not (isinstance(p, str) and p in MODEL_KINDS + SCENARIO_KINDS))
        path = clip(".".join(str(p) for p in loc)) or "<top level>"
        msg = err["msg"].removeprefix("Value error, ")
        if err["type"] == "extra_forbidden":
            owner = _model_at(loc[:-1], raw)
            msg = f"unknown key '{clip(str(loc[-1]))}'; {_describe_allowed(owner)}"
        elif err["type"] == "finite_number":
            msg = "must be a finite number (.inf and .nan are not allowed)"
        if not loc and " is missing; " in msg:  # the before-validator names its own field
            path, msg = msg.split(" is missing; ", 1)
            msg = "missing; " + msg
        value = err.get("input")
        shown = "" if err["type"] in {"extra_forbidden", "missing"} or isinstance(value, dict) else \
            f" (got {short_repr(value)})"
        lines.append(f"  {path}: {msg}{shown}")
    if len(errors) > SHOWN_PROBLEMS:
        lines.append(f"  ... and {len(errors) - SHOWN_PROBLEMS} more")
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


#: Largest input file read, bytes; a configuration is a few hundred bytes.
MAX_CONFIG_BYTES = 1 << 20
#: Largest document, counted in YAML nodes with every alias expanded (a full config has about
#: 100); refuses "billion laughs" alias bombs before anything walks or prints the data.
MAX_YAML_NODES = 100_000
#: Deepest nesting of YAML collections (a config nests 3 deep; the composer recurses per level).
MAX_YAML_DEPTH = 50


class YamlLimitError(yaml.YAMLError):
    """A YAML document beyond MAX_YAML_NODES / MAX_YAML_DEPTH."""


class LimitedLoader(yaml.SafeLoader):
    """yaml.SafeLoader that bounds nesting depth while composing and the alias-expanded size
    of the document before constructing Python objects from it."""

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        self._depth += 1
        try:
            if self._depth > MAX_YAML_DEPTH:
                raise YamlLimitError(f"nested deeper than {MAX_YAML_DEPTH} levels")
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def get_single_data(self) -> Any:
        node = self.get_single_node()
        if node is None:
            return None
        expanded_size(node, MAX_YAML_NODES)
        return self.construct_document(node)


def expanded_size(root: yaml.Node, limit: int) -> int:
    """Number of nodes of the document with every alias expanded (a scalar counts 1, a collection
    1 + its items, a mapping's keys and values); YamlLimitError past `limit` or on a
    self-referencing alias. Each distinct node is visited once (iterative, memoised)."""
    size: dict[int, int] = {}
    on_path: set[int] = set()
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, done = stack.pop()
        key = id(node)
        if done:
            on_path.discard(key)
            total = 1 + sum(size[id(c)] for c in _children(node))
            if total > limit:
                raise YamlLimitError(f"more than {limit:,} values once aliases (*name) are expanded")
            size[key] = total
            continue
        if key in size:
            continue
        if key in on_path:
            raise YamlLimitError("an alias (*name) refers to a collection that contains it")
        on_path.add(key)
        stack.append((node, True))
        stack.extend((c, False) for c in _children(node) if id(c) not in size)
    return size[id(root)]


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    if isinstance(node, yaml.MappingNode):
        return [n for pair in node.value for n in pair]
    return []


def read_config_text(path: Path) -> str:
    """The file's text: at most MAX_CONFIG_BYTES, UTF-8 (a BOM is allowed), else ConfigError."""
    try:
        with open(path, "rb") as fh:
            raw = fh.read(MAX_CONFIG_BYTES + 1)
            size = os.fstat(fh.fileno()).st_size
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read input file ({exc.strerror})") from None
    if len(raw) > MAX_CONFIG_BYTES:
        got = f"{size:,} bytes" if size > MAX_CONFIG_BYTES else f"over {MAX_CONFIG_BYTES:,} bytes"
        raise ConfigError(f"{path}: input file too large ({got}; a configuration may have at most "
                          f"{MAX_CONFIG_BYTES:,} bytes)")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise ConfigError(f"{path}: not UTF-8 text: byte offset {exc.start} (line {line}) is "
                          f"0x{raw[exc.start]:02x} ({exc.reason}); save the file as UTF-8") from None


def load_yaml(text: str, source: str) -> Any:
    """Parse YAML text with LimitedLoader; ConfigError (short message) on a syntax error or a limit."""
    loader = None
    try:
        loader = LimitedLoader(text)  # the reader refuses control characters here
        loader.name = source  # error marks name the file, not "<unicode string>"
        return loader.get_single_data()
    except YamlLimitError as exc:
        raise ConfigError(f"{source}: YAML refused: {exc}") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{source}: not valid YAML: {clip(str(exc), 1000)}") from None
    finally:
        if loader is not None:
            loader.dispose()


def load_config(path: str | Path) -> RunConfig:
    """Read and validate an input YAML file (size, encoding, YAML limits, then the schema)."""
    path = Path(path)
    return parse_config(load_yaml(read_config_text(path), str(path)), str(path))


def resolved_yaml(cfg: RunConfig) -> str:
    """The config with every default filled in, as YAML (what the run actually used)."""
    return yaml.safe_dump(cfg.model_dump(mode="json"), sort_keys=False)


def steps_for_strain(strain: float, strain_rate: float, timestep: float) -> int:
    """Number of steps to reach a true strain at a given rate (rounded to the nearest step)."""
    return int(math.floor(strain / (strain_rate * timestep) + 0.5))
