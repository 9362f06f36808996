"""BPM mode-I toughness test (SPEC 2.3, driver/bpm/mode1.py, analysis/mode1.py): the refusal
of a sample without the void, the void cut checked against a hand computation on the arrays,
and a real LAMMPS pull: a peak with the stress rising before it and falling after it, and the
first breaks at the void's tips; in 2D and on a thin 3D slab periodic in z."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from analysis.mode1 import feddersen_factor, mode1_toughness, tip_distances
from driver.bpm.cuts import segment_meets_ellipse
from driver.bpm.mode1 import cut_sample
from driver.bpm.network import Network, delaunay_network
from driver.bpm.packing import Packing
from driver.config import parse_config
from driver.pipeline import execute
from driver.schema import ConfigError


def mode1_config(out, **scenario) -> dict:
    return {"name": "mode1", "model": {"kind": "bpm", "dimension": 2, "L": 40},
            "scenario": {"kind": "calibrate", "test": "mode1", **scenario},
            "output": {"dir": str(out), "plots": False}}


def test_mode1_without_the_void_is_refused(tmp_path):
    with pytest.raises(ConfigError, match="scenario.void = false"):
        parse_config(mode1_config(tmp_path, void=False))
    # the void must leave the finite-width factor's range: 2c / W <= 0.7
    with pytest.raises(ConfigError, match="model.L >= 28.57"):
        parse_config({**mode1_config(tmp_path), "model": {"kind": "bpm", "dimension": 2, "L": 24}})
    assert parse_config(mode1_config(tmp_path)).scenario.void_axes == (20.0, 2.0)


def test_segment_meets_ellipse_by_hand():
    """Ellipse of semi-axes 10 and 1 at the origin: a vertical chord at x = 9.9 crosses it
    ((9.9/10)^2 = 0.98 < 1 at y = 0), one at x = 10.5 misses; the line y = 1 touches it at
    (0, 1) (closed ellipse); a segment ending short of it misses; one inside meets it."""
    p0 = np.array([[9.9, -0.5], [10.5, -0.5], [-3.0, 1.0], [0.0, 1.2], [1.0, 0.1], [0.0, 1.5]])
    p1 = np.array([[9.9, 0.5], [10.5, 0.5], [3.0, 1.0], [0.0, 3.0], [2.0, -0.1], [20.0, 1.5]])
    got = segment_meets_ellipse(p0, p1, np.zeros(2), np.array([10.0, 1.0]))
    assert got.tolist() == [True, False, True, False, True, False]


def triangular_packing(nx: int = 30, ny: int = 34) -> Packing:
    """A periodic triangular lattice of spacing 1 (nx x ny rows; ny even), box [0, nx) x
    [0, ny sqrt(3)/2), radius 1/2 (all type 2)."""
    h = math.sqrt(3) / 2
    pos = np.array([[i + 0.5 * (j % 2) + 0.25, (j + 0.5) * h, 0.0] for j in range(ny) for i in range(nx)])
    box = (np.array([0.0, 0.0, -0.5]), np.array([float(nx), ny * h, 0.5]))
    return Packing(positions=pos, radii=np.full(len(pos), 0.5), types=np.full(len(pos), 2), box=box, dimension=2)


def test_the_void_removes_the_particles_inside_and_the_bonds_across_it():
    """On a triangular lattice, against a hand computation: the particles with
    (x/10)^2 + (y/1)^2 < 1 around the centre go; a bond goes when one of its ends went, when it
    joins the two sides of the box through an image (|dx| > L/2 or |dy| > L/2), or when a point
    of its segment (sampled at 2001 points) lies in the ellipse; an angle goes with either arm."""
    packing = triangular_packing()
    net = delaunay_network(packing, None)
    sample, out, removed = cut_sample(packing, net, (20.0, 2.0))
    lo, hi = packing.box
    centre, semi, L = 0.5 * (lo + hi)[:2], np.array([10.0, 1.0]), (hi - lo)[:2]
    x = packing.positions[:, :2]
    inside = ((x - centre) / semi) ** 2 @ np.ones(2) < 1
    assert removed["particles_in_void"] == inside.sum() > 0
    assert sample.n == packing.n - inside.sum()
    assert np.array_equal(sample.positions, packing.positions[~inside])
    t = np.linspace(0.0, 1.0, 2001)[None, :, None]
    expected = set()
    for (i, j) in net.bonds:
        d = x[j] - x[i]
        if inside[i] or inside[j] or np.any(np.abs(d) > L / 2):
            continue
        pts = x[i] + t[0] * d
        if np.any(np.sum(((pts - centre) / semi) ** 2, axis=1) <= 1):
            continue
        expected.add((i, j))
    old_of_new = np.nonzero(~inside)[0]
    got = {(int(old_of_new[a]), int(old_of_new[b])) for a, b in out.bonds}
    assert got == expected
    # across x: one horizontal and one diagonal bond per row (34 rows); across y: two bonds
    # from each of the 30 atoms of the top row; one of them crosses both
    assert removed["bonds_across_box"] == 2 * 34 + 2 * 30 - 1
    angles = {tuple(int(old_of_new[k]) for k in row) for row in out.angles}
    want = {tuple(int(v) for v in row) for row in net.angles
            if tuple(sorted(row[:2])) in expected and tuple(sorted(row[1:])) in expected}
    assert angles == want
    assert np.allclose(out.r0, np.linalg.norm(sample.positions[out.bonds[:, 1]] - sample.positions[out.bonds[:, 0]],
                                              axis=1))


def test_a_3d_slab_is_cut_free_in_x_and_y_and_stays_periodic_in_z():
    """A simple cubic lattice of spacing 1 in the periodic box [0, 12) x [0, 12) x [0, 4), bonded
    to its 6 neighbours: the bonds through the x faces (12 x 4) and the y faces (12 x 4) go, the
    12 x 12 through the z faces stay. The void, a cylinder along z of semi-axes 3.2 and 0.6 about
    the box centre (6, 6), holds the 7 particles per layer at y = 6, x = 3..9; the bonds with an
    end among them go: per layer 8 along x and 14 along y, and 7 columns of 4 along z."""
    nx, nz = 12, 4
    grid = np.array([[i, j, k] for k in range(nz) for j in range(nx) for i in range(nx)], dtype=float)
    index = {tuple(p.astype(int)): n for n, p in enumerate(grid)}
    bonds = []
    for (i, j, k), n in index.items():
        for d in ((1, 0, 0), (0, 1, 0), (0, 0, 1)):
            bonds.append(sorted((n, index[((i + d[0]) % nx, (j + d[1]) % nx, (k + d[2]) % nz)])))
    bonds = np.array(sorted(bonds))
    packing = Packing(positions=grid, radii=np.full(len(grid), 0.5), types=np.ones(len(grid), int),
                      box=(np.zeros(3), np.array([nx, nx, nz], float)), dimension=3)
    net = Network(bonds=bonds, r0=np.ones(len(bonds)), angles=np.zeros((0, 3), int), theta0=np.zeros(0),
                  n_atoms=len(grid))

    def z_through(sample, network) -> int:
        z = sample.positions[:, 2]
        return int(np.sum(np.abs(z[network.bonds[:, 1]] - z[network.bonds[:, 0]]) > 1.5))

    plain, free, removed = cut_sample(packing, net, None)
    assert removed["bonds_across_box"] == 2 * nx * nz
    assert free.n_bonds == 3 * len(grid) - 2 * nx * nz and z_through(plain, free) == nx * nx
    sample, cut, removed = cut_sample(packing, net, (6.4, 1.2))
    assert removed["particles_in_void"] == 7 * nz and sample.n == len(grid) - 7 * nz
    assert removed["bonds_crossing_void"] == nz * (8 + 14) + 7 * nz
    assert cut.n_bonds == free.n_bonds - removed["bonds_crossing_void"]
    assert z_through(sample, cut) == nx * nx - 7


def test_toughness_formula_by_hand():
    """K_IC = sqrt(sec(pi c / W)) sigma sqrt(pi c): c = 10, W = 40 -> sec(pi / 4) = sqrt 2."""
    assert feddersen_factor(10.0, 40.0) == pytest.approx(2 ** 0.25)
    assert mode1_toughness(0.5, 10.0, 40.0) == pytest.approx(2 ** 0.25 * 0.5 * math.sqrt(10 * math.pi))
    ev = pd.DataFrame({"x": [30.0, 9.0, 30.0, 20.0], "y": [20.0, 21.0, 23.0, 20.0]})
    assert tip_distances(ev, np.array([20.0, 20.0]), 10.0) == pytest.approx([0.0, math.sqrt(2), 3.0, 10.0])


@pytest.fixture(scope="module")
def pulled(shared_runs, plugin_path):
    """2D, L = 40 (2,659 particles after the cut), the default void, pulled at a nominal strain
    rate 1e-4 to strain 0.012 (measured: the peak near strain 0.0076, 14 crossings of the sample
    by sound, c_l = 7.4 from the moduli test; at half the rate sigma_c changes by 1 %)."""
    return shared_runs.get("bpm_mode1_2d", lambda out: execute(
        parse_config(mode1_config(out, strain_rate=1e-4, max_pull_strain=0.012, E_reference=90.5)),
        show_progress=False))


def test_a_pull_peaks_and_the_crack_runs_from_the_tips(pulled):
    summary = json.loads((pulled / "results" / "summary.json").read_text())
    system = json.loads((pulled / "system.json").read_text())
    record = pd.read_csv(pulled / "results" / "mode1.csv")
    k = int(record.stress.idxmax())
    assert summary["sigma_c"] == pytest.approx(record.stress[k]) and summary["failed"] and not summary["flagged"]
    # rising before the peak: the stress at a quarter, a half and three quarters of the peak's
    # displacement grows, each below the peak
    quarters = [record.stress[(record.displacement - f * record.displacement[k]).abs().idxmin()]
                for f in (0.25, 0.5, 0.75)]
    assert quarters[0] < quarters[1] < quarters[2] < record.stress[k]
    # falling after it: the mean over the last quarter of the records is below half the peak
    assert record.stress[len(record) * 3 // 4:].mean() < 0.5 * record.stress[k]
    assert summary["K_IC"] == pytest.approx(mode1_toughness(summary["sigma_c"], 10.0, system["width"]))
    assert summary["K_IC_over_E"] == pytest.approx(summary["K_IC"] / 90.5)
    assert summary["sound_crossings_to_peak"] > 5
    # the first breaks lie at the tips: |x - x_c| near 10, |y - y_c| small (measured with
    # seeds 1-3: within 2.7-3.9 a of a tip; a break on the void's flank would lie ~10 a away)
    events = pd.read_csv(pulled / "results" / "breaks.csv")
    first = events[events.kind == "bond"].sort_values("step", kind="stable").head(10)
    cx, cy = system["void_centre"]
    assert np.all(np.abs(np.abs(first.x - cx) - 10.0) < 5.0) and np.all(np.abs(first.y - cy) < 5.0)
    assert summary["first_breaks_max_tip_distance"] < 5.0
    assert summary["first_break_step"] < summary["peak_step"]
    # then the crack runs from both tips to both free edges, along the void's plane (measured:
    # |y - y_c| < 1.2 a for every broken bond)
    bonds = events[events.kind == "bond"]
    assert bonds.x.min() < 3.0 and bonds.x.max() > system["width"] - 3.0
    assert np.all(np.abs(bonds.y - cy) < 5.0)


def test_the_set_gives_toughness_per_lambda_c(tmp_path):
    """Means and standard deviations over the runs of each lambda_c, K_IC / E included."""
    from analysis.mode1 import analyse_mode1_set  # noqa: PLC0415

    def run(lam: float, K: float) -> dict:
        return {"cfg": {"name": f"r{lam}{K}"}, "dir": tmp_path,
                "summary": {"lambda_c": lam, "sigma_c": K / 10, "K_IC": K, "K_IC_over_E": K / 100, "flags": []}}

    analyse_mode1_set([run(1.05, 3.0), run(1.03, 1.0), run(1.05, 2.0)], tmp_path / "set", plots=False)
    points = pd.read_csv(tmp_path / "set" / "toughness.csv")
    assert points.lambda_c.tolist() == [1.03, 1.05]
    assert points.K_IC_mean.tolist() == pytest.approx([1.0, 2.5])
    assert points.K_IC_std[1] == pytest.approx(math.sqrt(0.5))  # sample std of (2, 3)
    assert points.K_IC_over_E_mean[1] == pytest.approx(0.025)


def test_a_pull_resumed_from_a_checkpoint_goes_on_identically(pulled, tmp_path, monkeypatch):
    """resume.lammps (the grips' fix move, groups and references from the checkpoint) carries
    the pull on exactly as an uninterrupted run does (1 rank): the same records."""
    from driver.engine import Lammps  # noqa: PLC0415

    for name in ("A", "B"):
        (tmp_path / name).mkdir()
        for f in ("setup.lammps", "resume.lammps", "system.data", "system.refs"):
            (tmp_path / name / f).write_bytes((pulled / f).read_bytes())
    monkeypatch.chdir(tmp_path / "A")
    with Lammps() as lmp:
        lmp.file("setup.lammps")
        lmp.commands("run 2000\nwrite_restart r.bin\nrun 1000")
    monkeypatch.chdir(tmp_path / "B")
    with Lammps() as lmp:
        lmp.command(f"variable checkpoint string {tmp_path / 'A' / 'r.bin'}")
        lmp.file("resume.lammps")
        lmp.command("run 1000")
    whole = (tmp_path / "A" / "thermo.dat").read_text().splitlines()
    resumed = (tmp_path / "B" / "thermo.dat").read_text().splitlines()
    assert len(resumed) > 20 and resumed[1:] == whole[-len(resumed) + 1:] and resumed[-1].startswith("3000 ")


def test_a_pull_too_fast_is_flagged(tmp_path, plugin_path):
    """At rate 1e-3 the peak comes about 10 tau into the pull, under 2 crossings of the sample
    by sound (L / sqrt(E / rho) = 40 / 7.4): flagged."""
    execute(parse_config(mode1_config(tmp_path, strain_rate=1e-3, max_pull_strain=0.02, E_reference=90.5)),
            show_progress=False)
    summary = json.loads((tmp_path / "results" / "summary.json").read_text())
    assert summary["sound_crossings_to_peak"] < 5 and summary["flagged"]
    assert any("sound crossings" in f for f in summary["flags"])


def mode1_3d_config(out, **scenario) -> dict:
    """A small 3D slab: L = 16, thickness 4, void 10 x 1 (2c / W = 0.625), pulled at 5e-4."""
    return {"name": "mode1_3d", "model": {"kind": "bpm", "dimension": 3, "L": 16},
            "scenario": {"kind": "calibrate", "test": "mode1", "void_axes": [10, 1], "thickness": 4,
                         "strain_rate": 5e-4, "max_pull_strain": 0.02, **scenario},
            "output": {"dir": str(out), "plots": False}}


@pytest.fixture(scope="module")
def pulled_3d(shared_runs, plugin_path):
    """1,253 spheres after the cut, 8,000 steps (about 8 s). Measured (seed 1): sigma_c = 0.526
    at nominal strain 0.011, 6 bonds broken before the peak, the first 10 within 1.0 a of a tip,
    then the crack through to both free edges within 0.93 a of the void's plane."""
    return shared_runs.get("bpm_mode1_3d", lambda out: execute(parse_config(mode1_3d_config(out)),
                                                                show_progress=False))


def test_a_3d_slab_pull_peaks_and_breaks_first_at_the_tips(pulled_3d):
    """The 2D expectations on the slab (free in x and y, periodic in z, the void a cylinder
    along z): a peak with the stress rising before it and falling after it, K_IC from it with
    c = 5, and the first broken bonds near the tips (|x - x_c| near 5, |y - y_c| small), before
    the peak."""
    summary = json.loads((pulled_3d / "results" / "summary.json").read_text())
    system = json.loads((pulled_3d / "system.json").read_text())
    setup = (pulled_3d / "setup.lammps").read_text()
    assert "boundary        s s p" in setup and "enforce2d" not in setup
    # the grips' force over the cross-section W T = 16 x 4
    assert "variable        stress equal (c_fbottom-c_ftop)/(2*64)" in setup
    assert system["thickness"] == 4.0 and system["bonds_across_box"] > 0
    record = pd.read_csv(pulled_3d / "results" / "mode1.csv")
    k = int(record.stress.idxmax())
    assert summary["sigma_c"] == pytest.approx(record.stress[k]) and summary["failed"]
    quarters = [record.stress[(record.displacement - f * record.displacement[k]).abs().idxmin()]
                for f in (0.25, 0.5, 0.75)]
    assert quarters[0] < quarters[1] < quarters[2] < record.stress[k]
    assert record.stress[len(record) * 3 // 4:].mean() < 0.5 * record.stress[k]
    assert summary["K_IC"] == pytest.approx(mode1_toughness(summary["sigma_c"], 5.0, system["width"]))
    events = pd.read_csv(pulled_3d / "results" / "breaks.csv")
    first = events[events.kind == "bond"].sort_values("step", kind="stable").head(10)
    cx, cy = system["void_centre"]
    assert np.all(np.abs(np.abs(first.x - cx) - 5.0) < 3.0) and np.all(np.abs(first.y - cy) < 3.0)
    assert summary["first_break_step"] < summary["peak_step"]
