"""Cost of a bed in compression per element-step (issue 25, point 5 "Scale"): a bed of grains
against the single-particle impact of the same model, on 1 MPI rank, and the bed's 2-rank
speed-up, both models, in one sitting; then what a bed of 1,000 BCM grains of 300 cells would
cost on 1, 32 and 128 ranks.

For each model (bcm, bpm) the driver's own code builds two runs (scenario units, run
directories, session.json), and the driver's own session (driver/session.py, the process
`driver run` starts: `python -m driver.session RUN_DIR`, under the wheel's `mpiexec` on 2
ranks) runs them:

  bed     the quick example (examples/<model>_bed_quick.yaml), by default smaller (--grains
          12 of its 30, in a box shrunk in x and y by sqrt(12/30); the loose height kept), its
          rest at most --rest-time (5e-5 s; the BCM example's is the default 2e-4 s) and its
          target stress --target-factor (10) times the example's, so that the runs stay short
          on a shared 2-core machine and the timed window is loading throughout (the target is
          a stop rule only: the steps before it are the same). Every change is printed.
          1) prepare: from step 0 on 1 rank through the fill and the rest (phases 0 and 1,
             breaking off) to the check at which the loading begins (phase 2: the cells
             stopped, breaking on), and a checkpoint there. Its chunks' loop time gives a
             "fill" row (1 rank; the fill's length depends on the start, not the cost model).
          2) load: from that checkpoint, --load-steps steps of the loading (phase 2, the platen
             down at platen_speed), the session's own resume (`python -m driver.session RUN_DIR
             CHECKPOINT`), on 1 and on 2 ranks, --repeats times each, alternately; best of the
             repeats. Only the number of windows is changed in session.json (and the stop rule's
             "did not reach the end of its test" error is dropped: the window is a sample).
  impact  the quick impact example (examples/<model>_impact_quick.yaml) from step 0 on 1 rank,
          the whole run (free flight, contact, settling), capped at --impact-steps.

The cost is LAMMPS's loop time ("Loop time of T on N procs for S steps with K atoms", summed
over the run's chunks) per element-step: cells for BCM, particles for BPM (K). Printed: a
table (model, run, phase, ranks, elements, steps, loop s, ns per element-step, bed / impact,
the bed's 2-rank speed-up), written as CSV to --out with the notes (what was changed, the
timed window's phases, sigma_v and breaks) and where the loop time went (LAMMPS's timing
breakdown by section, and the atoms per rank of a 2-rank run, max / mean); then the size model's figure
(driver/size_model.py) beside the measured one; then the estimate of a 1,000-grain BCM bed
(examples/bcm_bed.yaml with model.assembly.n_grains 1000, the box scaled to the same volume per
grain: its steps and memory from `driver validate`'s size model, its time from the measured
loading cost, on N ranks at the measured 2-rank efficiency).

Wall-clock figures on a shared machine are noisy: the load average is printed at the start,
before each timed loading and at the end; the ratios (bed / impact, 2 / 1 ranks) are measured in the same sitting.

    python bench/bed_cost.py --out bench/bed_cost.csv [--models bcm bpm] [--grains 12]
                             [--load-steps 3000] [--repeats 2] [--keep DIR]
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

LOOP = re.compile(r"Loop time of ([\d.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms")
SECTION = re.compile(r"^(Pair|Bond|Neigh|Comm|Output|Modify|Other)\s*\|(?:\s*[\d.eE+-]+\s*\|)?\s*([\d.eE+-]+)\s*\|",
                     re.MULTILINE)
NLOCAL = re.compile(r"^Nlocal:\s+([\d.eE+-]+) ave\s+([\d.eE+-]+) max", re.MULTILINE)
EXAMPLES = {"bcm": ("examples/bcm_bed_quick.yaml", "examples/bcm_impact_quick.yaml"),
            "bpm": ("examples/bpm_bed_quick.yaml", "examples/bpm_impact_quick.yaml")}
ELEMENT = {"bcm": "cells", "bpm": "particles"}
# the 1,000-grain bed: examples/bcm_bed.yaml (300 grains of 300 cells in 14 x 14 x 30 mm)
# with 1000 grains, each side of the box scaled by (1000 / 300)^(1/3) = 1.49
BIG_GRAINS, BIG_BOX = 1000, [2.1e-2, 2.1e-2, 4.5e-2]
BIG_RANKS = (1, 32, 128)
MARK = "bench_loading"


# ------------------------------------------------------------------------------ building
def read_example(example: str) -> dict:
    """An example's YAML as the driver reads it (its loader: 5.0e6 is a number)."""
    from driver.config import load_yaml, read_config_text  # noqa: PLC0415

    return load_yaml(read_config_text(ROOT / example), example)


