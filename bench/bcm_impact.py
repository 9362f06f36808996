"""BCM impact throughput (issue 3 figures): the 1728-cell impact at 4.5 m/s, G_c = 1 J/m^2.

Prints cells, interfaces, contact points, time step, then
  - intact phase: the first 1000 steps of the impact run (on 1 and 2 MPI ranks),
    cell-steps per second from LAMMPS's loop time;
  - whole run: the impact to its settled outcome through `driver run` on 1 rank: steps,
    simulated time, wall seconds, cell-steps per second, peak memory.
Targets: >= 3e5 cell-steps/s in the intact phase, whole run < 5 min, 2 ranks >= 1.5x.

    python bench/bcm_impact.py [--config examples/bcm_impact.yaml] [--skip-whole]
"""

from __future__ import annotations

import argparse
import re
import resource
import tempfile
import time
from pathlib import Path

import pandas as pd

from driver.config import load_config
from driver.pipeline import execute
from driver.plugin_build import plugin_library
from driver.rundir import RunDir
from driver.runner import run_input
from driver.bcm.impact import build_system, render_inputs

LOOP = re.compile(r"Loop time of ([\d.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms")


def intact_phase(cfg, plugin: Path, steps: int, ranks: int, work: Path) -> tuple[float, dict]:
    """Loop seconds of the first `steps` steps (settle loop replaced by one run)."""
    rd = RunDir(work / f"intact{ranks}")
    rd.prepare(force=True)
    system = build_system(cfg, rd)
    setup, _, _ = render_inputs(cfg, plugin, system)  # the setup ends at its `run 0`; no settle loop
    text = setup + f"\nrun {steps}\n"
    (rd.root / "in.lammps").write_text(text)
    run_input(rd.root, np=ranks)
    loop = float(LOOP.findall((rd.root / "log.lammps").read_text())[-1][0])
    return loop, system


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--config", default="examples/bcm_impact.yaml")
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--skip-whole", action="store_true")
    args = ap.parse_args()
    cfg = load_config(args.config)
    plugin = plugin_library()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        t1, system = intact_phase(cfg, plugin, args.steps, 1, work)
        t2, _ = intact_phase(cfg, plugin, args.steps, 2, work)
        n = system["n_cells"]
        print(f"cells {n}, interfaces {system['n_interfaces']}, contact points {system['contact_points']}, "
              f"dt {system['timestep']:.4g} s ({system['timestep_rule']})")
        print(f"intact phase, {args.steps} steps: 1 rank {n * args.steps / t1:,.0f} cell-steps/s "
              f"({args.steps / t1:.0f} steps/s; target >= 3e5), 2 ranks {n * args.steps / t2:,.0f} "
              f"(speed-up {t1 / t2:.2f}x; target >= 1.5x)")
        if args.skip_whole:
            return
        whole = cfg.model_copy(update={"output": cfg.output.model_copy(update={"dir": work / "whole",
                                                                                  "plots": False})})
        t0 = time.perf_counter()
        out = execute(whole, show_progress=False)
        wall = time.perf_counter() - t0
        thermo = pd.read_csv(out / "results" / "energies.csv")
        steps, sim = int(thermo.step.iloc[-1]), float(thermo.time.iloc[-1])
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(f"whole run: {steps:,} steps, {sim * 1e6:.1f} us simulated, {wall:.0f} s wall "
              f"(target < 300 s), {n * steps / wall:,.0f} cell-steps/s, peak memory {peak:.0f} MiB "
              f"(target < 1024)")


if __name__ == "__main__":
    main()
