"""What both models' calibrations (driver/calibration/bpm.py, bcm.py) share: reading a curve's
table, the record of a measured curve, a curve as the report draws it, a config with changed
keys for the round trip, and the round trip's relative errors."""

from __future__ import annotations

import copy
from typing import Any

from driver.calibration import curves as cv
from driver.calibration import solve


def means(table, name: str):
    """The column of a curve's per-point means of `name` (the set analysis' `<name>_mean`)."""
    return table[f"{name}_mean"].to_numpy(float)


def panel(x, y, inv: solve.Inverse, xlabel: str, ylabel: str, log: bool = False, shift: float = 0.0) -> dict:
    """A curve as report.plot_curves draws it: the points, the target, the chosen point (x less
    `shift`), axis labels, log-log or linear."""
    return {"x": [float(v) for v in x], "y": [float(v) for v in y], "target": inv.target,
            "chosen": (inv.x - shift, inv.y), "reached": inv.reached, "xlabel": xlabel, "ylabel": ylabel, "log": log}


def curve_record(c: cv.Curve) -> dict[str, Any]:
    """A measured curve as calibration.json keeps it: where, whether from the cache, its
    provenance and its table."""
    return {"directory": str(c.directory), "from_cache": c.cached, "provenance": c.provenance,
            "table": c.table.to_dict(orient="records")}


def with_changes(base: dict[str, Any], changes: dict[str, Any]) -> dict[str, Any]:
    """A copy of the config mapping `base` with the dotted keys of `changes` set (as a sweep
    sets its axes)."""
    from driver.sweep import _assign  # noqa: PLC0415 (imports the config and its units: only a round trip needs it)

    data = copy.deepcopy(base)
    for k, v in changes.items():
        _assign(data, k, v)
    return data


def round_trip_errors(target: dict[str, float], measured: dict[str, float]) -> dict[str, dict[str, float]]:
    """Each measured property against the target: both values and the relative error."""
    return {k: {"target": target[k], "measured": v, "relative_error": (v - target[k]) / abs(target[k])}
            for k, v in measured.items()}
