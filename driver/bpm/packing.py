"""Disordered, jammed packings of the BPM solid in a periodic box (SPEC 2.1).

3D: monodisperse spheres of diameter a = 1. 2D: bidisperse disks of diameters 3/5 (type 1)
and 1 (type 2), number ratio large : small = (1 + sqrt 5) / 4. All masses 1.

A packing is built from uniformly random positions (numpy ``default_rng(seed)``) and relaxed
by energy minimisation in LAMMPS, in two FIRE stages:

1. harmonic contact repulsion ``E = k (abar - r)^2`` (``pair_style harmonic/cut``), whose force
   stays finite as r -> 0, so the heavy overlaps of a random start are pushed apart;
2. the non-bonded repulsion of SPEC 2.2, Eq. 1 (WCA: ``lj/cut`` with epsilon = 1,
   sigma = abar / 2^(1/6), cutoff abar, shifted), the interaction the solid is later run with.

k = 36 gives stage 1 the same contact stiffness as the WCA, U''(abar) = 72 epsilon / abar^2.
Stage 1 stops at a loose tolerance (it only has to undo the random start), stage 2 at a max
force component of 1e-6. FIRE runs with the parameters of Bitzek et al. (2006): velocity
Verlet, N_min = 5, alpha_0 = 0.1; near jamming these took about half the steps of LAMMPS's
defaults.

Default packing fractions (nominal, from the diameters; overlapping volume counted twice) sit
just above the jamming point of a quench from random positions: 2D bidisperse disks jam at
phi_J ~ 0.84, 3D monodisperse spheres at random close packing phi_J ~ 0.64. At phi_J + 0.02
every particle except rattlers is in contact, so the packing is rigid and its Delaunay network
is the contact network plus near neighbours, while the mean overlap stays near
(phi - phi_J) / (d phi_J) ~ 1 % of a diameter.

Serial LAMMPS minimisation is deterministic, so the same seed gives identical positions.

3D preparations (model.packing, driver/bpm/section.py PACKING_SCALE): `contact` is the packing
above, nearest neighbours at about a. `lj_minimum` (nearest neighbours at about 2^(1/6) a) is
the contact packing of side L / 2^(1/6) scaled by s = 2^(1/6), positions and box, radii kept
(the repulsion's diameter stays a, so no particle touches another). Scaling rather than relaxing
again with a repulsion of diameter 2^(1/6) a: that relaxation is the same problem in units of
s a, so it would give the same jammed geometry up to the scale (and the minimiser's path);
scaling gives it exactly, with the same Delaunay topology, and reuses the cached relaxation.

3D boxes may be slabs L x L x T (`thickness` T), periodic in all three directions: the thin
samples of the 3D fracture tests (driver/bpm/slab.py).
"""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from driver.bpm.section import DEFAULT_PHI, PACKING_SCALE
from driver.engine import Lammps
from runfiles.atomic import atomic_save


#: 2D bidisperse mixture (SPEC 2.1): diameters of type 1 (small) and type 2 (large).
DIAMETER_SMALL_2D = 3.0 / 5.0
DIAMETER_LARGE_2D = 1.0
#: Number ratio large : small = (1 + sqrt 5) / 4, hence the fraction of large particles.
RATIO_LARGE_SMALL_2D = (1.0 + math.sqrt(5.0)) / 4.0
FRACTION_LARGE_2D = RATIO_LARGE_SMALL_2D / (1.0 + RATIO_LARGE_SMALL_2D)
#: 3D monodisperse diameter a.
DIAMETER_3D = 1.0

#: Stage 1 contact stiffness: E = k (abar - r)^2 matches WCA's U''(abar) = 72 / abar^2 at abar = 1.
_HARMONIC_K = 36.0
_FTOL_PRE = 1e-2      # stage 1 only has to undo the deep overlaps of the random start
_FTOL = 1e-6          # max force component at convergence (min_modify norm max)
_MAXITER = 200_000


@dataclass
class Packing:
    """Particles in a periodic orthogonal box.

    positions: (N, 3) float64, wrapped into [lo, hi); z = 0 in 2D.
    radii: (N,) float64. types: (N,) int (2D: 1 small, 2 large; 3D: all 1).
    box: (lo, hi), each a (3,) float64 array; in 2D z spans [-0.5, 0.5].
    relaxation: minimiser figures (empty for a hand-built packing).
    """

    positions: np.ndarray
    radii: np.ndarray
    types: np.ndarray
    box: tuple[np.ndarray, np.ndarray]
    dimension: int
    relaxation: dict = field(default_factory=dict)

    @property
    def n(self) -> int:
        return len(self.positions)

    @property
    def lengths(self) -> np.ndarray:
        """Box edge lengths of the periodic directions, shape (dimension,)."""
        lo, hi = self.box
        return (hi - lo)[: self.dimension]

    @property
    def packing_fraction(self) -> float:
        """Nominal packing fraction: sum of particle areas (2D) or volumes (3D) over the box."""
        if self.dimension == 2:
            occupied = np.pi * np.sum(self.radii**2)
        else:
            occupied = 4.0 / 3.0 * np.pi * np.sum(self.radii**3)
        return float(occupied / np.prod(self.lengths))

    def type_diameters(self) -> dict[int, float]:
        """Diameter of each particle type, {type: diameter} (a type's particles share one radius)."""
        return {int(t): float(2 * self.radii[self.types == t][0]) for t in np.unique(self.types)}


