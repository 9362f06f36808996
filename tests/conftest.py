"""Shared fixtures: the built plugin library and small LAMMPS instances with it loaded."""

from __future__ import annotations

import pytest

from driver.engine import Lammps
from driver.plugin_build import plugin_library


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
