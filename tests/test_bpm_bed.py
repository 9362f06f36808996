"""A bed of BPM grains in confined compression (issue 25; driver/bpm/bed.py, driver/bpm/compress.py,
analysis/bed_run.py BpmBedAnalysis): the builder places grains apart, each particle with its
grain id, bonds and angles only inside a grain, the grains' solid volume that of their parents;
a small bed (8 grains of about 100 particles) runs through its phases (fill with breaking off,
rest, load, unload) in real LAMMPS, its void ratio and stresses are what the box says, its
energy account closes from the start of the loading; 1 and 2 ranks give the same records and
break rows through the first break.

Units: a = d / 5.5 for 2 mm grains (about 105 particles a grain), m and u from rho = 6000 kg/m^3
and E = 10 GPa as the BPM particle's defaults (driver/bpm/particle_section.py); the walls'
k_n = 100 u/a^2 (the bonds' stiffness is 57 u/a^2), so the time step is the model's 0.005 tau.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from analysis.bed_run import read_bpm_compress_record
from analysis.breaks import read_break_log
from analysis.dumps import read_atom_dump
from driver.bcm.particle import parent_shape
from driver.bpm.bed import build_bpm_bed
from driver.config import parse_config
from driver.pipeline import execute
from driver.schema import ConfigError

A = 2e-3 / 5.5
UNITS = {"length_a_m": A, "mass_m_kg": 6000 * A ** 3 / 1.2605, "energy_u_J": 1e10 * A ** 3 / 100}


def bpm_bed_config(out: Path, seed: int = 1, n_grains: int = 8, sizes: dict | None = None, lambda_c: float = 1.05,
                   theta_c_deg: float = 10.0, box: list | None = None, plots: bool = True, **scenario) -> dict:
    return {
        "name": "bpm_bed", "seed": seed,
        "model": {"kind": "bpm", "dimension": 3, "k_A": 4.0, "lambda_c": lambda_c, "theta_c_deg": theta_c_deg,
                  "particle": {"diameter": 2e-3, "units": UNITS,
                               "contact": {"kn": 100 * UNITS["energy_u_J"] / A ** 2,
                                           "kt": 80 * UNITS["energy_u_J"] / A ** 2, "en2": 0.001, "mu": 0.3},
                               "G_c": 1.0},
                  "assembly": {"n_grains": n_grains, "sizes": sizes or {"kind": "list", "values": [2e-3]},
                               "box": box or [5e-3, 5e-3, 9e-3], "tessellations": 2}},
        "scenario": {"kind": "compress", "start_stress": 3.0e5, "target_stress": 2.0e6, "platen_speed": 2.0,
                     "fill_speed": 10.0, "rest_time": 5e-5, **scenario},
        "output": {"dir": str(out), "plots": plots},
    }


def run_bpm_bed(out: Path, ranks: int = 1, **kw) -> dict:
    execute(parse_config(bpm_bed_config(out, **kw)), np_ranks=ranks, show_progress=False)
    return json.loads((out / "results" / "summary.json").read_text())


@pytest.fixture(scope="module")
def small_bpm_bed(shared_runs, plugin_path) -> Path:
    """Read only (built once per session)."""
    return shared_runs.get("bpm_bed_small", lambda out: run_bpm_bed(out))


# ------------------------------------------------------------------------------ the builder
@pytest.mark.parametrize("sizes", [{"kind": "list", "values": [2e-3]}, {"kind": "uniform", "min": 1.5e-3, "max": 2.5e-3}])
def test_builder_places_grains_apart_with_their_ids_and_volume(tmp_path, sizes, plugin_path):
    """Every particle lies inside its grain's bounding sphere (so grains whose spheres are apart
    never overlap) and inside the box; the spheres are apart; bonds and angles join particles of
    one grain only (the packings are relaxed in LAMMPS, hence plugin_path); each grain's particle volumes sum to its parent's volume at its size (the
    Voronoi cells fill the parent) to 1e-6, so the solid volume is the sum of the grains'."""
    raw = bpm_bed_config(tmp_path, n_grains=10, sizes=sizes)
    raw["model"]["assembly"]["box"] = [6e-3, 6e-3, 1.2e-2]
    cfg = parse_config(raw)
    bed, diam, start, _ = build_bpm_bed(cfg)
    x = bed.positions * A
    assert len(diam) == 10 and set(np.unique(bed.grain)) == set(range(1, 11))
    for g in range(10):
        mine = x[bed.grain == g + 1]
        # the particle's centre within the sphere less its own radius a / 2
        assert np.linalg.norm(mine - start.centres[g], axis=1).max() <= start.radii[g] - 0.5 * A + 1e-12
    assert (x >= 0.5 * A - 1e-12).all() and (x <= start.box - 0.5 * A + 1e-12).all()
    d = np.linalg.norm(start.centres[:, None] - start.centres[None], axis=2)
    apart = d - (start.radii[:, None] + start.radii[None])
    assert apart[~np.eye(10, dtype=bool)].min() > 0.0
    assert (bed.grain[bed.bonds[:, 0]] == bed.grain[bed.bonds[:, 1]]).all()
    assert all((bed.grain[bed.angles[:, k]] == bed.grain[bed.angles[:, 1]]).all() for k in (0, 2))
    p = cfg.model.particle
    grain_volume = np.bincount(bed.grain - 1, weights=bed.volume) * A ** 3
    parents = np.array([parent_shape(p.shape, d_g, p.diameter_kind).volume for d_g in diam])
    np.testing.assert_allclose(grain_volume, parents, rtol=1e-6)


