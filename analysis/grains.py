"""Grains: connected components of the graph of intact bonds (SPEC 2.2, 1.5 'fragments').

Labels are deterministic: grain 0 is the largest, ties broken by the smallest atom index it
contains, so tables are stable across runs and MPI rank counts.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components


def grain_labels(n_atoms: int, pairs: np.ndarray, intact: np.ndarray | None = None) -> np.ndarray:
    """Grain id per atom (0-based atom indices), shape (n_atoms,).

    pairs: (n_bonds, 2) 0-based atom indices; intact: optional bool mask of bonds that count
    (e.g. bond type > 0). Atoms without intact bonds are grains of their own.
    """
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    if intact is not None:
        pairs = pairs[np.asarray(intact, dtype=bool)]
    if len(pairs) and (pairs.min() < 0 or pairs.max() >= n_atoms):
        raise ValueError(f"bond atom index outside 0..{n_atoms - 1}")
    graph = coo_matrix((np.ones(len(pairs), dtype=np.int8), (pairs[:, 0], pairs[:, 1])),
                       shape=(n_atoms, n_atoms)).tocsr()
    _, raw = connected_components(graph, directed=False)
    return relabel_largest_first(raw)


def relabel_largest_first(raw: np.ndarray) -> np.ndarray:
    """Renumber component labels: largest first, ties by smallest member index."""
    raw = np.asarray(raw)
    n = raw.max() + 1 if len(raw) else 0
    sizes = np.bincount(raw, minlength=n)
    first = np.full(n, len(raw), dtype=np.int64)
    np.minimum.at(first, raw, np.arange(len(raw)))
    order = np.lexsort((first, -sizes))  # primary: size descending; secondary: first index
    new = np.empty(n, dtype=np.int64)
    new[order] = np.arange(n)
    return new[raw]


def grain_sizes(labels: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Mass (or count when weights is None) of each grain, indexed by grain id."""
    return np.bincount(labels, weights=weights)


def grains_from_bond_dump(n_atoms: int, pairs_1based: np.ndarray, types: np.ndarray) -> np.ndarray:
    """Grain labels from a bond snapshot whose atom ids are 1..n_atoms; type 0 = broken."""
    return grain_labels(n_atoms, np.asarray(pairs_1based) - 1, np.asarray(types) > 0)
