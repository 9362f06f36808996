"""Grain tracking between frames: which grain at frame k a grain at frame k+1 came from.

Grains are the components of `analysis.grains` (labels 0.. largest first). With bonds that
only break, every child grain lies inside one parent; merges (re-bonding, or grains that
touch in a contact model) are handled too: a child then has several parents, each with the
fraction of the child's mass it supplied.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

PARENT_CHILD_COLUMNS = ["child", "parent", "shared", "shared_mass", "child_mass", "parent_mass",
                        "fraction_of_child", "fraction_of_parent", "main_parent", "main_child"]


def parent_child(labels_k: np.ndarray, labels_k1: np.ndarray, masses: np.ndarray | None = None) -> pd.DataFrame:
    """Parent-child table between grain labels at frame k and frame k+1 of the same atoms.

    labels_k, labels_k1: (n_atoms,) non-negative grain labels of the same atoms (same order:
    the readers sort every frame by atom id); masses: (n_atoms,)
    atom masses (default 1, so mass = number of atoms).

    One row per (child, parent) pair sharing atoms, sorted by child then shared mass
    (descending): shared = number of shared atoms, shared_mass, child_mass and parent_mass
    (over the atoms given), fraction_of_child = shared_mass / child_mass (the fraction of the
    child's mass that came from this parent), fraction_of_parent = shared_mass / parent_mass,
    main_parent (this parent supplied the most of the child's mass; ties: smallest parent
    label) and main_child (this child received the most of the parent's mass; ties: smallest
    child label).
    """
    a = np.asarray(labels_k, dtype=np.int64)
    b = np.asarray(labels_k1, dtype=np.int64)
    if a.shape != b.shape or a.ndim != 1:
        raise ValueError(f"labels must be 1-D of equal length, got {a.shape} and {b.shape}")
    if len(a) and (a.min() < 0 or b.min() < 0):
        raise ValueError("grain labels must be non-negative")
    w = np.ones(len(a)) if masses is None else np.asarray(masses, dtype=float)
    if w.shape != a.shape:
        raise ValueError(f"masses shape {w.shape} differs from labels {a.shape}")
    if len(a) == 0:
        return pd.DataFrame({c: [] for c in PARENT_CHILD_COLUMNS})
    n_parent = int(a.max()) + 1
    key = b * n_parent + a  # child-major, so np.unique sorts by child then parent
    pairs, inv, shared = np.unique(key, return_inverse=True, return_counts=True)
    shared_mass = np.bincount(inv, weights=w, minlength=len(pairs))
    child, parent = pairs // n_parent, pairs % n_parent
    child_mass = np.bincount(b, weights=w)[child]
    parent_mass = np.bincount(a, weights=w)[parent]
    df = pd.DataFrame({"child": child, "parent": parent, "shared": shared, "shared_mass": shared_mass,
                       "child_mass": child_mass, "parent_mass": parent_mass,
                       "fraction_of_child": shared_mass / child_mass,
                       "fraction_of_parent": shared_mass / parent_mass})
    df["main_parent"] = _is_main(df, group="child", other="parent")
    df["main_child"] = _is_main(df, group="parent", other="child")
    order = np.lexsort((df["parent"].to_numpy(), -df["shared_mass"].to_numpy(), df["child"].to_numpy()))
    return df.iloc[order].reset_index(drop=True)


def _is_main(df: pd.DataFrame, group: str, other: str) -> np.ndarray:
    """True on the row with the largest shared mass within each group (ties: smallest other)."""
    order = np.lexsort((df[other].to_numpy(), -df["shared_mass"].to_numpy(), df[group].to_numpy()))
    g = df[group].to_numpy()[order]
    first = np.ones(len(g), dtype=bool)
    first[1:] = g[1:] != g[:-1]
    main = np.zeros(len(df), dtype=bool)
    main[order[first]] = True
    return main


def lineage_table(labels: list[np.ndarray], masses: np.ndarray | None = None) -> pd.DataFrame:
    """parent_child tables of every consecutive pair of frames, with a column `frame` = k+1."""
    parts = []
    for k in range(1, len(labels)):
        t = parent_child(labels[k - 1], labels[k], masses)
        t.insert(0, "frame", k)
        parts.append(t)
    if not parts:
        return pd.DataFrame(columns=["frame", *PARENT_CHILD_COLUMNS])
    return pd.concat(parts, ignore_index=True)