def test_data_file_and_dumps_carry_the_grain(small_bpm_bed):
    """The data file's molecule id of each particle is its grain (grain by grain, as system.json's
    grain_particles counts them); the dumps carry it too (column mol)."""
    system = json.loads((small_bpm_bed / "system.json").read_text())
    expected = np.repeat(np.arange(1, system["n_grains"] + 1), system["grain_particles"])
    lines = (small_bpm_bed / "system.data").read_text().split("Atoms # hybrid")[1].split("Bonds")[0].split("\n")
    rows = np.array([ln.split() for ln in lines if ln.strip()], dtype=float)
    assert np.array_equal(rows[:, 5].astype(int), expected)
    frame = read_atom_dump(small_bpm_bed / "dumps" / "atoms.load.lammpstrj")[-1]
    assert np.array_equal(np.asarray(frame.extra["mol"], int), expected[np.asarray(frame.ids, int) - 1])


# ------------------------------------------------------------------------------ the run
def test_bed_runs_its_phases(small_bpm_bed):
    """Phases in order 0 (fill) -> 1 -> 2 -> 4 -> 5 (the run ends at 5); no bond or angle breaks before the loading;
    the platen never backs up while the bed is filled, never moves faster than fill_speed before
    the loading, and moves at -+platen_speed while loading and unloading; the void ratio is box / solid volume - 1 to 1e-10; dumps at the stresses."""
    system = json.loads((small_bpm_bed / "system.json").read_text())
    un = system["units"]
    rec = read_bpm_compress_record(small_bpm_bed / "thermo.dat", un)
    phases = rec.phase.to_numpy()
    # the last record is the unloading's: the check that ends it (phase 5) ends the run
    assert phases[0] == 0 and phases[-1] == 4 and (np.diff(phases[phases >= 1]) >= 0).all()
    assert {1, 2, 4}.issubset(set(phases))
    assert json.loads((small_bpm_bed / "outcome.json").read_text())["settled"]
    before = rec[rec.phase <= 1]
    assert before.bonds_broken.max() == 0 and before.angles_broken.max() == 0
    box = np.asarray(system["box"])
    np.testing.assert_allclose(rec.void_ratio, box[0] * box[1] * rec.height / system["solid_volume"] - 1,
                               rtol=0, atol=1e-10)
    v = 2.0  # scenario.platen_speed, m/s
    for phase, sign in ((2, -1), (4, 1)):
        part = rec[rec.phase == phase]
        speed = np.diff(part.height) / np.diff(part.time)
        np.testing.assert_allclose(speed[np.diff(part.step) > 0], sign * v, rtol=1e-6)
    # the servos: the fill never backs the platen up, neither moves it faster than fill_speed
    start = rec[rec.phase <= 1]
    speed = np.diff(start.height) / np.diff(start.time)
    assert np.abs(speed).max() <= 10.0 * (1 + 1e-6)
    both_fill = (phases[:-1] == 0) & (phases[1:] == 0)  # consecutive records of a fill (the bed may refill)
    assert (np.diff(rec.height.to_numpy())[both_fill] <= 1e-15).all()
    assert rec[rec.phase == 2].sigma_v.max() >= 1.0e6
    for name in ("start", "load", "grade1", "grade2", "grade3", "end"):
        assert (small_bpm_bed / "dumps" / f"atoms.{name}.lammpstrj").exists(), name


def test_bed_energy_account_closes(small_bpm_bed):
    """From the start of the loading, W_p = change of kinetic + elastic + W_f + dissipated (walls,
    platen, pair and bond damping) to 1e-3 of W_p (measured 1.3e-4 on the 8-grain bed at 2 m/s);
    the analysis gives the compression curve's measures and B_r = 0 at the intact start."""
    summary = json.loads((small_bpm_bed / "results" / "summary.json").read_text())
    assert summary["balance_residual"] < 1e-3
    assert summary["W_p"] > 0 and summary["e_start"] > summary["e_at_max"]
    first = summary["states"][0]
    assert first["state"] == "load" and first["B_r"] == 0.0 and first["fraction_broken"] == 0.0
    assert first["fragments_per_grain"] == 1.0
    for key in ("sigma_y", "C_c", "K0", "inertial_max"):
        assert key in summary
    assert (small_bpm_bed / "plots" / "compression.png").exists()


