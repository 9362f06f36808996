"""Sweep throughput on local Dask workers (issue 14 figures).

A 16-run BCM impact sweep at 300 cells (--cells; examples/bcm_impact_quick.yaml: G_c in {0.5, 1} J/m^2,
v_0 in {1, 2, 3, 5} m/s, 2 seeds) run twice from scratch through the command line, as a user
runs it: `driver sweep --workers 1` (one run after the other in the driver's process) and
`driver sweep --workers 2` (a Dask LocalCluster of 2 worker processes). Prints, for each, the
wall time of the whole command and of its runs phase (sweep_log.jsonl: from the first run's
start to the last run's end, without the set analysis that follows), the throughput ratios
(target >= 1.8x on 2 workers), and the sum of the runs' own times (provenance.json: build_seconds
+ wall_seconds), which shows what the workers cost each other. It also measures the machine's own ceiling: the
same CPU-bound Python loop run once, then as two processes side by side (2 x its time over the
time of the pair is the most any 2-process speed-up can reach here).

With --study DIR (a finished `--scale small` study, e.g. runs/bcm_impact_study_small) it also
prints the full BCM study's estimated cost, scaled by the measured over estimated time of
that directory's runs (the same as `driver sweep examples/studies/bcm_impact_study.yaml
--dry-run --cost-from DIR`).

    python bench/sweep_parallel.py [--cells 300] [--workers 2] [--study runs/bcm_impact_study_small]
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


def sweep_file(work: Path, cells: int) -> Path:
    path = work / "bench_sweep.yaml"
    base = yaml.safe_load(BASE.read_text())
    base["model"]["n_cells"] = cells
    path.write_text(yaml.safe_dump({"base": base, "axes": {"model.interface.G_c": [0.5, 1.0],
                                                                "scenario.velocity": [1.0, 2.0, 3.0, 5.0]},
                                    "seeds": 2}))
    return path


def timed_sweep(sweep: Path, out: Path, workers: int) -> tuple[float, float, float, int]:
    """(wall seconds of the whole command, of its runs phase, sum of the runs' own wall
    seconds, finished runs)."""
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "driver.cli", "sweep", str(sweep), "--out", str(out),
                           "--workers", str(workers)], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"sweep with {workers} worker(s) failed:\n{proc.stderr[-3000:]}")
    runs = [json.loads(p.read_text()) for p in out.glob("*/provenance.json")]
    log = json.loads((out / "sweep_log.jsonl").read_text().splitlines()[-1])
    own = sum(r.get("build_seconds", 0.0) + r.get("wall_seconds", 0.0) for r in runs)  # build + LAMMPS + analysis
    return wall, float(log["runs_seconds"]), own, len(runs)


_BURN = "import time\nt = time.perf_counter()\ns = 0\nfor i in range(40_000_000): s += i\nprint(time.perf_counter() - t)"


def machine_ceiling(repeats: int = 3) -> float:
    """2 x (one CPU-bound process alone) / (two side by side), each the fastest of `repeats`."""
    alone, pair = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", _BURN], capture_output=True, check=True)
        alone.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        procs = [subprocess.Popen([sys.executable, "-c", _BURN], stdout=subprocess.DEVNULL) for _ in range(2)]
        for p in procs:
            p.wait()
        pair.append(time.perf_counter() - t0)
    return 2 * min(alone) / min(pair)


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
    ap.add_argument("--cells", type=int, default=300, help="cells per particle (default 300)")
    ap.add_argument("--study", type=Path, default=None, help="a finished --scale small study directory")
    args = ap.parse_args()
    from driver.plugin_build import plugin_library  # noqa: PLC0415

    plugin_library()  # built before the clock starts
    with tempfile.TemporaryDirectory(prefix="bench-sweep-") as tmp:
        work = Path(tmp)
        sweep = sweep_file(work, args.cells)
        one = timed_sweep(sweep, work / "w1", 1)
        many = timed_sweep(sweep, work / f"w{args.workers}", args.workers)
    ceiling = machine_ceiling()
    print(f"16-run BCM impact sweep, {args.cells} cells ({BASE.relative_to(ROOT)}, G_c 0.5/1, v 1/2/3/5 m/s, "
          f"2 seeds)")
    print(f"{'workers':>8} {'command s':>10} {'runs phase s':>13} {'runs':>5} {'runs/h':>8} {'sum of runs s':>14}")
    for n, (wall, phase, runs_wall, count) in ((1, one), (args.workers, many)):
        print(f"{n:>8} {wall:>10.1f} {phase:>13.1f} {count:>5} {3600 * count / phase:>8.1f} {runs_wall:>14.1f}")
    print(f"throughput on {args.workers} workers: {one[1] / many[1]:.2f}x that of 1 worker over the runs phase "
          f"(target >= 1.8x), {one[0] / many[0]:.2f}x over the whole command (set analysis included); each run's "
          f"own wall time {many[2] / one[2]:.2f}x longer side by side")
    print(f"this machine's ceiling: two CPU-bound processes side by side do {ceiling:.2f}x the work of one")
    if args.study is not None:
        study_cost(args.study)


if __name__ == "__main__":
    main()
