"""Where a BCM impact's energy goes, interface by interface (issue 23, point 1): the losses of
each interface (its damping, friction and switch work, its slip; compute bond/local b7-b13 of
bond bcm/griffith, in the interface dump's loss columns) against its depth below the contact,
and the loss channels and the state of the broken interfaces against time (the impact record).

Depth: the height of the interface's centroid in the reference state (interfaces.txt, the
particle as placed, its lowest rounded point `gap` above the plane z = 0) above that lowest
point, in units of the particle's diameter; the plane touches the particle at depth 0.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

#: the per-interface loss columns of the interface dump (runfiles/records.py INTERFACES_DUMP)
LOSS_COLUMNS = ("W_damp", "W_damp_broken", "W_friction", "W_switch", "slip")


def interface_centroids(path: Path) -> pd.DataFrame:
    """atom1, atom2, area and the centroid (x, y, z) of each interface of an interfaces.txt
    (plugins/doc/bond_bcm_griffith.md, geometry file: `tag1 tag2 area nx ny nz npts points`)."""
    rows = []
    for line in Path(path).read_text().splitlines():
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        tok = line.split()
        npts = int(tok[6])
        pts = np.array(tok[7:7 + 3 * npts], dtype=float).reshape(npts, 3)
        c = pts.mean(axis=0)
        rows.append((int(tok[0]), int(tok[1]), float(tok[2]), *c))
    return pd.DataFrame(rows, columns=["atom1", "atom2", "area_ref", "x", "y", "z"])


def with_depth(interfaces: pd.DataFrame, centroids: pd.DataFrame, lowest_z: float, diameter: float) -> pd.DataFrame:
    """The interface table joined with its reference centroids, and `depth` = (z - lowest_z) /
    diameter: how far above the particle's lowest point (where the plane first touches) it lies."""
    out = interfaces.merge(centroids[["atom1", "atom2", "z"]], on=["atom1", "atom2"], how="left", validate="1:1")
    if out.z.isna().any():
        raise ValueError(f"{int(out.z.isna().sum())} interfaces of the dump are not in the geometry file")
    out["depth"] = (out.pop("z") - lowest_z) / diameter
    return out


def losses_by_depth(interfaces: pd.DataFrame, wk_minus: float, n_bins: int = 10) -> pd.DataFrame:
    """Per slab of depth (n_bins equal slabs over [0, 1] diameter): the interfaces, how many
    broke, the broken area, and the sums of their losses (LOSS_COLUMNS; W_damp_intact =
    W_damp - W_damp_broken), the energies also as shares of W_k^- (`<column>_share`)."""
    edges = np.linspace(0.0, 1.0, n_bins + 1)
    t = interfaces.assign(broken=interfaces.state <= 0.5, W_damp_intact=interfaces.W_damp - interfaces.W_damp_broken)
    slab = np.clip(np.digitize(t.depth, edges) - 1, 0, n_bins - 1)
    g = t.groupby(slab)
    out = pd.DataFrame({
        "depth_lo": edges[:-1], "depth_hi": edges[1:],
        "interfaces": g.size().reindex(range(n_bins), fill_value=0).to_numpy(),
        "broken": g.broken.sum().reindex(range(n_bins), fill_value=0).to_numpy(),
        "broken_area": g.apply(lambda x: x.area[x.broken].sum(), include_groups=False)
        .reindex(range(n_bins), fill_value=0.0).to_numpy(),
    })
    for col in ("W_friction", "W_switch", "W_damp_broken", "W_damp_intact", "slip"):
        out[col] = g[col].sum().reindex(range(n_bins), fill_value=0.0).to_numpy()
    for col in ("W_friction", "W_switch", "W_damp_broken", "W_damp_intact"):
        out[f"{col}_share"] = out[col] / wk_minus
    return out


#: loss channels against time, from the impact record: (label, record column(s) summed)
TIME_CHANNELS = (
    ("friction on broken interfaces", ("W_friction",)),
    ("switch (break, retirement)", ("W_switch",)),
    ("damping, broken interfaces", ("W_damp_broken",)),
    ("damping, intact interfaces", ("W_damp", "-W_damp_broken")),
    ("plane damping", ("W_wall_damp",)),
    ("plane friction", ("W_wall_friction",)),
    ("fracture W_f", ("W_f",)),
)


def channels_in_time(thermo: pd.DataFrame, wk_minus: float) -> pd.DataFrame:
    """time (s) and each TIME_CHANNELS entry as a share of W_k^-, per record; with the state of
    the broken interfaces (broken, broken_closed, closed_points, closed_force, slip) and the
    plane's force where the record has them."""
    out = pd.DataFrame({"time": thermo.time})
    for label, cols in TIME_CHANNELS:
        if all(c.lstrip("-") in thermo for c in cols):
            out[label] = sum(-thermo[c[1:]] if c.startswith("-") else thermo[c] for c in cols) / wk_minus
    for col in ("broken", "broken_closed", "closed_points", "closed_force", "slip", "wall_force"):
        if col in thermo:
            out[col] = thermo[col]
    return out
