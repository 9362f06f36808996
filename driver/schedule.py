"""Run schedules: how a scenario's steps are cut into chunks, and the files that carry them.

A scenario renders its LAMMPS input twice from one template (a fresh start from the data file,
`setup.lammps`, and a start from a checkpoint, `resume.lammps`) and describes the rest of the
run as a schedule (session.json) that driver/session.py executes chunk by chunk. `in.lammps`
is the same run as one standalone LAMMPS script (`include setup.lammps` and the schedule as
LAMMPS loops), so `lmp -in in.lammps -var plugin PATH` repeats it without the driver.

Chunk boundaries depend on the config alone (a whole `run` each, with its own setup), so an
interrupted and resumed run makes exactly the operations of an uninterrupted one.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from runfiles.atomic import atomic_write_json, atomic_write_text

# Element-steps per chunk when execution.chunk_steps is not set: about a second of one core
# (BCM ~0.9e6 cell-steps/s, BPM 2D ~7e6 particle-steps/s, 3D ~1.5e6; bench/), so a stop
# request is answered within about a second and a chunk's setup costs well under 1 %.
ELEMENT_STEPS_PER_CHUNK = {"bcm": 1.0e6, "bpm": 3.0e6}


def chunk_steps(model_kind: str, n_elements: int, configured: int | None, minimum: int = 50) -> int:
    """Steps per chunk: the configured value, or about a second of work on one core."""
    if configured:
        return int(configured)
    return max(minimum, int(ELEMENT_STEPS_PER_CHUNK[model_kind] / max(1, n_elements)))


# ---------------------------------------------------------------------- step counting
def steps_for_strain(strain: float, strain_rate: float, timestep: float) -> int:
    """Number of steps to reach a true strain at a given rate (rounded to the nearest step)."""
    return int(math.floor(strain / (strain_rate * timestep) + 0.5))


def total_steps(max_strain: float, strain_rate: float, timestep: float) -> int:
    """Steps to the strain max_strain growing at edot (strain = edot t: the nominal strain of the
    mode-I pull, the true strain of the mode-II shear), rounded up."""
    return int(math.ceil(max_strain / (strain_rate * timestep)))


def _loop(name: str, count: int, body: str) -> str:
    """LAMMPS text running `body` `count` times (a loop variable is deleted when exhausted)."""
    if count <= 0:
        return ""
    if count == 1:
        return body + "\n"
    return (f"variable        {name} loop {count}\nlabel           {name}_top\n{body}\n"
            f"next            {name}\njump            SELF {name}_top\n")


# ------------------------------------------------------------------------- segments
def segments(total_steps: int, chunk: int, snapshots: dict[int, list[str]]) -> dict[str, Any]:
    """Run to total_steps in chunks; after each step listed in snapshots, its commands."""
    return {"kind": "segments", "total_steps": int(total_steps), "chunk": int(chunk),
            "snapshots": {str(k): v for k, v in sorted(snapshots.items()) if 0 < k <= total_steps}}


def segments_script(sched: dict[str, Any]) -> str:
    chunk = sched["chunk"]
    snapshots = {int(k): v for k, v in sched["snapshots"].items()}
    out, step = [], 0
    for n, target in enumerate(sorted({*snapshots, sched["total_steps"]})):
        first = min(target, (step // chunk + 1) * chunk)
        if first > step:
            out.append(f"run             {first - step}")
            step = first
        full = (target - step) // chunk
        out.append(_loop(f"c{n}", full, f"run             {chunk}").rstrip())
        step += full * chunk
        if target > step:
            out.append(f"run             {target - step}")
            step = target
        out += snapshots.get(target, [])
    return "\n".join(line for line in out if line) + "\n"


# --------------------------------------------------------------------------- settle
def settle_windows(window_steps: int, chunk: int) -> tuple[int, int]:
    """(window, chunk) with the window a whole number of chunks: the window is rounded up by
    less than one chunk's share, so windows and chunks share boundaries."""
    k = max(1, math.ceil(window_steps / chunk))
    chunk = math.ceil(window_steps / k)
    return k * chunk, chunk


