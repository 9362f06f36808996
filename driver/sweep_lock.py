"""One `driver sweep` at a time in a sweep directory.

An OS file lock on `.brittle-sweep.lock` in the sweep directory, held while the sweep runs (its
runs, then the sweep and set tables), with its holder (pid, host, start, command line) written
into the lock file: a second sweep into the same directory is refused at once, naming the
holder, as a second run in a run directory is (driver/rundir.py). Without it the two would
each find the other's runs busy, report them as failed and rewrite the set tables. The lock
goes with the process: a sweep killed leaves no lock behind.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import socket
import time
from pathlib import Path
from typing import Iterator

from driver.rundir import RunDirError
from runfiles.atomic import FILE_MODE

SWEEP_LOCK = ".brittle-sweep.lock"


@contextlib.contextmanager
def sweep_lock(directory: Path, command: list[str]) -> Iterator[None]:
    """Hold the sweep lock of `directory` (an existing sweep directory) while the block runs;
    RunDirError naming the holder when another sweep holds it. command: this sweep's command
    line, recorded for the message another sweep would get."""
    path = Path(directory) / SWEEP_LOCK
    fd = os.open(path, os.O_RDWR | os.O_CREAT, FILE_MODE)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError as exc:
        os.close(fd)
        if exc.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
            raise RunDirError(f"{directory}: cannot lock {SWEEP_LOCK} ({exc.strerror}); this filesystem may not "
                              "support file locks: choose a sweep directory on a local disk") from None
        raise RunDirError(busy_message(Path(directory))) from None
    try:
        holder = {"pid": os.getpid(), "host": socket.gethostname(), "started": time.strftime("%Y-%m-%dT%H:%M:%S"),
                  "command": " ".join(command)}
        os.ftruncate(fd, 0)
        os.pwrite(fd, (json.dumps(holder) + "\n").encode(), 0)
        yield
    finally:
        os.close(fd)  # closing releases the lock


def busy_message(directory: Path) -> str:
    """Who holds the sweep lock of `directory`, as the refusal names it."""
    try:
        holder = json.loads((directory / SWEEP_LOCK).read_text())
    except (OSError, ValueError):  # taken a moment ago, its holder not written yet
        holder = {}
    command = f": {holder['command']}" if holder.get("command") else ""
    return (f"{directory}: busy, a sweep is running there (pid {holder.get('pid', '?')} on host "
            f"{holder.get('host', '?')}, since {holder.get('started', '?')}{command}); wait for it, stop it, or "
            "choose another sweep directory (--out)")
