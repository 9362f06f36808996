"""Per-grain table: size, mass, centre of mass, velocity, kinetic energy, gyration tensor.

Grains are connected components of intact bonds (`analysis.grains.grain_labels`). Dump
positions are wrapped into the periodic box, so a grain straddling a periodic boundary is
first unwrapped by walking its bonds: each grain along a spanning tree rooted at its
smallest-index atom (which keeps its wrapped position), each tree edge adding the
minimum-image bond vector. Everything is vectorised (one breadth-first search over the whole
bond graph, pointer jumping in O(log depth) rounds, sums by np.bincount), so millions of
atoms and tens of millions of bonds take seconds.

A grain that wraps onto itself through the periodic box (the intact solid spanning the box, a
ring of bonds around it) has no meaningful centre of mass or gyration: it is flagged
`percolating` and those columns are NaN.

Box conventions follow `analysis.dumps.AtomFrame`: box (3, 2) lo/hi, tilt None or
(xy, xz, yz) with LAMMPS' edge vectors a = (lx, 0, 0), b = (xy, ly, 0), c = (xz, yz, lz);
2D systems use the x, y rows of the box and the xy tilt only.
"""

from __future__ import annotations

import itertools
from typing import Sequence

import numpy as np
import pandas as pd
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import breadth_first_order

from analysis.dumps import AtomFrame, DumpError, LocalFrame, bond_pairs
from analysis.grains import grains_from_bond_dump

# Chunk of vectors searched at once when refining a triclinic minimum image over neighbour
# images (only vectors longer than half the shortest lattice vector get there: rare for bonds).
_REFINE_CHUNK = 65536
# Bonds per chunk in the percolation check.
_BOND_CHUNK = 1 << 20


def periodic_from_boundary(boundary: Sequence[str], dim: int = 3) -> tuple[bool, ...]:
    """Periodic flag per dimension from a LAMMPS boundary tuple like ('pp', 'ff', 'pp').

    An empty (unknown) boundary counts as fully periodic: for bonds shorter than half the box
    the minimum image of a non-periodic system is the plain difference anyway.
    """
    if not boundary:
        return (True,) * dim
    if len(boundary) < dim:
        raise ValueError(f"boundary {tuple(boundary)} has fewer than {dim} dimensions")
    return tuple(str(b).startswith("p") for b in boundary[:dim])


def cell_matrix(box: np.ndarray, tilt: np.ndarray | None = None, dim: int = 3) -> np.ndarray:
    """Edge vectors of the box as the columns of a (dim, dim) upper-triangular matrix H."""
    box = np.asarray(box, dtype=np.float64).reshape(-1, 2)
    if box.shape[0] < dim:
        raise ValueError(f"box has {box.shape[0]} rows, need {dim}")
    h = np.diag(box[:dim, 1] - box[:dim, 0])
    if np.any(np.diag(h) <= 0):
        raise ValueError(f"box lengths must be positive, got {np.diag(h)}")
    if tilt is not None:
        t = np.asarray(tilt, dtype=np.float64).ravel()
        h[0, 1] = t[0]
        if dim == 3:
            h[0, 2], h[1, 2] = t[1], t[2]
    return h


def _periodic_mask(periodic: Sequence[bool], dim: int) -> np.ndarray:
    mask = np.asarray(periodic, dtype=bool).ravel()
    if mask.size < dim:
        raise ValueError(f"periodic has {mask.size} entries, need {dim}")
    return mask[:dim]


def _image_shifts(mask: np.ndarray, reach: int = 2) -> np.ndarray:
    """Integer image shifts (k, dim) in -reach..reach along periodic dims, zero elsewhere."""
    ranges = [range(-reach, reach + 1) if p else (0,) for p in mask]
    return np.array(list(itertools.product(*ranges)), dtype=np.float64)


def _shortest_lattice_sq(h: np.ndarray, mask: np.ndarray) -> float:
    """Squared length of the shortest nonzero lattice vector along the periodic dimensions.

    A vector no longer than half of it is its own minimum image (|v + T| >= |T| - |v| >= |v|).
    """
    lattice = _image_shifts(mask) @ h.T
    norms = np.einsum("ij,ij->i", lattice, lattice)
    return float(norms[norms > 0].min())


