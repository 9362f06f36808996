"""`driver sweep`: one base config, some keys varied, one run directory per combination.

A sweep is given either as a sweep file or as a run config with `--set KEY=V1,V2,...`
(one axis per `--set`; on a sweep file `--set` adds axes). A sweep file (e.g. `sweep.yaml`):

    base: ../bcm_impact.yaml          # a config: a path relative to this file, or a mapping
    axes:                             # crossed as a grid, in this order
      scenario.velocity: {logspace: [0.5, 10, 12]}
      model.interface.G_c: [0.2, 0.5, 1.0, 2.0]
    zip:                              # groups whose keys vary together (equal lengths)
      - {model.n_cells: [300, 1728], scenario.max_time: [1.0e-4, 4.0e-4]}
    seeds: 5                          # seeds 1..5, or a list [3, 7]
    scales:                           # reduced variants: driver sweep FILE --scale small
      small:
        base: {model.n_cells: 300}    # dotted keys set in the base config
        axes: {scenario.velocity: {logspace: [0.5, 10, 6]}}   # replace (or add) these axes
        seeds: 2                      # replaces seeds (zip: would replace the zip groups)

A value list may be a range: `{linspace: [a, b, n]}` is n values from a to b evenly spaced,
`{logspace: [a, b, n]}` n values from a to b geometrically spaced (a and b are the end values
themselves, not exponents; both > 0). Grid order: the axes, the zip groups, the `--set` axes,
then the seeds. A scale's sweep goes to runs/<sweep file stem>_<scale> by default.

Each run's directory, under the sweep directory, is named from its varied values, e.g.
`velocity0.5_G_c0.2_seed1`: each key by its last dotted component (more of the path where two
keys share it), each value compact (floats as %g, with more digits where %g would merge two
values of a key). Every combination is validated before anything runs. Runs that already
finished are kept, so re-running a sweep resumes it; the sweep table (one row per run: the
varied values and the run's summary) is rewritten at the end.
"""

from __future__ import annotations

import copy
import itertools
import json
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import yaml

from driver.config import ConfigError, RunConfig, load_config, load_yaml, parse_config, read_config_text
from driver.rundir import MARKER, expand_path, has_marker, is_finished, run_state

#: Top-level keys of a sweep file; a YAML file with any of them is read as a sweep file.
SWEEP_KEYS = ("base", "axes", "zip", "seeds", "scales")
#: Keys of one entry of `scales:`.
SCALE_KEYS = ("base", "axes", "zip", "seeds")
#: Most runs one sweep may expand to (each is validated before anything runs).
MAX_RUNS = 10_000
#: Significant digits of a float in a directory name (%g); raised per key until its values differ.
NAME_DIGITS = 6
#: Significant digits kept of a linspace/logspace value (drops 0.30000000000000004 noise).
RANGE_DIGITS = 12

#: A group of keys varied together and its rows of values (an axis is a group of one key).
Group = tuple[tuple[str, ...], list[tuple[Any, ...]]]


def parse_assignment(text: str) -> tuple[str, list[Any]]:
    """'scenario.velocity=1,3,6' -> ('scenario.velocity', [1, 3, 6]) (values parsed as YAML)."""
    if "=" not in text:
        raise ConfigError(f"--set {text!r}: expected KEY.PATH=V1,V2,...")
    key, values = text.split("=", 1)
    parsed = [yaml.safe_load(v) for v in values.split(",") if v.strip() != ""]
    if not key or not parsed:
        raise ConfigError(f"--set {text!r}: expected KEY.PATH=V1,V2,...")
    return key.strip(), parsed


def _assign(data: dict, dotted: str, value: Any) -> None:
    keys = dotted.split(".")
    node = data
    for k in keys[:-1]:
        node = node.setdefault(k, {})
        if not isinstance(node, dict):
            raise ConfigError(f"{dotted}: '{k}' is not a section")
    node[keys[-1]] = value


