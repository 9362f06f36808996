"""The analysis of a set of runs (`driver scaling`, the end of a sweep): the runs are grouped by
(model, scenario) and each group is analysed by its unit (driver/registry.py).

A set of one kind writes its tables, plots and report into `out` itself. A set of several
kinds writes each group into `out/<model>_<scenario>/` and a short report in `out` that
lists the groups and the runs left out that no group could claim (their config unreadable).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from analysis.report import Report, clear_report, write_report
from analysis.runset import RunSetError, check_breakup_fraction, load_runs, no_runs, survey_runs
from driver.registry import unit_of
from driver.schema import ConfigError


def _tables(cfg: dict) -> tuple[str, ...]:
    try:
        tables = unit_of(cfg).result_tables
        return tables(cfg) if callable(tables) else tables
    except ConfigError as exc:  # a pair this version does not know: the run is left out
        raise ValueError(str(exc)) from None


def _key(run_dir: Path) -> tuple[str, str] | None:
    try:
        cfg = yaml.safe_load((Path(run_dir) / "config.resolved.yaml").read_text())
        return unit_of(cfg).key
    except (OSError, KeyError, TypeError, ValueError, yaml.YAMLError):
        return None


def analyse_set(paths: list[Path], out: Path, plots: bool = True, **options: Any) -> dict:
    """Tables, plots and report of the finished runs among `paths` into `out`, per (model,
    scenario). options go to each unit's set analysis (strain, n_bootstrap for shear sets;
    breakup_fraction for impact sets). Returns the figures of the one group, or
    {groups: {"model_scenario": figures}, left_out} for several; `left_out` lists the runs
    not analysed (run_dir, state, reason)."""
    if options.get("breakup_fraction") is not None:
        check_breakup_fraction(options["breakup_fraction"])
    finished, left = survey_runs(paths, required=_tables)
    if not finished:
        raise no_runs(paths, left)
    runs = load_runs(finished)
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in runs:
        groups.setdefault(unit_of(r["cfg"]).key, []).append(r)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    clear_report(out)
    if len(groups) == 1:
        (key, members), = groups.items()
        return unit_of(members[0]["cfg"]).analyse_set(members, out, plots, left, options)
    left_by_key: dict[tuple[str, str] | None, list[dict]] = {}
    for r in left:
        left_by_key.setdefault(_key(r["run_dir"]), []).append(r)
    results: dict[str, dict] = {}
    rep = Report(f"Set of {len(runs)} runs of {len(groups)} kinds",
                 "Each kind (model + scenario) is analysed on its own, in its folder.")
    for key, members in sorted(groups.items()):
        name = "_".join(key)
        sub = out / name
        sub.mkdir(parents=True, exist_ok=True)
        clear_report(sub)
        try:
            results[name] = unit_of(members[0]["cfg"]).analyse_set(members, sub, plots, left_by_key.get(key, []),
                                                                   options)
            rep.text(f"{key[0]} + {key[1]}: {len(members)} runs, see {name}/report.html")
        except RunSetError as exc:
            results[name] = {"error": str(exc)}
            rep.text(f"{key[0]} + {key[1]}: {len(members)} runs, NOT analysed: {exc}")
    unclaimed = [r for k, rs in left_by_key.items() if k not in groups for r in rs]
    if unclaimed:
        rep.text(f"{len(unclaimed)} runs were LEFT OUT of every group:")
        import pandas as pd  # noqa: PLC0415

        rep.table(pd.DataFrame([{"run_dir": str(r["run_dir"]), "state": r["state"], "reason": r["reason"]}
                                for r in unclaimed]), "runs left out, and why", max_rows=100)
    write_report(rep, out)
    return {"groups": results, "left_out": left}
