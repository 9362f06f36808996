"""Offscreen pictures of a frame: cells (BCM) or particles (BPM) coloured by grain/fragment.

matplotlib (Agg) renders without a display; polyhedra are drawn as shaded face polygons.
Grain 0 is the largest; colours cycle through a qualitative map, and single-cell or
single-particle grains are drawn light grey so that fragments stand out in greyscale too.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import PatchCollection  # noqa: E402
from matplotlib.patches import Circle  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

from runfiles.atomic import atomic_save  # noqa: E402

_SINGLE = (0.85, 0.85, 0.85, 1.0)


def grain_colours(labels: np.ndarray) -> np.ndarray:
    """RGBA per item: a qualitative colour per grain; grains of one item light grey."""
    labels = np.asarray(labels)
    sizes = np.bincount(labels)
    cmap = plt.get_cmap("tab20")
    cols = np.array([cmap(k % 20) for k in range(len(sizes))])
    cols[sizes == 1] = _SINGLE
    return cols[labels]


def view_direction(elev: float, azim: float) -> np.ndarray:
    """Unit vector from the scene towards the viewer of mplot3d's view_init(elev, azim), degrees."""
    e, a = np.radians(elev), np.radians(azim)
    return np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])


def visible_faces(cell_vertices: list[np.ndarray], cell_faces: list[list[np.ndarray]], labels: np.ndarray,
                  towards_viewer: np.ndarray) -> list[np.ndarray]:
    """Per cell, a mask of the faces an orthographic picture can show: its convex cell's faces
    turned towards the viewer, less the faces pressed against a face of another cell of the
    same grain (opposite normals, centroids within a tenth of the median cell size: the inside
    of a fragment). The rest are hidden behind them, whatever their order, so the picture is
    unchanged and holds a few times fewer polygons (a fragment shows its surface only)."""
    centroids, normals, owner = [], [], []
    for c, (verts, faces) in enumerate(zip(cell_vertices, cell_faces)):
        v = np.asarray(verts, dtype=float)
        middle = v.mean(0)
        for f in faces:
            p = v[np.asarray(f)]
            centre = p.mean(0)
            n = np.cross(p[1] - p[0], p[2] - p[0])
            nn = np.linalg.norm(n)
            n = n / nn if nn > 0 else np.zeros(3)
            if np.dot(n, centre - middle) < 0:  # outward, whatever the loop's orientation
                n = -n
            centroids.append(centre)
            normals.append(n)
            owner.append(c)
    if not centroids:
        return [np.zeros(0, bool) for _ in cell_faces]
    centroids, normals, owner = np.array(centroids), np.array(normals), np.array(owner)
    keep = normals @ np.asarray(towards_viewer, dtype=float) >= 0.0
    size = np.median([np.ptp(np.asarray(v, dtype=float), axis=0).max() for v in cell_vertices])
    from scipy.spatial import cKDTree  # noqa: PLC0415

    pairs = cKDTree(centroids).query_pairs(0.1 * size, output_type="ndarray")
    if len(pairs):
        a, b = pairs[:, 0], pairs[:, 1]
        lab = np.asarray(labels)
        inside = ((owner[a] != owner[b]) & (lab[owner[a]] == lab[owner[b]])
                  & (np.einsum("ij,ij->i", normals[a], normals[b]) < -0.9))
        keep[a[inside]] = False
        keep[b[inside]] = False
    bounds = np.cumsum([0] + [len(f) for f in cell_faces])
    return [keep[bounds[c]:bounds[c + 1]] for c in range(len(cell_faces))]