def make_config(example: str, out: Path, grains: int | None = None, rest_time: float | None = None,
                target_factor: float | None = None):
    """The example as a RunConfig writing to `out`, plots off; a bed with `grains` grains (fewer
    than the example's) in a box whose x and y shrink by sqrt(grains / n) (the loose height
    kept), its rest at most `rest_time` s, its target stress times `target_factor`. (The config
    and a note of what was changed.)"""
    from driver.config import parse_config  # noqa: PLC0415
    from driver.scenarios.sections import CompressScenario  # noqa: PLC0415

    raw = read_example(example)
    notes = []
    assembly = raw["model"].get("assembly")
    if assembly is not None:
        sc = raw["scenario"]
        if grains is not None and grains != assembly["n_grains"]:
            s = math.sqrt(grains / assembly["n_grains"])
            box = [float(b) for b in assembly["box"]]
            notes.append(f"{grains} grains instead of {assembly['n_grains']}, box {box[0] * s * 1e3:.2f} x "
                         f"{box[1] * s * 1e3:.2f} x {box[2] * 1e3:.1f} mm")
            assembly.update(n_grains=grains, box=[box[0] * s, box[1] * s, box[2]])
        example_rest = float(sc.get("rest_time", CompressScenario.model_fields["rest_time"].default))
        if rest_time is not None and rest_time < example_rest:
            notes.append(f"rest_time {rest_time:g} s instead of {example_rest:g}")
            sc["rest_time"] = rest_time
        if target_factor is not None and target_factor != 1:
            sc["target_stress"] = float(sc["target_stress"])
            notes.append(f"target_stress {sc['target_stress'] * target_factor:g} Pa instead of "
                         f"{sc['target_stress']:g} (the loading goes on through the timed window)")
            sc["target_stress"] = sc["target_stress"] * target_factor
    raw["output"] = {"dir": str(out), "plots": False}
    return parse_config(raw, example), "; ".join(notes)


def build(cfg) -> dict:
    """The run directory of `cfg`, built by the driver's own unit (as `driver run` does before
    it starts the session); the control file the session reads at each chunk boundary."""
    from driver.plugin_build import plugin_library  # noqa: PLC0415
    from driver.registry import unit_of  # noqa: PLC0415
    from driver.rundir import RunDir  # noqa: PLC0415
    from driver.session import write_control  # noqa: PLC0415

    rd = RunDir(cfg.run_dir())
    rd.prepare(force=True)
    try:
        system, _ = unit_of(cfg).build(cfg, rd, plugin_library())
    finally:
        rd.release()
    write_control(rd.root)
    shutil.copy(rd.root / "session.json", rd.root / "session.orig.json")
    return system


def set_schedule(run_dir: Path, max_windows: int) -> dict:
    """session.json: the original schedule with at most `max_windows` windows, no stop-rule error
    (a sample of the run, not the whole test), no end commands, no periodic checkpoints."""
    plan = json.loads((run_dir / "session.orig.json").read_text())
    sched = plan["schedule"]
    sched.update(max_windows=min(int(sched["max_windows"]), max_windows), never=None, end=[])
    plan["checkpoint_every_steps"] = None
    (run_dir / "session.json").write_text(json.dumps(plan, indent=1))
    return plan


