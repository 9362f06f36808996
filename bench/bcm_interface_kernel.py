"""Cost of `bond_style bcm/griffith` per interface point and step, on the impact particle.

Builds the particle of an impact config (default examples/bcm_impact.yaml: 1728 cells,
10,854 interfaces, 55,242 points) with the driver in a temporary run directory, writes the
impact input with the settle loop replaced by `run STEPS`, runs it on 1 rank REPEAT times
and prints LAMMPS's "Bond" time (the best of the repeats) as nanoseconds per interface point
and step, with the run's steps per second. The particle hits the plane within the first
1000 steps, so the window holds both intact and breaking interfaces.

    python bench/bcm_interface_kernel.py [--steps 2000] [--repeat 3] [--config FILE]
                                         [--plugin LIB ...]

Several --plugin libraries (e.g. builds of two versions of the sources) are timed on the same
particle, in turn; by default the plugin built from this checkout.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import tempfile
from pathlib import Path

import yaml

from driver.config import parse_config
from driver.engine import venv_bin
from driver.plugin_build import plugin_library
from driver.rundir import RunDir
from driver.bcm.impact import build_system, render_inputs

ROOT = Path(__file__).resolve().parent.parent


def bench_input(cfg, system: dict, steps: int) -> str:
    """The impact input up to its first `run 0`, then `run STEPS` (no settle loop, no print)."""
    text, _, _ = render_inputs(cfg, Path("PLUGIN"), system)
    head = text.split("\nrun             0")[0]
    lines = [ln for ln in head.splitlines() if not ln.startswith("fix             record")]
    return "\n".join(lines) + f"\nthermo {steps}\nrun {steps}\n"


def timed_run(run_dir: Path, plugin: Path) -> tuple[float, float]:
    """(Bond time, loop time) in seconds of one run of bench.in."""
    proc = subprocess.run([venv_bin("lmp"), "-in", "bench.in", "-var", "plugin", str(plugin), "-log",
                           "bench.log", "-screen", "none", "-nocite"], cwd=run_dir, capture_output=True,
                          text=True)
    log = (run_dir / "bench.log").read_text() if (run_dir / "bench.log").exists() else ""
    bond = re.search(r"^Bond\s*\|\s*([\d.]+)", log, re.M)
    loop = re.search(r"^Loop time of ([\d.]+)", log, re.M)
    if proc.returncode != 0 or not bond or not loop:
        raise RuntimeError(f"LAMMPS failed with {plugin}:\n{log[-3000:]}\n{proc.stderr[-2000:]}")
    return float(bond.group(1)), float(loop.group(1))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default=str(ROOT / "examples" / "bcm_impact.yaml"))
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--plugin", action="append", type=Path,
                    help="plugin library to time (repeatable; default: this checkout's build)")
    args = ap.parse_args()
    plugins = args.plugin or [plugin_library()]
    cfg = parse_config(yaml.safe_load(Path(args.config).read_text()), args.config)

    with tempfile.TemporaryDirectory(prefix="bcm-kernel-") as tmp:
        root = Path(tmp)
        rd = RunDir(root)
        for d in (rd.dumps, rd.results, rd.plots):
            d.mkdir(parents=True, exist_ok=True)
        system = build_system(cfg, rd)
        (root / "bench.in").write_text(bench_input(cfg, system, args.steps))
        npts, nif = system["contact_points"], system["n_interfaces"]
        print(f"{cfg.name}: {system['n_cells']} cells, {nif} interfaces, {npts} points; "
              f"{args.steps} steps, best of {args.repeat}")
        for plugin in plugins:
            runs = [timed_run(root, plugin) for _ in range(args.repeat)]
            bond = min(r[0] for r in runs)
            loop = min(r[1] for r in runs)
            print(f"  {plugin}: Bond {bond:.3f} s = {bond / args.steps / npts * 1e9:.1f} ns per point "
                  f"and step ({', '.join(f'{r[0]:.3f}' for r in runs)} s); run {loop:.3f} s = "
                  f"{args.steps / loop:.0f} steps/s")


if __name__ == "__main__":
    main()