# ------------------------------------------------------------------------------ values
def value_list(spec: Any, where: str) -> list[Any]:
    """The values of one key: a non-empty list as it is, or a range.

    `{linspace: [a, b, n]}`: n values from a to b, evenly spaced, both ends included (integers
    when a and b are integers and every value is whole). `{logspace: [a, b, n]}`: n values from
    a to b geometrically spaced; a and b are the end values themselves (not powers of ten) and
    must be > 0. Range values are rounded to RANGE_DIGITS significant digits. `where` names
    the key in messages.
    """
    if isinstance(spec, list):
        if not spec:
            raise ConfigError(f"{where}: an empty list of values")
        return list(spec)
    usage = "expected a list of values, {linspace: [a, b, n]} or {logspace: [a, b, n]}"
    if not isinstance(spec, dict) or len(spec) != 1 or next(iter(spec)) not in ("linspace", "logspace"):
        raise ConfigError(f"{where}: {usage} (got {spec!r})")
    kind, args = next(iter(spec.items()))
    numbers = isinstance(args, list) and len(args) == 3 and all(
        isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in args)
    if not numbers or not isinstance(args[2], int) or not 1 <= args[2] <= MAX_RUNS:
        raise ConfigError(f"{where}: {kind} takes [a, b, n]: finite numbers a, b and a count 1 <= n <= "
                          f"{MAX_RUNS:,} (got {args!r})")
    a, b, n = args
    if kind == "logspace":
        if a <= 0 or b <= 0:
            raise ConfigError(f"{where}: logspace [a, b, n] needs a > 0 and b > 0 (the end values, not "
                              f"exponents; got {args!r})")
        raw = np.geomspace(a, b, n)
    else:
        raw = np.linspace(a, b, n)
    values = [float(f"{v:.{RANGE_DIGITS}g}") for v in raw]
    if isinstance(a, int) and isinstance(b, int) and all(v.is_integer() for v in values):
        return [int(v) for v in values]
    return values


def _check_key(key: Any, where: str) -> str:
    if not isinstance(key, str) or not all(key.split(".")):
        raise ConfigError(f"{where}: {key!r} is not a dotted key such as scenario.velocity")
    return key


def _seed_group(seeds: Any, source: str) -> Group:
    if isinstance(seeds, int) and not isinstance(seeds, bool) and 1 <= seeds <= MAX_RUNS:
        return ("seed",), [(s,) for s in range(1, seeds + 1)]
    if isinstance(seeds, list) and seeds and all(isinstance(s, int) and not isinstance(s, bool) for s in seeds):
        return ("seed",), [(s,) for s in seeds]
    raise ConfigError(f"{source}: seeds: expected a count N >= 1 (seeds 1..N) or a list of integer seeds "
                      f"(got {seeds!r})")


def _zip_groups(groups: Any, source: str) -> list[Group]:
    if not isinstance(groups, list):
        raise ConfigError(f"{source}: zip: expected a list of groups, each a mapping of keys to equal-length "
                          f"lists, e.g. zip: [{{model.n_cells: [300, 1728], scenario.max_time: [1e-4, 4e-4]}}]")
    out = []
    for i, group in enumerate(groups, 1):
        if not isinstance(group, dict) or not group:
            raise ConfigError(f"{source}: zip group {i}: expected a mapping of keys to lists (got {group!r})")
        keys = tuple(_check_key(k, f"{source}: zip group {i}") for k in group)
        columns = [value_list(v, f"{source}: zip group {i}, {k}") for k, v in group.items()]
        lengths = [len(c) for c in columns]
        if len(set(lengths)) > 1:
            shown = ", ".join(f"{k}: {n}" for k, n in zip(keys, lengths))
            raise ConfigError(f"{source}: zip group {i} ({', '.join(keys)}): its lists must have equal lengths "
                              f"(got {shown})")
        out.append((keys, list(zip(*columns))))
    return out


