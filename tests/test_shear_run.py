"""End to end: `driver run` of a small BPM shear job, its run directory, post, reruns, ranks."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from driver.config import parse_config
from driver.pipeline import execute
from driver.rundir import RunDirError, read_status


def small_config(out: Path, **over) -> dict:
    cfg = {
        "name": "tiny", "seed": 5,
        "model": {"kind": "bpm", "dimension": 2, "L": 10},
        "scenario": {"kind": "shear", "strain_rate": 0.01, "max_strain": 0.3,
                     "measure_strains": [0.1, 0.3], "thermo_every": 100},
        "output": {"dir": str(out)},
    }
    for k, v in over.items():
        cfg[k].update(v) if isinstance(v, dict) else cfg.__setitem__(k, v)
    return cfg


@pytest.fixture(scope="module")
def finished_run(shared_runs, plugin_path) -> Path:
    """Read only (built once per session): a test that changes it copies it."""
    return shared_runs.get("bpm_shear_tiny", lambda out: execute(parse_config(small_config(out)),
                                                                  show_progress=False))


def test_run_directory_complete(finished_run):
    rd = finished_run
    assert read_status(rd)["state"] == "finished"
    for name in ["config.resolved.yaml", "in.lammps", "system.data", "log.lammps", "thermo.dat",
                 "provenance.json", "results/summary.json", "results/nm.parquet", "results/stress.csv",
                 "results/frames.parquet", "results/grains.parquet", "plots/nm.png", "plots/stress.png",
                 "dumps/bonds.0.lammpstrj", "dumps/atoms.6000.lammpstrj"]:
        assert (rd / name).exists(), name
    prov = json.loads((rd / "provenance.json").read_text())
    for key in ["package_version", "git_commit", "lammps_version", "plugin_build_hash", "seed", "wall_seconds",
                "command_line"]:
        assert key in prov
    summary = json.loads((rd / "results/summary.json").read_text())
    # A bonded solid at strain 0 is one grain; shear at this rate breaks bonds by strain 0.3.
    assert summary["grains_at_strain"]["0"] == 1
    assert summary["bonds_broken"] > 0
    assert 5.5 < summary["bonds_per_particle"] < 6.5
    frames = pd.read_parquet(rd / "results/frames.parquet")
    thermo = pd.read_csv(rd / "results/stress.csv")
    # bonds broken counted by the plugin = intact bonds lost in the dumps
    n_bonds = json.loads((rd / "system.json").read_text())["n_bonds"]
    assert frames.iloc[-1]["intact_bonds"] == n_bonds - thermo.iloc[-1]["bonds_broken"]
    assert abs(thermo["strain"].iloc[-1] - 0.3) < 1e-9


def test_generated_input_runs_standalone_with_lmp(finished_run, tmp_path, plugin_path):
    """in.lammps runs in the `lmp` executable on its own, given the plugin path, and
    reproduces the run's breakage record."""
    import shutil

    from driver.engine import venv_bin

    for name in ("in.lammps", "setup.lammps", "system.data", "system.refs"):
        shutil.copy(finished_run / name, tmp_path / name)
    (tmp_path / "dumps").mkdir()
    proc = subprocess.run([venv_bin("lmp"), "-in", "in.lammps", "-var", "plugin", plugin_path, "-screen", "none"],
                          cwd=tmp_path, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    last_run = (finished_run / "thermo.dat").read_text().splitlines()[-1].split()
    last_lmp = (tmp_path / "thermo.dat").read_text().splitlines()[-1].split()
    assert last_lmp[0] == last_run[0] and last_lmp[-2:] == last_run[-2:]


def test_post_reproduces_tables(finished_run, tmp_path):
    import shutil

    finished_run = Path(shutil.copytree(finished_run, tmp_path / "tiny"))  # post rewrites it
    names = ["nm", "frames", "grains", "stress", "nm_fits", "tracking"]
    before = {n: pd.read_parquet(finished_run / f"results/{n}.parquet") for n in names}
    summary = json.loads((finished_run / "results/summary.json").read_text())
    (finished_run / "results/summary.json").unlink()
    for name in ["report.md", "report.html", "plots/nm.png", "plots/grains.png"]:
        (finished_run / name).unlink()
    proc = subprocess.run([sys.executable, "-m", "driver.cli", "post", str(finished_run)], capture_output=True,
                          text=True)
    assert proc.returncode == 0, proc.stderr
    for name, df in before.items():
        pd.testing.assert_frame_equal(df, pd.read_parquet(finished_run / f"results/{name}.parquet"))
    for name in ["report.md", "report.html", "plots/nm.png", "plots/grains.png"]:
        assert (finished_run / name).exists(), name
    assert json.loads((finished_run / "results/summary.json").read_text()) == summary
    assert {"n_grains_M>=10", "n_grains_M>=100", "M2_nonpercolating"} <= set(before["frames"].columns)
    assert "data:image/png;base64," in (finished_run / "report.html").read_text()


def test_grain_table_and_tracking_consistent(finished_run):
    """Per-grain rows add up to the frame totals, and every grain at a strain has parents at the
    strain before whose shared masses add up to its mass (bonds only break)."""
    grains = pd.read_parquet(finished_run / "results/grains.parquet")
    frames = pd.read_parquet(finished_run / "results/frames.parquet")
    n = json.loads((finished_run / "system.json").read_text())["n_particles"]
    for eps, g in grains.groupby("strain"):
        row = frames[frames.strain == eps].iloc[0]
        assert g["size"].sum() == n and len(g) == row["n_grains"]
        assert g["mass"].max() == row["largest_grain"]
        # kinetic energy of a grain's atoms >= that of its centre of mass
        assert (g.ke - g.ke_cm >= -1e-12).all()
        # a grain that does not wrap the box has a centre of mass and a radius of gyration:
        # rg^2 is the trace of its gyration tensor, a lone particle has rg = 0, and two
        # particles joined by one bond of length r have rg = r / 2, with r near r0 = 0.6 to
        # 1.0 a (the pair's mean diameter, SPEC 2.1): between 0.8 r0 (compressed) and
        # lambda_c r0 = 1.05 r0 (the bond breaks beyond)
        ok = g[~g.percolating]
        assert ok[["x", "y"]].notna().all().all()
        np.testing.assert_allclose(ok.rg ** 2, ok.gxx + ok.gyy, rtol=1e-9, atol=1e-12)
        assert (ok[ok["size"] == 1].rg == 0).all()
        pair_rg = ok[ok["size"] == 2].rg
        assert ((pair_rg > 0.5 * 0.8 * 0.6) & (pair_rg < 0.5 * 1.05 * 1.0)).all(), pair_rg.describe()
    tracking = pd.read_parquet(finished_run / "results/tracking.parquet")
    assert set(tracking.columns) >= {"strain_parent", "strain_child", "child", "parent", "shared_mass"}
    for (eps, child), t in tracking.groupby(["strain_child", "child"]):
        mass = grains[(grains.strain == eps) & (grains.grain == child)]["mass"].iloc[0]
        assert t.shared_mass.sum() == mass
        assert len(t) == 1  # breakage only: one parent


def test_finished_run_not_overwritten(finished_run):
    cfg = parse_config(small_config(finished_run))
    with pytest.raises(RunDirError, match="--force"):
        execute(cfg, show_progress=False)


def test_unfinished_run_starts_clean(tmp_path, plugin_path):
    """A run of this tool that stopped without a checkpoint is started again; only the files of
    the run layout are removed, a file the user put beside them stays."""
    out = tmp_path / "tiny"
    cfg = parse_config(small_config(out, scenario={"max_strain": 0.1, "measure_strains": [0.1]}))
    execute(cfg, show_progress=False)
    (out / "status.json").write_text(json.dumps({"state": "failed", "error": "pretend"}))
    (out / "notes.txt").write_text("mine")
    (out / "dumps" / "atoms.99999.lammpstrj").write_text("left by the failed run")
    execute(cfg, show_progress=False)
    assert not (out / "dumps" / "atoms.99999.lammpstrj").exists()
    assert (out / "notes.txt").read_text() == "mine"
    assert read_status(out)["state"] == "finished"


@pytest.mark.mpi
def test_one_vs_two_ranks_same_breakage(tmp_path, plugin_path):
    """Same broken-bond count and grain counts on 1 and 2 MPI ranks, and a break log
    (results/breaks) with one row per broken bond and angle on both."""
    results = []
    for ranks in (1, 2):
        out = tmp_path / f"r{ranks}"
        cfg = parse_config(small_config(out, scenario={"max_strain": 0.2, "measure_strains": [0.2]}))
        execute(cfg, np_ranks=ranks, show_progress=False)
        results.append(json.loads((out / "results/summary.json").read_text()))
    one, two = results
    assert one["bonds_broken"] > 0
    assert one["bonds_broken"] == two["bonds_broken"]
    assert one["angles_broken"] == two["angles_broken"]
    assert one["grains_at_strain"] == two["grains_at_strain"]
    cfg_text = yaml.safe_load((tmp_path / "r2" / "config.resolved.yaml").read_text())
    assert cfg_text["model"]["L"] == 10
    tables = []
    for ranks, summary in ((1, one), (2, two)):
        breaks = pd.read_parquet(tmp_path / f"r{ranks}" / "results" / "breaks.parquet")
        counts = breaks.kind.value_counts()
        assert counts["bond"] == summary["bonds_broken"] and counts["angle"] == summary["angles_broken"]
        tables.append(breaks.sort_values(["step", "kind", "id1", "id2", "id3"])[["step", "kind", "id1", "id2", "id3"]])
    pd.testing.assert_frame_equal(tables[0].reset_index(drop=True), tables[1].reset_index(drop=True))


def test_3d_triaxial_run_with_periodic_dumps(tmp_path, plugin_path):
    """3D triaxial shear runs; dump_every writes atom and bond dumps at that interval."""
    out = tmp_path / "t3"
    cfg = small_config(out, model={"dimension": 3, "L": 6},
                       scenario={"max_strain": 0.05, "measure_strains": [0.05], "dump_every": 250},
                       output={"animation": True})
    execute(parse_config(cfg), show_progress=False)
    from PIL import Image

    assert Image.open(out / "plots" / "fragmentation.gif").n_frames == 5  # one frame per periodic dump
    summary = json.loads((out / "results/summary.json").read_text())
    assert 10.0 < summary["bonds_per_particle"] < 12.5
    steps = sorted(int(p.name.split(".")[1]) for p in (out / "dumps").glob("bonds.*.lammpstrj"))
    assert steps == [0, 250, 500, 750, 1000]
    thermo = pd.read_csv(out / "results/stress.csv")
    # constant volume: the triaxial deformation keeps the box volume
    assert thermo["vol"].max() / thermo["vol"].min() - 1 < 1e-9
    assert (out / "dumps" / "atoms.750.lammpstrj").exists()


def test_post_on_dump_files(finished_run, tmp_path):
    """`driver post FILE...` pairs atom and bond dumps by timestep and finds the run's grains."""
    dumps = sorted((finished_run / "dumps").glob("*.lammpstrj"))
    out = tmp_path / "post"
    proc = subprocess.run([sys.executable, "-m", "driver.cli", "post", *map(str, dumps), "--out", str(out)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert json.loads(proc.stdout)["dimension"] == 2
    mine = pd.read_parquet(out / "frames.parquet")
    run = pd.read_parquet(finished_run / "results/frames.parquet")
    assert list(mine.step) == list(run.step)
    assert list(mine.n_grains) == list(run.n_grains) and list(mine.M2) == list(run.M2)
    grains_run = pd.read_parquet(finished_run / "results/grains.parquet").drop(columns=["strain"])
    pd.testing.assert_frame_equal(pd.read_parquet(out / "grains.parquet"), grains_run)
    assert (out / "report.html").exists() and (out / "tracking.csv").exists()
    # MDAnalysis' reader (float32 positions) finds the same grains; centres of mass agree to float32
    mda = tmp_path / "mda"
    proc = subprocess.run([sys.executable, "-m", "driver.cli", "post", *map(str, dumps), "--out", str(mda),
                           "--reader", "mdanalysis", "--no-plots"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    other = pd.read_parquet(mda / "grains.parquet")
    assert list(other["size"]) == list(grains_run["size"])
    assert np.allclose(other.x, grains_run.x, atol=1e-5, equal_nan=True)


def test_post_on_dump_files_needs_both_kinds(finished_run, tmp_path):
    bonds = sorted((finished_run / "dumps").glob("bonds.*.lammpstrj"))
    proc = subprocess.run([sys.executable, "-m", "driver.cli", "post", *map(str, bonds), "--out", str(tmp_path / "p")],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert "need atom and bond dumps" in proc.stderr
    assert not (tmp_path / "p").exists()


def test_post_on_dump_files_with_truncated_dump(finished_run, tmp_path):
    """A dump cut short: a warning naming the file, frame and line; earlier frames analysed."""
    import shutil

    for p in (finished_run / "dumps").glob("*.lammpstrj"):
        shutil.copy(p, tmp_path / p.name)
    steps = sorted(int(p.name.split(".")[1]) for p in tmp_path.glob("atoms.*.lammpstrj"))
    last = tmp_path / f"atoms.{steps[-1]}.lammpstrj"
    last.write_bytes(last.read_bytes()[: len(last.read_bytes()) // 2])
    proc = subprocess.run([sys.executable, "-m", "driver.cli", "post", *map(str, sorted(tmp_path.glob("*.lammpstrj"))),
                           "--out", str(tmp_path / "post"), "--no-plots"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert f"atoms.{steps[-1]}.lammpstrj, frame 0 (timestep {steps[-1]}), line" in proc.stderr
    assert list(pd.read_csv(tmp_path / "post" / "frames.csv").step) == steps[:-1]
    assert "Warning" in (tmp_path / "post" / "report.md").read_text()


def test_post_on_unfinished_run_uses_snapshots_it_has(finished_run, tmp_path):
    """A run killed before its last snapshot: `driver post` analyses the earlier snapshots and
    says what it left out; in a finished run the same gap is an error."""
    import shutil

    rd = tmp_path / "killed"
    shutil.copytree(finished_run, rd)
    snaps = json.loads((rd / "snapshots.json").read_text())
    (rd / snaps[-1]["bonds"]).unlink()
    cmd = [sys.executable, "-m", "driver.cli", "post", str(rd), "--no-plots"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 2 and "bonds" in proc.stderr  # finished run: a missing dump is an error
    (rd / "status.json").write_text(json.dumps({"state": "failed", "error": "killed"}))
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "did not finish" in proc.stderr and f"strain {snaps[-1]['strain']:g} on left out" in proc.stderr
    frames = pd.read_parquet(rd / "results/frames.parquet")
    assert list(frames.strain) == [s["strain"] for s in snaps[:-1]]
    # cut short (analysis/completeness.py): flagged, the note first in the warnings and in the report
    summary = json.loads((rd / "results/summary.json").read_text())
    assert summary["completeness"] == "cut_short" and summary["warnings"][0].startswith("the run did not finish")
    assert "Cut short: the run did not finish" in (rd / "report.md").read_text()
    assert json.loads((rd / "status.json").read_text())["state"] == "failed"  # post does not relabel a run
