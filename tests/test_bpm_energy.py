"""A small bonded BPM solid (SPEC 2.1) under NVE: the breakable styles conserve energy and
momentum when nothing breaks.

108 atoms on a perturbed fcc lattice (nearest distance a = 1), WCA repulsion (SPEC Eq. 1)
between non-bonded pairs. Free boundaries: bonds = Delaunay edges shorter than 5/4 2^(1/6) a,
one angle at each vertex of each triangular face of the tetrahedra whose two bonds were kept.
Periodic: bonds = nearest neighbours by minimum image (many cross the boundaries), one angle
at each vertex of each triangle of bonds (24 per atom, as SPEC 2.1 expects in 3D).
"""

from __future__ import annotations

from itertools import combinations

import numpy as np
import pytest
from scipy.spatial import Delaunay

from driver.bpm.datafile import write_references

CELLS = 3
BOND_CUT = 1.25 * 2 ** (1 / 6)


def bonded_solid(seed=11):
    """Positions, bonds (i < j, 0-based) and angles (end, vertex, end) of the test solid."""
    rng = np.random.default_rng(seed)
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    cells = np.array([[i, j, k] for i in range(CELLS) for j in range(CELLS) for k in range(CELLS)])
    x = ((cells[:, None, :] + basis[None, :, :]).reshape(-1, 3)) * np.sqrt(2.0)
    x += rng.normal(scale=0.03, size=x.shape)

    tets = Delaunay(x).simplices
    edges = {tuple(sorted(e)) for t in tets for e in combinations(t, 2)}
    bonds = sorted(e for e in edges if np.linalg.norm(x[e[0]] - x[e[1]]) < BOND_CUT)
    kept = set(bonds)
    faces = {tuple(sorted(f)) for t in tets for f in combinations(t, 3)}
    angles = []
    for face in sorted(faces):
        for v in face:
            a, b = (w for w in face if w != v)
            if tuple(sorted((a, v))) in kept and tuple(sorted((b, v))) in kept:
                angles.append((a, v, b))
    return x, bonds, angles


def periodic_solid(seed=5):
    """Positions in [0, L)^3, bonds and angles of the periodic test solid, and L."""
    rng = np.random.default_rng(seed)
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    cells = np.array([[i, j, k] for i in range(CELLS) for j in range(CELLS) for k in range(CELLS)])
    length = CELLS * np.sqrt(2.0)
    x = ((cells[:, None, :] + basis[None, :, :]).reshape(-1, 3)) * np.sqrt(2.0)
    x = (x + rng.normal(scale=0.03, size=x.shape)) % length
    d = x[:, None, :] - x[None, :, :]
    d -= length * np.round(d / length)
    near = np.linalg.norm(d, axis=2) < 1.2
    np.fill_diagonal(near, False)
    bonds = [(i, j) for i, j in zip(*np.nonzero(near)) if i < j]
    angles = [(a, v, b) for v in range(len(x)) for a, b in combinations(np.flatnonzero(near[v]), 2)
              if near[a, b]]
    return x, bonds, angles, length


def write_data(path, x, bonds, angles, box=None):
    lo, hi = (x.min() - 3.0, x.max() + 3.0) if box is None else box
    lines = ["BPM energy test solid", "",
             f"{len(x)} atoms", f"{len(bonds)} bonds", f"{len(angles)} angles",
             "1 atom types", "1 bond types", "1 angle types", "",
             f"{lo} {hi} xlo xhi", f"{lo} {hi} ylo yhi", f"{lo} {hi} zlo zhi", "",
             "Masses", "", "1 1.0", "", "Atoms # angle", ""]
    lines += [f"{i + 1} 1 1 {p[0]!r} {p[1]!r} {p[2]!r}" for i, p in enumerate(x.tolist())]
    lines += ["", "Bonds", ""]
    lines += [f"{n + 1} 1 {i + 1} {j + 1}" for n, (i, j) in enumerate(bonds)]
    lines += ["", "Angles", ""]
    lines += [f"{n + 1} 1 {a + 1} {v + 1} {b + 1}" for n, (a, v, b) in enumerate(angles)]
    path.write_text("\n".join(lines) + "\n")


def test_solid_has_the_expected_topology():
    x, bonds, angles = bonded_solid()
    assert len(bonds) / len(x) > 4      # fcc interior: 6 bonds per atom, fewer at the surface
    assert len(angles) > 2 * len(bonds)


def test_periodic_solid_has_the_expected_topology():
    x, bonds, angles, _ = periodic_solid()
    assert len(bonds) == 6 * len(x)
    assert len(angles) == 24 * len(x)


