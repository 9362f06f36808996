"""The layers of the package: runfiles/ (files both sides handle) below analysis/ below
driver/. A module may import from its own layer and the ones below, never from above. Inside
driver/ the same rule holds for the order of DRIVER_LAYERS, no import cycle is left, and every
module of the three packages imports first in a fresh interpreter (a cycle hidden behind lazy
imports is still a cycle)."""

from __future__ import annotations

import ast
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("runfiles", "analysis", "driver")
#: what each layer may not import
FORBIDDEN = {"runfiles": ("driver", "analysis"), "analysis": ("driver",)}
#: The order inside driver/, lowest first: a module (or a subpackage: every module under it)
#: may import from its own layer and the ones below, never from a later one. The longest
#: entry naming a module places it (driver.scenarios.api sits below the units of
#: driver.scenarios). A new module must be placed here.
DRIVER_LAYERS: list[tuple[str, tuple[str, ...]]] = [
    ("foundations: the version, the section base, the cache location, templates, schedules, the "
     "moduli protocol, the site LAMMPS",
     ("driver", "driver.schema", "driver.cache", "driver.templates", "driver.schedule", "driver.moduli_protocol",
      "driver.lammps_site")),
    ("LAMMPS and the run directory: the engine, its sessions, the runner and its MPI launch, the plugin build, "
     "run directories",
     ("driver.engine", "driver.session", "driver.rundir", "driver.plugin_build", "driver.mpi_launch",
      "driver.runner")),
    ("the models: their sections and builders",
     ("driver.bcm", "driver.bpm")),
    ("what a unit provides and uses: the scenario API, the shared sections, the size model",
     ("driver.scenarios.api", "driver.scenarios.sections", "driver.size_model")),
    ("the units", ("driver.scenarios",)),
    ("the registry", ("driver.registry",)),
    ("the configuration", ("driver.config",)),
    ("one run and a set of runs: the size check, the pipeline, set analyses, run states, cluster files",
     ("driver.estimate", "driver.pipeline", "driver.sets", "driver.status", "driver.cluster")),
    ("many runs: Dask, sweeps and their lock", ("driver.distributed", "driver.sweep", "driver.sweep_lock")),
    ("calibration", ("driver.calibration",)),
    ("comparison of the models", ("driver.compare",)),
    ("the command line", ("driver.cli",)),
]


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    # `if TYPE_CHECKING:` blocks never run: the names they import are for annotations only
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip |= {id(n) for n in ast.walk(node)}
    return skip


def _imports(path: Path, runtime: bool = False) -> list[tuple[int, str]]:
    """(line, module) of every absolute import in the file, lazy ones inside functions too;
    runtime=True leaves out `if TYPE_CHECKING:` blocks. `from a import b` gives a and, where
    b may be a module, a.b (the callers resolve it)."""
    tree = ast.parse(path.read_text(), str(path))
    skip = _type_checking_nodes(tree) if runtime else set()
    found = []
    for node in ast.walk(tree):  # lazy imports inside functions count too
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.append((node.lineno, node.module))
            found += [(node.lineno, f"{node.module}.{a.name}") for a in node.names if a.name != "*"]
    return found


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules(package: str) -> dict[str, Path]:
    return {_module_name(p): p for p in sorted((ROOT / package).rglob("*.py"))}


def _resolve(name: str, modules: dict[str, Path]) -> str | None:
    """The module of `modules` an imported name refers to (a.b.func -> a.b), None if none."""
    while name and name not in modules:
        name = name.rpartition(".")[0]
    return name or None


def _layer(module: str, layers: list[tuple[str, tuple[str, ...]]]) -> int | None:
    """Index of the layer whose longest entry is `module` or a package above it."""
    best, best_len = None, -1
    for i, (_, entries) in enumerate(layers):
        for entry in entries:
            if (module == entry or module.startswith(entry + ".")) and len(entry) > best_len:
                best, best_len = i, len(entry)
    return best


def _driver_graph(root_modules: dict[str, Path]) -> dict[str, dict[str, int]]:
    """Runtime imports between driver/ modules: {importer: {imported: line}}."""
    graph: dict[str, dict[str, int]] = {}
    for name, path in root_modules.items():
        edges: dict[str, int] = {}
        for line, imported in _imports(path, runtime=True):
            target = _resolve(imported, root_modules)
            if target is not None and target != name:
                edges.setdefault(target, line)
        graph[name] = edges
    return graph


def _upward_imports(graph: dict[str, dict[str, int]], modules: dict[str, Path],
                    layers: list[tuple[str, tuple[str, ...]]], root: Path = ROOT) -> list[str]:
    bad = []
    for name, edges in sorted(graph.items()):
        mine = _layer(name, layers)
        for target, line in sorted(edges.items()):
            theirs = _layer(target, layers)
            if mine is not None and theirs is not None and theirs > mine:
                bad.append(f"{modules[name].relative_to(root)}:{line} imports {target} ({layers[theirs][0]}) from "
                           f"below it ({layers[mine][0]})")
    return bad


def _cycles(graph: dict[str, dict[str, int]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph.get(w, {})))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                if len(comp) > 1:
                    out.append(sorted(comp))
    return out


# ------------------------------------------------------------------------------ packages
@pytest.mark.parametrize("layer", sorted(FORBIDDEN))
def test_no_layer_imports_from_above(layer):
    bad = [f"{path.relative_to(ROOT)}:{line} imports {name}"
           for path in sorted((ROOT / layer).rglob("*.py")) for line, name in _imports(path)
           if name.split(".")[0] in FORBIDDEN[layer]]
    assert not bad, "\n".join(bad)


