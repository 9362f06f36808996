"""`driver sweep`: one config, some keys varied over lists, one run directory per combination.

Every combination is validated before anything runs. Runs that already finished are kept, so
re-running a sweep resumes it; the sweep table (one row per run: the varied values and the
run's summary) is rewritten at the end.
"""

from __future__ import annotations

import copy
import itertools
import json
from pathlib import Path
from typing import Any

import pandas as pd
import yaml

from driver.config import ConfigError, RunConfig, parse_config
from driver.rundir import is_finished


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
            raise ConfigError(f"--set {dotted}: '{k}' is not a section")
    node[keys[-1]] = value


def expand(base: dict, assignments: list[tuple[str, list[Any]]], sweep_dir: Path,
           source: str) -> list[tuple[dict[str, Any], RunConfig]]:
    """All combinations as (varied values, validated config) with run dirs under sweep_dir."""
    keys = [k for k, _ in assignments]
    out = []
    for combo in itertools.product(*(v for _, v in assignments)):
        data = copy.deepcopy(base)
        label = "_".join(f"{k.split('.')[-1]}{v}" for k, v in zip(keys, combo)) or "base"
        for k, v in zip(keys, combo):
            _assign(data, k, v)
        data["name"] = f"{base.get('name', 'run')}_{label}"
        data.setdefault("output", {})["dir"] = str(sweep_dir / label)
        out.append((dict(zip(keys, combo)), parse_config(data, f"{source} with {label}")))
    return out


def sweep_table(runs: list[tuple[dict[str, Any], RunConfig]]) -> pd.DataFrame:
    """One row per finished run: the varied values, then the run's summary figures."""
    rows = []
    for values, cfg in runs:
        summ = cfg.run_dir() / "results" / "summary.json"
        if not summ.exists():
            continue
        flat = {k: v for k, v in json.loads(summ.read_text()).items() if not isinstance(v, (dict, list))}
        rows.append({**values, "run_dir": str(cfg.run_dir()), **flat})
    return pd.DataFrame(rows)


def pending(runs: list[tuple[dict[str, Any], RunConfig]]) -> list[tuple[dict[str, Any], RunConfig]]:
    return [r for r in runs if not is_finished(r[1].run_dir())]
