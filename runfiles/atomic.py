"""Atomic writes: a reader sees the old file or the whole new one, never a part.

Every file the tool writes goes through here (results, figures, data files, caches). The
temporary file has a unique name in the target's folder (parallel sweep workers may write the
same cache entry at once), starts with '.' and holds '.tmp' (run-directory clean-up patterns
know it), and gets the permissions of an ordinary file (mkstemp makes it private).
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any, Callable

_UMASK = os.umask(0)
os.umask(_UMASK)
#: Permissions of a file the tool writes (0666 less the umask, as open() gives).
FILE_MODE = 0o666 & ~_UMASK


def atomic_save(path: str | os.PathLike, writer: Callable[[Path], Any]) -> Path:
    """Call writer(tmp) to write a temporary file beside `path` (same suffix, so writers that
    go by it, e.g. np.savez or matplotlib, keep their format), then rename it onto `path`."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(prefix=f".{path.name}.tmp", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    tmp = Path(name)
    try:
        writer(tmp)
        os.chmod(tmp, FILE_MODE)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """Write `text` (UTF-8, '\\n' line ends) atomically."""
    return atomic_save(path, lambda tmp: _write(tmp, text))


def _write(tmp: Path, text: str) -> None:
    with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(text)


def atomic_write_json(path: str | os.PathLike, obj: Any) -> Path:
    """`obj` as indented JSON, atomically."""
    return atomic_write_text(path, json.dumps(obj, indent=2, default=str) + "\n")
