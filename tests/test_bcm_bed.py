"""A bed of BCM grains in confined compression (issue 25; driver/bcm/bed.py, driver/bcm/compress.py,
analysis/bed_run.py): the builder places grains without overlap, with the right grain ids and
the solid volume of its grains; a small bed (8 grains of 30 cells) runs through its phases
(fill with breaking off, rest, load to 2 MPa, unload) in real LAMMPS, its record's void ratio
and stresses are what the box says, its energy account closes from the start of the loading,
an intact bed has no breakage; 1 and 2 ranks give the same records through the first break.

The small bed takes about 15 s: its grains first break near 0.3 MPa, 61 interfaces by 2 MPa.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from analysis.bed_run import read_compress_record
from analysis.breaks import read_break_log
from driver.bcm.bed import build_bed
from driver.bcm.particle import parent_shape
from driver.config import parse_config
from driver.pipeline import execute
from driver.schema import ConfigError


def bed_config(out: Path, seed: int = 1, n_grains: int = 8, n_cells: int = 30, plots: bool = True,
               sizes: dict | None = None, G_c: float = 1.0, box: list[float] | None = None, **scenario) -> dict:
    return {
        "name": "bed", "seed": seed,
        "model": {"kind": "bcm", "n_cells": n_cells, "density": 6000,
                  "interface": {"kn": 1.0e7, "kt": 0.8e7, "en2": 0.999, "G_c": G_c},
                  "contact": {"kn": 1.0e7, "kt": 0.8e7, "en2": 0.001, "mu": 0.3},
                  "assembly": {"n_grains": n_grains, "sizes": sizes or {"kind": "list", "values": [2.0e-3]},
                               "box": box or [5.0e-3, 5.0e-3, 9.0e-3], "tessellations": 2}},
        "scenario": {"kind": "compress", "target_stress": 2.0e6, **scenario},
        "output": {"dir": str(out), "plots": plots},
    }


def run_bed(out: Path, ranks: int = 1, **kw) -> dict:
    execute(parse_config(bed_config(out, **kw)), np_ranks=ranks, show_progress=False)
    return json.loads((out / "results" / "summary.json").read_text())


@pytest.fixture(scope="module")
def small_bed(shared_runs, plugin_path) -> Path:
    """Read only (built once per session)."""
    return shared_runs.get("bcm_bed_small", lambda out: run_bed(out))


# ------------------------------------------------------------------------------ the builder
@pytest.mark.parametrize("sizes", [{"kind": "list", "values": [2.0e-3]},
                                   {"kind": "uniform", "min": 1.5e-3, "max": 2.5e-3}])
def test_builder_places_grains_apart_with_their_ids_and_volume(tmp_path, sizes):
    """No two grains overlap: every cell vertex of a grain lies inside its bounding sphere, and
    the spheres are apart (so are the grains) and inside the box; every cell carries its grain
    id, the interfaces join cells of one grain; the solid volume is the sum of the grains'
    volumes (the parent's, scaled by (d / diameter)^3) to 1e-6."""
    cfg = parse_config(bed_config(tmp_path, n_grains=12, sizes=sizes))
    m = cfg.model
    cells, diam, start, pool = build_bed(m, cfg.seed)
    assert len(diam) == 12 and np.bincount(cells.grain)[1:].tolist() == [m.n_cells] * 12
    # cell vertices in space, grain by grain, against the grain's bounding sphere
    from analysis.rotations import quat_to_matrix  # noqa: PLC0415

    rot = quat_to_matrix(cells.quats)
    for i, (v, r, c) in enumerate(zip(cells.cell_vertices, rot, cells.centroids)):
        g = cells.grain[i] - 1
        x = v @ r.T + c
        assert np.linalg.norm(x - start.centres[g], axis=1).max() <= start.radii[g] * (1 + 1e-9)
        assert (x >= -1e-12).all() and (x <= start.box + 1e-12).all()
    d = np.linalg.norm(start.centres[:, None] - start.centres[None], axis=2)
    apart = d - (start.radii[:, None] + start.radii[None])
    assert apart[~np.eye(12, dtype=bool)].min() > 0.0
    assert (cells.grain[cells.pairs[:, 0]] == cells.grain[cells.pairs[:, 1]]).all()
    parent = parent_shape(m.shape, m.diameter, m.diameter_kind).volume
    grain_volume = np.bincount(cells.grain - 1, weights=cells.volumes)
    np.testing.assert_allclose(grain_volume, parent * (diam / m.diameter) ** 3, rtol=1e-6)
    assert cells.volumes.sum() == pytest.approx(parent * np.sum((diam / m.diameter) ** 3), rel=1e-6)


def test_data_file_carries_grain_ids(small_bed):
    """system.data's molecule column is each cell's grain, in the order of system.json's grains."""
    text = (small_bed / "system.data").read_text()
    atoms = text.split("Atoms # bpm/sphere")[1].split("Bonds")[0]
    rows = np.array([line.split() for line in atoms.strip().splitlines()], dtype=float)
    system = json.loads((small_bed / "system.json").read_text())
    expected = np.repeat(np.arange(1, system["n_grains"] + 1), system["grain_cells"])
    np.testing.assert_array_equal(rows[np.argsort(rows[:, 0]), 1], expected)  # id molecule type ...


# ------------------------------------------------------------------------------- the run
def test_bed_runs_through_its_phases(small_bed):
    """Fill, rest, load to the target, unload: every phase in order; breaking off while filled
    (no break before the loading), the target reached, the end back at the start stress."""
    rec = read_compress_record(small_bed / "thermo.dat")
    phases = rec.phase.to_numpy()
    # fill and rest may alternate (a bed that lets go of the platen while it rests is filled
    # again); from the loading on, the phases only go forward
    loaded = phases[np.argmax(phases >= 2):]
    assert (loaded >= 2).all() and (np.diff(loaded) >= 0).all()
    assert set(phases) >= {0, 1, 2, 4}  # the switch to 5 (done) comes at the last check, after the last record
    assert rec.broken[rec.phase < 2].max() == 0
    loading = rec[rec.phase == 2]
    # the target is checked every check_every steps on the force of that step; the record of a
    # check's step is written again when the next chunk starts, with the new phase and the
    # platen's new velocity in its contact damping: a few % off the value the check saw
    assert rec.sigma_v[rec.phase >= 2].max() >= 0.95 * 2.0e6
    assert rec.broken.iloc[-1] > 0
    breaks = read_break_log(small_bed / "breaks.dat")
    assert breaks.step.min() > loading.step.min()


def test_fill_ends_on_a_stress_through_the_bed(small_bed):
    """The check log (phases.dat) follows the rules of driver/bed_phases.py: each line's phase
    before is the previous line's phase; the fill ends (the rest begins) only after FILL_CHECKS
    checks in a row with the bottom and the platen at 1 - FILL_TOLERANCE of start_stress on the
    window's mean (a grain's blow on the bottom is no stress through the bed); the loading begins
    from a rest with the platen's mean between REST_HOLDS and REST_ABOVE x start_stress. The drag
    of the fill and the rest is gone from the loading on (the loading's account closes:
    test_bed_analysis)."""
    from driver import bed_phases
    from runfiles.records import read_record

    log = read_record(small_bed / bed_phases.CHECK_LOG_FILE, bed_phases.CHECK_LOG_COLUMNS)
    cfg = parse_config(bed_config(small_bed))
    start = cfg.scenario.start_stress
    assert len(log) >= 3 and (log.phase_before.to_numpy()[1:] == log.phase.to_numpy()[:-1]).all()
    assert (np.diff(log.step) == cfg.scenario.check_every).all()
    rests = np.flatnonzero((log.phase_before == 0) & (log.phase == 1))
    assert len(rests) >= 1
    reach = (1 - bed_phases.FILL_TOLERANCE) * start
    for k in rests:
        window = log.iloc[k - bed_phases.FILL_CHECKS + 1:k + 1]
        assert len(window) == bed_phases.FILL_CHECKS and (window.phase_before == 0).all()
        assert (window.sigma_v_bottom_mean >= reach).all() and (window.sigma_v_mean >= reach).all(), window
        assert log.fill_hits.iloc[k] == bed_phases.FILL_CHECKS
    loads = log[(log.phase_before == 1) & (log.phase == 2)]
    assert len(loads) == 1
    mean = loads.sigma_v_mean.iloc[0]
    assert bed_phases.REST_HOLDS * start <= mean <= bed_phases.REST_ABOVE * start
    # the start is calm and in balance (measured: kinetic 1.9e-3 of the elastic energy after the
    # test's rest, where the fill ended at 5; the platen 40 kPa and the bottom 47 kPa); the BPM's
    # quenched start had the bottom at 15 x the platen
    assert loads.ke.iloc[0] <= 0.1 * loads.elastic.iloc[0]
    assert abs(loads.sigma_v_bottom_mean.iloc[0] - mean) <= 0.25 * mean


def test_every_file_of_the_run_is_the_tools_own(small_bed):
    """A re-run starts clean only from files the run layout names (driver/rundir.py)."""
    from driver.rundir import RunDir

    assert RunDir(small_bed).foreign_entries() == []


def test_bed_record_is_what_the_box_says(small_bed):
    """Void ratio = box volume / solid volume - 1 with the platen's height; the platen moves
    at platen_speed down while loading and up while unloading, never faster than fill_speed
    while it fills (servo-controlled); bottom and top carry the same stress at the peak of the
    loading to 10 %."""
    rec = read_compress_record(small_bed / "thermo.dat")
    system = json.loads((small_bed / "system.json").read_text())
    bx, by, _ = system["box"]
    np.testing.assert_allclose(rec.void_ratio, bx * by * rec.height / system["solid_volume"] - 1, rtol=1e-10)
    cfg = parse_config(bed_config(small_bed))
    dt = system["timestep"]
    def speeds(phase: int) -> np.ndarray:
        # between records both in the phase (a record at a phase change holds the new phase)
        part = rec[(rec.phase == phase) & (rec.phase.shift(1) == phase) & (rec.phase.shift(-1) == phase)]
        return np.diff(part.height.to_numpy()) / (np.diff(part.step.to_numpy()) * dt)

    for phase, speed in ((2, -cfg.scenario.platen_speed), (4, cfg.scenario.platen_speed)):
        v = speeds(phase)
        v = v[np.isfinite(v)]
        assert len(v) > 5
        np.testing.assert_allclose(np.median(v), speed, rtol=1e-6)
        assert np.mean(np.isclose(v, speed, rtol=1e-6)) > 0.9
    assert np.nanmax(np.abs(speeds(0))) <= cfg.scenario.fill_speed * (1 + 1e-9)
    peak = rec.sigma_v.idxmax()
    assert rec.sigma_v_bottom[peak] == pytest.approx(rec.sigma_v[peak], rel=0.1)


def test_bed_analysis(small_bed):
    """The summary: an energy account that closes from the start of the loading to 1e-3, no
    breakage at the start of the loading (B_r exactly 0: intact grains keep their size),
    breakage growing with the stress, the dumped states at the grading stresses."""
    s = json.loads((small_bed / "results" / "summary.json").read_text())
    assert s["balance_residual"] < 1e-3
    states = pd.DataFrame(s["states"])
    assert states.state.tolist() == ["load", "grade1", "grade2", "grade3", "end"]
    assert states.B_r.iloc[0] == 0.0 and states.B_r_star.iloc[0] == 0.0
    assert states.fraction_broken.iloc[0] == 0.0
    grades = states.iloc[1:4]
    assert (np.diff(grades.sigma_v) > 0).all()
    assert (grades.sigma_v.to_numpy() >= 0.95 * np.array([0.25, 0.5, 1.0]) * 2.0e6).all()  # as in the phases test
    assert (np.diff(states.B_r.iloc[:4]) >= 0).all()
    assert s["broken_interfaces"] > 0 and s["W_f"] > 0
    for name in ("compression", "grading", "breakage", "energy", "fragments"):
        assert (small_bed / "plots" / f"{name}.png").exists(), name


@pytest.mark.parametrize("field, value, message", [
    ("target_stress", 1.0e4, "must exceed scenario.start_stress"),
    ("grading_at", [0.5, 1.5], "grading_at"),
])
def test_bed_config_errors(tmp_path, field, value, message):
    with pytest.raises(ConfigError, match=message):
        parse_config(bed_config(tmp_path, **{field: value}))


def test_compress_needs_an_assembly_and_the_others_refuse_one(tmp_path):
    cfg = bed_config(tmp_path)
    del cfg["model"]["assembly"]
    with pytest.raises(ConfigError, match="model.assembly"):
        parse_config(cfg)
    for scenario in ({"kind": "impact"}, {"kind": "crush"}, {"kind": "calibrate", "test": "moduli"}):
        cfg = bed_config(tmp_path)
        cfg["scenario"] = scenario
        with pytest.raises(ConfigError, match="model.assembly: a bed of grains is for scenario compress"):
            parse_config(cfg)


@pytest.mark.mpi
def test_bed_one_vs_two_ranks(tmp_path, plugin_path):
    """A weak bed of 4 grains (G_c = 0.05 J/m², so the first break comes as the loading begins)
    with a short rest (3e-6 s) on 1 and 2 MPI ranks (grains cross the sub-domains; the walls sum
    their forces over the ranks): the records agree to 1e-9 through the first break, and the
    break table's rows through the first break are the same. A bed is chaotic: the two runs
    differ by round-off (the order of the force sums) from the first collisions, and the
    difference grows by about a decade every 2,000 steps of the damped fill (measured on the
    8-grain bed: 2e-11 of the largest sigma_v at step 3,000, 6e-9 at 8,000), so the check holds
    for a bed that is filled and breaks early (measured: loading and first break at step 1,600,
    the runs 8e-12 apart), not for one that breaks late. About 10 s."""
    small_bed = tmp_path / "r1"
    weak = dict(plots=False, G_c=0.05, target_stress=8.0e4, unload=False, rest_time=3.0e-6, n_grains=4,
                box=[5.0e-3, 5.0e-3, 6.0e-3])
    run_bed(small_bed, ranks=1, **weak)
    run_bed(tmp_path / "r2", ranks=2, **weak)
    a = read_compress_record(small_bed / "thermo.dat")
    b = read_compress_record(tmp_path / "r2" / "thermo.dat")
    ba = read_break_log(small_bed / "breaks.dat")
    bb = read_break_log(tmp_path / "r2" / "breaks.dat")
    first = int(ba.step.min())
    assert int(bb.step.min()) == first
    ra, rb = a[a.step <= first].reset_index(drop=True), b[b.step <= first].reset_index(drop=True)
    assert len(ra) == len(rb) > 10
    for col in ("height", "sigma_v", "sigma_v_bottom", "sigma_x", "sigma_y", "W_p", "kinetic", "elastic"):
        scale = max(float(ra[col].abs().max()), 1e-300)
        np.testing.assert_allclose(rb[col], ra[col], rtol=1e-9, atol=1e-9 * scale, err_msg=col)
    key = ["step", "id1", "id2"]
    pa = ba[ba.step == first].sort_values(key).reset_index(drop=True)
    pb = bb[bb.step == first].sort_values(key).reset_index(drop=True)
    pd.testing.assert_frame_equal(pa[key], pb[key])


@pytest.mark.extended
def test_bed_interrupted_and_resumed_is_identical(tmp_path, plugin_path):
    """A bed stopped by SIGINT in its loading and resumed gives the very results of the
    uninterrupted run: the phase, its times and the dumps made come back from the checkpoint's
    variables, the bond and pair coefficients of the phase (breaking on, the model's friction)
    from the checkpoint itself. About 90 s."""
    from test_resume import assert_same_results, config_file, reference_interrupted_resumed  # noqa: PLC0415

    base = bed_config(tmp_path / "unused", plots=False)
    base["output"] = {"plots": False}
    base["execution"] = {}
    ref, out = reference_interrupted_resumed(config_file(tmp_path, base, "bed"), tmp_path, at_fraction=0.6)
    assert_same_results(ref, out)
