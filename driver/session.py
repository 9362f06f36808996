"""The LAMMPS side of a run: set up, then run the schedule in chunks, checkpointing and stoppable.

This code runs on every MPI rank (`python -m driver.session RUN_DIR` in a process of its own
on 1 rank, under `mpiexec` on N ranks) and issues the same commands on each. Every
chunk is a `run` command with its own setup (neighbour lists and atom order rebuilt); a
checkpoint is only ever taken between chunks, and chunk boundaries depend on the config alone,
so a run resumed from a checkpoint performs exactly the operations of an uninterrupted one.

Decisions shared by all ranks come from LAMMPS: the settle rule is a LAMMPS variable (global,
identical on every rank), and requests from the driver (stop, checkpoint now) are read with
`include control.lmp`, which rank 0 reads and broadcasts. A stop request ends the run at the
next chunk boundary with a checkpoint; the driver then marks the run `interrupted`.

The schedule (session.json, written by the scenario) is one of:
  segments: run to `total_steps`; after the listed steps, run the listed commands (snapshots);
  settle:   windows of `window` steps, at most `max_windows`; after each, `check` commands and
            the equal-style variable `settled` decide; then `advance`; at the end, `end`.
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path
from typing import Any

from driver.engine import Lammps, LammpsError

SESSION = "session.json"
CONTROL = "control.lmp"
ERROR_FILE = ".session_error.json"
OUTCOME = "outcome.json"
EXIT_STOPPED = 75  # the run stopped on request after writing a checkpoint
KEEP_CHECKPOINTS = 2


class SessionError(LammpsError):
    """The schedule cannot give a result (e.g. the particle never reached the plane)."""


class StopRequested(Exception):
    """The driver asked the run to stop; a checkpoint was written at `step`."""

    def __init__(self, step: int):
        super().__init__(f"stopped at step {step}")
        self.step = step


def write_control(run_dir: Path, stop: bool = False, checkpoint: int = 0) -> None:
    """The driver's requests, read by the session at each chunk boundary (atomic: rank 0 must
    never read half a file)."""
    from runfiles.atomic import atomic_write_text  # noqa: PLC0415

    atomic_write_text(Path(run_dir) / CONTROL, f"variable ctl_stop equal {int(stop)}\n"
                                               f"variable ctl_checkpoint equal {int(checkpoint)}\n")


def chunk_bounds(start: int, end: int, chunk: int) -> list[int]:
    """Chunk ends in (start, end]: on the grid of multiples of `chunk`, and `end`."""
    first = (start // chunk + 1) * chunk
    return [*range(first, end, chunk), end] if end > start else []


class Session:
    """Runs one plan on an open LAMMPS instance whose working directory is the run directory."""

    def __init__(self, lmp: Lammps, plan: dict[str, Any], run_dir: Path):
        self.lmp, self.plan, self.run_dir = lmp, plan, Path(run_dir)
        self.rank = int(lmp.extract_setting("world_rank"))
        self.step = 0
        self.state: dict[str, Any] = {}
        self.checkpoint_requests_done = 0
        self.last_checkpoint_step = 0
        every = plan.get("checkpoint_every_steps")
        self.every_steps = int(every) if every else None

    # ----------------------------------------------------------------- start
    def start_fresh(self) -> None:
        self.lmp.file(self.plan["setup"])
        self.step = int(self.lmp.extract_global("ntimestep"))

    def start_resumed(self, checkpoint: dict[str, Any]) -> None:
        self.lmp.command(f"variable checkpoint string {self.plan['checkpoints']}/{checkpoint['restart']}")
        self.lmp.file(self.plan["resume"])
        self.step = int(self.lmp.extract_global("ntimestep"))
        if self.step != checkpoint["step"]:
            raise LammpsError(f"checkpoint {checkpoint['restart']} holds step {self.step}, its record says "
                              f"{checkpoint['step']}")
        self.state = dict(checkpoint.get("state", {}))
        restore_as = self.plan.get("checkpoint_restore_as", {})
        for name, value in checkpoint.get("variables", {}).items():
            self.lmp.command(f"variable {restore_as.get(name, name)} equal {float(value)!r}")
        self.last_checkpoint_step = self.step  # the driver's request counter starts again at 0

    # ------------------------------------------------------------ schedule
    def run(self) -> None:
        sched = self.plan["schedule"]
        if sched["kind"] == "segments":
            self._run_segments(sched)
        elif sched["kind"] == "settle":
            self._run_settle(sched)
        else:
            raise ValueError(f"unknown schedule kind {sched['kind']!r}")

    def _advance_to(self, target: int, chunk: int, pre: bool = True) -> None:
        """Run to step `target` in chunks; pre=False: `run N pre no` (LAMMPS still sets up the
        first run of an instance)."""
        for end in chunk_bounds(self.step, target, chunk):
            self.lmp.command(f"run {end - self.step}" + ("" if pre else " pre no"))
            self.step = end
            if end != target:
                self._boundary()

    def _commands(self, lines: list[str]) -> None:
        for line in lines:
            self.lmp.command(line)

    def _run_segments(self, sched: dict[str, Any]) -> None:
        snapshots = {int(k): v for k, v in sched["snapshots"].items()}
        stops = sorted({*snapshots, int(sched["total_steps"])})
        for target in stops:
            if target <= self.step:
                continue
            self._advance_to(target, int(sched["chunk"]))
            self._commands(snapshots.get(target, []))
            if target != stops[-1]:
                self._boundary()

    def _run_settle(self, sched: dict[str, Any]) -> None:
        window, chunk = int(sched["window"]), int(sched["chunk"])
        while (w := int(self.state.get("windows_done", 0))) < int(sched["max_windows"]):
            self._advance_to((w + 1) * window, chunk, pre=not sched.get("pre_no", False))
            self._commands(sched["check"])
            settled = self.lmp.extract_variable(sched["settled_variable"]) > 0
            self.state["windows_done"] = w + 1
            if settled:
                self.state["settled"] = True
                break
            self._commands(sched["advance"])
            self._boundary()
        if not self.state.get("settled") and sched.get("never") \
                and self.lmp.extract_variable(sched["never"][0]) <= 0:
            raise SessionError(sched["never"][1])
        self._commands(sched["end"])
        self._outcome(settled=bool(self.state.get("settled")), windows=int(self.state.get("windows_done", 0)),
                      max_windows=int(sched["max_windows"]))

    def _outcome(self, **facts: Any) -> None:
        """What the schedule ended with (outcome.json), for the analysis; with rank 0's peak
        resident memory so far (this process holds LAMMPS and little else: the figure the
        benchmark reports)."""
        if self.rank == 0:
            from runfiles.atomic import atomic_write_json  # noqa: PLC0415

            atomic_write_json(self.run_dir / OUTCOME, {"end_step": self.step, **facts,
                                                       "session_peak_rss_mib": peak_rss_mib()})

    # ------------------------------------------------------------ boundaries
    def _boundary(self) -> None:
        """Between two chunks: read the driver's requests; checkpoint or stop."""
        self.lmp.command(f"include {CONTROL}")
        stop = self.lmp.extract_variable("ctl_stop") > 0
        requested = int(self.lmp.extract_variable("ctl_checkpoint"))
        due = self.every_steps is not None and self.step - self.last_checkpoint_step >= self.every_steps
        if stop or due or requested > self.checkpoint_requests_done:
            self.checkpoint_requests_done = max(requested, self.checkpoint_requests_done)
            self.write_checkpoint()
        if stop:
            raise StopRequested(self.step)

    def write_checkpoint(self) -> None:
        """LAMMPS restart file (plugins' state included) and the driver's record, atomically:
        the restart is renamed into place, then the record naming it is written; the record is
        what makes a checkpoint valid. The last KEEP_CHECKPOINTS are kept."""
        folder = self.run_dir / self.plan["checkpoints"]
        self.last_checkpoint_step = self.step
        name = f"step{self.step:012d}.restart"
        partial = f"{self.plan['checkpoints']}/.partial.restart"
        self.lmp.command(f"write_restart {partial}")
        if self.plan["schedule"].get("pre_no"):
            # write_restart runs LAMMPS's init(), which sets fix print's next record to this step and
            # leaves it to a set-up to print it and move on: under `run N pre no` none comes and the
            # record stops for good (measured: thermo.dat ended at the first checkpoint). A set-up
            # here prints this step's record again (read_record keeps the last) and sees a moving
            # region platen at rest for its one force evaluation (driver/bpm/platen.py), as a resume does.
            self.lmp.command("run 0 post no")
        # on every rank: a variable of a compute (a running integral's power) reduces over all ranks,
        # so a rank that skipped it would leave the others waiting in that reduction
        variables = {v: self.lmp.extract_variable(v) for v in self.plan.get("checkpoint_variables", [])}
        if self.rank != 0:
            return
        from runfiles.atomic import atomic_write_json  # noqa: PLC0415

        os.replace(self.run_dir / partial, folder / name)
        atomic_write_json(folder / f"step{self.step:012d}.json", {
            "step": self.step, "restart": name, "time": time.strftime("%Y-%m-%dT%H:%M:%S"),
            "simulated_time": self.lmp.extract_global("atime"), "state": self.state,
            "variables": variables})
        records = sorted(folder.glob("step*.json"))
        for old in records[:-KEEP_CHECKPOINTS]:
            old.unlink(missing_ok=True)
            old.with_suffix(".restart").unlink(missing_ok=True)