# ------------------------------------------------------------------------------- names
def short_keys(keys: list[str]) -> list[str]:
    """Each dotted key by its last component, or by as many trailing components as make it
    differ from every other key's (model.interface.kn, model.contact.kn -> interface.kn,
    contact.kn)."""
    parts = [k.split(".") for k in keys]
    out = []
    for i, p in enumerate(parts):
        n = 1
        while n < len(p) and any(q[-n:] == p[-n:] for j, q in enumerate(parts) if j != i):
            n += 1
        out.append(".".join(p[-n:]))
    return out


def format_value(value: Any, digits: int = NAME_DIGITS) -> str:
    """A value as it appears in a directory name: floats as %g (`digits` significant digits,
    `e+` shortened to `e`), booleans and None in lower case, lists joined by '-', any other
    character than letters, digits, _ . - replaced by '-'."""
    if isinstance(value, bool) or value is None:
        text = str(value).lower()
    elif isinstance(value, float):
        text = f"{value:.{digits}g}".replace("e+", "e")
    elif isinstance(value, (list, tuple)):
        text = "-".join(format_value(v, digits) for v in value)
    elif isinstance(value, dict):
        text = json.dumps(value, sort_keys=True, separators=(",", "="))
    else:
        text = str(value)
    return re.sub(r"[^A-Za-z0-9_.\-]+", "-", text)


def _digits_for(values: list[Any]) -> int:
    """Fewest significant digits (>= NAME_DIGITS) at which a key's distinct values get distinct names."""
    distinct = {repr(v): v for v in values}
    for digits in range(NAME_DIGITS, 18):
        if len({format_value(v, digits) for v in distinct.values()}) == len(distinct):
            return digits
    return 17


def run_labels(keys: list[str], combos: list[tuple[Any, ...]]) -> list[str]:
    """Directory names of the combinations (`base` when nothing varies)."""
    if not keys:
        return ["base" for _ in combos]
    shorts = short_keys(keys)
    digits = [_digits_for([c[i] for c in combos]) for i in range(len(keys))]
    return ["_".join(f"{s}{format_value(v, d)}" for s, v, d in zip(shorts, combo, digits)) for combo in combos]


# ----------------------------------------------------------------------------- expand
def expand_groups(base: dict, groups: list[Group], sweep_dir: Path,
                  source: str) -> list[tuple[dict[str, Any], RunConfig]]:
    """The grid of `groups` (crossed; the keys of one group vary together) as (varied values,
    validated config), each run in sweep_dir/<its name>. ConfigError naming `source` and the
    combination on the first invalid one, before anything is written."""
    keys = [k for g_keys, _ in groups for k in g_keys]
    repeated = sorted({k for k in keys if keys.count(k) > 1})
    if repeated:
        raise ConfigError(f"{source}: varied more than once: {', '.join(repeated)}")
    count = math.prod(len(rows) for _, rows in groups)
    if count > MAX_RUNS:
        raise ConfigError(f"{source}: {count:,} runs; a sweep may have at most {MAX_RUNS:,}")
    combos = [tuple(v for row in rows for v in row) for rows in itertools.product(*(r for _, r in groups))]
    labels = run_labels(keys, combos)
    seen: dict[str, tuple[Any, ...]] = {}
    for label, combo in zip(labels, combos):
        if label in seen:
            raise ConfigError(f"{source}: two runs would share the directory {label!r}: "
                              f"{_describe(keys, seen[label])} and {_describe(keys, combo)}; remove the repeated value")
        seen[label] = combo
    out = []
    for label, combo in zip(labels, combos):
        where = f"{source}, run {label}" + (f" ({_describe(keys, combo)})" if keys else "")
        data = copy.deepcopy(base)
        try:
            for k, v in zip(keys, combo):
                _assign(data, k, v)
        except ConfigError as exc:
            raise ConfigError(f"{where}: {exc}") from None
        data["name"] = f"{base.get('name', 'run')}_{label}"[:100]
        data.setdefault("output", {})
        if not isinstance(data["output"], dict):
            raise ConfigError(f"{where}: output must be a section")
        data["output"]["dir"] = str(sweep_dir / label)
        out.append((dict(zip(keys, combo)), parse_config(data, where)))
    return out


