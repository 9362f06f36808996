"""Calibration curves: the sweeps of calibration tests that measure them, run on first use and
kept in the cache with their provenance (issue 12, point 3).

A curve is an ordinary sweep (driver/sweep.py) of a calibration scenario over one parameter,
with seeds; its set analysis (the scenario unit's `analyse_set`) writes the table the curve is
read from. Each curve lives in `<cache>/calibration/<curve>-<key>/`:

    sweep.yaml    the sweep, runnable by hand: driver sweep sweep.yaml --out runs
    runs/         its run directories (a re-run resumes them)
    set/          the set analysis (tables, plots, report)
    curve.json    written last: the table, the provenance (package, git commit, LAMMPS, plugin
                  build, when, how long), the sweep; its presence means the curve is complete

The key hashes the sweep, the package version, CURVES_VERSION and the plugin build's source
hash, so a changed test, package or plugin measures the curve again; an unchanged one is read
back in seconds.

Default sizes (what `driver calibrate` measures unless the material file's `curves:` changes
them; the cost on 2 cores is in docs/calibration.md):
- bpm_moduli: the moduli test of driver/bpm/moduli.py; 2D L = 24 (976 disks), k_A 0 to 12 by
  2, 2 seeds; 3D L = 8 (645 spheres on `contact`), k_A in K_A[3], 1 seed (the seeds differ by
  0.4 % in B and G).
- bpm_mode1: at the k_A chosen from nu, lambda_c in LAMBDA_C; the 20 x 2 void; 2D L = 40
  (2711 disks), 3D L = 32 and T = 4 (5163 spheres); 2 seeds; the pull as
  PULL_STRAIN and PULL_RATE say.
"""

from __future__ import annotations

import copy
import hashlib
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import pandas as pd
import yaml
from rich.console import Console

import driver
from driver.schema import ConfigError
from runfiles.atomic import atomic_write_json, atomic_write_text

#: Bumped whenever what a curve's sweep measures changes beyond its sweep file (the key).
CURVES_VERSION = 1
#: lambda_c of the mode-I curve: K_IC / E grows about as lambda_c - 1, and a real material at a
#: resolution of tens of particles across a grain needs lambda_c - 1 of 1e-4 to 1e-3 (its strain
#: at failure; the material of the BCM defaults at 12 across: 4.5e-4), so the points are spread
#: logarithmically down to 3e-4; 3D runs cost about 30 times more, and the curve is a power law to
#: the measured precision (2D: K_IC = 50.0 (lambda_c - 1) from 1.001 to 1.1; 3D on lj_minimum:
#: 77.8 (lambda_c - 1)), so fewer points there.
LAMBDA_C = {2: (1.0003, 1.001, 1.003, 1.01, 1.03, 1.05, 1.1), 3: (1.0003, 1.001, 1.01, 1.03, 1.1)}
#: Pull of the mode-I runs: to PULL_STRAIN (lambda_c - 1), past the peak (near 0.16 (lambda_c - 1)),
#: at PULL_RATE (lambda_c - 1) per tau, so every run lasts as long and the peak comes after the
#: same number of sound crossings whatever lambda_c (2D, L = 40: about 18; 3D, L = 32: about 9,
#: above the 5 that analysis/toughness.py asks of both modes; 3D at half the rate measured sigma_c 2 % lower).
PULL_STRAIN = {2: 0.4, 3: 0.3}
PULL_RATE = {2: 2e-3, 3: 4e-3}
#: Sizes: the moduli sample's side L, the mode-I sample's side and (3D) slab thickness, in a.
MODULI_L = {2: 24, 3: 8}
MODE1_L = {2: 40, 3: 32}
MODE1_THICKNESS = 4
#: k_A of the moduli curve (SPEC 2.2: 0 to 12 in 2D, 0 to 5 in 3D; 3D goes on to 10, where nu
#: reaches about 0, so that the nu of a stiff ceramic is within reach) and seeds per point.
K_A = {2: (0, 2, 4, 6, 8, 10, 12), 3: (0, 1, 2, 3, 4, 5, 6, 8, 10)}
MODULI_SEEDS = {2: 2, 3: 1}
#: Significant digits a chosen parameter is rounded to before it enters a later curve's
#: sweep (so that the same target finds the same cache entry).
DIGITS = 4


class CalibrationError(RuntimeError):
    """A curve could not be measured (runs failed) or read."""


@dataclass(frozen=True)
class CurveSpec:
    """One calibration curve: its name (a key of CURVES), the sweep that measures it, the table
    of its set analysis that holds it and the column of the varied parameter."""

    name: str
    sweep: dict[str, Any]
    table: str
    x: str


def rounded(x: float, digits: int = DIGITS) -> float:
    return float(f"{x:.{digits}g}")


