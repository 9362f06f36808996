"""A bed of many grains (issue 25, point 1; SPEC 4.2): the `model.assembly` section and the pure
geometry of a loose start — grain sizes from a list or a distribution, random orientations, and
the grains' bounding spheres placed without overlap in a rigid box.

The placement is random sequential addition (each grain, largest first, at the first random
position where its bounding sphere overlaps neither a wall nor a grain already placed; overlaps
found with scipy's cKDTree). Random sequential addition of spheres jams near 38 % of the volume,
so the box it fills is the loose start's: the scenario then brings the bed to a dense, nearly
stress-free state in LAMMPS (walls moved in with breaking switched off). A box too small for the
grains is refused with the volume fraction it would need.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np
from pydantic import Field, model_validator

from driver.schema import _Strict

if TYPE_CHECKING:  # scipy is imported where the geometry is made, not when a config is read
    from scipy.spatial.transform import Rotation

#: random sequential addition of equal spheres jams at a volume fraction of about 0.38; a start
#: asked for above this is refused before any attempt
RSA_JAMMING = 0.38


class GrainSizes(_Strict):
    """Grain diameters (the parent's size measure, m): a list repeated to n_grains, or a
    distribution truncated to [min, max]."""

    kind: Literal["list", "uniform", "lognormal"] = Field(
        "list", description="list: `values` in turn; uniform: between min and max; lognormal: median and "
                            "sigma (of ln d), truncated to [min, max] by redrawing")
    values: list[float] = Field(default_factory=lambda: [2.0e-3], description="diameters for `list`, m")
    min: float | None = Field(None, gt=0.0, description="smallest diameter (uniform, lognormal), m")
    max: float | None = Field(None, gt=0.0, description="largest diameter (uniform, lognormal), m")
    median: float | None = Field(None, gt=0.0, description="median diameter (lognormal), m")
    sigma: float | None = Field(None, gt=0.0, le=3.0, description="standard deviation of ln d (lognormal)")

    @model_validator(mode="after")
    def _complete(self) -> GrainSizes:
        if self.kind == "list":
            if not self.values or min(self.values) <= 0.0:
                raise ValueError("sizes.values: at least one diameter, every one > 0 (m)")
            return self
        if self.min is None or self.max is None or not self.min < self.max:
            raise ValueError(f"sizes.min and sizes.max: both needed for kind {self.kind}, with min < max "
                             f"(got min = {self.min}, max = {self.max})")
        if self.kind == "lognormal":
            if self.median is None or self.sigma is None:
                raise ValueError("sizes.median and sizes.sigma: both needed for kind lognormal")
            if not self.min <= self.median <= self.max:
                raise ValueError(f"sizes.median = {self.median:g} must lie in [min, max] = "
                                 f"[{self.min:g}, {self.max:g}]")
        return self


class AssemblySection(_Strict):
    """`model.assembly`: how many grains, their sizes, and the box they start loose in."""

    n_grains: int = Field(10, ge=1, le=100_000, description="number of grains")
    sizes: GrainSizes = Field(default_factory=GrainSizes, description="grain diameters")
    box: list[float] = Field(default_factory=lambda: [1.0e-2, 1.0e-2, 2.0e-2], min_length=3, max_length=3,
                             description="inner size of the rigid box at the start (x, y, z), m; the loose start "
                                         "fills it to at most ~38 % (random sequential addition)")
    tessellations: int = Field(8, ge=1, description="BCM: distinct tessellations drawn per run, each grain takes "
                                                    "one of them (cached), turned at random")
    max_attempts: int = Field(10_000, ge=1, description="random positions tried per grain before the box is "
                                                        "declared full")

    @model_validator(mode="after")
    def _box(self) -> AssemblySection:
        if min(self.box) <= 0.0:
            raise ValueError(f"box: every side > 0 m (got {self.box})")
        return self


def grain_sizes(spec: GrainSizes, n: int, rng: np.random.Generator) -> np.ndarray:
    """n diameters by spec (list: its values in turn; uniform; lognormal truncated by redrawing)."""
    if spec.kind == "list":
        return np.resize(np.asarray(spec.values, dtype=float), n)
    if spec.kind == "uniform":
        return rng.uniform(spec.min, spec.max, n)
    out = np.empty(0)
    mu = np.log(spec.median)
    while out.size < n:  # truncation by redrawing keeps the shape of the law inside the bounds
        d = rng.lognormal(mu, spec.sigma, 2 * (n - out.size) + 16)
        out = np.concatenate([out, d[(d >= spec.min) & (d <= spec.max)]])
    return out[:n]


@dataclass(frozen=True)
class LooseStart:
    """The grains' bounding spheres placed in the box [0, box]: centres, radii, orientations."""

    centres: np.ndarray      # (n, 3), m
    radii: np.ndarray        # (n,), m: bounding radius of each grain
    rotations: Rotation      # n random orientations
    box: np.ndarray          # (3,), m
    order: np.ndarray        # the grains in placement order (largest first), indices into radii

    @property
    def solid_fraction(self) -> float:
        """Volume of the bounding spheres over the box's."""
        return float(4.0 / 3.0 * np.pi * np.sum(self.radii**3) / np.prod(self.box))


def loose_start(radii: np.ndarray, box, rng: np.random.Generator, max_attempts: int = 10_000) -> LooseStart:
    """Place spheres of the given radii in the box [0, box]^3 without overlap (walls included) by
    random sequential addition, largest first. Raises ValueError when the spheres cannot fit: above
    the jamming fraction at once, or when a sphere finds no place in max_attempts tries."""
    from scipy.spatial import cKDTree  # noqa: PLC0415
    from scipy.spatial.transform import Rotation  # noqa: PLC0415

    radii = np.asarray(radii, dtype=float)
    box = np.asarray(box, dtype=float)
    if radii.ndim != 1 or radii.size == 0 or radii.min() <= 0.0:
        raise ValueError("radii: a non-empty list of positive radii")
    if box.shape != (3,) or box.min() <= 0.0:
        raise ValueError(f"box: three positive sides, m (got {box.tolist()})")
    if np.any(2.0 * radii.max() > box):
        raise ValueError(f"box {box.tolist()} m: narrower than the largest grain's bounding sphere "
                         f"(diameter {2.0 * radii.max():.4g} m)")
    phi = 4.0 / 3.0 * np.pi * np.sum(radii**3) / np.prod(box)
    if phi > RSA_JAMMING:
        raise ValueError(f"box {box.tolist()} m: the grains' bounding spheres would fill {phi:.0%} of it, above "
                         f"the ~{RSA_JAMMING:.0%} that random sequential addition reaches; make the box at least "
                         f"{(phi / RSA_JAMMING) ** (1 / 3):.2f} times larger in each direction (or taller)")
    order = np.argsort(-radii, kind="stable")
    centres = np.full((radii.size, 3), np.nan)
    placed: list[int] = []
    tree, tree_size = None, 0
    rmax = radii.max()
    for k, i in enumerate(order):
        r = radii[i]
        lo, hi = np.full(3, r), box - r
        for _ in range(max_attempts):
            c = rng.uniform(lo, hi)
            # rebuild the tree as it doubles; the spheres placed since are checked one by one
            if tree is None or len(placed) >= 2 * tree_size:
                tree = cKDTree(centres[placed]) if placed else None
                tree_size = len(placed)
            clear = True
            if tree is not None:
                for j in tree.query_ball_point(c, r + rmax):
                    if np.linalg.norm(c - centres[placed[j]]) < r + radii[placed[j]]:
                        clear = False
                        break
            if clear:
                for j in placed[tree_size:]:
                    if np.linalg.norm(c - centres[j]) < r + radii[j]:
                        clear = False
                        break
            if clear:
                centres[i] = c
                placed.append(int(i))
                break
        else:
            raise ValueError(f"box {box.tolist()} m: grain {k + 1} of {radii.size} (radius {r:.4g} m) found no place "
                             f"in {max_attempts} tries at {phi:.0%} solid (bounding spheres); make the box larger")
    return LooseStart(centres=centres, radii=radii, rotations=Rotation.random(radii.size, random_state=rng),
                      box=box, order=order)



def _push_apart(c: np.ndarray, r: np.ndarray, box: np.ndarray, margin: float) -> float:
    """One sweep of overlap removal: the centres clipped into the walls, then every overlapping
    pair of spheres pushed apart along its line of centres by a quarter of (overlap + margin)
    each (under-relaxed: a sphere pushed by several neighbours does not overshoot). Returns
    the largest overlap found (0 when none)."""
    np.clip(c, r[:, None], box - r[:, None], out=c)
    from scipy.spatial import cKDTree  # noqa: PLC0415

    pairs = cKDTree(c).query_pairs(2.0 * float(r.max()), output_type="ndarray")
    if len(pairs) == 0:
        return 0.0
    d = c[pairs[:, 1]] - c[pairs[:, 0]]
    dist = np.linalg.norm(d, axis=1)
    overlap = r[pairs[:, 0]] + r[pairs[:, 1]] - dist
    hit = overlap > 0.0
    if not hit.any():
        return 0.0
    push = (0.25 * (overlap[hit] + margin))[:, None] * d[hit] / dist[hit, None]
    move = np.zeros_like(c)
    np.add.at(move, pairs[hit, 0], -push)
    np.add.at(move, pairs[hit, 1], push)
    c += move
    return float(overlap.max())


def dense_start(start: LooseStart, drift: float = 0.05, sweeps: int = 8, margin: float = 1e-4,
                max_final_sweeps: int = 100_000) -> LooseStart:
    """The loose start settled to the bottom of its box: every sphere drifts down by `drift` x
    the smallest radius, then `sweeps` sweeps of overlap removal (_push_apart), repeated until
    the drift has carried a sphere twice down the box; then overlaps are removed to none (a gap
    of at least `margin` x the smallest radius is sought) and the box's height is set to the
    highest sphere's top, where the platen starts. A projected settling, not dynamics: it
    reaches a bounding-sphere fraction of about 0.45-0.5 (300 grains), the LAMMPS run closes
    the rest (the platen moved down with breaking switched off). Pure geometry: grains inside
    their bounding spheres never overlap."""
    r = start.radii
    rmin = float(r.min())
    c = start.centres.copy()
    open_box = np.array([start.box[0], start.box[1], np.inf])
    for _ in range(int(np.ceil(2.0 * start.box[2] / (drift * rmin)))):
        c[:, 2] -= drift * rmin
        for _ in range(sweeps):
            _push_apart(c, r, open_box, margin * rmin)
    for _ in range(max_final_sweeps):
        if _push_apart(c, r, open_box, margin * rmin) == 0.0:
            break
    else:
        raise RuntimeError(f"dense_start: overlaps left after {max_final_sweeps} sweeps")
    box = np.array([start.box[0], start.box[1], float((c[:, 2] + r).max())])
    return LooseStart(centres=c, radii=r, rotations=start.rotations, box=box, order=start.order)