def _describe(keys: list[str], combo: tuple[Any, ...]) -> str:
    return ", ".join(f"{k}={v!r}" for k, v in zip(keys, combo))


@dataclass(frozen=True)
class Sweep:
    """An expanded sweep: where it came from, its folder, the varied keys and its runs."""

    source: str
    directory: Path
    keys: list[str]
    runs: list[tuple[dict[str, Any], RunConfig]]


def is_sweep_file(data: Any) -> bool:
    """A YAML document is a sweep file when its top level has one of SWEEP_KEYS."""
    return isinstance(data, dict) and any(k in data for k in SWEEP_KEYS)


def _base_of(spec: Any, sweep_file: Path) -> dict:
    source = str(sweep_file)
    if isinstance(spec, dict):
        parse_config(spec, f"{source} (base)")  # the base itself must be valid
        return spec
    if not isinstance(spec, str) or not spec.strip():
        raise ConfigError(f"{source}: base: expected a config file path (relative to the sweep file) or a "
                          f"mapping (got {spec!r})")
    path = sweep_file.parent / expand_path(spec)
    try:
        data = load_yaml(read_config_text(path), str(path))
        if is_sweep_file(data):
            raise ConfigError(f"{path} is a sweep file; base must be a run config")
        parse_config(data, str(path))
    except ConfigError as exc:
        raise ConfigError(f"{source}: base: {exc}") from None
    return data


def apply_scale(data: dict, scale: str, source: str) -> dict:
    """The sweep file `data` with its `scales: {scale: ...}` entry applied: `base` sets dotted
    keys of the base config, `axes` replaces or adds axes, `zip` replaces the zip groups, `seeds`
    the seeds. ConfigError naming the scales that exist."""
    scales = data.get("scales") or {}
    if not isinstance(scales, dict) or not all(isinstance(v, dict) for v in scales.values()):
        raise ConfigError(f"{source}: scales: expected a mapping of names to {{base, axes, zip, seeds}} mappings")
    if scale not in scales:
        have = ", ".join(map(str, scales)) or "none"
        raise ConfigError(f"{source}: --scale {scale}: no such scale under scales: (defined: {have})")
    spec = scales[scale]
    unknown = [str(k) for k in spec if k not in SCALE_KEYS]
    if unknown:
        raise ConfigError(f"{source}: scales.{scale}: unknown key(s) {', '.join(unknown)}; allowed: "
                          f"{', '.join(SCALE_KEYS)}")
    out = {k: v for k, v in data.items() if k != "scales"}
    overrides = spec.get("base") or {}
    if not isinstance(overrides, dict):
        raise ConfigError(f"{source}: scales.{scale}.base: expected a mapping of dotted keys to values")
    if overrides:
        base = copy.deepcopy(_base_of(data.get("base"), Path(source)))
        for key, value in overrides.items():
            try:
                _assign(base, _check_key(key, f"{source}: scales.{scale}.base"), value)
            except ConfigError as exc:
                raise ConfigError(f"{source}: scales.{scale}.base: {exc}") from None
        out["base"] = base
    if spec.get("axes") is not None:
        if not isinstance(spec["axes"], dict):
            raise ConfigError(f"{source}: scales.{scale}.axes: expected a mapping of dotted keys to lists or ranges")
        out["axes"] = {**(data.get("axes") or {}), **spec["axes"]}
    for key in ("zip", "seeds"):
        if key in spec:
            out[key] = spec[key]
    return out