# ----------------------------------------------------------------------------- sessions
def session_env() -> dict:
    """The driver's own environment for its ranks (driver/mpi_launch.py), this tree first."""
    from driver.mpi_launch import launch_env  # noqa: PLC0415

    return launch_env(dict(os.environ, PYTHONPATH=str(ROOT) + (os.pathsep + os.environ["PYTHONPATH"]
                                                                if os.environ.get("PYTHONPATH") else "")))


def run_session(run_dir: Path, ranks: int, checkpoint: Path | None = None) -> dict:
    """The driver's session on `ranks` ranks (the command line of driver/runner.py), fresh or from
    `checkpoint`; its log's loop times (summed), steps and atoms, and the process's wall time."""
    from driver.mpi_launch import launcher  # noqa: PLC0415
    from driver.rundir import has_marker  # noqa: PLC0415

    # the files of the last session are removed only in a run directory the driver made (build())
    if not has_marker(run_dir):
        raise RuntimeError(f"{run_dir} is not a run directory of this tool: nothing in it is removed")
    (run_dir / "log.lammps").unlink(missing_ok=True)
    for name in ("thermo.dat", "breaks.dat", "outcome.json", ".session_error.json"):
        (run_dir / name).unlink(missing_ok=True)
    cmd = launcher(ranks) + \
        [sys.executable, "-m", "driver.session", str(run_dir)] + ([str(checkpoint)] if checkpoint else [])
    load_before = os.getloadavg()[0]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=run_dir, env=session_env(), capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"session in {run_dir} on {ranks} ranks failed ({proc.returncode}):\n"
                           f"{proc.stdout[-2000:]}{proc.stderr[-2000:]}")
    return {**loops(run_dir / "log.lammps"), "wall": wall, "load_before": load_before}


def loops(log: Path) -> dict:
    """Loop seconds and steps summed over a log's runs, its atoms and ranks; the sections of
    LAMMPS's timing breakdown (avg time over ranks, summed over the runs); the last run's
    atoms per rank (Nlocal max / ave: the load imbalance)."""
    text = log.read_text()
    found = LOOP.findall(text)
    if not found:
        raise RuntimeError(f"{log}: no loop time")
    sections: dict[str, float] = {}
    for name, avg in SECTION.findall(text):
        sections[name] = sections.get(name, 0.0) + float(avg)
    nlocal = NLOCAL.findall(text)
    imbalance = float(nlocal[-1][1]) / float(nlocal[-1][0]) if nlocal and float(nlocal[-1][0]) > 0 else 1.0
    return {"loop": sum(float(t) for t, *_ in found), "steps": sum(int(s) for _, _, s, _ in found),
            "atoms": int(found[-1][3]), "ranks": int(found[-1][1]), "chunks": len(found), "sections": sections,
            "imbalance": imbalance}


def breakdown(fig: dict) -> str:
    """Where the loop time went (LAMMPS's sections, % of their sum), and the load imbalance."""
    sec = fig["sections"]
    total = sum(sec.values()) or 1.0
    parts = [f"{k} {100 * v / total:.0f}%" for k, v in sec.items() if v / total >= 0.005]
    return ", ".join(parts) + (f"; atoms per rank max / mean {fig['imbalance']:.2f}" if fig["ranks"] > 1 else "")


def prepare_here(run_dir: Path, max_steps: int) -> None:
    """(In a process of its own, 1 rank.) The session from step 0, its settle rule replaced by
    "the loading has begun" (phase >= 2, evaluated after the phase checks of the same window),
    then a checkpoint through the session's own writer. Prints the step as JSON."""
    from driver.engine import Lammps  # noqa: PLC0415
    from driver.session import Session  # noqa: PLC0415

    run_dir = run_dir.resolve()
    os.chdir(run_dir)
    plan = json.loads((run_dir / "session.orig.json").read_text())
    sched = plan["schedule"]
    sched["check"] = [*sched["check"], f'variable        {MARK} equal "v_phase >= 2"']
    sched.update(settled_variable=MARK, never=None, end=[],
                 max_windows=min(int(sched["max_windows"]), math.ceil(max_steps / int(sched["window"]))))
    plan["checkpoint_every_steps"] = None
    (run_dir / plan["checkpoints"]).mkdir(exist_ok=True)
    lmp = Lammps(log=None)
    try:
        lmp.command("log log.prepare.lammps")
        session = Session(lmp, plan, run_dir)
        session.start_fresh()
        session.run()
        loaded = bool(session.state.pop("settled", False))
        if loaded:
            session.write_checkpoint()
        print(json.dumps({"step": session.step, "loading": loaded}))
    finally:
        lmp.lmp.finalize()