def particle_count(dimension: int, L: float, phi: float, thickness: float | None = None,
                   preparation: str = "contact") -> int:
    """Number of particles giving nominal packing fraction phi in a box of side L (3D: L x L x
    thickness, default L); with preparation `lj_minimum`, that of the contact packing of side
    L / 2^(1/6) that is scaled to L (module docstring)."""
    s = PACKING_SCALE[preparation]
    if dimension == 2:
        f = FRACTION_LARGE_2D
        mean_area = np.pi / 4.0 * (f * DIAMETER_LARGE_2D**2 + (1.0 - f) * DIAMETER_SMALL_2D**2)
        return int(round(phi * L * L / mean_area))
    if dimension == 3:
        T = L if thickness is None else thickness
        return int(round(phi * (L / s) ** 2 * (T / s) / (np.pi / 6.0 * DIAMETER_3D**3)))
    raise ValueError(f"dimension must be 2 or 3, got {dimension}")


def make_packing(dimension: int, L: float, seed: int, phi: float | None = None,
                 thickness: float | None = None) -> Packing:
    """A relaxed, jammed periodic packing of side L (see module docstring).

    phi: nominal packing fraction; default DEFAULT_PHI[dimension]. thickness: 3D only, the z
    side of an L x L x thickness slab (default L, a cube). The particle count is
    particle_count(dimension, L, phi, thickness).
    """
    if dimension not in (2, 3):
        raise ValueError(f"dimension must be 2 or 3, got {dimension}")
    if phi is None:
        phi = DEFAULT_PHI[dimension]
    if not 0.0 < phi < 1.0:
        raise ValueError(f"packing fraction must be in (0, 1), got {phi}")
    if thickness is not None and dimension != 3:
        raise ValueError("thickness: 3D slabs only")
    T = float(L if thickness is None else thickness)
    n = particle_count(dimension, L, phi, T)
    if n < 2:
        raise ValueError(f"box of side {L} holds fewer than 2 particles at phi = {phi}")

    rng = np.random.default_rng(seed)
    if dimension == 2:
        n_large = int(round(n * FRACTION_LARGE_2D))
        types = np.ones(n, dtype=np.int64)
        types[rng.permutation(n)[:n_large]] = 2
        diameter = {1: DIAMETER_SMALL_2D, 2: DIAMETER_LARGE_2D}
        lo = np.array([0.0, 0.0, -0.5])
        hi = np.array([L, L, 0.5])
    else:
        types = np.ones(n, dtype=np.int64)
        diameter = {1: DIAMETER_3D}
        lo = np.zeros(3)
        hi = np.array([L, L, T], dtype=float)
    radii = np.array([diameter[1], diameter.get(2, 0.0)])[types - 1] / 2.0
    x = np.zeros((n, 3))
    if thickness is None:  # the draws of a square or cubic box as before slabs existed
        x[:, :dimension] = rng.uniform(0.0, L, size=(n, dimension))
    else:
        x[:, :3] = rng.uniform(0.0, 1.0, size=(n, 3)) * (hi - lo)

    positions, relaxation = _relax(x, types, diameter, lo, hi, dimension)
    return Packing(positions=positions, radii=radii, types=types, box=(lo, hi),
                   dimension=dimension, relaxation=relaxation)