def test_the_loading_starts_from_a_calm_balanced_bed(small_bpm_bed):
    """The check log (phases.dat): the loading begins after a rest with the platen's mean between
    REST_HOLDS and REST_ABOVE x start_stress, the bottom carrying what the platen does and the bed
    calm (measured: the two within 10 %, the kinetic energy 4.7e-4 of the elastic one after the
    test's short rest, where the fills ended at 0.5-0.7; the quenched rest began the loading with
    the bottom at 15 x start_stress and the platen at 1.2 x)."""
    from driver import bed_phases
    from runfiles.records import read_record

    log = read_record(small_bpm_bed / bed_phases.CHECK_LOG_FILE, bed_phases.CHECK_LOG_COLUMNS)
    assert (log.phase_before.to_numpy()[1:] == log.phase.to_numpy()[:-1]).all()
    system = json.loads((small_bpm_bed / "system.json").read_text())
    config = yaml.safe_load((small_bpm_bed / "config.resolved.yaml").read_text())
    start = config["scenario"]["start_stress"] * system["units"]["a"] ** 3 / system["units"]["u"]  # LJ
    loads = log[(log.phase_before == 1) & (log.phase == 2)]
    assert len(loads) == 1
    top, bottom = loads.sigma_v_mean.iloc[0], loads.sigma_v_bottom_mean.iloc[0]
    assert bed_phases.REST_HOLDS * start <= top <= bed_phases.REST_ABOVE * start
    assert abs(bottom - top) <= 0.25 * top
    assert loads.ke.iloc[0] <= 0.1 * loads.elastic.iloc[0]


def test_every_file_of_the_run_is_the_tools_own(small_bpm_bed):
    """A re-run starts clean only from files the run layout names (driver/rundir.py): the BPM
    bed's Voronoi areas and volumes and its check log were once left behind as foreign."""
    from driver.rundir import RunDir

    assert RunDir(small_bpm_bed).foreign_entries() == []


def test_bpm_bed_refuses_a_bed_without_grains_or_in_2d(tmp_path):
    raw = bpm_bed_config(tmp_path)
    del raw["model"]["assembly"]
    with pytest.raises((ConfigError, ValueError), match="model.assembly"):
        parse_config(raw)
    raw = bpm_bed_config(tmp_path)
    raw["model"]["dimension"] = 2
    with pytest.raises((ConfigError, ValueError), match="3D"):
        parse_config(raw)


@pytest.mark.mpi
def test_one_and_two_ranks_agree_through_the_first_break(tmp_path, plugin_path):
    """A weak bed of 4 grains (lambda_c 1.002, theta_c 1 degree: the first bond breaks soon after
    the loading begins, at step 3,329 (loading from 3,300), strained past its lambda_c by the fill) with a short rest
    (3e-6 s: two runs of a bed drift apart, measured 1e-12 at step 3,200 to 7e-8 by 9,600 with a
    rest of 5e-5 s), on 1 and 2 MPI ranks: the records agree to 1e-9 (relative to each column's
    largest value) up to the first break's step, and the break log's rows up to and including
    the first break's step are the same; both write checkpoints every 1,000 steps on the way."""
    runs = {}
    for ranks in (1, 2):
        out = tmp_path / f"r{ranks}"
        raw = bpm_bed_config(out, n_grains=4, box=[5e-3, 5e-3, 6e-3], lambda_c=1.002, theta_c_deg=1.0, rest_time=3e-6,
                             target_stress=1.5e6, unload=False, plots=False)
        # checkpoints on the way: their running integrals' powers reduce over every rank (a rank
        # that skipped them left the others waiting: the 30-grain example hung at its first one)
        raw["execution"] = {"checkpoint_every": "1000steps"}
        execute(parse_config(raw), np_ranks=ranks, show_progress=False)
        runs[ranks] = out
    system = json.loads((runs[1] / "system.json").read_text())
    recs = [read_bpm_compress_record(runs[r] / "thermo.dat", system["units"]) for r in (1, 2)]
    breaks = [read_break_log(runs[r] / "breaks.dat") for r in (1, 2)]
    assert len(breaks[0]) > 0, "the weak bed should break"
    first = int(breaks[0].step.min())
    upto = [r[r.step <= first].reset_index(drop=True) for r in recs]
    assert len(upto[0]) == len(upto[1]) > 10
    cols = [c for c in upto[0].columns if c != "phase"]
    a, b = upto[0][cols].to_numpy(float), upto[1][cols].to_numpy(float)
    scale = np.maximum(np.abs(a).max(axis=0), 1e-300)
    assert np.max(np.abs(a - b) / scale) < 1e-9
    rows = [bk[bk.step <= first].sort_values(["step", "id1", "id2", "id3"]).reset_index(drop=True) for bk in breaks]
    pd.testing.assert_frame_equal(rows[0][["step", "id1", "id2", "id3", "kind"]],
                                  rows[1][["step", "id1", "id2", "id3", "kind"]])
