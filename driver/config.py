"""Run configuration: the YAML schema, its defaults, and errors that name the field.

Every default of the tool lives in the schema: the common sections here (output, execution),
the `model:` sections in driver/bcm/section.py and driver/bpm/section.py, the `scenario:`
sections in driver/scenarios/ (a unit's own, or one several units share in sections.py), all
joined through driver/registry.py. A config is
checked completely before anything runs or is written: unknown keys, wrong types,
out-of-range values, an unregistered (model, scenario) pair and inconsistent choices are
refused with the field's path, the value given and what is allowed; defaults that depend on
other keys are filled in, so config.resolved.yaml holds every value the run used.
"""

from __future__ import annotations

import os
import re
import reprlib
from pathlib import Path
from typing import Annotated, Any, Union

import yaml
from pydantic import BaseModel, Field, ValidationError, field_validator, model_validator

from driver.bpm.section import BPMModel
from driver.registry import MODELS, scenario_sections, unit
from driver.schema import ConfigError, _Strict


class Output(_Strict):
    dir: Path | None = Field(None, description="run directory; default runs/<name> (filled in when the config is "
                                               "read)")
    plots: bool = Field(True, description="write the PNG plots and pictures (tables and the report are always "
                                          "written)")
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
                                "about one second of one core (driver/schedule.py; filled in when the config is "
                                "read)")

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


# the sections a config may hold, from the registry (driver/registry.py; the units are imported here)
SCENARIOS = scenario_sections()
MODEL_KINDS = tuple(MODELS)
SCENARIO_KINDS = tuple(SCENARIOS)
ModelSection = Annotated[Union[tuple(MODELS.values())], Field(discriminator="kind")]
ScenarioSection = Annotated[Union[tuple(SCENARIOS.values())], Field(discriminator="kind")]


class RunConfig(_Strict):
    """A whole run: which model, which scenario, where and how."""

    name: str = Field("run", pattern=r"^[A-Za-z0-9_][A-Za-z0-9_.\-]*$", max_length=100,
                      description="run name: a plain file name (letters, digits, _ . -; starts with a letter, "
                                  "digit or _, so never . or ..)")
    seed: int = Field(1, ge=1, le=2**31 - 1, description="seeds the packing/tessellation and orientations")
    # without model: and scenario:, a BPM shear run
    model: ModelSection = Field(default_factory=BPMModel,
                                description="the model and its parameters; model.kind chooses the section")
    scenario: ScenarioSection = Field(default_factory=SCENARIOS["shear"],
                                      description="the scenario and its parameters; scenario.kind chooses the "
                                                  "section, and (model.kind, scenario.kind) must be a registered pair")
    output: Output = Field(default_factory=Output, description="where the run goes and what it writes")
    execution: Execution = Field(default_factory=Execution,
                                 description="how the run executes: MPI ranks, checkpoints, chunks")

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
        # the pair must be registered; then its unit checks its sections together
        scenario = unit(self.model.kind, self.scenario.kind)
        scenario.check(self)
        # config.resolved.yaml holds the values the run uses, not null
        if self.output.dir is None:
            self.output.dir = Path("runs") / self.name
        if self.execution.chunk_steps is None:
            from driver.schedule import chunk_steps  # noqa: PLC0415

            self.execution.chunk_steps = chunk_steps(self.model.kind, scenario.elements(self), None)
        return self

    def run_dir(self) -> Path:
        return self.output.dir if self.output.dir is not None else Path("runs") / self.name  # before validation


# ------------------------------------------------------------------------------ loading
def _describe_allowed(model_cls: type[BaseModel] | None) -> str:
    if model_cls is None:
        return ""
    return "allowed keys: " + ", ".join(model_cls.model_fields)


def _tag(cls: type[BaseModel]) -> Any:
    """The `kind` a section of a discriminated union answers to (None: not such a section)."""
    field = cls.model_fields.get("kind")
    return field.default if field is not None else None


def _located(loc: tuple[Any, ...], root: type[BaseModel], data: Any) -> tuple[tuple[Any, ...], type[BaseModel] | None]:
    """An error's location as the input file spells it (the tag pydantic puts after a
    discriminated union, `model.bcm.interface`, left out: `model.interface`), and the pydantic
    class that owns the mapping there (for listing its keys; None below a list or a plain value).
    Walked from `root`, the class of the whole file."""
    shown: list[Any] = []
    cls: type[BaseModel] | None = root
    i = 0
    while i < len(loc):
        key = loc[i]
        shown.append(key)
        i += 1
        if cls is None or not isinstance(key, str) or key not in cls.model_fields:
            cls = None  # a list index, a key of a free mapping, or the unknown key itself
            continue
        ann = cls.model_fields[key].annotation
        candidates = [a for a in getattr(ann, "__args__", (ann,)) if isinstance(a, type) and issubclass(a, BaseModel)]
        data = data.get(key) if isinstance(data, dict) else None
        if len(candidates) > 1:
            tagged = [c for c in candidates if i < len(loc) and _tag(c) is not None and _tag(c) == loc[i]]
            if tagged:  # a discriminated union: the next element of loc is the tag, not a key
                candidates, i = tagged, i + 1
            elif isinstance(data, dict):
                candidates = [c for c in candidates if _tag(c) == data.get("kind")] or candidates
        cls = candidates[0] if candidates else None
    return tuple(shown), cls


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


def format_validation_error(exc: ValidationError, source: str, raw: Any, root: type[BaseModel] | None = None) -> str:
    """The problems of a refused input file, one line each: where (as the file spells it), what
    is wrong, the value given, and for an unknown key the keys allowed there. root: the class
    of the whole file (default: RunConfig; a material or compare file passes its own)."""
    root = RunConfig if root is None else root
    errors = exc.errors()
    lines = [f"{source}: invalid configuration ({len(errors)} problem(s))"]
    for err in errors[:SHOWN_PROBLEMS]:
        loc, _ = _located(tuple(err["loc"]), root, raw)
        path = clip(".".join(str(p) for p in loc)) or "<top level>"
        msg = err["msg"].removeprefix("Value error, ")
        if err["type"] == "extra_forbidden":
            _, owner = _located(tuple(err["loc"][:-1]), root, raw)
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

