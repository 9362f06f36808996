"""The plugin library is built on first use, cached by source hash, safe under concurrency."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from driver import plugin_build
from driver.plugin_build import plugin_source_dir, source_hash


@pytest.mark.lammps
def test_hash_changes_with_source(tmp_path):
    src = tmp_path / "plugins"
    shutil.copytree(plugin_source_dir(), src)
    h0 = source_hash(src)
    assert source_hash(src) == h0  # deterministic
    f = src / "src" / "brittleplugin.cpp"
    f.write_text(f.read_text() + "\n// edited\n")
    assert source_hash(src) != h0


@pytest.mark.lammps
@pytest.mark.slow
def test_concurrent_first_builds_share_one_library(tmp_path):
    """Two runs starting at once on a fresh cache: one build, both get the same whole file."""
    env = {**os.environ, "BRITTLE_CACHE": str(tmp_path / "cache")}
    code = "from driver.plugin_build import plugin_library; print(plugin_library())"
    procs = [subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True) for _ in range(2)]
    outs = [p.communicate(timeout=600) for p in procs]
    assert all(p.returncode == 0 for p in procs), [o[1][-2000:] for o in outs]
    paths = {o[0].strip() for o in outs}
    assert len(paths) == 1
    lib = Path(paths.pop())
    assert lib.exists() and lib.stat().st_size > 10_000
    # no leftovers of the build (temporary dirs, staged copies)
    assert sorted(p.name for p in lib.parent.iterdir()) == [plugin_build.LIBRARY_NAME]
    # and the library loads into LAMMPS
    check = (f"from driver.engine import Lammps\nl = Lammps()\nl.command('plugin load {lib}')\n"
             "assert 'breakable/cr' in l.lmp.available_styles('bond')\n")
    subprocess.run([sys.executable, "-c", check], env=env, check=True)
