"""Running LAMMPS for a run directory: the session in its own lean process (1 rank) or under
mpiexec (N ranks), with progress, heartbeat, periodic checkpoints and clean stops on SIGINT/SIGTERM.

The session (driver/session.py) runs as `python -m driver.session`, alone on 1 rank, under the
wheel's `mpiexec` on N (command line and environment: driver/mpi_launch.py), in its own process
group so that a terminal's Ctrl-C reaches only the driver. It imports LAMMPS and little else:
the driver's own memory (the tessellation it built, numpy, pandas, matplotlib for the analysis)
never adds to the peak of the process that holds LAMMPS, and the analysis that follows starts
from a process without LAMMPS's arrays. Either way:
  - a thread tails the run's progress record (an absolute path: the 1-rank session changes
    directory) for the progress bar, refreshes the heartbeat in status.json, and asks for a
    checkpoint every `checkpoint_every` of wall time (control.lmp, read at chunk boundaries);
  - the first SIGINT or SIGTERM asks the session to stop at the next chunk boundary, where it
    writes a checkpoint: the run raises RunInterrupted. A second signal (or no answer within
    STOP_GRACE_S) ends an MPI run at once; its last periodic checkpoint stands.
Errors arrive as LammpsError with LAMMPS's message.
"""

from __future__ import annotations

import contextlib
import ctypes
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

from driver.engine import Lammps, LammpsError, venv_bin
from driver.mpi_launch import launch_env, launcher
from driver.session import ERROR_FILE, EXIT_STOPPED, SessionError, write_control

HEARTBEAT_S = 10.0
STOP_GRACE_S = 60.0


class RunInterrupted(Exception):
    """A run stopped on a signal; `checkpoint` is the step it can resume from (None: none)."""

    def __init__(self, signum: int, checkpoint: int | None = None, phase: str = "lammps",
                 lammps_done: bool = False):
        name = signal.Signals(signum).name
        where = f"; resume from the checkpoint at step {checkpoint}" if checkpoint is not None else ""
        if lammps_done:
            where = "; its simulation is complete: --resume analyses it"
        super().__init__(f"stopped by {name} during {phase}{where}")
        self.signum, self.checkpoint, self.phase, self.lammps_done = signum, checkpoint, phase, lammps_done

    @property
    def exit_code(self) -> int:
        return 128 + self.signum


@dataclass
class ProgressSpec:
    """Where progress is recorded and how to read it: `file` is a whitespace table whose
    first column is the step; `columns` names the columns to show (name -> index)."""

    file: str
    total_steps: int
    columns: dict[str, int]
    label: str = "LAMMPS"


@contextlib.contextmanager
def _chdir(path: Path):
    old = Path.cwd()
    os.chdir(path)
    try:
        yield
    finally:
        os.chdir(old)


# ------------------------------------------------------------------------- control
#: Sessions running in this process, and the sweep invocation each run belongs to: a sweep's
#: client stops its runs on its Dask workers by its token (request_stop_sweep).
_active: dict[Path, "Control"] = {}
_run_tokens: dict[Path, str] = {}
_stopped_tokens: set[str] = set()
_registry_lock = threading.Lock()


def bind_sweep_token(run_dir: Path, token: str) -> bool:
    """Mark `run_dir` as run for the sweep invocation `token`; False when that invocation was
    already asked to stop (the run should not begin)."""
    with _registry_lock:
        _run_tokens[Path(run_dir).resolve()] = token
        return token not in _stopped_tokens


def request_stop_sweep(token: str, signum: int = signal.SIGINT) -> list[str]:
    """Ask the sessions of sweep invocation `token` in this process to stop at their next chunk
    boundary (writing a checkpoint); its runs that begin later stop at once. Returns the run
    dirs that were running here."""
    with _registry_lock:
        _stopped_tokens.add(token)
        running = [c for d, c in _active.items() if _run_tokens.get(d) == token]
    for control in running:
        control.request_stop(signum)
    return [str(c.run_dir) for c in running]


class Control:
    """The driver's side of control.lmp: stop and checkpoint requests, written atomically."""

    def __init__(self, run_dir: Path):
        self.run_dir = run_dir
        self.stop = False
        self.signum: int | None = None
        self.checkpoints = 0
        self._lock = threading.Lock()
        with _registry_lock:
            if _run_tokens.get(Path(run_dir).resolve()) in _stopped_tokens:
                self.stop, self.signum = True, signal.SIGINT
        self._write()

    def _write(self) -> None:
        write_control(self.run_dir, stop=self.stop, checkpoint=self.checkpoints)

    def request_stop(self, signum: int) -> None:
        with self._lock:
            self.stop, self.signum = True, signum
            self._write()

    def request_checkpoint(self) -> None:
        with self._lock:
            self.checkpoints += 1
            self._write()


