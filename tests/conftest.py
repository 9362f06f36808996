"""Shared fixtures, and the tiers of the suite (docs/testing.md).

Tiers: a test is `lammps` when it starts LAMMPS, in this process or in a subprocess (`driver
run`, `lmp`, `mpiexec`); the others are pure Python. The marker is set here
on every test that uses the `plugin_path` fixture (directly, or through `lmp`, `plugin_cache`
or a fixture of a reference run) or carries `mpi`, and by hand (`@pytest.mark.lammps`) on a
test that starts LAMMPS otherwise. A test not marked `lammps` that starts LAMMPS fails with a
message saying so, so the marking cannot rot. `slow` and `mpi` are set by hand.

Every test has a time limit (pytest-timeout, in the `test` extra): TIME_LIMIT_S, SLOW_TIME_LIMIT_S
for the `slow` ones; `--timeout` on the command line replaces both (`--timeout=0`: none).
"""

from __future__ import annotations

import fcntl
import json
import os
import shutil
import subprocess
from pathlib import Path
from typing import Callable

import pytest

from driver import engine
from driver.cache import cache_base
from driver.engine import Lammps
from driver.plugin_build import cache_root, plugin_library

#: Per-test limits in seconds (fixture setup included), so that only a hang reaches them: about
#: three times the slowest test of each kind seen on 2 cores loaded 4-5 times over (load 7-10):
#: 112 s quick (a setup waiting for the plugin build), 415 s slow (tests/test_compare.py).
TIME_LIMIT_S = 300
SLOW_TIME_LIMIT_S = 1200

#: `driver` commands that start LAMMPS (the others read run directories).
LAMMPS_COMMANDS = {"run", "sweep", "calibrate", "compare", "plugins"}


def pytest_configure(config):
    # One plugin cache for the whole session, whatever a test does to HOME or XDG_CACHE_HOME
    # (a test that moved it would build the plugins again); subprocesses inherit it.
    os.environ.setdefault("BRITTLE_CACHE", str(cache_base()))


def pytest_collection_modifyitems(config, items):
    limits = config.pluginmanager.hasplugin("timeout") and config.getoption("timeout", None) is None \
        and not config.getini("timeout") and "PYTEST_TIMEOUT" not in os.environ
    if os.environ.get("PYTEST_XDIST_WORKER"):
        # the slow tests first, so that the workers do not end on a long one each (or one alone)
        items.sort(key=lambda item: item.get_closest_marker("slow") is None)
    for item in items:
        if "plugin_path" in item.fixturenames or item.get_closest_marker("mpi"):
            item.add_marker(pytest.mark.lammps)
        if limits and item.get_closest_marker("timeout") is None:
            item.add_marker(pytest.mark.timeout(SLOW_TIME_LIMIT_S if item.get_closest_marker("slow")
                                                else TIME_LIMIT_S))


# ------------------------------------------------------------------------------ the lammps guard
def _starts_lammps(argv) -> bool:
    """Whether a subprocess's command line starts LAMMPS: `lmp` or `mpiexec`, a `driver`
    command that runs it, or Python code that opens it or builds the plugins."""
    args = [os.fspath(a) for a in ([argv] if isinstance(argv, (str, bytes, os.PathLike)) else argv)]
    args = [a.decode() if isinstance(a, bytes) else a for a in args]
    if not args:
        return False
    if Path((args[0].split() or [""])[0]).name in {"lmp", "mpiexec", "mpirun"}:
        return True
    code = " ".join(args[i + 1] for i, a in enumerate(args[:-1]) if a == "-c")
    if any(s in code for s in ("plugin_library", "Lammps(", "lammps.lammps(")):
        return True
    # the command follows the entry point: `driver CMD`, `-m driver.cli CMD`, `-c "...main()" CMD`
    entry = [i for i, a in enumerate(args[:4]) if a == "driver.cli" or Path(a).name == "driver"
             or "driver.cli import" in a]
    return bool(entry) and entry[0] + 1 < len(args) and args[entry[0] + 1] in LAMMPS_COMMANDS


