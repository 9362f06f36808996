"""BCM impact throughput and memory (issue 15): the 1728-cell impact at 4.5 m/s, G_c = 1 J/m^2.

Prints
  - the system: cells, interfaces, contact points, the time step and the rule that chose it;
  - the whole run through `driver run` on 1 rank: steps, simulated time, wall seconds, and the
    peak memory of the LAMMPS process (the session's own VmHWM), LAMMPS's own allocation
    figure, and the peak of the driver process (build + analysis) and of the analysis alone;
  - the phases of that run, from its own records: free flight (up to the last record before
    the plane's first contact), contact and fracture (first contact to the last break of
    breaks.dat), the settled tail (to the end); each timed from a restart file taken at its
    start, `--repeats` times on 1 and on 2 MPI ranks (at most `--phase-steps` steps of it),
    in simulated us per wall second and cell-steps per second (minimum and median of the
    repeats, from LAMMPS's loop time);
  - the memory table: the same figures for 300, 1728 and 8000 cells (build and a short run of
    `--memory-steps` steps), with bytes per cell of the LAMMPS process above the smallest
    system's (memory that grows linearly with the cells keeps it constant).
Targets: LAMMPS process <= 150 MB at 1728 cells; the driver's analysis below it.

    python bench/bcm_impact.py [--config examples/bcm_impact.yaml] [--repeats 3] [--skip-memory]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
LOOP = re.compile(r"Loop time of ([\d.eE+-]+) on (\d+) procs for (\d+) steps")
ALLOC = re.compile(r"Per MPI rank memory allocation \(min/avg/max\) = [\d.]+ \| [\d.]+ \| ([\d.]+) Mbytes")
MEMORY_CELLS = (300, 1728, 8000)
# the session process with its peak read from inside, after exec (VmHWM): ru_maxrss of a child
# forked from this process would count this process's pages too
SESSION_WITH_PEAK = ("import sys; from driver.session import main, peak_rss_mib; rc = main(sys.argv[1:]); "
                     "print(f'PEAK {peak_rss_mib()}'); sys.exit(rc)")


def _config(path: str, n_cells: int | None, out: Path):
    from driver.config import load_config  # noqa: PLC0415

    cfg = load_config(path)
    if n_cells is not None:
        cfg = cfg.model_copy(update={"model": cfg.model.model_copy(update={"n_cells": n_cells})})
    return cfg.model_copy(update={"output": cfg.output.model_copy(update={"dir": out, "plots": False})})


def _self_peak_mib() -> float:
    """This process's peak (VmHWM, reset by exec; ru_maxrss is not, so a probe started from a
    large process would report its parent's peak)."""
    from driver.session import peak_rss_mib  # noqa: PLC0415

    peak = peak_rss_mib()
    return peak if peak is not None else resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _lammps_allocation(log: Path) -> float:
    """LAMMPS's own 'Per MPI rank memory allocation' (max over ranks and over the log), MB."""
    return max(float(m) for m in ALLOC.findall(log.read_text()))


