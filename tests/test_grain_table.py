"""Grain table on hand-built systems: minimum image, unwrapping across boundaries, percolation."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from analysis.grain_table import grain_table, minimum_image, unwrap_by_bonds
from analysis.grains import grain_labels

BOX4 = np.array([[0.0, 4.0], [0.0, 4.0], [0.0, 4.0]])


def brute_minimum_image(d, box, tilt=None, periodic=(True, True, True)):
    """Shortest of d + integer combinations of the periodic edge vectors (all that can matter)."""
    d = np.asarray(d, dtype=float)
    dim = d.shape[1]
    lengths = box[:dim, 1] - box[:dim, 0]
    reach = int(np.ceil(np.abs(d).max() / lengths.min())) + 2
    h = np.diag(lengths)
    if tilt is not None:
        h[0, 1] = tilt[0]
        if dim == 3:
            h[0, 2], h[1, 2] = tilt[1], tilt[2]
    out = np.empty_like(d)
    ranges = [range(-reach, reach + 1) if periodic[k] else (0,) for k in range(dim)]
    shifts = np.array(list(itertools.product(*ranges)), dtype=float) @ h.T
    for i, v in enumerate(d):
        cand = v + shifts
        out[i] = cand[np.argmin((cand ** 2).sum(axis=1))]
    return out


# ---------------------------------------------------------------- minimum image

def test_minimum_image_orthogonal_3d():
    box = np.array([[-1.0, 9.0], [0.0, 6.0], [2.0, 5.0]])  # lengths 10, 6, 3
    d = np.array([[6.0, -4.0, 1.0], [-14.0, 2.5, -2.0], [0.1, 0.2, 0.3], [25.0, -13.0, 7.4]])
    want = np.array([[-4.0, 2.0, 1.0], [-4.0, 2.5, 1.0], [0.1, 0.2, 0.3], [5.0, -1.0, 1.4]])
    np.testing.assert_allclose(minimum_image(d, box), want, atol=1e-12)
    rng = np.random.default_rng(1)
    d = rng.uniform(-30, 30, (200, 3))
    np.testing.assert_allclose(minimum_image(d, box), brute_minimum_image(d, box), atol=1e-9)


def test_minimum_image_triclinic_matches_brute_force():
    box = np.array([[0.0, 5.0], [1.0, 5.0], [-1.0, 5.0]])  # lengths 5, 4, 6
    tilt = np.array([2.0, -2.5, 1.5])  # within LAMMPS' limits |xy| <= lx/2 etc.
    rng = np.random.default_rng(2)
    d = rng.uniform(-12, 12, (500, 3))
    got = minimum_image(d, box, tilt)
    want = brute_minimum_image(d, box, tilt)
    np.testing.assert_allclose((got ** 2).sum(axis=1), (want ** 2).sum(axis=1), atol=1e-9)
    np.testing.assert_allclose(got, want, atol=1e-9)
    # the tilt matters: the orthogonal answer is different
    assert not np.allclose(got, minimum_image(d, box))
    # the result differs from d by a lattice vector
    h = np.array([[5.0, 2.0, -2.5], [0.0, 4.0, 1.5], [0.0, 0.0, 6.0]])
    k = np.linalg.solve(h, (d - got).T)
    np.testing.assert_allclose(k, np.round(k), atol=1e-9)


def test_minimum_image_non_periodic_dimension_left_alone():
    box = np.array([[0.0, 4.0], [0.0, 4.0], [0.0, 4.0]])
    d = np.array([[3.0, 3.0, 3.0], [-3.5, -3.5, -3.5]])
    got = minimum_image(d, box, periodic=(True, False, True))
    np.testing.assert_allclose(got, [[-1.0, 3.0, -1.0], [0.5, -3.5, 0.5]])
    # with a tilt too
    tilt = np.array([1.0, 0.0, 0.0])
    rng = np.random.default_rng(3)
    d = rng.uniform(-10, 10, (100, 3))
    got = minimum_image(d, box, tilt, periodic=(True, True, False))
    np.testing.assert_allclose(got[:, 2], d[:, 2])
    np.testing.assert_allclose(got, brute_minimum_image(d, box, tilt, (True, True, False)), atol=1e-9)
    np.testing.assert_allclose(minimum_image(d, box, periodic=(False, False, False)), d)


def test_minimum_image_2d():
    box = np.array([[0.0, 10.0], [0.0, 4.0], [-0.5, 0.5]])  # z row ignored in 2D
    d = np.array([[7.0, 3.0], [-6.0, -1.0]])
    np.testing.assert_allclose(minimum_image(d, box), [[-3.0, -1.0], [4.0, -1.0]])
    tilt = np.array([1.5, 0.0, 0.0])
    rng = np.random.default_rng(4)
    d = rng.uniform(-15, 15, (300, 2))
    got = minimum_image(d, box, tilt)
    assert got.shape == (300, 2)
    np.testing.assert_allclose(got, brute_minimum_image(d, box, tilt), atol=1e-9)


# ---------------------------------------------------------------- unwrapping and the table

def test_chain_across_x_boundary():
    # unwrapped chain x = 2.5, 3.5, 4.5, 5.5 in a box [0, 4): wrapped 2.5, 3.5, 0.5, 1.5
    pos = np.array([[2.5, 1.0, 1.0], [3.5, 1.5, 1.0], [0.5, 1.0, 1.0], [1.5, 1.5, 2.0]])
    pairs = np.array([[0, 1], [1, 2], [2, 3]])
    labels = grain_labels(4, pairs)
    unwrapped, perc = unwrap_by_bonds(pos, pairs, labels, BOX4)
    np.testing.assert_allclose(unwrapped[:, 0], [2.5, 3.5, 4.5, 5.5])
    assert perc.tolist() == [False]

    t = grain_table(labels, pos, None, None, pairs, BOX4)
    assert len(t) == 1 and t["size"][0] == 4 and t["mass"][0] == 4.0
    assert not t["percolating"][0]
    # COM of the unwrapped chain: (4.0, 1.25, 1.25) -> x wrapped to 0.0
    np.testing.assert_allclose(t.loc[0, ["x", "y", "z"]].to_numpy(float), [0.0, 1.25, 1.25], atol=1e-12)
    r = np.array([[2.5, 1.0, 1.0], [3.5, 1.5, 1.0], [4.5, 1.0, 1.0], [5.5, 1.5, 2.0]])
    r = r - r.mean(axis=0)
    g = r.T @ r / 4
    want = {"gxx": g[0, 0], "gyy": g[1, 1], "gzz": g[2, 2], "gxy": g[0, 1], "gxz": g[0, 2], "gyz": g[1, 2]}
    for col, val in want.items():
        assert t[col][0] == pytest.approx(val, abs=1e-12), col
    assert t["gxx"][0] == pytest.approx(1.25)
    assert t["rg"][0] == pytest.approx(np.sqrt(np.trace(g)))
    assert "vx" not in t.columns and "ke" not in t.columns


def test_chain_across_boundary_com_wrapped_inside_box():
    # unwrapped x = 3.0, 3.6, 4.2, 4.8: COM 3.9 (inside) ; shift by +0.5 -> COM 4.4 -> 0.4
    for shift, want in [(0.0, 3.9), (0.5, 0.4)]:
        x = (np.array([3.0, 3.6, 4.2, 4.8]) + shift) % 4.0
        pos = np.column_stack([x, np.full(4, 2.0), np.full(4, 2.0)])
        pairs = np.array([[2, 3], [1, 2], [0, 1]])
        t = grain_table(grain_labels(4, pairs), pos, None, None, pairs, BOX4)
        assert t["x"][0] == pytest.approx(want)
        assert t["gxx"][0] == pytest.approx(np.var([3.0, 3.6, 4.2, 4.8]))


def test_ring_around_box_percolates_square_across_corner_does_not():
    # grain A: 4 atoms along x spanning the box, loop closed across the boundary
    ring = np.array([[0.5, 1.0, 1.0], [1.5, 1.0, 1.0], [2.5, 1.0, 1.0], [3.5, 1.0, 1.0]])
    # grain B: a unit square around the box corner (3.5/0.5 in x and y), a closed ring too
    square = np.array([[3.5, 3.5, 3.0], [0.5, 3.5, 3.0], [0.5, 0.5, 3.0], [3.5, 0.5, 3.0]])
    pos = np.vstack([ring, square])
    pairs = np.array([[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4]])
    labels = grain_labels(8, pairs)
    assert labels.tolist() == [0, 0, 0, 0, 1, 1, 1, 1]
    t = grain_table(labels, pos, None, None, pairs, BOX4)
    assert t["percolating"].tolist() == [True, False]
    for col in ["x", "y", "z", "gxx", "gyy", "gzz", "gxy", "gxz", "gyz", "rg"]:
        assert np.isnan(t[col][0]), col
        assert np.isfinite(t[col][1]), col
    # square centred on the corner: COM at (0, 0, 3), gyration diag(1/4, 1/4, 0)
    np.testing.assert_allclose(t.loc[1, ["x", "y", "z"]].to_numpy(float), [0.0, 0.0, 3.0], atol=1e-12)
    np.testing.assert_allclose(t.loc[1, ["gxx", "gyy", "gzz", "gxy"]].to_numpy(float), [0.25, 0.25, 0, 0],
                               atol=1e-12)
    # the open chain (loop bond removed) no longer percolates
    t2 = grain_table(labels, pos, None, None, pairs[1:], BOX4)
    assert t2["percolating"].tolist() == [False, False]
    assert np.isfinite(t2["x"][0])


def test_ring_not_periodic_along_x_is_not_percolating():
    ring = np.array([[0.5, 1.0], [1.5, 1.0], [2.5, 1.0], [1.5, 2.0]])
    pairs = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])
    labels = grain_labels(4, pairs)
    t = grain_table(labels, ring, None, None, pairs, BOX4, periodic=(False, False, False))
    assert not t["percolating"][0]
    np.testing.assert_allclose(t.loc[0, ["x", "y"]].to_numpy(float), [1.5, 1.25])
    # periodic x, non-periodic y: a pair across the x boundary, outside the box in y (shrink-wrapped
    # box lagging): x unwrapped and wrapped back, y left as it is
    pair = np.array([[3.5, 4.5], [0.3, 5.5]])
    t = grain_table(np.zeros(2, dtype=int), pair, None, None, np.array([[0, 1]]), BOX4,
                    periodic=(True, False, True))
    np.testing.assert_allclose(t.loc[0, ["x", "y"]].to_numpy(float), [3.9, 5.0])
    assert t["gxx"][0] == pytest.approx(0.16) and t["gyy"][0] == pytest.approx(0.25)


def test_isolated_atoms_are_own_grains():
    pos = np.array([[0.5, 0.5, 0.5], [3.9, 0.1, 2.0], [1.0, 1.0, 1.0], [1.5, 1.0, 1.0]])
    vel = np.array([[1.0, 2.0, 0.0], [0.0, -1.0, 3.0], [1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    masses = np.array([2.0, 0.5, 1.0, 1.0])
    pairs = np.array([[2, 3]])
    labels = grain_labels(4, pairs)
    assert labels.tolist() == [1, 2, 0, 0]
    t = grain_table(labels, pos, vel, masses, pairs, BOX4)
    assert t["size"].tolist() == [2, 1, 1]
    assert t.index.tolist() == [0, 1, 2] and t["grain"].tolist() == [0, 1, 2]
    for g, atom in [(1, 0), (2, 1)]:
        assert t["rg"][g] == 0.0
        assert t["ke"][g] == pytest.approx(t["ke_cm"][g])
        assert t["ke"][g] == pytest.approx(0.5 * masses[atom] * vel[atom] @ vel[atom])
        np.testing.assert_allclose(t.loc[g, ["x", "y", "z"]].to_numpy(float), pos[atom])
        np.testing.assert_allclose(t.loc[g, ["vx", "vy", "vz"]].to_numpy(float), vel[atom])
    # the pair moves apart: no COM motion, all energy internal
    assert t["ke_cm"][0] == 0.0 and t["ke"][0] == pytest.approx(1.0)
    assert t["rg"][0] == pytest.approx(0.25)


def test_mass_weighted_com_and_energies():
    # two atoms bonded across the x boundary: unwrapped x = 3.5 (m=1) and 4.3 (m=3)
    pos = np.array([[3.5, 1.0, 2.0], [0.3, 2.0, 2.0]])
    vel = np.array([[4.0, 0.0, 0.0], [0.0, 2.0, 0.0]])
    masses = np.array([1.0, 3.0])
    pairs = np.array([[0, 1]])
    t = grain_table(grain_labels(2, pairs), pos, vel, masses, pairs, BOX4)
    assert t["mass"][0] == 4.0
    # COM x = (3.5 + 3 * 4.3) / 4 = 4.1 -> 0.1 ; y = (1 + 6) / 4
    np.testing.assert_allclose(t.loc[0, ["x", "y", "z"]].to_numpy(float), [0.1, 1.75, 2.0], atol=1e-12)
    np.testing.assert_allclose(t.loc[0, ["vx", "vy", "vz"]].to_numpy(float), [1.0, 1.5, 0.0])
    assert t["ke"][0] == pytest.approx(0.5 * 16 + 0.5 * 3 * 4)
    assert t["ke_cm"][0] == pytest.approx(0.5 * 4 * (1.0 + 2.25))
    # gyration about the COM: offsets (-0.6, -0.75) and (0.2, 0.25), weights 1 and 3
    assert t["gxx"][0] == pytest.approx((0.36 + 3 * 0.04) / 4)
    assert t["gyy"][0] == pytest.approx((0.5625 + 3 * 0.0625) / 4)
    assert t["gxy"][0] == pytest.approx((0.45 + 3 * 0.05) / 4)


def test_labels_from_grain_labels_and_mismatch_rejected():
    pos = np.array([[0.5, 0.5], [1.5, 0.5], [3.0, 3.0], [2.5, 0.5], [3.5, 3.5], [1.0, 3.9]])
    pairs = np.array([[0, 1], [1, 3], [2, 4]])
    labels = grain_labels(6, pairs)
    assert labels.tolist() == [0, 0, 1, 0, 1, 2]
    t = grain_table(labels, pos, None, None, pairs, BOX4)
    assert t["size"].tolist() == [3, 2, 1]
    assert list(t.columns) == ["grain", "size", "mass", "x", "y", "gxx", "gyy", "gxy", "rg", "percolating"]
    np.testing.assert_allclose(t.loc[0, ["x", "y"]].to_numpy(float), [1.5, 0.5])
    np.testing.assert_allclose(t.loc[1, ["x", "y"]].to_numpy(float), [3.25, 3.25])
    # labels that do not match the bonds are refused
    with pytest.raises(ValueError):
        grain_table(np.array([0, 0, 1, 1, 1, 2]), pos, None, None, pairs, BOX4)
    with pytest.raises(ValueError):
        grain_table(np.array([0, 0, 1, 0, 1, 1]), pos, None, None, pairs, BOX4)


def _blob_system(rng, box, n_blobs=5, per_blob=30, cutoff=1.2):
    """Random 3D blobs (intact bonds between close atoms of one blob): (wrapped, pairs, unwrapped)."""
    lo, hi = box[:, 0], box[:, 1]
    centres = rng.uniform(lo, hi, (n_blobs, 3))
    pos = np.concatenate([c + rng.normal(0, 0.8, (per_blob, 3)) for c in centres])
    blob = np.repeat(np.arange(n_blobs), per_blob)
    i, j = np.triu_indices(len(pos), 1)
    keep = (blob[i] == blob[j]) & (np.linalg.norm(pos[i] - pos[j], axis=1) < cutoff)
    pairs = np.column_stack([i[keep], j[keep]])
    wrapped = lo + np.mod(pos - lo, hi - lo)
    return wrapped, pairs, pos


@pytest.mark.parametrize("tilt", [None, np.array([2.0, -1.5, 1.0])])
def test_unwrap_recovers_blobs_up_to_one_lattice_vector(tilt):
    rng = np.random.default_rng(11)
    box = np.array([[0.0, 6.0], [0.0, 6.0], [0.0, 6.0]])  # small box: most blobs straddle it
    lo, hi = box[:, 0], box[:, 1]
    _, pairs, true = _blob_system(rng, box)
    h = np.diag(hi - lo)
    if tilt is not None:
        h[0, 1], h[0, 2], h[1, 2] = tilt
    s = np.linalg.solve(h, (true - lo).T).T
    wrapped = lo + np.mod(s, 1.0) @ h.T
    labels = grain_labels(len(true), pairs)
    unwrapped, perc = unwrap_by_bonds(wrapped, pairs, labels, box, tilt)
    assert not perc.any()
    assert np.any(np.abs(unwrapped - wrapped).max(axis=1) > 1.0)  # grains were really cut
    k = np.linalg.solve(h, (unwrapped - true).T).T  # integer lattice shifts, one per grain
    np.testing.assert_allclose(k, np.round(k), atol=1e-9)
    for g in range(labels.max() + 1):  # loop over a handful of grains (test only)
        kg = np.round(k[labels == g])
        assert (kg == kg[0]).all()
        root = np.flatnonzero(labels == g)[0]
        np.testing.assert_array_equal(unwrapped[root], wrapped[root])  # root keeps its position


@pytest.mark.parametrize("tilt", [None, np.array([1.0, -0.5, 0.8])])
def test_translation_invariance(tilt):
    rng = np.random.default_rng(7)
    box = np.array([[0.0, 8.0], [-2.0, 6.0], [1.0, 9.0]])
    pos, pairs, _ = _blob_system(rng, box)
    if tilt is not None:  # map into the triclinic cell
        h = np.array([[8.0, tilt[0], tilt[1]], [0.0, 8.0, tilt[2]], [0.0, 0.0, 8.0]])
        s = (pos - box[:, 0]) / 8.0
        pos = box[:, 0] + s @ h.T
    n = len(pos)
    masses = rng.uniform(1, 3, n)
    vel = rng.normal(size=(n, 3))
    labels = grain_labels(n, pairs)
    t0 = grain_table(labels, pos, vel, masses, pairs, box, tilt)
    assert (t0["size"] > 5).sum() >= 3  # several real grains, some crossing the boundary below
    shift = np.array([3.7, -5.1, 2.3])
    # translate and rewrap (in fractional coordinates of the cell)
    h = np.diag(box[:, 1] - box[:, 0])
    if tilt is not None:
        h[0, 1], h[0, 2], h[1, 2] = tilt
    s = np.linalg.solve(h, (pos + shift - box[:, 0]).T).T
    moved = box[:, 0] + np.mod(s, 1.0) @ h.T
    # grains really straddle the boundary after the move (unwrapping changes positions)
    unwrapped, perc = unwrap_by_bonds(moved, pairs, labels, box, tilt)
    assert not perc.any()
    assert np.any(np.abs(unwrapped - moved).max(axis=1) > 1.0)
    t1 = grain_table(labels, moved, vel, masses, pairs, box, tilt)
    same = ["size", "mass", "vx", "vy", "vz", "ke", "ke_cm", "gxx", "gyy", "gzz", "gxy", "gxz", "gyz", "rg",
            "percolating"]
    for col in same:
        np.testing.assert_allclose(t1[col].to_numpy(float), t0[col].to_numpy(float), atol=1e-9, err_msg=col)
    # COM moves by the shift modulo the cell
    dcom = t1[["x", "y", "z"]].to_numpy() - t0[["x", "y", "z"]].to_numpy() - shift
    k = np.linalg.solve(h, dcom.T)
    np.testing.assert_allclose(k, np.round(k), atol=1e-9)
    # and both lie inside the cell
    for t in (t0, t1):
        sc = np.linalg.solve(h, (t[["x", "y", "z"]].to_numpy() - box[:, 0]).T)
        assert np.all((sc >= 0) & (sc < 1))


def test_empty_and_all_isolated():
    t = grain_table(np.zeros(0, dtype=int), np.zeros((0, 3)), np.zeros((0, 3)), None,
                    np.zeros((0, 2), dtype=int), BOX4)
    assert len(t) == 0 and "ke" in t.columns
    pos = np.array([[0.5, 0.5, 0.5], [1.5, 2.5, 3.5]])
    t = grain_table(grain_labels(2, np.zeros((0, 2))), pos, None, None, np.zeros((0, 2), dtype=int), BOX4)
    assert t["rg"].tolist() == [0.0, 0.0]
    np.testing.assert_allclose(t[["x", "y", "z"]].to_numpy(), pos)