def prepare(run_dir: Path, max_steps: int) -> tuple[dict, Path]:
    """Fill and rest to the loading's first step, on 1 rank; (loop figures, checkpoint record)."""
    proc = subprocess.run([sys.executable, __file__, "--prepare-here", str(run_dir), str(max_steps)], cwd=ROOT,
                          env=session_env(), capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"prepare {run_dir} failed:\n{proc.stdout[-2000:]}{proc.stderr[-3000:]}")
    answer = json.loads(proc.stdout.strip().splitlines()[-1])
    if not answer["loading"]:
        raise RuntimeError(f"{run_dir}: the loading did not begin within {max_steps} steps (raise --fill-steps)")
    record = sorted((run_dir / "checkpoints").glob("step*.json"))[-1]
    return loops(run_dir / "log.prepare.lammps"), record


def window_facts(run_dir: Path, model: str, cfg) -> tuple[list[int], str]:
    """The phases, and a line of the phases, sigma_v (MPa) and breaks of the timed window, from
    its thermo.dat."""
    from runfiles.records import BPM_COMPRESS_RECORD, COMPRESS_RECORD  # noqa: PLC0415

    rec = COMPRESS_RECORD if model == "bcm" else BPM_COMPRESS_RECORD
    rows = [line.split() for line in (run_dir / "thermo.dat").read_text().splitlines()
            if line.strip() and not line.startswith("#")]
    if not rows:
        return [], "(no record)"
    col = rec.column
    phases = sorted({int(float(r[col("phase")])) for r in rows})
    sv = [float(r[col("sigma_v")]) for r in rows]
    if model == "bpm":  # LJ: u / a^3
        u = cfg.model.particle.units
        sv = [s * u.energy_u_J / u.length_a_m ** 3 for s in sv]
        broken = [float(r[col("bonds_broken")]) + float(r[col("angles_broken")]) for r in rows]
        what = "bonds+angles broken"
    else:
        broken = [float(r[col("broken")]) for r in rows]
        what = "interfaces broken"
    return phases, (f"phase {'/'.join(map(str, phases))}, sigma_v {sv[0] / 1e6:.3g} -> {sv[-1] / 1e6:.3g} MPa "
            f"(target {cfg.scenario.target_stress / 1e6:g}), {broken[-1] - broken[0]:.0f} {what}")


# --------------------------------------------------------------------------------- bench
def ns(fig: dict) -> float:
    return fig["loop"] / (fig["steps"] * fig["atoms"]) * 1e9


