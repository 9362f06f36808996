"""BPM elastic calibration (SPEC 2.3): the affine (Born) moduli against lattices worked by hand,
and the moduli test in real LAMMPS: B just below its affine value at k_A = 0, B independent of
k_A while G grows linearly with it, and a test run too fast flagged."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
import yaml

from driver.bpm.moduli import BOND_STIFFNESS, affine_moduli
from driver.moduli_protocol import phases


def square_lattice(n: int):
    """n x n square lattice of spacing 1 in a periodic box: bonds to the 4 neighbours, the four
    90-degree angles between consecutive arms at each vertex."""
    idx = lambda i, j: (i % n) * n + (j % n)  # noqa: E731
    pos = np.array([[i, j, 0.0] for i in range(n) for j in range(n)], dtype=float)
    bonds = np.array([(idx(i, j), idx(i + 1, j)) for i in range(n) for j in range(n)]
                     + [(idx(i, j), idx(i, j + 1)) for i in range(n) for j in range(n)])
    arms = [(1, 0), (0, 1), (-1, 0), (0, -1)]
    angles = np.array([(idx(i + a[0], j + a[1]), idx(i, j), idx(i + b[0], j + b[1]))
                       for i in range(n) for j in range(n) for a, b in zip(arms, arms[1:] + arms[:1])])
    return pos, np.array([n, n, 1.0]), bonds, angles


def test_affine_moduli_of_a_square_lattice_by_hand():
    """Springs k along the axes: B = (1 / (d^2 V)) sum k r0^2 = 2 k / 4 = k / 2 per unit cell,
    and simple shear leaves their lengths unchanged to first order (G_bond = 0); each 90-degree
    angle opens or closes by gamma (d theta / d gamma = -+1), four per site: G = 4 k_A."""
    pos, box, bonds, angles = square_lattice(4)
    m = affine_moduli(pos, box, bonds, angles, 2, k_A=3.0, k_bond=10.0)
    assert m["B_affine"] == pytest.approx(10.0 / 2, rel=1e-7)
    assert m["G_affine"] == pytest.approx(4 * 3.0, rel=1e-7)


def test_affine_moduli_of_a_triangular_lattice_by_hand():
    """Central springs on a triangular lattice of spacing a: B = sqrt(3) k / 2 and G =
    sqrt(3) k / 4 (the isotropic values: 3 bonds and sqrt(3)/2 a^2 of area per site)."""
    nx, ny = 6, 4  # 6 x 4 rhombic cells fill a periodic 6 x 2 sqrt(3) box
    pos = np.array([[i + 0.5 * (j % 2), j * math.sqrt(3) / 2, 0.0] for j in range(ny) for i in range(nx)])
    box = np.array([nx, ny * math.sqrt(3) / 2, 1.0])
    d = pos[None, :, :2] - pos[:, None, :2]
    d -= box[:2] * np.round(d / box[:2])
    near = np.isclose(np.linalg.norm(d, axis=2), 1.0)
    bonds = np.array([(i, j) for i, j in zip(*np.nonzero(near)) if i < j])
    assert len(bonds) == 3 * nx * ny
    m = affine_moduli(pos, box, bonds, np.empty((0, 3), dtype=int), 2, k_A=0.0, k_bond=1.0)
    assert m["B_affine"] == pytest.approx(math.sqrt(3) / 2, rel=1e-7)
    assert m["G_affine"] == pytest.approx(math.sqrt(3) / 4, rel=1e-7)
    assert BOND_STIFFNESS == pytest.approx(36 * 2 ** (2 / 3))


def test_phases_cover_compression_and_every_shear_plane_at_two_rates():
    plan = phases(3, 1e-4, 0.005, 0.005)
    assert [p.load for p in plan] == ["compression", "xy", "xz", "yz"] * 2
    assert [p.rate for p in plan] == [1e-4] * 4 + [5e-5] * 4
    assert plan[0].steps == 3334 and plan[1].steps == 10000 and plan[4].steps == 6667  # ceil(0.005 / (d r dt))
    assert all(b.start == a.end for a, b in zip(plan, plan[1:]))


def _sweep(tmp_path, k_a: str, rate: float):
    base = tmp_path / "moduli.yaml"
    base.write_text(yaml.safe_dump({"name": "mod", "model": {"kind": "bpm", "dimension": 2, "L": 12},
                                    "scenario": {"kind": "calibrate", "test": "moduli", "strain_rate": rate},
                                    "output": {"plots": False}}))
    out = tmp_path / "sweep"
    proc = subprocess.run([sys.executable, "-m", "driver.cli", "sweep", str(base), "--set", f"model.k_A={k_a}",
                           "--out", str(out), "--workers", "1"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return out


@pytest.mark.slow
def test_moduli_against_k_A_in_lammps(tmp_path, plugin_path):
    """2D, L = 12 (244 particles), k_A = 0, 2, 4 at the default rate: at k_A = 0, B lies within
    10 % below its affine value (non-affine relaxation can only lower it) and G > 0; B changes by
    less than 5 % over k_A (angles do not resist isotropic compression) while G grows linearly
    (the fit's largest residual below 2 % of G); no run is flagged (the rates agree to 5 %)."""
    out = _sweep(tmp_path, "0,2,4", 1e-4)
    runs = pd.read_csv(out / "runs.csv").sort_values("k_A")
    assert list(runs.k_A) == [0, 2, 4] and not runs.flagged.any()
    zero = runs.iloc[0]
    assert 0.9 * zero.B_affine <= zero.B <= zero.B_affine and zero.G > 0
    assert (runs.rate_deviation < 0.05).all()
    log = json.loads((out / "sweep_log.jsonl").read_text().splitlines()[-1])  # the sweep itself ended well
    assert log["outcome"] == "complete"
    moduli = pd.read_csv(out / "moduli.csv")
    assert (moduli.B_mean.max() - moduli.B_mean.min()) / moduli.B_mean.mean() < 0.05
    slope, icpt = np.polyfit(moduli.k_A, moduli.G_mean, 1)
    assert slope > 0 and np.max(np.abs(moduli.G_mean - (icpt + slope * moduli.k_A))) < 0.02 * moduli.G_mean.max()
    # E and nu from B and G (2D)
    four = runs.iloc[-1]
    assert four.E == pytest.approx(4 * four.B * four.G / (four.B + four.G))
    assert four.nu == pytest.approx((four.B - four.G) / (four.B + four.G))


def test_a_test_run_too_fast_is_flagged(tmp_path, plugin_path):
    """At rate 0.1 a phase lasts 5 steps, far less than a sound crossing of the box: both rates
    give nearly affine moduli (so they agree), and the crossing check flags the run."""
    out = _sweep(tmp_path, "0", 0.1)
    run = pd.read_csv(out / "runs.csv").iloc[0]
    assert run.flagged and run.sound_crossings < 1
    summary = json.loads(next(out.glob("*/results/summary.json")).read_text())
    assert any("sound-crossing" in f for f in summary["flags"])