def load_sweep(path: Path, set_args: list[str], out: Path | None = None, scale: str | None = None) -> Sweep:
    """Read a sweep file (at `scale`, one of its `scales:`, if given), or a run config varied
    by `set_args` (KEY=V1,V2,...), and expand it.

    The sweep directory is `out`, else runs/<sweep file stem>[_<scale>] (sweep file) or
    runs/<config name>_sweep (run config)."""
    path = Path(path)
    source = str(path)
    data = load_yaml(read_config_text(path), source)
    extra = [parse_assignment(a) for a in set_args]
    extra_groups: list[Group] = [((k,), [(v,) for v in values]) for k, values in extra]
    if scale is not None and not is_sweep_file(data):
        raise ConfigError(f"{source}: --scale needs a sweep file with scales: (this is a run config)")
    if is_sweep_file(data):
        unknown = [str(k) for k in data if k not in SWEEP_KEYS]
        if unknown:
            raise ConfigError(f"{source}: unknown key(s) {', '.join(unknown)} in a sweep file; allowed: "
                              f"{', '.join(SWEEP_KEYS)} (run settings go under base:)")
        if "base" not in data:
            raise ConfigError(f"{source}: a sweep file needs base: (a config path relative to it, or a mapping)")
        if scale is not None:
            data = apply_scale(data, scale, source)
        base = _base_of(data["base"], path)
        axes = data.get("axes") or {}
        if not isinstance(axes, dict):
            raise ConfigError(f"{source}: axes: expected a mapping of dotted keys to lists or ranges")
        groups: list[Group] = []
        for key, spec in axes.items():
            _check_key(key, f"{source}: axes")
            groups.append(((key,), [(v,) for v in value_list(spec, f"{source}: axes, {key}")]))
        groups += _zip_groups(data["zip"], source) if data.get("zip") is not None else []
        groups += extra_groups
        if data.get("seeds") is not None:
            groups.append(_seed_group(data["seeds"], source))
        stem = path.stem if scale is None else f"{path.stem}_{scale}"
        directory = expand_path(out) if out is not None else Path("runs") / stem
    else:
        base_cfg = parse_config(data, source)  # the base itself must be valid
        if not extra:
            raise ConfigError(f"{source}: a run config; vary keys with --set KEY.PATH=V1,V2, or give a sweep file "
                              f"(top-level {', '.join(SWEEP_KEYS)})")
        base, groups = data, extra_groups
        directory = expand_path(out) if out is not None else Path("runs") / f"{base_cfg.name}_sweep"
    runs = expand_groups(base, groups, directory, source)
    return Sweep(source=source, directory=directory, keys=[k for g, _ in groups for k in g], runs=runs)


# -------------------------------------------------------------------------------- cost
@dataclass(frozen=True)
class PlannedRun:
    """One run of a dry run: its name, varied values, state and cost.

    estimate: seconds from driver/estimate.py (the size model of driver/size_model.py; None where
    no estimate is possible); bound: it is an upper bound (BCM impacts stop when they settle);
    measured: wall_seconds of a finished run's provenance.json.
    """

    name: str
    values: dict[str, Any]
    state: str
    estimate: float | None
    bound: bool
    measured: float | None


@dataclass(frozen=True)
class Plan:
    """A dry run. scale: measured wall time over estimate of the finished runs in the sweep
    directory (None when there are none), from `scaled_runs` runs."""

    directory: Path
    keys: list[str]
    runs: list[PlannedRun]
    scale: float | None
    scaled_runs: int
    reference: Path | None = None  # the directory whose finished runs gave `scale`
    ranks: int = 1  # MPI ranks per run

    def cost(self, run: PlannedRun) -> float | None:
        if run.estimate is None:
            return None
        return run.estimate * (self.scale if self.scale is not None else 1.0)


_STATES = {"absent": "pending", "new": "pending", "stale": "interrupted"}


def _estimate(cfg: RunConfig, np_ranks: int | None) -> tuple[float | None, bool]:
    from driver import estimate as size  # noqa: PLC0415 (imports the builders' geometry)

    try:
        est = size.estimate(cfg, np_ranks)
    except Exception:  # noqa: BLE001 - a model the cost model does not cover: cost unknown
        return None, False
    return est.seconds, est.model == "BCM"


def _wall_seconds(run_dir: Path) -> float | None:
    try:
        wall = json.loads((run_dir / "provenance.json").read_text()).get("wall_seconds")
    except (OSError, ValueError, AttributeError):
        return None
    return float(wall) if isinstance(wall, (int, float)) and not isinstance(wall, bool) and wall > 0 else None