def measure(model: str, args, work: Path) -> tuple[list[dict], dict]:
    bed_example, impact_example = EXAMPLES[model]
    rows: list[dict] = []
    # the bed
    cfg, note = make_config(bed_example, work / f"{model}_bed", args.grains, args.rest_time, args.target_factor)
    t0 = time.perf_counter()
    system = build(cfg)
    run_dir = cfg.run_dir()
    count = system.get("n_cells") or system.get("n_particles")
    print(f"\n{model}: bed {bed_example}{' (' + note + ')' if note else ''}: {count} {ELEMENT[model]} in "
          f"{system['n_grains']} grains, built in {time.perf_counter() - t0:.0f} s", flush=True)
    t0 = time.perf_counter()
    fill, ckpt = prepare(run_dir, args.fill_steps)
    print(f"  fill and rest to the loading: {fill['steps']} steps, loop {fill['loop']:.1f} s "
          f"(process {time.perf_counter() - t0:.0f} s)", flush=True)
    rows.append(dict(model=model, run="bed", phase="fill+rest (0-1)", ranks=1, elements=fill["atoms"],
                     steps=fill["steps"], loop_s=fill["loop"], ns_per_element_step=ns(fill), note=note,
                     time_by_section=breakdown(fill)))
    start = json.loads(ckpt.read_text())
    plan = set_schedule(run_dir, int(start["state"]["windows_done"]) + 1)
    window = int(plan["schedule"]["window"])
    n_windows = max(1, round(args.load_steps / window))
    set_schedule(run_dir, int(start["state"]["windows_done"]) + n_windows)
    best: dict[int, dict] = {}
    phases, facts = None, ""
    for rep in range(args.repeats):
        for ranks in ((1, 2) if rep % 2 == 0 else (2, 1)):
            fig = run_session(run_dir, ranks, ckpt)
            if ranks == 1 and phases is None:
                phases, facts = window_facts(run_dir, model, cfg)
            print(f"  load from step {start['step']}: {fig['steps']} steps on {ranks} rank{'s' * (ranks > 1)}, "
                  f"loop {fig['loop']:.1f} s (process {fig['wall']:.0f} s; load average before it "
                  f"{fig['load_before']:.2f})", flush=True)
            if ranks not in best or fig["loop"] < best[ranks]["loop"]:
                best[ranks] = fig
    speedup = best[1]["loop"] / best[2]["loop"]
    for ranks in (1, 2):
        f = best[ranks]
        label = "load (2)" if phases == [2] else f"phases {'/'.join(map(str, phases))} (from the loading's start)"
        rows.append(dict(model=model, run="bed", phase=label, ranks=ranks, elements=f["atoms"], steps=f["steps"],
                         loop_s=f["loop"], ns_per_element_step=ns(f), speedup_2_ranks=speedup if ranks == 2 else None,
                         note=facts if ranks == 1 else "", time_by_section=breakdown(f)))
    # the impact
    icfg, _ = make_config(impact_example, work / f"{model}_impact", None)
    t0 = time.perf_counter()
    isystem = build(icfg)
    irun = icfg.run_dir()
    iplan = set_schedule(irun, math.ceil(args.impact_steps / json.loads((irun / "session.orig.json").read_text())
                                        ["schedule"]["window"]))
    fig = run_session(irun, 1)
    outcome = json.loads((irun / "outcome.json").read_text()) if (irun / "outcome.json").exists() else {}
    ended = "settled" if outcome.get("settled") else f"capped at {iplan['schedule']['max_windows']} windows"
    print(f"  impact {impact_example}: {fig['atoms']} {ELEMENT[model]}, {fig['steps']} steps ({ended}), loop "
          f"{fig['loop']:.1f} s (build and run {time.perf_counter() - t0:.0f} s)", flush=True)
    rows.append(dict(model=model, run="impact", phase=f"whole impact ({ended})", ranks=1, elements=fig["atoms"],
                     steps=fig["steps"], loop_s=fig["loop"], ns_per_element_step=ns(fig), note="",
                     time_by_section=breakdown(fig)))
    impact_ns = rows[-1]["ns_per_element_step"]
    for r in rows:
        if r["run"] == "bed":
            r["bed_over_impact"] = r["ns_per_element_step"] / impact_ns if r["ranks"] == 1 else None
    return rows, {"cfg": cfg, "speedup": speedup, "load_ns": rows[1]["ns_per_element_step"],
                  "fill_ns": rows[0]["ns_per_element_step"], "system": system, "isystem": isystem}


COLUMNS = ("model", "run", "phase", "ranks", "elements", "steps", "loop_s", "ns_per_element_step",
           "bed_over_impact", "speedup_2_ranks", "note", "time_by_section")