def _refuse(what: str):
    raise RuntimeError(f"this test {what} but is not marked `lammps`: give it the `plugin_path` fixture "
                       "or @pytest.mark.lammps (tests/conftest.py, docs/testing.md)")


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    """Outside the `lammps` tier, starting LAMMPS is an error, in process or in a subprocess,
    from the test or from any fixture it sets up (module and session ones included)."""
    if item.get_closest_marker("lammps"):
        yield
        return
    # the version is cached once read; cleared, a test that needs it opens LAMMPS every time
    engine.lammps_version.cache_clear()
    lammps_class, popen_init = engine.lammps_module().lammps, subprocess.Popen.__init__
    lammps_init = lammps_class.__init__

    def refused(self, *a, **k):
        self.lmp = None  # what lammps.__del__ closes
        _refuse("opens LAMMPS")

    def guarded(self, args, *a, **k):
        if _starts_lammps(args):
            _refuse(f"starts LAMMPS in a subprocess ({' '.join(map(str, args))[:200]})")
        popen_init(self, args, *a, **k)

    lammps_class.__init__, subprocess.Popen.__init__ = refused, guarded
    try:
        yield
    finally:
        lammps_class.__init__, subprocess.Popen.__init__ = lammps_init, popen_init
        engine.lammps_version.cache_clear()


# ------------------------------------------------------------------------------ plugins
@pytest.fixture(scope="session")
def plugin_path() -> str:
    """The project's plugin library, built on first use exactly as a run builds it."""
    return str(plugin_library())


@pytest.fixture
def lmp(plugin_path):
    """A fresh LAMMPS instance (no log, no screen) with the plugin library loaded."""
    inst = Lammps()
    inst.command(f"plugin load {plugin_path}")
    yield inst
    inst.close()


@pytest.fixture
def plugin_cache(tmp_path, monkeypatch, plugin_path) -> Path:
    """An empty cache of the project (BRITTLE_CACHE) but for the plugins already built: for the
    tests of what is cached (calibration curves, tessellations), without building the plugins
    again. The library is shared, read-only, with the session's cache."""
    cache = tmp_path / "cache"
    cache.mkdir()
    os.symlink(cache_root().resolve(), cache / "plugins")
    monkeypatch.setenv("BRITTLE_CACHE", str(cache))
    return cache


# ------------------------------------------------------------------------------ reference runs
class SharedRuns:
    """Run directories built once per test session and read by several tests: under
    pytest-xdist the first worker to ask builds one, the others wait on its lock and read it.
    Tests only read them; a test that changes a run works on a copy (shutil.copytree). A run
    changed all the same (a file added, removed or rewritten) fails the next test asking for it
    and the session's end."""

    def __init__(self, root: Path):
        self.root = root
        self.used: set[str] = set()

    def get(self, name: str, build: Callable[[Path], object]) -> Path:
        """The run `name`, built by `build(out)` into `out` on first use."""
        out, done = self.root / name, self.root / f"{name}.done.json"
        if not done.exists():
            self.root.mkdir(parents=True, exist_ok=True)
            with open(self.root / f"{name}.lock", "w") as lock:
                fcntl.flock(lock, fcntl.LOCK_EX)
                if not done.exists():
                    shutil.rmtree(out, ignore_errors=True)  # an attempt that failed
                    build(out)
                    done.write_text(json.dumps(_manifest(out)))
        self.used.add(name)
        self.check(name)
        return out

    def check(self, name: str) -> None:
        before = json.loads((self.root / f"{name}.done.json").read_text())
        now = _manifest(self.root / name)
        if now != before:
            changed = sorted(set(before.items()) ^ set(now.items()))
            pytest.fail(f"the shared run {name!r} was changed by a test (copy it before changing it): "
                        f"{[c[0] for c in changed][:10]}", pytrace=False)


def _manifest(root: Path) -> dict[str, str]:
    return {str(p.relative_to(root)): f"{p.stat().st_size} {p.stat().st_mtime_ns}"
            for p in sorted(root.rglob("*")) if p.is_file() and not p.name.endswith(".lock")}  # a refused run opens its lock


@pytest.fixture(scope="session")
def shared_runs(tmp_path_factory):
    """The session's SharedRuns, in the folder that every xdist worker of the session shares, or
    in $BRITTLE_SHARED_RUNS: a folder kept from one session to the next (.ci/run's two pytest
    calls), for one state of the sources only."""
    base = tmp_path_factory.getbasetemp()
    root = os.environ.get("BRITTLE_SHARED_RUNS") or (base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base)
    runs = SharedRuns(Path(root) / "shared_runs")
    yield runs
    for name in sorted(runs.used):
        runs.check(name)
