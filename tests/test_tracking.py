"""Grain tracking on hand-made label sequences, and the vectorised table against brute force."""

from __future__ import annotations

import numpy as np

from analysis.grains import grain_labels
from analysis.tracking import lineage_table, parent_child


def rows(table, cols=("child", "parent", "shared", "fraction_of_child", "fraction_of_parent")):
    return [tuple(float(v) for v in r) for r in table[list(cols)].itertuples(index=False)]


def test_split_by_hand():
    # Grain 0 (atoms 0-3) splits into {0,1} and {2,3}; grains 1 and 2 stay whole.
    a = np.array([0, 0, 0, 0, 1, 1, 2])
    b = np.array([0, 0, 2, 2, 1, 1, 3])
    t = parent_child(a, b)
    assert rows(t) == [(0, 0, 2, 1.0, 0.5), (1, 1, 2, 1.0, 1.0), (2, 0, 2, 1.0, 0.5), (3, 2, 1, 1.0, 1.0)]
    assert t["main_parent"].all()
    # Parent 0 gave 2 atoms to each of children 0 and 2: the tie goes to the smaller child.
    assert t.loc[t.parent == 0, "main_child"].tolist() == [True, False]


def test_merge_with_masses():
    a = np.array([0, 0, 1, 1, 2])
    b = np.array([0, 0, 0, 1, 1])
    m = np.array([1.0, 1.0, 2.0, 1.0, 3.0])
    t = parent_child(a, b, m)
    c0 = t[t.child == 0]
    assert c0["parent"].tolist() == [0, 1]  # equal shared mass 2: smaller parent first
    assert c0["fraction_of_child"].tolist() == [0.5, 0.5] and c0["main_parent"].tolist() == [True, False]
    c1 = t[t.child == 1]
    assert c1["parent"].tolist() == [2, 1]  # 3 from parent 2, 1 from parent 1
    assert np.allclose(c1["fraction_of_child"], [0.75, 0.25])
    assert np.allclose(c1["fraction_of_parent"], [1.0, 1 / 3])
    assert t["child_mass"].tolist() == [4, 4, 4, 4] and np.allclose(t.groupby("child").fraction_of_child.sum(), 1)


def test_against_brute_force():
    rng = np.random.default_rng(5)
    n = 300
    pairs = rng.integers(0, n, (500, 2))
    intact = rng.random(500) < 0.7
    a = grain_labels(n, pairs[intact])
    b = grain_labels(n, pairs[intact & (rng.random(500) < 0.8)])  # more bonds break: splits only
    m = rng.random(n) + 0.5
    t = parent_child(a, b, m)
    expected = {}
    for i in range(n):
        expected.setdefault((b[i], a[i]), [0, 0.0])
        expected[(b[i], a[i])][0] += 1
        expected[(b[i], a[i])][1] += m[i]
    got = {(r.child, r.parent): [r.shared, r.shared_mass] for r in t.itertuples()}
    assert got.keys() == expected.keys()
    for k, (cnt, mass) in expected.items():
        assert got[k][0] == cnt and np.isclose(got[k][1], mass)
    assert t["fraction_of_child"].eq(1.0).all()  # bonds only broke: one parent per child
    assert len(t) == b.max() + 1


def test_lineage_table_of_three_frames():
    frames = [np.array([0, 0, 0, 0, 0, 0]),
              np.array([0, 0, 0, 0, 1, 1]),
              np.array([1, 0, 0, 0, 2, 3])]
    table = lineage_table(frames)
    assert table["frame"].unique().tolist() == [1, 2] and len(table) == 2 + 4