def print_table(rows: list[dict]) -> None:
    print(f"\n{'model':5s} {'run':6s} {'phase':34s} {'ranks':>5s} {'elements':>8s} {'steps':>7s} {'loop s':>7s} "
          f"{'ns/el-step':>10s} {'bed/impact':>10s} {'2-rank x':>8s}")
    for r in rows:
        ratio = f"{r['bed_over_impact']:.2f}" if r.get("bed_over_impact") else "-"
        sp = f"{r['speedup_2_ranks']:.2f}" if r.get("speedup_2_ranks") else "-"
        print(f"{r['model']:5s} {r['run']:6s} {r['phase']:34s} {r['ranks']:5d} {r['elements']:8d} {r['steps']:7d} "
              f"{r['loop_s']:7.2f} {r['ns_per_element_step']:10.0f} {ratio:>10s} {sp:>8s}")
    for r in rows:
        if r.get("note"):
            print(f"  {r['model']} {r['run']} {r['phase']}, {r['ranks']} rank: {r['note']}")
    print("where the loop time goes (LAMMPS's timing breakdown, avg over ranks):")
    for r in rows:
        print(f"  {r['model']} {r['run']:6s} {r['phase']:34s} {r['ranks']} rank{'s' * (r['ranks'] > 1)}: "
              f"{r['time_by_section']}")


def write_csv(rows: list[dict], path: Path, header: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as fh:
        fh.write(f"# {header}\n")
        w = csv.DictWriter(fh, fieldnames=COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else ("" if v is None else v))
                        for k, v in ((c, r.get(c)) for c in COLUMNS)})


def size_model_lines(results: dict) -> None:
    from driver import size_model as sm  # noqa: PLC0415

    print("\nthe size model (driver/size_model.py) against the measured 1-rank loading cost:")
    if "bcm" in results:
        print(f"  bcm: BCM_SECONDS_PER_CELL {sm.BCM_SECONDS_PER_CELL:g} s per cell per 1000 steps = "
              f"{sm.BCM_SECONDS_PER_CELL * 1e6:,.0f} ns per cell-step; measured {results['bcm']['load_ns']:,.0f}")
    if "bpm" in results:
        print(f"  bpm: BPM_SECONDS_PER_PARTICLE[3] {sm.BPM_SECONDS_PER_PARTICLE[3]:g} = "
              f"{sm.BPM_SECONDS_PER_PARTICLE[3] * 1e6:,.0f} ns per particle-step; measured "
              f"{results['bpm']['load_ns']:,.0f}")


def big_bed(res: dict) -> None:
    """The 1,000-grain BCM bed: steps and memory from the size model, time from the measured
    loading cost at the measured 2-rank efficiency."""
    from driver.config import parse_config  # noqa: PLC0415
    from driver.estimate import estimate  # noqa: PLC0415
    from driver.size_model import GIB  # noqa: PLC0415

    raw = read_example("examples/bcm_bed.yaml")
    raw["model"]["assembly"].update(n_grains=BIG_GRAINS, box=BIG_BOX)
    raw["model"]["n_cells"] = 300
    cfg = parse_config(raw, "examples/bcm_bed.yaml with 1000 grains")
    sc = cfg.scenario
    one = estimate(cfg, 1)
    travel = 0.01 * BIG_BOX[2]  # the size model's guess (driver/size_model.py bcm_compress)
    t_sim = min(sc.max_time, travel / sc.fill_speed + travel / sc.platen_speed * (2.0 if sc.unload else 1.0)
                + sc.hold_time)
    eff = res["speedup"] / 2.0
    print(f"\na bed of {BIG_GRAINS:,} BCM grains of {cfg.model.n_cells} cells (examples/bcm_bed.yaml, "
          f"model.assembly.n_grains {BIG_GRAINS}, box {' x '.join(f'{b * 1e3:g}' for b in BIG_BOX)} mm):")
    print(f"  size model: {one.describe()}")
    print(f"  steps: the size model's guess, fill and loading each over 1 % of the loose height "
          f"({0.01 * BIG_BOX[2] * 1e3:g} mm) at fill_speed {sc.fill_speed:g} and platen_speed {sc.platen_speed:g} m/s, "
          f"unloading as loading: {t_sim * 1e3:.1f} ms at dt ~ {t_sim / one.steps * 1e9:.2f} ns, {one.steps:,} steps")
    cell_steps = one.elements * one.steps
    print(f"  measured: {res['load_ns']:,.0f} ns per cell-step loading on 1 rank (the fill: {res['fill_ns']:,.0f}; "
          f"a bed of grains of {res['cfg'].model.n_cells} cells), 2-rank speed-up {res['speedup']:.2f} "
          f"(efficiency {eff:.2f}), assumed to hold on N ranks")
    print(f"  {'ranks':>5s} {'speed-up':>8s} {'s / 1000 steps':>14s} {'whole run':>12s} {'memory (size model)':>20s}")
    out = []
    for ranks in BIG_RANKS:
        sp = 1.0 if ranks == 1 else ranks * eff
        secs = cell_steps * res["load_ns"] * 1e-9 / sp
        mem = estimate(cfg, ranks).memory_bytes / GIB
        per1000 = one.elements * 1000 * res["load_ns"] * 1e-9 / sp
        print(f"  {ranks:5d} {sp:8.1f} {per1000:14.1f} {_human(secs):>12s} {mem:17.1f} GiB")
        out.append((ranks, sp, secs, mem))
    return out


