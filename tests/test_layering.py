"""The layers of the package: runfiles/ (files both sides handle) below analysis/ below
driver/. A module may import from its own layer and the ones below, never from above."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
#: what each layer may not import
FORBIDDEN = {"runfiles": ("driver", "analysis"), "analysis": ("driver",)}


def _imports(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text(), str(path))
    found = []
    for node in ast.walk(tree):  # lazy imports inside functions count too
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.append((node.lineno, node.module))
    return found


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
    assert _imports(f) == [(2, "driver.rundir")]