def minimum_image(d: np.ndarray, box: np.ndarray, tilt: np.ndarray | None = None,
                  periodic: Sequence[bool] = (True, True, True)) -> np.ndarray:
    """Minimum-image version of displacement vectors d, shape (n, dim), dim 2 or 3.

    Only periodic dimensions are wrapped. Orthogonal boxes: each fractional component rounded
    (exact). Triclinic boxes (a nonzero tilt): fractional rounding, then the few vectors
    longer than half the shortest lattice vector (for which rounding may not give the
    shortest image) are checked against the neighbouring images and the shortest kept.
    """
    d = np.asarray(d, dtype=np.float64)
    squeeze = d.ndim == 1
    d = np.atleast_2d(d)
    dim = d.shape[1]
    if dim not in (2, 3):
        raise ValueError(f"displacements must have 2 or 3 components, got {dim}")
    mask = _periodic_mask(periodic, dim)
    h = cell_matrix(box, tilt, dim)
    out = d.copy()
    if not mask.any() or len(d) == 0:
        return out[0] if squeeze else out
    triclinic = np.any(h[np.triu_indices(dim, 1)] != 0)
    if not triclinic:
        lengths = np.diag(h)
        shift = out * np.where(mask, 1.0 / lengths, 0.0)
        np.round(shift, out=shift)
        shift *= lengths
        out -= shift
        return out[0] if squeeze else out
    s = out @ np.linalg.inv(h).T  # fractional coordinates
    shift = np.where(mask, np.round(s), 0.0)
    out -= shift @ h.T
    # rounding is the minimum image for |v| <= lambda_1 / 2 (lambda_1: shortest lattice vector)
    lattice = _image_shifts(mask) @ h.T
    lam2 = _shortest_lattice_sq(h, mask)
    v2 = np.einsum("ij,ij->i", out, out)
    far = np.flatnonzero(v2 > lam2 / 4 * (1 - 1e-12))
    for start in range(0, len(far), _REFINE_CHUNK):  # loop over chunks of rare vectors
        idx = far[start:start + _REFINE_CHUNK]
        cand = out[idx, None, :] - lattice[None, :, :]
        best = np.argmin(np.einsum("ikj,ikj->ik", cand, cand), axis=1)
        out[idx] = cand[np.arange(len(idx)), best]
    return out[0] if squeeze else out


def wrap_into_box(x: np.ndarray, box: np.ndarray, tilt: np.ndarray | None = None,
                  periodic: Sequence[bool] = (True, True, True)) -> np.ndarray:
    """Positions (n, dim) mapped into the primary cell along periodic dimensions.

    NaN rows stay NaN.
    """
    x = np.asarray(x, dtype=np.float64)
    dim = x.shape[1]
    mask = _periodic_mask(periodic, dim)
    h = cell_matrix(box, tilt, dim)
    lo = np.asarray(box, dtype=np.float64).reshape(-1, 2)[:dim, 0]
    s = (x - lo) @ np.linalg.inv(h).T
    s = np.where(mask, s - np.floor(s), s)
    s = np.where(mask & (s >= 1.0), 0.0, s)  # s - floor(s) can round up to exactly 1
    return lo + s @ h.T


def grain_roots(labels: np.ndarray) -> np.ndarray:
    """Smallest atom index of each grain, indexed by label; labels must be 0..n_grains-1."""
    labels = np.asarray(labels, dtype=np.int64)
    n = len(labels)
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    if labels.min() < 0:
        raise ValueError("grain labels must be >= 0")
    n_grains = int(labels.max()) + 1
    roots = np.full(n_grains, n, dtype=np.int64)
    np.minimum.at(roots, labels, np.arange(n, dtype=np.int64))
    if np.any(roots == n):
        raise ValueError("grain labels must be contiguous 0..n_grains-1 (a label has no atoms)")
    return roots


