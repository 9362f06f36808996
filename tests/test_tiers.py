"""The suite's own machinery (tests/conftest.py, docs/testing.md): outside the `lammps` tier a
test cannot start LAMMPS, in process or in a subprocess; which command lines count as starting
it; a shared reference run is built once and a change to it is caught."""

from __future__ import annotations

import subprocess
import sys

import pytest
from conftest import SharedRuns, _starts_lammps

from driver.engine import Lammps


def test_this_test_is_in_the_pure_tier_with_a_time_limit(request):
    assert request.node.get_closest_marker("lammps") is None
    if request.config.pluginmanager.hasplugin("timeout") and request.config.getoption("timeout", None) is None:
        assert request.node.get_closest_marker("timeout").args == (300,)


def test_opening_lammps_outside_the_tier_fails():
    with pytest.raises(RuntimeError, match="not marked `lammps`"):
        Lammps()


def test_a_driver_run_in_a_subprocess_outside_the_tier_fails(tmp_path):
    with pytest.raises(RuntimeError, match="starts LAMMPS in a subprocess"):
        subprocess.run([sys.executable, "-m", "driver.cli", "run", str(tmp_path / "x.yaml")])
    # a command that only reads run directories is allowed
    subprocess.run([sys.executable, "-m", "driver.cli", "status", str(tmp_path)], capture_output=True)


@pytest.mark.parametrize("argv,starts", [
    (["/venv/bin/lmp", "-in", "in.lammps"], True),
    (["mpiexec", "-n", "2", "lmp"], True),
    ([sys.executable, "-m", "driver.cli", "run", "c.yaml"], True),
    ([sys.executable, "-m", "driver.cli", "sweep", "s.yaml", "--workers", "1"], True),
    ([sys.executable, "-c", "from driver.cli import main; main()", "calibrate", "m.yaml"], True),
    (["/venv/bin/driver", "compare", "c.yaml"], True),
    ([sys.executable, "-c", "from driver.plugin_build import plugin_library; print(plugin_library())"], True),
    ([sys.executable, "-m", "driver.cli", "post", "runs/a"], False),
    ([sys.executable, "-m", "driver.cli", "scaling", "runs", "--out", "run"], False),  # "run" is a value here
    (["git", "rev-parse", "HEAD"], False),
    ("lmp -in in.lammps", True),
])
def test_which_command_lines_start_lammps(argv, starts):
    assert _starts_lammps(argv) is starts


def test_a_shared_run_is_built_once_and_a_change_to_it_is_caught(tmp_path):
    runs, built = SharedRuns(tmp_path), []

    def build(out):
        built.append(out)
        out.mkdir()
        (out / "summary.json").write_text("{}")

    first = runs.get("ref", build)
    assert runs.get("ref", build) == first and built == [first]
    (first / "results.csv").write_text("a test wrote here")
    with pytest.raises(pytest.fail.Exception, match="'ref' was changed by a test"):
        runs.get("ref", build)
