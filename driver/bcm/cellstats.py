"""Cell statistics of a BCM tessellation (SPEC 1.1): equivalent-volume diameter and aspect ratio.

- Equivalent-volume diameter ``d_eq = (6 V / pi)^(1/3)``.
- Aspect ratio: longest over shortest side of the cell's bounding box aligned with its
  principal axes of inertia (the box of the vertices' coordinates in the principal frame,
  ``(x - centroid) @ R``). That box follows the cell's own orientation, so a cell's ratio does
  not depend on how the particle sits in the lab frame.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from driver.bcm.tessellation import Tessellation


def cell_statistics(tess: Tessellation) -> pd.DataFrame:
    """One row per cell: ``cell``, ``volume`` (length^3), ``d_eq`` (length), ``box_long``,
    ``box_mid``, ``box_short`` (principal-frame box sides, length), ``aspect_ratio`` =
    box_long / box_short, ``n_interfaces``, ``on_surface`` (has a face on the parent).
    Lengths in the tessellation's unit (m for a parent built in m)."""
    n = tess.n_cells
    # every (cell, vertex) pair once
    pairs = np.unique(np.c_[np.repeat(tess.face_cell, np.diff(tess.face_ptr)), tess.face_vertices], axis=0)
    cell, vid = pairs[:, 0], pairs[:, 1]
    local = np.einsum("pk,pkj->pj", tess.vertices[vid] - tess.centroid[cell], tess.principal_axes[cell])
    hi = np.full((n, 3), -np.inf)
    lo = np.full((n, 3), np.inf)
    np.maximum.at(hi, cell, local)
    np.minimum.at(lo, cell, local)
    sides = np.sort(hi - lo, axis=1)[:, ::-1]
    on_surface = np.zeros(n, dtype=bool)
    on_surface[tess.face_cell[tess.face_neighbor < 0]] = True
    return pd.DataFrame({
        "cell": np.arange(n),
        "volume": tess.volume,
        "d_eq": (6.0 * tess.volume / math.pi) ** (1.0 / 3.0),
        "box_long": sides[:, 0],
        "box_mid": sides[:, 1],
        "box_short": sides[:, 2],
        "aspect_ratio": sides[:, 0] / sides[:, 2],
        "n_interfaces": tess.faces_per_cell(),
        "on_surface": on_surface,
    })


def plot_cell_stats(df: pd.DataFrame, path: str | Path, length_unit: str = "mm",
                    length_scale: float = 1e3) -> Path:
    """Two-panel histogram PNG: d_eq (in ``length_unit``, values times ``length_scale``) and
    aspect ratio; surface and interior cells stacked in two greys, mean marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(1, 2, figsize=(9.0, 3.6), constrained_layout=True)
    surface = df["on_surface"].to_numpy()
    d_label = f"equivalent-volume diameter\n$d_{{eq}} = (6V/\\pi)^{{1/3}}$ ({length_unit})"
    panels = [(df["d_eq"].to_numpy() * length_scale, d_label),
              (df["aspect_ratio"].to_numpy(), "aspect ratio\n(longest / shortest side of the principal-axes box)")]
    for ax, (values, label) in zip(axes, panels):
        bins = np.histogram_bin_edges(values, bins=30)
        ax.hist([values[~surface], values[surface]], bins=bins, stacked=True, color=["0.25", "0.7"],
                edgecolor="black", linewidth=0.4, label=["interior cells", "surface cells"])
        mean = values.mean()
        ax.axvline(mean, color="black", linestyle="--", linewidth=1.0, label=f"mean {mean:.3g}")
        ax.xaxis.set_major_locator(MaxNLocator(nbins=6))
        ax.set_xlabel(label)
        ax.set_ylabel("number of cells")
        ax.legend(frameon=False, fontsize=8)
    fig.suptitle(f"{len(df)} cells: d_eq = {panels[0][0].mean():.3g} ± {panels[0][0].std():.2g} {length_unit}, "
                 f"aspect ratio = {panels[1][0].mean():.3g} ± {panels[1][0].std():.2g}", fontsize=10)
    fig.savefig(path, dpi=150)
    plt.close(fig)
    return path