def _rows(a: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """a[idx] for an (n, k) array, each row gathered as one item by np.take.

    Several times faster than numpy's row fancy indexing for tens of millions of indices.
    """
    a = np.ascontiguousarray(a)
    k = a.shape[1]
    return np.take(a.view(np.dtype((np.void, a.itemsize * k))).ravel(), idx).view(a.dtype).reshape(-1, k)


def _set_rows(a: np.ndarray, idx: np.ndarray, values: np.ndarray) -> None:
    """a[idx] = values for a C-contiguous (n, k) array, each row scattered as one item."""
    item = np.dtype((np.void, a.itemsize * a.shape[1]))
    a.view(item).ravel()[idx] = np.ascontiguousarray(values, dtype=a.dtype).view(item).ravel()


def _check_pairs(pairs: np.ndarray, n: int) -> np.ndarray:
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    if len(pairs) and (pairs.min() < 0 or pairs.max() >= n):
        raise ValueError(f"bond atom index outside 0..{n - 1}")
    return pairs


def _adjacency(pairs: np.ndarray, roots: np.ndarray, n: int) -> csr_matrix:
    """CSR graph on n + 1 nodes: the bonds, plus virtual node n -> each grain root.

    Grouped by source node with scipy's O(nnz) counting sort (a one-entry-per-row matrix
    converted to CSC) instead of coo -> csr, which also sorts and sums duplicates.
    """
    m = len(pairs) + len(roots)
    itype = np.int32 if max(m, n + 1) < np.iinfo(np.int32).max else np.int64
    src = np.concatenate([pairs[:, 0], np.full(len(roots), n)], dtype=itype, casting="same_kind")
    dst = np.concatenate([pairs[:, 1], roots], dtype=itype, casting="same_kind")
    edges = csr_matrix((dst, src, np.arange(m + 1, dtype=itype)), shape=(m, n + 1)).tocsc()
    return csr_matrix((np.ones(m), edges.data, edges.indptr), shape=(n + 1, n + 1))


def unwrap_by_bonds(positions: np.ndarray, pairs: np.ndarray, labels: np.ndarray, box: np.ndarray,
                    tilt: np.ndarray | None = None,
                    periodic: Sequence[bool] = (True, True, True)) -> tuple[np.ndarray, np.ndarray]:
    """Unwrap each grain along its bonds; return (unwrapped (n, dim), percolating (n_grains,)).

    positions: (n, dim) wrapped; pairs: (n_bonds, 2) 0-based intact bonds only; labels: grain
    per atom (0..n_grains-1, the connected components of pairs, e.g. from grain_labels). Each
    grain is walked along a breadth-first spanning tree rooted at its smallest-index atom,
    which keeps its wrapped position; every tree edge adds the minimum-image bond vector.
    A grain percolates when one of its bonds, unwrapped, differs from its minimum image (by a
    lattice vector): it wraps onto itself through the periodic box.
    """
    pos = np.ascontiguousarray(positions, dtype=np.float64)
    n, dim = pos.shape
    labels = np.asarray(labels, dtype=np.int64)
    if len(labels) != n:
        raise ValueError(f"{len(labels)} labels for {n} atoms")
    pairs = _check_pairs(pairs, n)
    roots = grain_roots(labels)
    n_grains = len(roots)
    if n == 0:
        return pos.copy(), np.zeros(0, dtype=bool)

    # one BFS over all grains: a virtual node n linked to every grain's root
    graph = _adjacency(pairs, roots, n)
    _, pred = breadth_first_order(graph, n, directed=False, return_predecessors=True)
    p = pred[:n]
    if np.any(p < 0):
        raise ValueError("some atoms are not bonded to their grain: labels do not match the bonds")
    is_root = p == n
    p[is_root] = np.flatnonzero(is_root)
    off = minimum_image(pos - _rows(pos, p), box, tilt, periodic)  # edge pred -> atom; 0 at roots

    # pointer jumping: keep unwrapped[i] = unwrapped[p[i]] + off[i] until p[i] is a root
    act = np.flatnonzero(~is_root[p])
    while len(act):  # O(log tree depth) rounds
        pa = p[act]
        _set_rows(off, act, _rows(off, act) + _rows(off, pa))
        pa = p[pa]
        p[act] = pa
        act = act[~is_root[pa]]
    unwrapped = _rows(pos, p) + off

    # Percolation: an unwrapped bond is the wrapped bond plus a lattice vector, so it has the
    # same minimum image; a consistent bond is its own minimum image, a bond closing a loop
    # around the box is not. Bonds shorter than half the shortest lattice vector are their own
    # minimum image, so only longer ones are checked. The same pass checks that no bond joins
    # two grains. Bonds go in chunks to bound the temporaries (and keep them in cache).
    h = cell_matrix(box, tilt, dim)
    mask = _periodic_mask(periodic, dim)
    lam2 = _shortest_lattice_sq(h, mask) if mask.any() else np.inf
    tol = 1e-6 * np.abs(h).sum(axis=0).max()
    percolating = np.zeros(n_grains, dtype=bool)
    for start in range(0, len(pairs), _BOND_CHUNK):  # loop over chunks of 2**20 bonds
        i, j = pairs[start:start + _BOND_CHUNK, 0], pairs[start:start + _BOND_CHUNK, 1]
        li = np.take(labels, i)
        if np.any(li != np.take(labels, j)):
            raise ValueError("a bond joins atoms of different grains: labels do not match the bonds")
        du = _rows(unwrapped, j) - _rows(unwrapped, i)
        far = np.flatnonzero(np.einsum("ij,ij->i", du, du) > lam2 / 4 * (1 - 1e-9))
        if len(far):
            d = du[far]
            bad = (np.abs(d - minimum_image(d, box, tilt, periodic)) > tol).any(axis=1)
            percolating[li[far[bad]]] = True
    return unwrapped, percolating


def grain_table(labels: np.ndarray, positions: np.ndarray, velocities: np.ndarray | None,
                masses: np.ndarray | None, pairs: np.ndarray, box: np.ndarray,
                tilt: np.ndarray | None = None,
                periodic: Sequence[bool] = (True, True, True)) -> pd.DataFrame:
    """One row per grain (index = grain label): size, mass, COM, velocity, energies, gyration.

    Columns: grain, size, mass, x, y[, z] (centre of mass of the unwrapped grain, wrapped back
    into the primary cell), vx, vy[, vz] (centre-of-mass velocity), ke (sum of m v^2 / 2),
    ke_cm (M |v_cm|^2 / 2), gxx, gyy[, gzz], gxy[, gxz, gyz] (mass-weighted gyration tensor
    about the centre of mass), rg (sqrt of its trace), percolating. Percolating grains have NaN
    centre of mass and gyration. masses None: all 1; velocities None: no velocity/ke columns.
    pairs: (n_bonds, 2) 0-based intact bonds whose components are the labels.
    """
    pos = np.ascontiguousarray(positions, dtype=np.float64)
    n, dim = pos.shape
    labels = np.asarray(labels, dtype=np.int64)
    m = np.ones(n) if masses is None else np.asarray(masses, dtype=np.float64).ravel()
    if len(m) != n:
        raise ValueError(f"{len(m)} masses for {n} atoms")
    axes = "xyz"[:dim]

    unwrapped, percolating = unwrap_by_bonds(pos, pairs, labels, box, tilt, periodic)
    roots = grain_roots(labels)
    ng = len(roots)
    size = np.bincount(labels, minlength=ng)
    mass = np.bincount(labels, weights=m, minlength=ng)
    cols: dict[str, np.ndarray] = {"grain": np.arange(ng), "size": size, "mass": mass}

    # centre of mass relative to each grain's root (small numbers: no cancellation)
    rel = unwrapped - _rows(pos[roots], labels)
    com_rel = np.column_stack([np.bincount(labels, weights=m * rel[:, k], minlength=ng)
                               for k in range(dim)]) / mass[:, None] if ng else np.zeros((0, dim))
    r = rel - _rows(com_rel, labels)
    com = wrap_into_box(pos[roots] + com_rel, box, tilt, periodic) if ng else com_rel
    com[percolating] = np.nan
    for k, a in enumerate(axes):
        cols[a] = com[:, k]

    if velocities is not None:
        v = np.asarray(velocities, dtype=np.float64)
        if v.shape != pos.shape:
            raise ValueError(f"velocities shape {v.shape} != positions shape {pos.shape}")
        vcm = np.column_stack([np.bincount(labels, weights=m * v[:, k], minlength=ng)
                               for k in range(dim)]) / mass[:, None] if ng else np.zeros((0, dim))
        for k, a in enumerate(axes):
            cols["v" + a] = vcm[:, k]
        cols["ke"] = np.bincount(labels, weights=0.5 * m * np.einsum("ij,ij->i", v, v), minlength=ng)
        cols["ke_cm"] = 0.5 * mass * np.einsum("ij,ij->i", vcm, vcm)

    components = [(k, k) for k in range(dim)] + list(itertools.combinations(range(dim), 2))
    trace = np.zeros(ng)
    for k, q in components:  # loop over <= 6 tensor components
        g = np.bincount(labels, weights=m * r[:, k] * r[:, q], minlength=ng) / mass if ng else np.zeros(0)
        g[percolating] = np.nan
        cols["g" + axes[k] + axes[q]] = g
        if k == q:
            trace = trace + g
    cols["rg"] = np.sqrt(np.maximum(trace, 0.0))
    cols["percolating"] = percolating
    return pd.DataFrame(cols, index=pd.RangeIndex(ng, name=None))


def frame_grains(atoms: AtomFrame, bonds: LocalFrame, dim: int) -> tuple[np.ndarray, pd.DataFrame]:
    """Grain label per atom (in atom-id order) and grain table (`grain_table`) of one atom
    frame and its bond frame (bonds of type > 0 intact; masses from the dump's mass column,
    else 1). Atom ids need not be 1..n: bonds are mapped onto the frame's ids."""
    pairs, types = bond_pairs(bonds)
    index = np.searchsorted(atoms.ids, pairs)
    bad = (index >= len(atoms.ids)) | (atoms.ids[np.minimum(index, len(atoms.ids) - 1)] != pairs)
    if bad.any():
        raise DumpError(f"bond dump at timestep {bonds.timestep}: atom id {int(pairs[bad][0])} is not in the atom "
                        "dump of that timestep")
    labels = grains_from_bond_dump(len(atoms.ids), index + 1, types)
    periodic = periodic_from_boundary(atoms.boundary, dim)
    masses = atoms.extra.get("mass")
    vel = None if atoms.velocities is None else atoms.velocities[:, :dim]
    table = grain_table(labels, atoms.positions[:, :dim], vel, masses, index[types > 0], atoms.box, atoms.tilt,
                        periodic)
    return labels, table