def settle(window: int, chunk: int, max_windows: int, check: list[str], settled_variable: str,
           advance: list[str], end: list[str], never: tuple[str, str] | None = None,
           pre_no: bool = False) -> dict[str, Any]:
    """Windows of `window` steps (a multiple of `chunk`); after each, `check`, then stop if the
    equal-style variable `settled_variable` is > 0, else `advance`; `end` after the last.
    never = (variable, message): a run that never settled and whose variable is still 0 at the
    end is an error with that message, not a result.
    pre_no: chunks are `run N pre no` (LAMMPS still sets up the first run of an instance), for a
    run whose set-up would disturb it: the BPM platen's velocity (driver/bpm/platen.py)."""
    if window % chunk:
        raise ValueError(f"window {window} is not a multiple of the chunk {chunk}")
    return {"kind": "settle", "window": int(window), "chunk": int(chunk), "max_windows": int(max_windows),
            "check": check, "settled_variable": settled_variable, "advance": advance, "end": end,
            "never": list(never) if never else None, **({"pre_no": True} if pre_no else {})}


def run_command(steps: int, sched: dict[str, Any]) -> str:
    """The `run` command of a chunk of `steps` steps under schedule `sched` (settle: pre_no)."""
    return f"run             {steps}" + (" pre no" if sched.get("pre_no") else "")


def settle_script(sched: dict[str, Any]) -> str:
    inner = _loop("k", sched["window"] // sched["chunk"], run_command(sched["chunk"], sched)).rstrip()
    lines = ["label           settle", f"variable        w loop {sched['max_windows']}", inner, *sched["check"],
             'if              "${' + sched["settled_variable"] + '} > 0" then "jump SELF finished"',
             *sched["advance"], "next            w", "jump            SELF settle", "label           finished",
             *sched["end"]]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------- files
def write_session(root: Path, setup: str, resume: str, schedule: dict[str, Any], checkpoint_every_steps: int | None,
                  checkpoint_variables: list[str] = (), restore_as: dict[str, str] | None = None) -> None:
    """setup.lammps, resume.lammps, in.lammps (standalone) and session.json of a run.

    checkpoint_variables: equal-style variables saved with each checkpoint and set again, as
    constants, when the run resumes from it; restore_as maps a saved variable to another name
    to set instead (a running total saved as the base its resumed formula adds to)."""
    atomic_write_text(root / "setup.lammps", setup)
    atomic_write_text(root / "resume.lammps", resume)
    body = segments_script(schedule) if schedule["kind"] == "segments" else settle_script(schedule)
    atomic_write_text(root / "in.lammps", "# The whole run as one LAMMPS script (the driver runs the same steps in\n"
                                          "# checkpointed chunks):  lmp -in in.lammps -var plugin /path/to/plugin.so\n"
                                          "include         setup.lammps\n\n" + body)
    atomic_write_json(root / "session.json", {
        "setup": "setup.lammps", "resume": "resume.lammps", "checkpoints": "checkpoints",
        "schedule": schedule, "checkpoint_every_steps": checkpoint_every_steps,
        "checkpoint_variables": list(checkpoint_variables),
        **({"checkpoint_restore_as": dict(restore_as)} if restore_as else {})})


def peak_drop_check(stop_after_drop: float) -> dict:
    """settle() keywords of the crush's stop rule (SPEC 4.1), both models: at each check the
    force `${force}` is compared with the largest seen at the checks (peak_prev, which the input
    defines; it can only be below the true peak, so a stop is never early); once an element has
    broken (`${nb}` > 0: chatter at first touch, before any damage, is no peak) a force below
    stop_after_drop x peak settles the run."""
    return dict(
        check=["variable        f_now equal ${force}",
               # max() of a LAMMPS formula is a special function of computes: the larger by booleans
               'variable        peak_now equal "(v_peak_prev >= v_f_now)*v_peak_prev + '
               '(v_peak_prev < v_f_now)*v_f_now"',
               "variable        peak_now equal ${peak_now}",
               "variable        nb_now equal ${nb}",
               f'variable        dropped equal "(v_nb_now > 0) && (v_peak_now > 0) && '
               f'(v_f_now < {stop_after_drop!r}*v_peak_now)"'],
        settled_variable="dropped",
        advance=["variable        peak_prev equal ${peak_now}"])