def test_the_check_sees_an_import_from_above(tmp_path):
    """The scan itself: a lazy `from driver...` inside a function is found."""
    f = tmp_path / "m.py"
    f.write_text("def f():\n    from driver.rundir import RunDir\n    return RunDir\n")
    assert _imports(f) == [(2, "driver.rundir"), (2, "driver.rundir.RunDir")]


# ------------------------------------------------------------------------------ inside driver/
def test_every_driver_module_has_a_layer():
    missing = [name for name in _modules("driver") if _layer(name, DRIVER_LAYERS) is None]
    assert not missing, f"place these modules in DRIVER_LAYERS: {', '.join(missing)}"


def test_driver_modules_import_only_from_their_layer_and_below():
    modules = _modules("driver")
    bad = _upward_imports(_driver_graph(modules), modules, DRIVER_LAYERS)
    assert not bad, "\n".join(bad)


def test_no_import_cycle_inside_driver():
    """Lazy imports inside functions count: a cycle behind them still breaks a fresh import of
    whichever module of it comes first."""
    cycles = _cycles(_driver_graph(_modules("driver")))
    assert not cycles, "\n".join(" <-> ".join(c) for c in cycles)


def test_the_order_check_sees_a_lazy_import_from_above_and_a_cycle(tmp_path):
    """The checks themselves, on a made-up package: a lazy import from a higher layer is named,
    `if TYPE_CHECKING:` imports are not, and two modules importing each other are a cycle."""
    (tmp_path / "low.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    import high\n"
                                     "def f():\n    import high\n    return high\n")
    (tmp_path / "high.py").write_text("import low\n")
    modules = {"low": tmp_path / "low.py", "high": tmp_path / "high.py"}
    graph = _driver_graph(modules)
    layers = [("low layer", ("low",)), ("high layer", ("high",))]
    assert graph == {"low": {"high": 5}, "high": {"low": 1}}
    assert _upward_imports(graph, modules, layers, root=tmp_path) == [
        "low.py:5 imports high (high layer) from below it (low layer)"]
    assert _cycles(graph) == [["high", "low"]]


# ------------------------------------------------------------------------------ fresh imports
#: Prints the modules outside our packages that importing all of ours loads.
_LOADED_BY = textwrap.dedent("""
    import importlib, json, sys
    ours = sys.argv[1].split(",")
    before = set(sys.modules)
    for name in sys.argv[2].split(","):
        try:
            importlib.import_module(name)
        except BaseException:
            pass  # the fresh-import check below names it
    print(json.dumps(sorted(m for m, v in sys.modules.items()
                            if v is not None and m not in before and m.split(".")[0] not in ours)))
""")
#: Imports each module named on the command line first, each in a child forked from a process
#: that holds no module of the project: the other modules they load (numpy, pandas, pydantic,
#: ...) are loaded once before the forks (they cannot take part in a cycle of ours, and loading
#: them again in every child would make this check minutes long). Prints one line per failure.
_FRESH_IMPORTS = textwrap.dedent("""
    import importlib, json, os, sys, traceback
    preload, modules = json.loads(sys.argv[1]), sys.argv[2].split(",")
    for name in preload:
        try:
            importlib.import_module(name)
        except BaseException:
            pass  # a module made by another's import (not importable by name); the child loads it
    failed = 0
    for name in modules:
        pid = os.fork()
        if pid == 0:
            try:
                importlib.import_module(name)
            except BaseException:
                last = traceback.format_exc().strip().splitlines()[-1]
                print(f"{name}: {last}", flush=True)
                os._exit(1)
            os._exit(0)
        failed += os.waitpid(pid, 0)[1] != 0
    sys.exit(1 if failed else 0)
""")


def fresh_import_failures(modules: list[str], packages: tuple[str, ...], cwd: Path = ROOT) -> list[str]:
    """One line per module of `modules` (of `packages`) that fails to import first in a fresh
    interpreter."""
    loaded = subprocess.run([sys.executable, "-c", _LOADED_BY, ",".join(packages), ",".join(modules)],
                            capture_output=True, text=True, cwd=cwd, timeout=600)
    assert loaded.returncode == 0, loaded.stderr[-3000:]
    proc = subprocess.run([sys.executable, "-c", _FRESH_IMPORTS, loaded.stdout.strip(), ",".join(modules)],
                          capture_output=True, text=True, cwd=cwd, timeout=600)
    lines = [ln for ln in proc.stdout.splitlines() if ln.strip()]
    assert proc.returncode == (1 if lines else 0), proc.stderr[-3000:]
    return lines


def test_every_module_imports_first_in_a_fresh_interpreter():
    modules = [name for package in PACKAGES for name in _modules(package)]
    failures = fresh_import_failures(modules, PACKAGES)
    assert not failures, "\n".join(failures)


def test_the_fresh_import_check_sees_a_module_that_fails_only_when_imported_first(tmp_path):
    """The check itself, on the cycle a -> b -> a: `a` imported first works, `b` imported first
    fails (a asks for b's VALUE before b has defined it), as driver/scenarios/bpm_shear.py did
    before the registry read its units lazily. Each module is checked in its own process: in
    one process, `a` first would hide b's failure."""
    (tmp_path / "a.py").write_text("from b import VALUE\nNAME = 'a'\n")
    (tmp_path / "b.py").write_text("import a\nVALUE = 1\n")
    failures = fresh_import_failures(["a", "b"], ("a", "b"), cwd=tmp_path)
    assert len(failures) == 1 and failures[0].startswith("b: ImportError: cannot import name 'VALUE'"), failures