def _human(seconds: float) -> str:
    if seconds < 3600:
        return f"{seconds / 60:.1f} min"
    if seconds < 86400 * 2:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / 86400:.1f} days"


def git(*a: str) -> str:
    return subprocess.run(["git", *a], cwd=ROOT, capture_output=True, text=True).stdout.strip()


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--prepare-here":
        prepare_here(Path(sys.argv[2]), int(sys.argv[3]))
        return
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, required=True, help="CSV of the table")
    ap.add_argument("--models", nargs="+", default=["bcm", "bpm"], choices=["bcm", "bpm"])
    ap.add_argument("--grains", type=int, default=12,
                    help="grains of the bed (the quick examples have 30; the box's x and y shrink with them)")
    ap.add_argument("--rest-time", type=float, default=5e-5,
                    help="the bed's rest lasts at most this long, s (when the example's is longer): a shorter start")
    ap.add_argument("--target-factor", type=float, default=10.0,
                    help="the bed's target stress times this, so that the timed window is all loading")
    ap.add_argument("--load-steps", type=int, default=3000, help="steps of the loading timed (whole check windows)")
    ap.add_argument("--fill-steps", type=int, default=60000, help="the most steps the fill and rest may take")
    ap.add_argument("--impact-steps", type=int, default=20000, help="the most steps of the impact")
    ap.add_argument("--repeats", type=int, default=2, help="timed loading runs per rank count (best of)")
    ap.add_argument("--keep", type=Path, default=None, help="keep the run directories here")
    args = ap.parse_args()

    load0 = os.getloadavg()
    dirty = git("status", "--porcelain", "--untracked-files=no")
    header = (f"bench/bed_cost.py {' '.join(sys.argv[1:])}; HEAD {git('rev-parse', '--short', 'HEAD')}"
              f"{' (uncommitted changes)' if dirty else ''}; {time.strftime('%Y-%m-%d %H:%M')}; "
              f"{os.cpu_count()} cores; load average {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f}")
    print(header, flush=True)
    work = args.keep or Path(tempfile.mkdtemp(prefix="bed_cost_"))
    work.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    rows, results = [], {}
    try:
        for model in args.models:
            r, res = measure(model, args, work)
            rows += r
            results[model] = res
    finally:
        if args.keep is None:
            shutil.rmtree(work, ignore_errors=True)
    print_table(rows)
    write_csv(rows, args.out, header)
    print(f"(CSV: {args.out})")
    size_model_lines(results)
    if "bcm" in results:
        big_bed(results["bcm"])
    load1 = os.getloadavg()
    print(f"\nload average at the end {load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f}; "
          f"{time.perf_counter() - t_start:.0f} s in all")


if __name__ == "__main__":
    main()