@pytest.mark.parametrize("periodic", [False, True])
def test_nve_conserves_energy_and_momentum(lmp, tmp_path, periodic):
    data = tmp_path / "solid.data"
    if periodic:
        x, bonds, angles, length = periodic_solid()
        write_data(data, x, bonds, angles, box=(0.0, length))
        write_references(tmp_path / "solid.refs", x, bonds, angles, np.full(3, length))
    else:
        x, bonds, angles = bonded_solid()
        write_data(data, x, bonds, angles)
        write_references(tmp_path / "solid.refs", x, bonds, angles)
    lmp.commands(f"""
        units lj
        atom_style angle
        boundary {"p p p" if periodic else "f f f"}
        newton on off
        comm_modify vel yes
        special_bonds lj 0 1 1 coul 1 1 1
        read_data {data}
        pair_style lj/cut 1.0
        pair_coeff * * 1.0 {2 ** (-1 / 6)!r} 1.0
        pair_modify shift yes
        bond_style breakable/cr
        bond_coeff 1 1.2 0.0
        angle_style breakable/cr
        angle_coeff 1 2.0 30.0 1.2
        fix references all breakable/references {tmp_path / "solid.refs"}
        velocity all create 0.02 4928 mom yes rot yes dist gaussian
        fix integrate all nve
        timestep 0.005
        thermo_style custom step etotal ke pe ebond eangle epair
        thermo_modify norm no
        run 0
    """)
    e0 = lmp.get_thermo("etotal")
    ke0 = lmp.get_thermo("ke")
    assert abs(lmp.get_thermo("pe")) < 1e-12  # references of the starting geometry

    energies = []
    for _ in range(100):
        lmp.command("run 100 pre no post no")
        energies.append(lmp.get_thermo("etotal"))
    energies = np.array(energies)

    assert lmp.extract_fix("BREAKABLE_SPECIAL", 0, 1, 0) == 0  # nothing broke
    assert lmp.extract_fix("BREAKABLE_SPECIAL", 0, 1, 1) == 0
    assert lmp.get_thermo("eangle") > 1e-3 * ke0  # the angles did work

    drift = abs(energies[-10:].mean() - energies[:10].mean()) / abs(e0)
    assert drift < 1e-4
    assert np.abs(energies - e0).max() / abs(e0) < 1e-2  # Verlet fluctuation only

    v = lmp.numpy.extract_atom("v")[: len(x)]
    xx = lmp.numpy.extract_atom("x")[: len(x)]
    p_scale = np.abs(v).sum()
    np.testing.assert_allclose(v.sum(axis=0), 0.0, atol=1e-12 * p_scale)
    if not periodic:  # no angular momentum conservation in a periodic box
        l_scale = np.linalg.norm(xx, axis=1) @ np.linalg.norm(v, axis=1)
        np.testing.assert_allclose(np.cross(xx, v).sum(axis=0), 0.0, atol=1e-11 * l_scale)


def _breaking_run(plugin_path, tmp_path, monkeypatch, no_avx):
    """The periodic solid, hot enough that bonds and angles break, 300 steps: x, v, f, breaks."""
    from driver.engine import Lammps

    monkeypatch.setenv("BRITTLE_NO_AVX", "1" if no_avx else "0")
    x, bonds, angles, length = periodic_solid()
    data = tmp_path / "solid.data"
    write_data(data, x, bonds, angles, box=(0.0, length))
    write_references(tmp_path / "solid.refs", x, bonds, angles, np.full(3, length))
    lmp = Lammps()
    try:
        lmp.commands(f"""
            plugin load {plugin_path}
            units lj
            atom_style angle
            boundary p p p
            newton on off
            comm_modify vel yes cutoff 3.3
            special_bonds lj 0 1 1 coul 1 1 1
            read_data {data}
            pair_style cr/repulsion
            pair_coeff 1 1 1.0 1.0 50.0
            bond_style breakable/cr
            bond_coeff 1 1.05 50.0
            angle_style breakable/cr
            angle_coeff 1 4.0 10.0 1.05
            fix references all breakable/references {tmp_path / "solid.refs"}
            velocity all create 0.3 4928 mom yes rot no dist gaussian
            fix integrate all nve
            timestep 0.005
            run 300
        """)
        n = len(x)
        out = {k: lmp.numpy.extract_atom(k)[:n].copy() for k in ("x", "v", "f")}
        order = np.argsort(lmp.numpy.extract_atom("id")[:n])
        out = {k: v[order] for k, v in out.items()}
        out["broken"] = (lmp.extract_fix("BREAKABLE_SPECIAL", 0, 1, 0),
                         lmp.extract_fix("BREAKABLE_SPECIAL", 0, 1, 1))
        return out
    finally:
        lmp.close()


def test_avx_and_baseline_force_loops_agree_bit_for_bit(plugin_path, tmp_path, monkeypatch):
    """The 4-lane AVX force loops of the bond and angle styles (taken where the processor has
    AVX) and the baseline 2-lane loops (BRITTLE_NO_AVX=1) give the same trajectory to the last
    bit, breaks included."""
    a = _breaking_run(plugin_path, tmp_path, monkeypatch, no_avx=False)
    b = _breaking_run(plugin_path, tmp_path, monkeypatch, no_avx=True)
    assert a["broken"][0] > 0 and a["broken"][1] > 0  # the run exercised the break paths
    assert a["broken"] == b["broken"]
    for k in ("x", "v", "f"):
        assert np.array_equal(a[k], b[k]), k