def _probe(*args: str) -> dict:
    """Run this script as `--probe-...` in a fresh process; its JSON answer."""
    out = subprocess.run([sys.executable, __file__, *args], capture_output=True, text=True, cwd=ROOT)
    if out.returncode != 0:
        raise RuntimeError(f"probe {args} failed:\n{out.stderr[-3000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


# ----------------------------------------------------------------------------- probes
def probe_memory(config: str, n_cells: int, steps: int) -> dict:
    """Build the impact of n_cells and run its first `steps` steps in the driver's session
    process; peak memory of each side."""
    from driver.bcm.impact import build_system, render_inputs  # noqa: PLC0415
    from driver.config import resolved_yaml  # noqa: PLC0415
    from driver.plugin_build import plugin_library  # noqa: PLC0415
    from driver.rundir import RunDir  # noqa: PLC0415
    from driver.schedule import segments, write_session  # noqa: PLC0415
    from driver.session import write_control  # noqa: PLC0415

    with tempfile.TemporaryDirectory() as tmp:
        cfg = _config(config, n_cells, Path(tmp) / "run")
        # a snapshot at the last step, for the analysis
        cfg = cfg.model_copy(update={"scenario": cfg.scenario.model_copy(update={"dump_every": steps})})
        rd = RunDir(cfg.run_dir())
        rd.prepare(force=True)
        system = build_system(cfg, rd)
        (rd.root / "config.resolved.yaml").write_text(resolved_yaml(cfg))  # for the analysis
        setup, resume, schedule = render_inputs(cfg, plugin_library(), system)
        system.update(window_steps=schedule["window"], max_steps=schedule["window"] * schedule["max_windows"])
        (rd.root / "system.json").write_text(json.dumps(system))
        write_session(rd.root, setup, resume, segments(steps, steps, {}), None)
        write_control(rd.root)
        build_peak = _self_peak_mib()
        proc = subprocess.run([sys.executable, "-c", SESSION_WITH_PEAK, str(rd.root)], capture_output=True,
                              text=True, cwd=ROOT)
        if proc.returncode != 0:
            raise RuntimeError(proc.stderr[-3000:])
        peak = float(re.findall(r"PEAK ([\d.]+)", proc.stdout)[-1])
        # the analysis of what the session left (its last snapshot, as `driver post` of a run cut
        # short), in a fresh process, with and without figures
        analysis = {plots: _probe("--probe-analysis", str(rd.root), "cut_short", plots)["analysis_mib"]
                    for plots in ("plots", "noplots")}
        return {"cells": n_cells, "interfaces": system["n_interfaces"], "lammps_process_mib": peak,
                "lammps_allocation_mb": _lammps_allocation(rd.root / "log.lammps"), "build_mib": build_peak,
                "analysis_mib": analysis["plots"], "analysis_noplots_mib": analysis["noplots"]}


def probe_run(config: str, out: str) -> dict:
    """`driver run` of the config (1 rank) into `out`; the driver process's peak (build and
    analysis; LAMMPS runs in the session process) and the session's."""
    from driver.pipeline import execute  # noqa: PLC0415

    cfg = _config(config, None, Path(out))
    t0 = time.perf_counter()
    run = execute(cfg, show_progress=False)
    wall = time.perf_counter() - t0
    outcome = json.loads((run / "outcome.json").read_text())
    lammps_wall = json.loads((run / "provenance.json").read_text())["lammps_wall_seconds"]
    return {"wall_s": wall, "lammps_wall_s": lammps_wall, "driver_mib": _self_peak_mib(),
            "lammps_process_mib": outcome["session_peak_rss_mib"],
            "lammps_allocation_mb": _lammps_allocation(run / "log.lammps")}


def probe_analysis(run_dir: str, completeness: str = "finished", plots: str = "plots") -> dict:
    """The analysis of a run alone, in a fresh process: its peak, and the peak of the same
    imports with no analysis (the floor the libraries set). completeness: finished or cut_short
    (analysis/completeness.py)."""
    from analysis.completeness import RunCompleteness  # noqa: PLC0415
    from driver.pipeline import analyse_run, load_resolved  # noqa: PLC0415

    cfg = load_resolved(Path(run_dir))
    cfg["output"]["plots"] = plots == "plots"
    analyse_run(Path(run_dir), cfg, RunCompleteness(completeness))
    return {"analysis_mib": _self_peak_mib()}


def probe_imports() -> dict:
    """Peak of a process that imports what the impact analysis imports and does nothing."""
    import analysis.breaks  # noqa: F401, PLC0415
    import analysis.bcm_impact  # noqa: F401, PLC0415
    import driver.pipeline  # noqa: F401, PLC0415

    return {"imports_mib": _self_peak_mib()}


# ----------------------------------------------------------------------------- phases
def phase_bounds(run: Path) -> dict[str, tuple[int, int]]:
    """(first, last) step of each phase of a finished impact run, from its own records:
    free flight ends at the last record before the plane's first contact (wall_contacts > 0),
    contact and fracture at the last break of breaks.dat, the settled tail at the end."""
    from analysis.breaks import read_break_log  # noqa: PLC0415
    from analysis.bcm_impact import read_impact_thermo  # noqa: PLC0415

    thermo = read_impact_thermo(run / "thermo.dat")
    touching = thermo.step[thermo.wall_contacts > 0]
    before = thermo.step[thermo.step < touching.iloc[0]]
    contact = int(before.iloc[-1]) if len(before) else 0
    breaks = read_break_log(run / "breaks.dat")
    last_break = int(breaks.step.max()) if len(breaks) else contact
    end = int(thermo.step.iloc[-1])
    return {"free flight": (0, contact), "contact and fracture": (contact, last_break),
            "settled tail": (last_break, end)}


def prepare_restarts(run: Path, bounds: dict[str, tuple[int, int]], work: Path) -> dict[str, Path]:
    """Restart files at the start of each phase: the run's own setup, run again to each start."""
    from driver.runner import run_input  # noqa: PLC0415

    work.mkdir(parents=True, exist_ok=True)
    for name in ("system.data", "cells.txt", "interfaces.txt", "setup.lammps", "resume.lammps"):
        (work / name).write_bytes((run / name).read_bytes())
    (work / "dumps").mkdir(exist_ok=True)
    lines, step, files = [(run / "setup.lammps").read_text()], 0, {}
    for i, (phase, (first, _)) in enumerate(bounds.items()):
        if first > step:
            lines.append(f"run {first - step}")
            step = first
        files[phase] = work / f"phase{i}.restart"
        lines.append(f"write_restart {files[phase].name}")
    (work / "prepare.lammps").write_text("\n".join(lines) + "\n")
    run_input(work, "prepare.lammps")
    return files


def time_phase(work: Path, restart: Path, steps: int, ranks: int) -> float:
    """Loop seconds of `steps` steps from `restart` on `ranks` ranks (the run's resume input)."""
    from driver.runner import run_input  # noqa: PLC0415

    text = f"variable checkpoint string {restart.name}\n" + (work / "resume.lammps").read_text() + f"\nrun {steps}\n"
    name = f"time_{restart.stem}_{ranks}.lammps"
    (work / name).write_text(text)
    run_input(work, name, np=ranks)
    return float(LOOP.findall((work / "log.lammps").read_text())[-1][0])


def print_phases(run: Path, system: dict, repeats: int, cap: int, ranks: list[int], work: Path) -> None:
    bounds = phase_bounds(run)
    restarts = prepare_restarts(run, bounds, work)
    n, dt = system["n_cells"], system["timestep"]
    print(f"\nphases ({repeats} repeats each, at most {cap:,} steps of a phase timed; best (the minimum loop "
          f"time) / median; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores):")
    print(f"  {'phase':22s} {'steps':>15s} {'timed':>6s} {'ranks':>5s} {'sim us per wall s':>22s} "
          f"{'cell-steps/s':>24s}")
    for phase, (first, last) in bounds.items():
        steps = min(last - first, cap)
        if steps <= 0:
            print(f"  {phase:22s} {f'{first}-{last}':>15s}  (empty)")
            continue
        for r in ranks:
            loops = [time_phase(work, restarts[phase], steps, r) for _ in range(repeats)]
            rate = sorted(steps / t for t in loops)[::-1]  # steps per second, best first
            best, med = rate[0], statistics.median(rate)
            print(f"  {phase:22s} {f'{first}-{last}':>15s} {steps:6d} {r:5d} "
                  f"{best * dt * 1e6:10.4f} / {med * dt * 1e6:9.4f} {best * n:12,.0f} / {med * n:10,.0f}")


# ----------------------------------------------------------------------------- main
def print_memory_table(config: str, steps: int) -> None:
    rows = [_probe("--probe-memory", config, str(n), str(steps)) for n in MEMORY_CELLS]
    floor = _probe("--probe-imports")["imports_mib"]
    print(f"\nmemory by size (build, then {steps} steps in the driver's session process, then the analysis of "
          f"its last snapshot in a fresh process, with figures / without):")
    print(f"  {'cells':>6s} {'interfaces':>10s} {'LAMMPS process MiB':>19s} {'LAMMPS alloc MB':>16s} "
          f"{'driver build MiB':>17s} {'analysis MiB':>16s} {'bytes/cell above ' + str(rows[0]['cells']):>22s}"
          f"{'(analysis, no figures)':>23s}")
    for row in rows:
        extra = extra_an = ""
        if row is not rows[0]:
            cells = row["cells"] - rows[0]["cells"]
            extra = f"{(row['lammps_process_mib'] - rows[0]['lammps_process_mib']) * 2**20 / cells:,.0f}"
            extra_an = f"{(row['analysis_noplots_mib'] - rows[0]['analysis_noplots_mib']) * 2**20 / cells:,.0f}"
        print(f"  {row['cells']:6d} {row['interfaces']:10d} {row['lammps_process_mib']:19.1f} "
              f"{row['lammps_allocation_mb']:16.1f} {row['build_mib']:17.1f} "
              f"{row['analysis_mib']:7.1f} / {row['analysis_noplots_mib']:6.1f} {extra:>22s}{extra_an:>23s}")
    print(f"  the analysis's imports alone (numpy, scipy, pandas with pyarrow, matplotlib, the tool's modules): "
          f"{floor:.1f} MiB")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--config", default="examples/bcm_impact.yaml")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--phase-steps", type=int, default=1000, help="at most this many steps of a phase timed")
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--memory-steps", type=int, default=300)
    ap.add_argument("--skip-memory", action="store_true")
    ap.add_argument("--skip-phases", action="store_true")
    ap.add_argument("--probe-memory", nargs=3, metavar=("CONFIG", "CELLS", "STEPS"), help=argparse.SUPPRESS)
    ap.add_argument("--probe-run", nargs=2, metavar=("CONFIG", "OUT"), help=argparse.SUPPRESS)
    ap.add_argument("--probe-analysis", nargs="+", metavar="RUN_DIR", help=argparse.SUPPRESS)
    ap.add_argument("--probe-imports", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.probe_memory:
        print(json.dumps(probe_memory(args.probe_memory[0], int(args.probe_memory[1]), int(args.probe_memory[2]))))
        return
    if args.probe_run:
        print(json.dumps(probe_run(*args.probe_run)))
        return
    if args.probe_analysis:
        print(json.dumps(probe_analysis(*args.probe_analysis)))
        return
    if args.probe_imports:
        print(json.dumps(probe_imports()))
        return
    with tempfile.TemporaryDirectory() as tmp:
        run = Path(tmp) / "whole"
        whole = _probe("--probe-run", args.config, str(run))
        system = json.loads((run / "system.json").read_text())
        from analysis.bcm_impact import read_impact_thermo  # noqa: PLC0415

        thermo = read_impact_thermo(run / "thermo.dat")
        n, steps, sim = system["n_cells"], int(thermo.step.iloc[-1]), float(thermo.time.iloc[-1])
        print(f"cells {n}, interfaces {system['n_interfaces']}, contact points {system['contact_points']}")
        print(f"dt {system['timestep']:.6g} s, rule: {system['timestep_rule']} "
              f"(shortest contact period {system['shortest_period']:.6g} s)")
        lw = whole["lammps_wall_s"]
        print(f"whole run (driver run, 1 rank): {steps:,} steps, {sim * 1e6:.2f} us simulated; LAMMPS session "
              f"{lw:.1f} s wall: {sim * 1e6 / lw:.4f} sim us per wall s, {n * steps / lw:,.0f} cell-steps/s; "
              f"driver run in all {whole['wall_s']:.1f} s (build, session, analysis)")
        analysis = _probe("--probe-analysis", str(run))
        print(f"memory at {n} cells: LAMMPS process peak {whole['lammps_process_mib']:.1f} MiB (target <= 150 MB; "
              f"LAMMPS's own allocation {whole['lammps_allocation_mb']:.1f} MB); driver process peak "
              f"{whole['driver_mib']:.1f} MiB (build + analysis); the analysis alone "
              f"{analysis['analysis_mib']:.1f} MiB (target: below the LAMMPS process)")
        if not args.skip_phases:
            print_phases(run, system, args.repeats, args.phase_steps, args.ranks, Path(tmp) / "phases")
    if not args.skip_memory:
        print_memory_table(args.config, args.memory_steps)


if __name__ == "__main__":
    main()