def _scale(directory: Path) -> tuple[float | None, int]:
    """Measured over estimated time of the finished runs in `directory` (each estimated from
    its own config.resolved.yaml and MPI ranks), and how many runs gave it."""
    measured = estimated = 0.0
    count = 0
    if not directory.is_dir():
        return None, 0
    for run_dir in sorted(p for p in directory.iterdir() if p.is_dir() and has_marker(p, MARKER)):
        wall = _wall_seconds(run_dir)
        if wall is None or not is_finished(run_dir):
            continue
        try:
            cfg = load_config(run_dir / "config.resolved.yaml")
            ranks = json.loads((run_dir / "provenance.json").read_text()).get("mpi_ranks")
        except (ConfigError, OSError, ValueError):
            continue
        est, _ = _estimate(cfg, ranks if isinstance(ranks, int) and ranks > 0 else None)
        if est is not None and est > 0:
            measured, estimated, count = measured + wall, estimated + est, count + 1
    return (measured / estimated, count) if count else (None, 0)


def plan(sweep: Sweep, np_ranks: int | None = None, cost_from: Path | None = None) -> Plan:
    """Every run of `sweep` with its state and cost; reads the sweep directory, writes nothing.
    The estimates are scaled by the finished runs of `cost_from` (another sweep directory, e.g.
    the small scale of the same study) when given, else by those of the sweep itself."""
    rows = []
    for values, cfg in sweep.runs:
        state = run_state(cfg.run_dir())["state"]
        state = _STATES.get(state, state)
        est, bound = _estimate(cfg, np_ranks)
        rows.append(PlannedRun(name=cfg.run_dir().name, values=values, state=state, estimate=est, bound=bound,
                               measured=_wall_seconds(cfg.run_dir()) if state == "finished" else None))
    reference = expand_path(cost_from) if cost_from is not None else sweep.directory
    if cost_from is not None and not reference.is_dir():
        raise ConfigError(f"--cost-from {cost_from}: not a directory")
    scale, scaled_runs = _scale(reference)
    return Plan(directory=sweep.directory, keys=sweep.keys, runs=rows, scale=scale, scaled_runs=scaled_runs,
                reference=reference, ranks=np_ranks or 1)


def _cost_text(p: Plan, run: PlannedRun) -> str:
    from driver.size_model import _duration  # noqa: PLC0415

    if run.measured is not None:
        return f"took {_duration(run.measured)}"
    cost = p.cost(run)
    if cost is None:
        return "unknown"
    return f"{'≤' if run.bound and p.scale is None else '~'} {_duration(cost)}"


def plan_table(p: Plan):
    """A rich table: one row per run (name, varied values, state, cost)."""
    from rich.table import Table  # noqa: PLC0415

    table = Table("run", *short_keys(p.keys), "state", "cost")
    for run in p.runs:
        shown = (f"{v:.6g}" if isinstance(v, float) else str(v) for v in (run.values[k] for k in p.keys))
        table.add_row(run.name, *shown, run.state, _cost_text(p, run))
    return table