def _bpm_model(dimension: int, packing: str | None) -> dict[str, Any]:
    model: dict[str, Any] = {"kind": "bpm", "dimension": dimension}
    if dimension == 3 and packing:
        model["packing"] = packing
    return model


def bpm_moduli(dimension: int, packing: str | None = None) -> CurveSpec:
    base = {"name": f"cal_bpm_moduli_{dimension}d", "seed": 1,
            "model": {**_bpm_model(dimension, packing), "L": MODULI_L[dimension]},
            "scenario": {"kind": "calibrate", "test": "moduli", "strain_rate": 1e-4, "max_strain": 0.005}}
    return CurveSpec("bpm_moduli", {"base": base, "axes": {"model.k_A": list(K_A[dimension])},
                                    "seeds": MODULI_SEEDS[dimension]}, "moduli", "k_A")


def pull_keys(lambda_c, dimension: int) -> dict[str, list[float]]:
    """The pull's strain and rate for each lambda_c (PULL_STRAIN, PULL_RATE)."""
    return {"scenario.max_pull_strain": [rounded(PULL_STRAIN[dimension] * (lc - 1.0)) for lc in lambda_c],
            "scenario.strain_rate": [rounded(PULL_RATE[dimension] * (lc - 1.0)) for lc in lambda_c]}


def bpm_mode1(dimension: int, k_A: float, theta_c_deg: float, packing: str | None = None) -> CurveSpec:
    scenario: dict[str, Any] = {"kind": "calibrate", "test": "mode1", "void_axes": [20, 2]}
    if dimension == 3:
        scenario["thickness"] = MODE1_THICKNESS
    base = {"name": f"cal_bpm_mode1_{dimension}d", "seed": 1,
            "model": {**_bpm_model(dimension, packing), "L": MODE1_L[dimension], "k_A": rounded(k_A),
                      "theta_c_deg": theta_c_deg},
            "scenario": scenario}
    lcs = LAMBDA_C[dimension]
    zipped = [{"model.lambda_c": list(lcs), **pull_keys(lcs, dimension)}]
    return CurveSpec("bpm_mode1", {"base": base, "zip": zipped, "seeds": 2}, "toughness", "lambda_c")


#: Curve name -> what it is, for messages and the material file's `curves:` keys.
CURVES: dict[str, str] = {
    "bpm_moduli": "BPM B, G, E, nu against k_A (test moduli)",
    "bpm_mode1": "BPM K_IC against lambda_c at the chosen k_A (test mode1)",
    "bcm_moduli": "BCM block B, G, E, nu against k_t / k_n (test moduli)",
    "bcm_fracture": "BCM block released energy per new crack area against G_c (test fracture)",
}


def changed(spec: CurveSpec, change: Any) -> CurveSpec:
    """The spec with a material file's `curves:` entry applied (as a sweep file's scale)."""
    if change is None:
        return spec
    from driver.sweep import _assign, apply_scale  # noqa: PLC0415

    data = copy.deepcopy(spec.sweep)
    ch = change.model_dump(exclude_none=True)
    base = data["base"]
    for key, value in ch.pop("base", {}).items():
        _assign(base, key, value)
    data = apply_scale({**data, "scales": {"material": ch}}, "material", f"curves.{spec.name}") if ch else data
    return CurveSpec(spec.name, data, spec.table, spec.x)