# ------------------------------------------------------------------------- monitor
class _Monitor(threading.Thread):
    """Tails the progress file, shows a progress bar, beats the heart, times checkpoints."""

    def __init__(self, path: Path, spec: ProgressSpec | None, console: Console | None,
                 heartbeat: Callable[[dict[str, Any]], None] | None = None,
                 control: Control | None = None, checkpoint_seconds: float | None = None):
        super().__init__(daemon=True)
        self.path, self.spec = Path(path).resolve(), spec
        self.heartbeat, self.control, self.checkpoint_seconds = heartbeat, control, checkpoint_seconds
        self.stop_event = threading.Event()
        self.last: dict[str, Any] = {}
        self.progress = None
        if spec is not None and console is not None:
            cols = [TextColumn(f"[bold]{spec.label}"), BarColumn(),
                    TextColumn("step {task.completed:,.0f}/{task.total:,.0f}")]
            cols += [TextColumn(f"{name} {{task.fields[{name}]}}") for name in spec.columns]
            cols += [TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn()]
            self.progress = Progress(*cols, console=console, transient=False)
            self.task = self.progress.add_task("run", total=spec.total_steps, **{n: "-" for n in spec.columns})

    def _poll(self, fh) -> None:
        last = None
        for line in fh:
            if line.strip() and not line.startswith("#") and line.endswith("\n"):
                last = line.split()
        if last and self.spec is not None:
            try:
                fields = {n: last[i] for n, i in self.spec.columns.items()}
                self.last = {"step": int(float(last[0])), **fields}
                if self.progress is not None:
                    self.progress.update(self.task, completed=float(last[0]), **fields)
            except (IndexError, ValueError):
                pass

    def _loop(self) -> None:
        fh = None
        beat = ckpt = time.monotonic()
        while not self.stop_event.wait(0.5):
            if fh is None and self.path.exists():
                fh = open(self.path)
            if fh is not None:
                self._poll(fh)
            now = time.monotonic()
            if self.heartbeat is not None and now - beat >= HEARTBEAT_S:
                beat = now
                with contextlib.suppress(OSError):
                    self.heartbeat(self.last)
            if self.control is not None and self.checkpoint_seconds and now - ckpt >= self.checkpoint_seconds:
                ckpt = now
                self.control.request_checkpoint()
        if fh is None and self.path.exists():
            fh = open(self.path)
        if fh is not None:
            self._poll(fh)
            fh.close()

    def run(self) -> None:
        if self.progress is None:
            self._loop()
            return
        with self.progress:
            self._loop()


# ------------------------------------------------------------------------- signals
_STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


@contextlib.contextmanager
def _on_stop_signals(handler: Callable[[int, Any], None]):
    """`handler` for SIGINT and SIGTERM while the block runs (the previous ones restored after);
    a no-op outside the main thread, where Python cannot install handlers."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = {s: signal.signal(s, handler) for s in _STOP_SIGNALS}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)


_deferred: list[int] = []  # signals held back while a deferred_signals() block runs
_deferring = threading.Event()


def interruptible():
    """SIGINT/SIGTERM raise RunInterrupted in the main thread (outside a LAMMPS session, i.e.
    while a system is built or a run analysed), or at the end of a deferred_signals() block."""

    def handler(signum, _frame):
        if _deferring.is_set():
            _deferred.append(signum)
            return
        raise RunInterrupted(signum, phase="driver")

    return _on_stop_signals(handler)


@contextlib.contextmanager
def deferred_signals():
    """A block that a stop signal must not cut in two (e.g. swapping results into place): the
    signal takes effect when it ends."""
    _deferring.set()
    try:
        yield
    finally:
        _deferring.clear()
    if _deferred:
        signum = _deferred.pop()
        _deferred.clear()
        raise RunInterrupted(signum, phase="driver")


def _signals_request_stop(control: Control, on_second: Callable[[], None] | None = None):
    """Inside a session: the first signal asks for a stop at the next chunk boundary; a second
    one calls `on_second` (an MPI run: end it at once)."""

    def handler(signum, _frame):
        if control.stop and on_second is not None:
            on_second()
        control.request_stop(signum)

    return _on_stop_signals(handler)


# ------------------------------------------------------------------------- session
def run_session(run_dir: Path, np: int = 1, checkpoint: dict[str, Any] | None = None,
                progress: ProgressSpec | None = None, show_progress: bool = True, console: Console | None = None,
                heartbeat: Callable[[dict[str, Any]], None] | None = None,
                checkpoint_seconds: float | None = None) -> None:
    """Run the session of `run_dir` (fresh, or from `checkpoint`) on `np` ranks.

    Raises RunInterrupted after a stop on a signal, LammpsError when LAMMPS fails."""
    run_dir = Path(run_dir).resolve()
    (run_dir / ERROR_FILE).unlink(missing_ok=True)
    control = Control(run_dir)
    monitor = _Monitor(run_dir / (progress.file if progress else "thermo.dat"), progress,
                       (console or Console(stderr=True)) if show_progress else None,
                       heartbeat=heartbeat, control=control, checkpoint_seconds=checkpoint_seconds)
    monitor.start()
    with _registry_lock:
        _active[run_dir] = control
    try:
        _session_process(run_dir, np, checkpoint, control)
    finally:
        with _registry_lock:
            _active.pop(run_dir, None)
        monitor.stop_event.set()
        monitor.join()
    if control.stop:  # asked during the last chunk: the simulation is complete, the rest waits
        raise RunInterrupted(control.signum or signal.SIGINT, phase="the end of the LAMMPS run", lammps_done=True)


def _set_pdeathsig() -> None:  # pragma: no cover - runs in the child between fork and exec
    """The MPI launcher ends with the driver (SIGTERM: mpiexec then ends its ranks)."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG


