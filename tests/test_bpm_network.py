"""BPM solid (SPEC 2.1): packing, periodic Delaunay bond/angle network, LAMMPS data file.

Expectations come from geometry, not from the code's output:
- a periodic 2D triangulation lives on a torus (Euler characteristic 0): E = 3N, F = 2N, hence
  exactly 6 bonds and 6 angles per particle, and the angles around every vertex sum to 2 pi;
- on the 3-torus V - E + F - T = 0 with F = 2T, so the unpruned network has
  Na = 3F = 6 (Nb - N) angles;
- in a jammed packing every contact (r < abar) is a Gabriel edge, hence a Delaunay edge, hence
  a bond; non-rattlers carry at least the isostatic 2d contacts;
- perfect lattices (triangular, FCC) have known neighbour shells and angles.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from driver.bpm.datafile import write_data
from driver.bpm.network import MAX_BOND_LENGTH_3D, Network, delaunay_network, minimum_image
from driver.bpm.packing import (
    DEFAULT_PHI,
    FRACTION_LARGE_2D,
    Packing,
    make_packing,
    particle_count,
)
from driver.engine import Lammps, lammps_module

SEED = 3


@pytest.fixture(scope="module")
def pack2d(plugin_path) -> Packing:
    return make_packing(2, 16.0, SEED)


@pytest.fixture(scope="module")
def pack3d(plugin_path) -> Packing:
    return make_packing(3, 7.0, SEED)


@pytest.fixture(scope="module")
def net2d(pack2d) -> Network:
    return delaunay_network(pack2d, None)


@pytest.fixture(scope="module")
def net3d(pack3d) -> Network:
    return delaunay_network(pack3d, MAX_BOND_LENGTH_3D)


def _contacts(p: Packing) -> np.ndarray:
    """Pairs (i < j) closer than abar = r_i + r_j, found without any triangulation."""
    d = p.dimension
    x, L = p.positions[:, :d] - p.box[0][:d], p.lengths
    pairs = cKDTree(x, boxsize=L).query_pairs(2 * p.radii.max(), output_type="ndarray")
    r = np.linalg.norm(minimum_image(x[pairs[:, 1]] - x[pairs[:, 0]], L), axis=1)
    return np.sort(pairs[r < p.radii[pairs[:, 0]] + p.radii[pairs[:, 1]]], axis=1)


def _max_overlap(p: Packing) -> float:
    """Largest overlap of a contact relative to its abar = r_i + r_j: max(1 - r / abar), >= 0."""
    dim = p.dimension
    L = p.lengths
    x = np.mod(p.positions[:, :dim] - p.box[0][:dim], L)
    x[x >= L] = 0.0  # mod can return L for tiny negative values
    pairs = cKDTree(x, boxsize=L).query_pairs(2.0 * float(p.radii.max()), output_type="ndarray")
    if len(pairs) == 0:
        return 0.0
    r = np.linalg.norm(minimum_image(x[pairs[:, 1]] - x[pairs[:, 0]], L), axis=1)
    return float(max(0.0, np.max(1.0 - r / (p.radii[pairs[:, 0]] + p.radii[pairs[:, 1]]))))


def _pairs_within(p: Packing, cut: float) -> set[tuple[int, int]]:
    d = p.dimension
    x = p.positions[:, :d] - p.box[0][:d]
    return {tuple(e) for e in np.sort(cKDTree(x, boxsize=p.lengths).query_pairs(
        cut, output_type="ndarray"), axis=1)}


def _bond_set(net: Network) -> set[tuple[int, int]]:
    return {tuple(b) for b in net.bonds}


def _check_structure(p: Packing, net: Network) -> None:
    """Invariants every network must satisfy."""
    d, L = p.dimension, p.lengths
    b, a = net.bonds, net.angles
    assert b.dtype.kind == "i" and a.dtype.kind == "i"
    assert np.all(b[:, 0] < b[:, 1])
    assert len(np.unique(b, axis=0)) == len(b)
    x = p.positions[:, :d]
    r = np.linalg.norm(minimum_image(x[b[:, 1]] - x[b[:, 0]], L), axis=1)
    np.testing.assert_allclose(net.r0, r, rtol=0, atol=1e-12)
    assert net.r0.max() < 0.5 * L.min()
    # every angle: i < k, i != vertex, both arms are bonds, unique
    assert np.all(a[:, 0] < a[:, 2]) and np.all(a[:, 0] != a[:, 1]) and np.all(a[:, 2] != a[:, 1])
    bonds = _bond_set(net)
    for i, v, k in a:
        assert (min(i, v), max(i, v)) in bonds and (min(k, v), max(k, v)) in bonds
    assert len(np.unique(a, axis=0)) == len(a)
    assert np.all((net.theta0 > 0) & (net.theta0 < np.pi))


# --- packing -----------------------------------------------------------------------------

def test_packing_2d_composition(pack2d):
    p = pack2d
    n = particle_count(2, 16.0, DEFAULT_PHI[2])
    assert p.n == n and p.dimension == 2
    n_large = int(np.sum(p.types == 2))
    assert n_large == round(n * FRACTION_LARGE_2D)
    assert set(np.unique(p.types)) == {1, 2}
    # SPEC 2.1: small d = 3/5 (type 1), large d = 1 (type 2)
    np.testing.assert_array_equal(p.radii, np.where(p.types == 2, 0.5, 0.3))
    assert n_large / (n - n_large) == pytest.approx((1 + math.sqrt(5)) / 4, abs=2 / n)
    assert np.all(p.positions[:, 2] == 0.0)
    assert np.all(p.positions[:, :2] >= 0.0) and np.all(p.positions[:, :2] < 16.0)
    assert p.packing_fraction == pytest.approx(DEFAULT_PHI[2], abs=1.0 / n)


def test_packing_3d_composition(pack3d):
    p = pack3d
    assert p.n == particle_count(3, 7.0, DEFAULT_PHI[3])
    assert np.all(p.types == 1) and np.all(p.radii == 0.5)
    assert np.all(p.positions >= 0.0) and np.all(p.positions < 7.0)
    assert p.packing_fraction == pytest.approx(DEFAULT_PHI[3], abs=1.0 / p.n)


@pytest.mark.lammps  # its packing fixture, by name
@pytest.mark.parametrize("which", ["pack2d", "pack3d"])
def test_packing_is_relaxed_and_jammed(which, request):
    p = request.getfixturevalue(which)
    d = p.dimension
    assert p.relaxation["converged"]
    # phi - phi_J ~ 0.02 gives mean overlaps ~ (phi - phi_J) / (d phi_J) ~ 1 % of abar
    assert 0.0 < _max_overlap(p) < 0.05
    z = np.bincount(_contacts(p).ravel(), minlength=p.n)
    rattlers = z < d + 1
    assert rattlers.mean() < 0.1
    assert z[~rattlers].mean() > 2 * d  # above jamming: hyperstatic, Z > Z_iso = 2d


@pytest.mark.lammps
def test_packing_reproducible_from_seed():
    a = make_packing(2, 12.0, 11)
    b = make_packing(2, 12.0, 11)
    c = make_packing(2, 12.0, 12)
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.types, b.types)
    assert not np.array_equal(a.positions, c.positions)


# --- network on packings -------------------------------------------------------------------

def test_network_2d_torus_counts(pack2d, net2d):
    _check_structure(pack2d, net2d)
    # Euler on the torus: exactly 3N edges and 2N triangles
    assert net2d.n_bonds == 3 * pack2d.n
    assert net2d.n_angles == 6 * pack2d.n
    assert net2d.bonds_per_particle == 6.0 and net2d.angles_per_particle == 6.0
    # the triangles around each vertex tile the full turn
    around = np.bincount(net2d.angles[:, 1], weights=net2d.theta0, minlength=pack2d.n)
    np.testing.assert_allclose(around, 2 * np.pi, atol=1e-9)


@pytest.mark.lammps  # its packing fixture, by name
@pytest.mark.parametrize("which", ["2d", "3d"])
def test_every_contact_is_a_bond(which, request):
    p = request.getfixturevalue(f"pack{which}")
    net = request.getfixturevalue(f"net{which}")
    contacts = {tuple(e) for e in _contacts(p)}
    assert contacts and contacts <= _bond_set(net)


def test_network_3d_counts(pack3d, net3d):
    _check_structure(pack3d, net3d)
    assert net3d.r0.max() < MAX_BOND_LENGTH_3D
    # bonds are the pairs within the cut that are also Delaunay edges
    assert _bond_set(net3d) <= _pairs_within(pack3d, MAX_BOND_LENGTH_3D)
    full = delaunay_network(pack3d, None)
    _check_structure(pack3d, full)
    # 3-torus: Na = 3F = 6T = 6 (Nb - N) for the unpruned triangulation
    assert full.n_angles == 6 * (full.n_bonds - pack3d.n)
    # mean Delaunay degree: below the Poisson value 2 + 48 pi^2 / 35 = 15.54, above a
    # perturbed crystal's (~13.5)
    assert 13.5 < full.bonds_per_particle < 2 + 48 * np.pi**2 / 35
    # pruned at 5/4 2^(1/6) = 1.40: the first neighbour shell of a jammed packing (the first
    # minimum of g(r) is near 1.4 a); contacts alone give >= 6 (isostatic)
    assert 10.5 < net3d.bonds_per_particle < 12.0  # SPEC 2.1: about 11
    assert 22.0 < net3d.angles_per_particle < 28.0  # SPEC 2.1: about 24
    assert net3d.angles_per_particle < full.angles_per_particle


# --- hand-checkable lattices ---------------------------------------------------------------

def _triangular(nx: int, ny: int, shift=(0.0, 0.0)) -> Packing:
    """Triangular lattice of constant 1 in a periodic box nx x ny sqrt(3)/2 (ny even)."""
    j, i = np.meshgrid(np.arange(ny), np.arange(nx), indexing="ij")
    x = i + 0.5 * (j % 2)
    y = j * math.sqrt(3) / 2
    hi = np.array([nx, ny * math.sqrt(3) / 2, 0.5])
    pos = np.zeros((nx * ny, 3))
    pos[:, 0] = np.mod(x.ravel() + shift[0], hi[0])
    pos[:, 1] = np.mod(y.ravel() + shift[1], hi[1])
    n = len(pos)
    return Packing(pos, np.full(n, 0.5), np.ones(n, dtype=np.int64),
                   (np.array([0.0, 0.0, -0.5]), hi), 2)


@pytest.mark.parametrize("shift", [(0.0, 0.0), (0.37, 0.61)])
def test_triangular_lattice(shift):
    p = _triangular(8, 8, shift)
    net = delaunay_network(p, None)
    _check_structure(p, net)
    np.testing.assert_array_equal(np.bincount(net.bonds.ravel(), minlength=p.n), 6)
    np.testing.assert_allclose(net.r0, 1.0, atol=1e-12)
    np.testing.assert_array_equal(np.bincount(net.angles[:, 1], minlength=p.n), 6)
    np.testing.assert_allclose(net.theta0, np.pi / 3, atol=1e-9)


def test_fcc_lattice_bonds():
    """FCC with nearest-neighbour distance 1: its Delaunay cells are regular tetrahedra and
    octahedra (cospherical, so qhull splits them); the octahedron diagonals, sqrt 2 > 1.40,
    are pruned, leaving the 12 nearest neighbours. Every unit triangle is a face: 24 angles
    of 60 degrees per site; the only other angles are the right angles of the split octahedra."""
    cells = 4
    a = math.sqrt(2)
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    grid = np.stack(np.meshgrid(*[np.arange(cells)] * 3, indexing="ij"), -1).reshape(-1, 1, 3)
    pos = ((grid + basis) * a).reshape(-1, 3)
    n = len(pos)
    p = Packing(pos, np.full(n, 0.5), np.ones(n, dtype=np.int64),
                (np.zeros(3), np.full(3, cells * a)), 3)
    net = delaunay_network(p, MAX_BOND_LENGTH_3D)
    _check_structure(p, net)
    np.testing.assert_array_equal(np.bincount(net.bonds.ravel(), minlength=n), 12)
    np.testing.assert_allclose(net.r0, 1.0, atol=1e-12)
    deg = np.degrees(net.theta0)
    sixty = np.isclose(deg, 60.0, atol=1e-6)
    assert np.all(sixty | np.isclose(deg, 90.0, atol=1e-6))
    np.testing.assert_array_equal(np.bincount(net.angles[sixty, 1], minlength=n), 24)


def test_small_box_rejected():
    p = _triangular(3, 4)  # 3 x 3.46: shorter than 4 diameters
    with pytest.raises(ValueError, match="diameters"):
        delaunay_network(p, None)


# --- data file ---------------------------------------------------------------------------

@pytest.mark.lammps  # its packing fixture, by name
@pytest.mark.parametrize("which", ["2d", "3d"])
def test_data_file_round_trip(which, request, tmp_path):
    p = request.getfixturevalue(f"pack{which}")
    net = request.getfixturevalue(f"net{which}")
    path = write_data(tmp_path / "solid.data", p, net)
    assert sorted(f.name for f in tmp_path.iterdir()) == ["solid.data", "solid.refs"]  # no temp file
    # the references of fix breakable/references: the network's r0 and theta0, ids 1-based
    refs = [line.split() for line in (tmp_path / "solid.refs").read_text().splitlines()
            if not line.startswith("#")]
    bonds = np.array([[int(w) for w in r[1:3]] for r in refs if r[0] == "bond"])
    angles = np.array([[int(w) for w in r[1:4]] for r in refs if r[0] == "angle"])
    values = np.array([[float(w) for w in r[4:]] for r in refs if r[0] == "angle"])
    np.testing.assert_array_equal(bonds, net.bonds + 1)
    np.testing.assert_allclose([float(r[3]) for r in refs if r[0] == "bond"], net.r0, rtol=1e-14)
    np.testing.assert_array_equal(angles, net.angles + 1)
    np.testing.assert_allclose(values[:, 0], net.theta0, atol=1e-9)
    lengths = dict(zip(map(tuple, net.bonds.tolist()), net.r0))
    arm = [lengths[tuple(sorted(pair))] for pair in net.angles[:, [0, 1]].tolist()]
    np.testing.assert_allclose(values[:, 1], arm, rtol=1e-14)
    lmod = lammps_module()
    with Lammps() as lmp:
        lmp.commands(f"""
            units lj
            dimension {p.dimension}
            atom_style angle
            read_data {path}
            pair_style zero 1.0
            pair_coeff * *
            comm_modify cutoff {2.0 * net.r0.max() + 0.5}
            bond_style zero
            bond_coeff *
            angle_style zero
            angle_coeff *
            compute r all bond/local dist
            compute t all angle/local theta
            run 0
        """)
        assert lmp.get_natoms() == p.n
        assert lmp.extract_global("nbonds") == net.n_bonds
        assert lmp.extract_global("nangles") == net.n_angles
        assert lmp.extract_global("ntypes") == p.types.max()
        nlocal = lmp.extract_global("nlocal")
        ids = np.array(lmp.numpy.extract_atom("id"))[:nlocal]
        x = np.array(lmp.numpy.extract_atom("x"))[:nlocal]
        np.testing.assert_array_equal(x[np.argsort(ids)], p.positions)
        r = np.array(lmp.numpy.extract_compute("r", lmod.LMP_STYLE_LOCAL, lmod.LMP_TYPE_VECTOR))
        t = np.array(lmp.numpy.extract_compute("t", lmod.LMP_STYLE_LOCAL, lmod.LMP_TYPE_VECTOR))
    # LAMMPS measures the same lengths and (vertex = atom2) angles as the network
    np.testing.assert_allclose(np.sort(r), np.sort(net.r0), atol=1e-12)
    np.testing.assert_allclose(np.sort(t), np.sort(np.degrees(net.theta0)), atol=1e-9)


def test_repulsion_at_break_by_hand():
    """A bond breaks at lambda_c r0; below the sum of radii its break switches the non-bonded
    repulsion on (SPEC 2.2: Eq. 1 acts on pairs not bonded) with U = (abar/r)^12 - 2 (abar/r)^6 + 1."""
    from driver.bpm.network import repulsion_at_break  # noqa: PLC0415

    n, u_max, u_sum = repulsion_at_break(np.array([0.98, 1.0, 1.1, 0.95]), 1.0, 1.01)
    r = np.array([0.98, 0.95]) * 1.01
    u = (1 / r) ** 12 - 2 * (1 / r) ** 6 + 1
    assert n == 2 and u_max == pytest.approx(u.max()) and u_sum == pytest.approx(u.sum())
    assert repulsion_at_break(np.array([1.0, 1.2]), 1.0, 1.05) == (0, 0.0, 0.0)