def curve_key(spec: CurveSpec) -> str:
    from driver.plugin_build import source_hash  # noqa: PLC0415

    blob = json.dumps({"sweep": spec.sweep, "package": driver.__version__, "curves": CURVES_VERSION,
                       "plugins": source_hash()}, sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()[:12]


@dataclass
class Curve:
    """A measured curve: its table (one row per parameter value, mean and std columns), where it
    lives, its provenance, and whether it was read from the cache."""

    spec: CurveSpec
    table: pd.DataFrame
    directory: Path
    provenance: dict[str, Any]
    cached: bool


def curve_dir(spec: CurveSpec, cache: Path) -> Path:
    return Path(cache) / "calibration" / f"{spec.name}-{curve_key(spec)}"


def measure(spec: CurveSpec, cache: Path, workers: int = 1, console: Console | None = None,
            runner: Callable[[list, int, Console], list[str]] | None = None) -> Curve:
    """The curve from the cache, or measured now (module docstring); CalibrationError when runs
    failed (the finished ones are kept: the next call resumes)."""
    console = console or Console(stderr=True)
    where = curve_dir(spec, cache)
    done = where / "curve.json"
    if done.exists():
        data = json.loads(done.read_text())
        return Curve(spec, pd.DataFrame(data["table"]), where, data["provenance"], True)
    from driver.rundir import SWEEP_MARKER, claim_dir  # noqa: PLC0415
    from driver.sets import analyse_set  # noqa: PLC0415
    from driver.sweep import load_sweep, pending  # noqa: PLC0415

    claim_dir(where, ".brittle-curve", "calibration curve")
    sweep_file = where / "sweep.yaml"
    atomic_write_text(sweep_file, f"# calibration curve {spec.name}: {CURVES[spec.name]}\n"
                      + yaml.safe_dump(spec.sweep, sort_keys=False))
    runs_dir = claim_dir(where / "runs", SWEEP_MARKER, "sweep directory")
    sweep = load_sweep(sweep_file, [], out=runs_dir)
    todo = pending(sweep.runs)
    console.print(f"calibration curve [bold]{spec.name}[/]: {CURVES[spec.name]}; {len(sweep.runs)} runs, "
                  f"{len(sweep.runs) - len(todo)} already finished, in {where}")
    t0 = time.time()
    failed = (runner or run_pending)(todo, workers, console) if todo else []
    if failed:
        raise CalibrationError(f"curve {spec.name}: {len(failed)} of {len(sweep.runs)} runs failed ({', '.join(failed)}"
                               f"); see their status.json; run the same command again to retry them")
    try:
        result = analyse_set([cfg.run_dir() for _, cfg in sweep.runs], where / "set")
    except ValueError as exc:  # RunSetError is one: the runs finished but their set cannot be analysed
        raise CalibrationError(f"curve {spec.name}: the set analysis of {where / 'runs'} failed: {exc}") from None
    if result.get("left_out"):
        raise CalibrationError(f"curve {spec.name}: runs left out of the set analysis: {result['left_out']}")
    table = pd.read_csv(where / "set" / f"{spec.table}.csv")
    prov = _provenance(sweep.runs[0][1].run_dir(), time.time() - t0)
    atomic_write_json(done, {"curve": spec.name, "what": CURVES[spec.name], "key": curve_key(spec),
                             "sweep": spec.sweep, "provenance": prov, "set_result": result,
                             "table": json.loads(table.to_json(orient="records"))})
    return Curve(spec, table, where, prov, False)


def _provenance(first_run: Path, seconds: float) -> dict[str, Any]:
    from driver.plugin_build import source_hash  # noqa: PLC0415
    from driver.rundir import provenance  # noqa: PLC0415

    run = json.loads((first_run / "provenance.json").read_text())
    return provenance({"measured": time.strftime("%Y-%m-%dT%H:%M:%S"), "runs_seconds": round(seconds, 1),
                       "plugin_source_hash": source_hash(), "plugin_build_hash": run.get("plugin_build_hash")})


def run_pending(todo: list, workers: int, console: Console) -> list[str]:
    """Run the pending runs of a curve's sweep: on a local Dask cluster of `workers` processes,
    or here one after the other; the failed run directories."""
    if workers > 1:
        from driver.distributed import run_on_dask  # noqa: PLC0415

        records = run_on_dask(todo, None, workers, None, console)
        return [r["run_dir"] for r in records if r["state"] == "failed"]
    from driver.pipeline import execute  # noqa: PLC0415
    from driver.rundir import can_resume  # noqa: PLC0415
    from driver.runner import RunInterrupted  # noqa: PLC0415

    failed = []
    for values, cfg in todo:
        try:
            execute(cfg, show_progress=True, console=console, resume=can_resume(cfg.run_dir()))
        except (KeyboardInterrupt, ConfigError, RunInterrupted):
            raise
        except Exception as exc:  # noqa: BLE001 - one failed run must not stop the others
            failed.append(str(cfg.run_dir()))
            console.print(f"[red]failed[/] {values}: {type(exc).__name__}: {exc}")
    return failed


def run_configs(configs: dict[str, dict[str, Any]], directory: Path, workers: int, console: Console
                ) -> dict[str, dict[str, Any]]:
    """Run configs (name -> config mapping) in directory/<name> (finished ones are kept) and
    return their summaries; CalibrationError when one failed."""
    from driver.config import parse_config  # noqa: PLC0415
    from driver.rundir import SWEEP_MARKER, claim_dir, is_finished  # noqa: PLC0415

    claim_dir(directory, SWEEP_MARKER, "sweep directory")
    cfgs = {}
    for name, data in configs.items():
        data = copy.deepcopy(data)
        data["name"] = name
        data.setdefault("output", {})["dir"] = str(Path(directory) / name)
        cfgs[name] = parse_config(data, f"{directory} ({name})")
    todo = [({"run": n}, c) for n, c in cfgs.items() if not is_finished(c.run_dir())]
    failed = run_pending(todo, workers, console) if todo else []
    if failed:
        raise CalibrationError(f"{len(failed)} run(s) failed: {', '.join(failed)}; see their status.json")
    return {n: json.loads((c.run_dir() / "results" / "summary.json").read_text()) for n, c in cfgs.items()}