def render_cells(cell_vertices: list[np.ndarray], cell_faces: list[list[np.ndarray]], labels: np.ndarray,
                 path: Path, title: str = "", view=(20.0, -60.0), length_unit: float = 1e-3,
                 unit_name: str = "mm") -> None:
    """Polyhedral cells (lab-frame vertices per cell, faces as vertex loops) coloured by label,
    in an orthographic view, drawing the faces that can be seen (visible_faces)."""
    cols = grain_colours(labels)
    polys, face_cols = [], []
    light = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    shown = visible_faces(cell_vertices, cell_faces, labels, view_direction(*view))
    for verts, faces, col, mask in zip(cell_vertices, cell_faces, cols, shown):
        v = np.asarray(verts) / length_unit
        for f, visible in zip(faces, mask):
            if not visible:
                continue
            p = v[np.asarray(f)]
            n = np.cross(p[1] - p[0], p[2] - p[0])
            nn = np.linalg.norm(n)
            shade = 0.55 + 0.45 * abs(np.dot(n / nn, light)) if nn > 0 else 1.0
            polys.append(p)
            face_cols.append((*(np.asarray(col[:3]) * shade), 1.0))
    allv = np.concatenate([np.asarray(v) for v in cell_vertices]) / length_unit
    fig = plt.figure(figsize=(5.5, 5.0), dpi=150)
    ax = fig.add_subplot(projection="3d")
    ax.set_proj_type("ortho")  # the faces turned away are then exactly the hidden ones
    # Faces padded to one length by repeating their last vertex (a zero-length edge). Given a
    # ragged list (pentagons beside hexagons), mplot3d >= 3.9 pads it into an np.empty array
    # and autoscales from the padding too, i.e. from whatever memory the process freed last
    # (after another figure: NaN or 1e308, "Axis limits cannot be NaN or Inf"). The limits
    # are then set explicitly from the finite vertices.
    ax.add_collection3d(Poly3DCollection(_pad_faces(polys), facecolors=face_cols, edgecolors=(0, 0, 0, 0.25),
                                         linewidths=0.2))
    _set_cube_limits(ax, allv)
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(*view)
    ax.set_xlabel(f"x [{unit_name}]")
    ax.set_ylabel(f"y [{unit_name}]")
    ax.set_zlabel(f"z [{unit_name}]")
    if title:
        ax.set_title(title, fontsize=9)
    atomic_save(path, lambda p: fig.savefig(p, format="png"))
    plt.close(fig)


def _pad_faces(polys: list[np.ndarray]) -> np.ndarray:
    """(n_faces, max_vertices, 3) array of face loops, each padded with its last vertex."""
    if not polys:
        return np.zeros((0, 3, 3))
    width = max(len(p) for p in polys)
    return np.stack([np.concatenate([p, np.repeat(p[-1:], width - len(p), axis=0)]) for p in polys])


def finite_cube_limits(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre and half side of a cube holding the finite points of (n, 3) `points`; a point
    set with no finite point or no extent gets a unit cube (limits are always finite and
    distinct)."""
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    pts = pts[np.isfinite(pts).all(axis=1)]
    if not len(pts):
        return np.zeros(3), 1.0
    lo, hi = pts.min(0), pts.max(0)
    half = 0.5 * float((hi - lo).max())
    centre = 0.5 * (lo + hi)
    if not half > 0:
        half = max(1.0, float(np.abs(centre).max())) * 1e-3
    return centre, half


def _set_cube_limits(ax, points: np.ndarray) -> None:
    centre, half = finite_cube_limits(points)
    for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):
        setter(c - half, c + half)


def render_particles_2d(positions: np.ndarray, radii: np.ndarray, labels: np.ndarray, box: np.ndarray,
                        path: Path, title: str = "") -> None:
    """Disks (BPM 2D) coloured by grain; box = [[xlo, xhi], [ylo, yhi], ...] in units of a."""
    cols = grain_colours(labels)
    fig, ax = plt.subplots(figsize=(5.5, 5.5 * (box[1][1] - box[1][0]) / (box[0][1] - box[0][0]) + 0.5), dpi=150)
    patches = [Circle((x, y), r) for (x, y), r in zip(positions[:, :2], radii)]
    ax.add_collection(PatchCollection(patches, facecolors=cols, edgecolors=(0, 0, 0, 0.4), linewidths=0.2))
    ax.set_xlim(*box[0])
    ax.set_ylim(*box[1])
    ax.set_aspect("equal")
    ax.set_xlabel("x [a]")
    ax.set_ylabel("y [a]")
    if title:
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    atomic_save(path, lambda p: fig.savefig(p, format="png"))
    plt.close(fig)


def render_particles_3d(positions: np.ndarray, labels: np.ndarray, path: Path, title: str = "") -> None:
    """Spheres (BPM 3D) as points coloured by grain."""
    cols = grain_colours(labels)
    fig = plt.figure(figsize=(5.5, 5.0), dpi=150)
    ax = fig.add_subplot(projection="3d")
    ax.scatter(*positions.T, c=cols, s=4, depthshade=True)
    _set_cube_limits(ax, np.asarray(positions, dtype=float))
    ax.set_xlabel("x [a]")
    ax.set_ylabel("y [a]")
    ax.set_zlabel("z [a]")
    if title:
        ax.set_title(title, fontsize=9)
    atomic_save(path, lambda p: fig.savefig(p, format="png"))
    plt.close(fig)