def peak_rss_mib() -> float | None:
    """Peak resident memory of this process (VmHWM) in MiB; None where /proc is missing. Not
    ru_maxrss: a child forked from the driver inherits the driver's pages until it execs, and
    ru_maxrss keeps that figure."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return None


def load_plan(run_dir: Path) -> dict[str, Any]:
    return json.loads((Path(run_dir) / SESSION).read_text())


def run_plan(lmp: Lammps, run_dir: Path, checkpoint: dict[str, Any] | None) -> None:
    """Set up (fresh or from `checkpoint`) and run the schedule; StopRequested on a stop."""
    plan = load_plan(run_dir)
    session = Session(lmp, plan, run_dir)
    (Path(run_dir) / plan["checkpoints"]).mkdir(exist_ok=True)
    if checkpoint is None:
        session.start_fresh()
    else:
        session.start_resumed(checkpoint)
    session.run()


def main(argv: list[str] | None = None) -> int:
    """`python -m driver.session RUN_DIR [CHECKPOINT_JSON]`: the session, or one rank of it."""
    args = sys.argv[1:] if argv is None else argv
    run_dir = Path(args[0]).resolve()
    checkpoint = json.loads(Path(args[1]).read_text()) if len(args) > 1 else None
    os.chdir(run_dir)
    lmp = None
    try:
        lmp = Lammps(log=None)
        lmp.command("log log.lammps append" if checkpoint else "log log.lammps")
        run_plan(lmp, run_dir, checkpoint)
    except StopRequested:
        return EXIT_STOPPED
    except Exception as exc:  # noqa: BLE001 - reported to the driver, which raises it
        from runfiles.atomic import atomic_write_json  # noqa: PLC0415

        atomic_write_json(run_dir / ERROR_FILE, {"type": type(exc).__name__, "message": str(exc)})
        print(f"{type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
    finally:
        # every rank ends MPI properly: a rank that leaves without MPI_Finalize while another is
        # still closing is taken by mpiexec for a crash, and the others are killed (signal 9)
        if lmp is not None and lmp.lmp is not None:
            lmp.lmp.finalize()
            lmp.lmp = None
    return 0


if __name__ == "__main__":
    sys.exit(main())