def plan_summary(p: Plan) -> list[str]:
    """Lines under the table: how the cost was estimated, and the totals."""
    from driver.size_model import _duration  # noqa: PLC0415

    lines = ["cost: LAMMPS time from driver/size_model.py (fitted on runs measured on the development machine; "
             "an upper bound '≤' for BCM impacts, which stop when they settle)"]
    if p.scale is not None:
        lines.append(f"scaled by {p.scale:.3g}: measured wall time (provenance.json wall_seconds) over the estimate "
                     f"of {_runs(p.scaled_runs)} finished in {p.reference or p.directory}")
    else:
        lines.append(f"not scaled: no finished run with a measured wall time in {p.reference or p.directory} yet")
    todo = [r for r in p.runs if r.state != "finished"]
    costs = [p.cost(r) for r in todo]
    known = [c for c in costs if c is not None]
    unknown = len(costs) - len(known)
    if not todo:
        total = "nothing to run"
    elif not known:
        total = f"unknown for the {_runs(len(todo))} to do"
    else:
        bound = p.scale is None and all(r.bound for r, c in zip(todo, costs) if c is not None)
        from driver.distributed import default_workers  # noqa: PLC0415

        slots = default_workers(p.ranks)
        mark = "≤" if bound else "~"
        total = (f"{mark} {_duration(sum(known))} for the {_runs(len(todo))} to do, one after the other "
                 f"({mark} {sum(known) * p.ranks / 3600:.3g} CPU hours; {mark} {_duration(sum(known) / slots)} on "
                 f"{slots} local worker{'s' if slots > 1 else ''})"
                 + (f" ({unknown} of them unknown, not counted)" if unknown else ""))
    done = [r for r in p.runs if r.state == "finished"]
    if done:
        measured = sum(r.measured or 0.0 for r in done)
        total += f"; {len(done)} finished" + (f" in {_duration(measured)}" if measured else "")
    lines.append(f"total: {total}; {_runs(len(p.runs))} in {p.directory}")
    return lines


def _runs(n: int) -> str:
    return f"{n} run{'' if n == 1 else 's'}"


# ------------------------------------------------------------------------------ table
def sweep_table(runs: list[tuple[dict[str, Any], RunConfig]]) -> pd.DataFrame:
    """One row per run of the sweep: its varied values, run_dir, state (finished, failed,
    interrupted, stale, pending) and error, then, for a finished run, its summary figures."""
    rows = []
    for values, cfg in runs:
        run_dir = cfg.run_dir()
        st = run_state(run_dir)
        state = _STATES.get(st["state"], st["state"])
        row: dict[str, Any] = {**values, "run_dir": str(run_dir), "state": state,
                               "error": st.get("error") if state != "finished" else None}
        summ = run_dir / "results" / "summary.json"
        if state == "finished" and summ.exists():
            row.update({k: v for k, v in json.loads(summ.read_text()).items() if not isinstance(v, (dict, list))})
        rows.append(row)
    return pd.DataFrame(rows)


def seed_points(table: pd.DataFrame, keys: list[str]) -> pd.DataFrame:
    """Means and standard deviations (ddof 1; NaN for one run) over seeds of every numeric
    summary column, one row per combination of the varied keys other than `seed`, from the
    finished runs of `table` (sweep_table). Columns: the keys, n_runs, <col>_mean, <col>_std."""
    group_keys = [k for k in keys if k != "seed" and k in table.columns]
    done = table[table["state"] == "finished"] if "state" in table.columns else table
    skip = set(keys) | {"run_dir", "state", "error"}
    numeric = [c for c in done.columns if c not in skip and pd.api.types.is_numeric_dtype(done[c])
               and not pd.api.types.is_bool_dtype(done[c])]
    if done.empty:
        return pd.DataFrame(columns=[*group_keys, "n_runs"])
    done = done.copy()
    for k in group_keys:  # a varied list or mapping (measure_strains: [0.5, 1]) groups by its JSON text
        if done[k].map(lambda v: isinstance(v, (list, dict, tuple))).any():
            done[k] = done[k].map(lambda v: json.dumps(v) if isinstance(v, (list, dict, tuple)) else v)
    grouped = done.groupby(group_keys, sort=False, dropna=False) if group_keys else done.groupby(
        lambda _: 0, sort=False)
    stats = grouped[numeric].agg(["mean", "std"])
    stats.columns = [f"{a}_{b}" for a, b in stats.columns]
    stats.insert(0, "n_runs", grouped.size())
    stats = stats.reset_index()
    return stats.drop(columns=["index"]) if not group_keys else stats


def pending(runs: list[tuple[dict[str, Any], RunConfig]]) -> list[tuple[dict[str, Any], RunConfig]]:
    return [r for r in runs if not is_finished(r[1].run_dir())]