def _relax(x, types, diameter, lo, hi, dimension):
    """Minimise the two-stage repulsion in LAMMPS; return wrapped positions and figures."""
    n = len(x)
    ntypes = len(diameter)
    pairs = [(i, j, 0.5 * (diameter[i] + diameter[j]))  # abar = r_i + r_j
             for i in range(1, ntypes + 1) for j in range(i, ntypes + 1)]
    cut_max = max(c for _, _, c in pairs)
    lmp = Lammps()
    try:
        lmp.commands(f"""
            units lj
            dimension {dimension}
            atom_style atomic
            boundary p p p
            region box block {lo[0]:.17g} {hi[0]:.17g} {lo[1]:.17g} {hi[1]:.17g} {lo[2]:.17g} {hi[2]:.17g}
            create_box {ntypes} box
            mass * 1.0
        """)
        lmp.create_atoms(n, list(range(1, n + 1)), types.tolist(), x.ravel().tolist())
        if lmp.get_natoms() != n:
            raise RuntimeError(f"LAMMPS created {lmp.get_natoms()} of {n} atoms")
        lmp.commands("""
            neighbor 0.3 bin
            neigh_modify every 1 delay 0 check yes
            min_style fire
            min_modify norm max integrator verlet delaystep 5 alpha0 0.1
            thermo_style custom step pe fmax
            thermo 0
            pair_style harmonic/cut
        """)
        if dimension == 2:
            lmp.command("fix twod all enforce2d")
        for i, j, abar in pairs:
            lmp.command(f"pair_coeff {i} {j} {_HARMONIC_K} {abar:.17g}")
        lmp.command(f"minimize 0.0 {_FTOL_PRE} {_MAXITER} {10 * _MAXITER}")
        steps_soft = int(lmp.extract_global("ntimestep"))
        # SPEC 2.2, Eq. 1: WCA repulsion, cut at abar where it reaches zero (shifted).
        lmp.command(f"pair_style lj/cut {cut_max:.17g}")
        lmp.command("pair_modify shift yes")
        for i, j, abar in pairs:
            lmp.command(f"pair_coeff {i} {j} 1.0 {abar / 2.0 ** (1.0 / 6.0):.17g} {abar:.17g}")
        lmp.command(f"minimize 0.0 {_FTOL} {_MAXITER} {10 * _MAXITER}")
        relaxation = {
            "steps_harmonic": steps_soft,
            "steps_wca": int(lmp.extract_global("ntimestep")) - steps_soft,
            "pe_per_atom": float(lmp.get_thermo("pe")),  # lj units normalise thermo pe by N
            "fmax": float(lmp.get_thermo("fmax")),
        }
        relaxation["converged"] = relaxation["fmax"] <= _FTOL
        if not relaxation["converged"]:
            warnings.warn(f"packing relaxation stopped at max force {relaxation['fmax']:.3g} "
                          f"> {_FTOL:g} after {_MAXITER} FIRE steps", RuntimeWarning, stacklevel=3)
        ids = np.array(lmp.numpy.extract_atom("id"), dtype=np.int64)
        pos = np.array(lmp.numpy.extract_atom("x"), dtype=np.float64)
    finally:
        lmp.close()
    out = np.empty((n, 3))
    out[ids - 1] = pos[: len(ids)]
    L = hi - lo
    out[:, :dimension] = lo[:dimension] + np.mod(out[:, :dimension] - lo[:dimension], L[:dimension])
    # np.mod can round a tiny negative offset up to exactly L: fold it back onto lo
    edge = out[:, :dimension] >= hi[:dimension]
    out[:, :dimension][edge] = np.broadcast_to(lo[:dimension], out[:, :dimension].shape)[edge]
    if dimension == 2:
        out[:, 2] = 0.0
    return out, relaxation


def scaled_packing(packing: Packing, s: float) -> Packing:
    """The packing with positions and box multiplied by s, radii kept (the `lj_minimum`
    preparation, module docstring). In 2D z stays as it is."""
    lo, hi = (np.asarray(b, float).copy() for b in packing.box)
    x = packing.positions.copy()
    d = packing.dimension
    x[:, :d] *= s
    lo[:d] *= s
    hi[:d] *= s
    relaxation = {**packing.relaxation, "scale": s}
    return Packing(positions=x, radii=packing.radii.copy(), types=packing.types.copy(), box=(lo, hi),
                   dimension=d, relaxation=relaxation)


def cached_packing(cache_dir: str | Path, dimension: int, L: float, seed: int, phi: float | None = None,
                   preparation: str = "contact", thickness: float | None = None) -> Packing:
    """The packing of a run: `make_packing`, read from `cache_dir` when this (dimension, L,
    thickness, seed, phi) was built before; with preparation `lj_minimum` (3D), the contact
    packing of side L / 2^(1/6) (cached under that side, a key no contact run of side L shares)
    scaled to side L.

    Relaxing a 3D packing of 30,000 particles takes minutes; a sweep over bond parameters on the
    same packing should pay it once. The file is written atomically.
    """
    if preparation != "contact":
        if dimension != 3:
            raise ValueError(f"preparation {preparation!r}: 3D only")
        s = PACKING_SCALE[preparation]
        base = cached_packing(cache_dir, dimension, L / s, seed, phi, "contact",
                              None if thickness is None else thickness / s)
        return scaled_packing(base, s)
    phi_val = DEFAULT_PHI[dimension] if phi is None else phi
    cache_dir = Path(cache_dir)
    shape = f"L{L:.12g}" if thickness is None else f"L{L:.12g}x{thickness:.12g}"
    path = cache_dir / f"packing_d{dimension}_{shape}_s{seed}_phi{phi_val:.12g}.npz"
    if path.exists():
        with np.load(path) as z:
            return Packing(positions=z["positions"], radii=z["radii"], types=z["types"],
                           box=(z["lo"], z["hi"]), dimension=dimension,
                           relaxation=json.loads(str(z["relaxation"])))
    pack = make_packing(dimension, L, seed, phi, thickness)
    atomic_save(path, lambda tmp: np.savez(tmp, positions=pack.positions, radii=pack.radii, types=pack.types,
                                            lo=pack.box[0], hi=pack.box[1],
                                            relaxation=json.dumps(pack.relaxation, default=float)))
    return pack
