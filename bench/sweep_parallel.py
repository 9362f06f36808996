"""Sweep throughput on local Dask workers (issue 14 figures).

A 16-run BCM impact sweep at 300 cells (examples/bcm_impact_quick.yaml: G_c in {0.5, 1} J/m^2,
v_0 in {1, 2, 3, 5} m/s, 2 seeds) run twice from scratch through the command line, as a user
runs it: `driver sweep --workers 1` (one run after the other in the driver's process) and
`driver sweep --workers 2` (a Dask LocalCluster of 2 worker processes). Prints the wall time
of each, the throughput ratio (target >= 1.8x on 2 workers) and the sum of the runs' own wall
times (provenance.json) to show what the workers cost each other (memory bandwidth, the
shared cores).

With --study DIR (a finished `--scale small` study, e.g. runs/bcm_impact_study_small) it also
prints the full BCM study's estimated cost, scaled by the measured over estimated time of
that directory's runs (the same as `driver sweep examples/studies/bcm_impact_study.yaml
--dry-run --cost-from DIR`).

    python bench/sweep_parallel.py [--study runs/bcm_impact_study_small] [--workers 2]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent
BASE = ROOT / "examples" / "bcm_impact_quick.yaml"
STUDY = ROOT / "examples" / "studies" / "bcm_impact_study.yaml"


def sweep_file(work: Path) -> Path:
    path = work / "bench_sweep.yaml"
    path.write_text(yaml.safe_dump({"base": str(BASE), "axes": {"model.interface.G_c": [0.5, 1.0],
                                                                "scenario.velocity": [1.0, 2.0, 3.0, 5.0]},
                                    "seeds": 2}))
    return path


def timed_sweep(sweep: Path, out: Path, workers: int) -> tuple[float, float, int]:
    """(wall seconds of the whole command, sum of the runs' own wall seconds, finished runs)."""
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "driver.cli", "sweep", str(sweep), "--out", str(out),
                           "--workers", str(workers)], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"sweep with {workers} worker(s) failed:\n{proc.stderr[-3000:]}")
    runs = [json.loads(p.read_text()) for p in out.glob("*/provenance.json")]
    return wall, sum(r.get("wall_seconds", 0.0) for r in runs), len(runs)


def study_cost(study_dir: Path) -> None:
    from driver.sweep import load_sweep, plan, plan_summary  # noqa: PLC0415

    full = plan(load_sweep(STUDY, []), cost_from=study_dir)
    print(f"\nfull BCM study ({STUDY.relative_to(ROOT)}, {len(full.runs)} runs at 1728 cells), cost scaled by "
          f"{study_dir}:")
    for line in plan_summary(full):
        print("  " + line)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--study", type=Path, default=None, help="a finished --scale small study directory")
    args = ap.parse_args()
    from driver.plugin_build import plugin_library  # noqa: PLC0415

    plugin_library()  # built before the clock starts
    with tempfile.TemporaryDirectory(prefix="bench-sweep-") as tmp:
        work = Path(tmp)
        sweep = sweep_file(work)
        one = timed_sweep(sweep, work / "w1", 1)
        many = timed_sweep(sweep, work / f"w{args.workers}", args.workers)
    print(f"16-run BCM impact sweep, 300 cells ({BASE.relative_to(ROOT)}, G_c 0.5/1, v 1/2/3/5 m/s, 2 seeds)")
    print(f"{'workers':>8} {'wall s':>8} {'runs':>5} {'runs/h':>8} {'sum of run walls s':>19}")
    for n, (wall, runs_wall, count) in ((1, one), (args.workers, many)):
        print(f"{n:>8} {wall:>8.1f} {count:>5} {3600 * count / wall:>8.1f} {runs_wall:>19.1f}")
    print(f"throughput on {args.workers} workers: {one[0] / many[0]:.2f}x that of 1 worker (target >= 1.8x); "
          f"each run's own wall time {many[1] / one[1]:.2f}x longer side by side")
    if args.study is not None:
        study_cost(args.study)


if __name__ == "__main__":
    main()
