"""LAMMPS errors surface as Python exceptions carrying LAMMPS's own message, on 1 and N ranks."""

from __future__ import annotations

import pytest

from driver.engine import Lammps, LammpsError, lammps_version_string
from driver.runner import run_input


@pytest.mark.lammps
def test_in_process_error_has_lammps_message():
    with Lammps() as lmp, pytest.raises(LammpsError, match="Unknown command"):
        lmp.command("frobnicate all")


def test_plugin_loads_and_styles_exist(lmp):
    lmp.command("units lj")
    styles = lmp.lmp.available_styles("bond")
    assert "breakable/cr" in styles
    assert "breakable/cr" in lmp.lmp.available_styles("angle")


def test_version_string():
    assert lammps_version_string(20250722) == "22 Jul 2025"


@pytest.mark.mpi
@pytest.mark.parametrize("np_ranks", [1, 2])
def test_run_input_error(tmp_path, np_ranks):
    (tmp_path / "in.lammps").write_text("units lj\nfix bad all nosuchfix\n")
    with pytest.raises(LammpsError, match="nosuchfix"):
        run_input(tmp_path, np=np_ranks)