def _session_command(run_dir: Path, np: int) -> list[str]:
    """The session's command line: 1 rank needs no launcher (LAMMPS runs as an MPI singleton)."""
    return [*launcher(np), sys.executable, "-m", "driver.session", str(run_dir)]


def _session_process(run_dir: Path, np: int, checkpoint: dict[str, Any] | None, control: Control) -> None:
    cmd = _session_command(run_dir, np)
    if checkpoint is not None:
        ckpt_file = run_dir / "checkpoints" / ".resume_from.json"
        ckpt_file.write_text(json.dumps(checkpoint))
        cmd.append(str(ckpt_file))
    with open(run_dir / "log.session.txt", "a") as out:
        proc = subprocess.Popen(cmd, cwd=run_dir, stdout=out, stderr=subprocess.STDOUT, start_new_session=True,
                                preexec_fn=_set_pdeathsig, env=launch_env())

        def kill() -> None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGTERM)

        with _signals_request_stop(control, on_second=kill):
            stop_seen = None
            while True:
                try:
                    code = proc.wait(timeout=0.5)
                    break
                except subprocess.TimeoutExpired:
                    if control.stop and stop_seen is None:
                        stop_seen = time.monotonic()
                    if stop_seen is not None and time.monotonic() - stop_seen > STOP_GRACE_S:
                        kill()
    if code == EXIT_STOPPED or (control.stop and code != 0):
        from driver.rundir import latest_checkpoint  # noqa: PLC0415

        last = latest_checkpoint(run_dir)
        raise RunInterrupted(control.signum or signal.SIGINT, last["step"] if last else None)
    if code != 0:
        with contextlib.suppress(OSError, ValueError):
            if json.loads((run_dir / ERROR_FILE).read_text()).get("type") == "SessionError":
                raise SessionError(json.loads((run_dir / ERROR_FILE).read_text())["message"])
        raise LammpsError(_mpi_error(run_dir, np, code))


_ERROR_RE = re.compile(r"^(ERROR.*)$", re.MULTILINE)


def _mpi_error(run_dir: Path, np: int, code: int) -> str:
    where = f"mpiexec -n {np}" if np > 1 else "session process"
    err = run_dir / ERROR_FILE
    if err.exists():
        with contextlib.suppress(OSError, ValueError):
            return f"{json.loads(err.read_text())['message']} ({where}, exit code {code})"
    text = ""
    for name in ("log.lammps", "log.session.txt"):
        if (run_dir / name).exists():
            text += (run_dir / name).read_text(errors="replace") + "\n"
    found = _ERROR_RE.findall(text)
    msg = found[-1] if found else (text.strip().splitlines() or ["LAMMPS failed"])[-1]
    return f"{msg} ({where}, exit code {code})"


# ------------------------------------------------------------------ plain input files
def run_input(run_dir: Path, input_name: str = "in.lammps", np: int = 1,
              progress: ProgressSpec | None = None, show_progress: bool = True,
              console: Console | None = None) -> None:
    """Run a plain input file `run_dir/input_name` (no checkpoints) with the run directory as
    working directory. Raises LammpsError with LAMMPS's message if LAMMPS stops with an error."""
    run_dir = Path(run_dir).resolve()
    monitor = None
    if progress is not None and show_progress:
        monitor = _Monitor(run_dir / progress.file, progress, console or Console(stderr=True))
        monitor.start()
    try:
        if np == 1:
            with _chdir(run_dir), Lammps(log="log.lammps") as lmp:
                lmp.file(input_name)
        else:
            cmd = [*launcher(np), venv_bin("lmp"), "-in", input_name,
                   "-log", "log.lammps", "-screen", "none", "-nocite"]
            proc = subprocess.run(cmd, cwd=run_dir, capture_output=True, text=True, env=launch_env())
            if proc.returncode != 0:
                (run_dir / "log.session.txt").write_text(proc.stdout + proc.stderr)
                raise LammpsError(_mpi_error(run_dir, np, proc.returncode))
    finally:
        if monitor is not None:
            monitor.stop_event.set()
            monitor.join()
