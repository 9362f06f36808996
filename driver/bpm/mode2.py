"""BPM mode-II toughness test (SPEC 2.3): a fully periodic sample with an elliptic void at 45
degrees under pure shear, breakable bonds only in a thin band along the void; in 3D a thin
slab, periodic in x, y and z, the void a cylinder through it.

Sample. The periodic packing of the run (driver/bpm/packing.py) and its Delaunay network
(driver/bpm/network.py), periodic bonds kept; in 3D the periodic slab L x L x T of
driver/bpm/slab.py (T the scenario's `thickness`; SPEC 2.3: "a thin periodic third dimension"),
kept periodic in all three directions. The void: an ellipse of full axes
(void_axes[0], void_axes[1]) centred in the box, its major axis at VOID_ANGLE = 45 degrees from
+x, halfway between the tensile (x) and compressive (y) directions; the particles whose centre
lies inside it are removed, and every bond whose segment (minimum image) meets the ellipse is
deleted, with the angles that have it as an arm (SPEC 2.1: an angle exists only on two intact
bonds). The geometry is mode1's (driver/bpm/cuts.py) with the ellipse rotated. In 3D every test
is on the (x, y) projection (positions, bond segments, midpoints): the void is an elliptic
cylinder along z through the slab, and the band below a slab through it, so that the sample,
and the crack it grows, are the same in every z plane (a through-thickness crack whose front
runs along z).

Band. In a square periodic box of side L the line through the box centre at 45 degrees closes
on itself after L sqrt(2) (it runs through the box corners); its periodic images are the
parallel lines at perpendicular offsets k L / sqrt(2). The band is the strip of full width
`band_width` around that periodic line, across the whole box, so a crack from either tip can
run along the diagonal until it meets the void's periodic image: the sample then slides along
a through crack and tau falls (the normal stress on the 45-degree planes, (sigma_xx + sigma_yy)
/ 2, is zero under pure shear, so the crack faces do not lock by friction). A bond is in the band
when its midpoint (minimum image) is. Only the band's bonds can break.

Bond and angle types. Type 1: the band's bonds, and the angles whose two arms are band bonds,
with the material's coefficients (lambda_c, gamma; k_A, theta_c, lambda_c). Type 2: all other
bonds and angles, made unbreakable within the plugin's per-type coefficients
(plugins/doc/bond_breakable_cr.md, angle_breakable_cr.md), which have no switch to turn breaking
off and are not to be changed here:

- bonds: lambda_c' = UNBREAKABLE_LAMBDA = 1.5, a stretch no bond outside the band reaches at the
  strains of the test (a few per cent). Eq. 2's cubic term then scales by (eps_c / eps_c')^2 =
  (0.05 / 0.5)^2 = 1 %: the type-2 bonds are linear springs of the same stiffness C1 (the
  band's bonds soften by (eps / eps_c)^2, 4 % at 1 % stretch). The bonded damping of Eq. 5,
  gamma (1 - r / (lambda_c r0))^2, would grow from 0.0023 gamma to 0.11 gamma at r0 with
  lambda_c': gamma' = gamma ((1 - 1/lambda_c) / (1 - 1/lambda_c'))^2 gives the same damping at
  r0 (it then varies less with r than the band's).
- angles: theta_c' = 180 degrees (the plugin's largest; the cubic term of Eq. 3 is
  (dtheta / pi)^2 of the linear one) and lambda_c' in S of Eq. 4 (S = 1 to 1 % at the test's
  stretches). An angle with one band arm still breaks with that arm (the plugin breaks the
  angles on a broken bond).

Load. Pure shear of the periodic box at constant area (as SPEC 2.4 in 2D): x at true rate
+edot, y at -edot, positions remapped affinely (fix deform ... remap x); strain eps = edot t.
In 3D the same deformation with z held fixed (fix deform leaves the z edge as it is): plane
strain, eps_zz = 0, so the slab carries sigma_zz (about nu (sigma_xx + sigma_yy), near zero under
pure shear), which does not enter tau.
Stress: the pressure tensor (virial + kinetic) over the box area (3D: the box volume L^2 T),
void included, sigma = -p; the shear stress on the 45-degree planes, the crack's plane among them,
is tau = (sigma_xx - sigma_yy) / 2 = (p_yy - p_xx) / 2 (analysis/mode2.py gives K_IIC from its peak).
"""

from __future__ import annotations

import math
import time

import numpy as np

from driver.bpm.cuts import inside_ellipse, keep_subnetwork, segment_meets_ellipse
from driver.bpm.datafile import write_data
from driver.bpm.input_blocks import SYSTEM_FRESH, SYSTEM_RESUME, comm_cutoff, common_values, pair_coeff_lines
from driver.bpm.network import Network
from driver.bpm.packing import Packing
from driver.bpm.slab import fracture_sample
from driver.runner import ProgressSpec
from driver.schedule import chunk_steps, segments, total_steps, write_session
from driver.templates import render
from runfiles.atomic import atomic_write_json
from runfiles.records import MODE2_RECORD

#: The void's major axis from +x (radians): halfway between the tensile x and compressive y axes.
VOID_ANGLE = math.pi / 4.0
#: lambda_c of the unbreakable bonds and angles (module docstring).
UNBREAKABLE_LAMBDA = 1.5
#: theta_c of the unbreakable angles, degrees: the largest the plugin accepts.
UNBREAKABLE_THETA_DEG = 180.0


def min_image(d: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """Separations (N, 2) wrapped to the nearest periodic image of a box of edges `lengths`."""
    return d - lengths * np.round(d / lengths)


def band_offset(points: np.ndarray, centre: np.ndarray, L: float) -> np.ndarray:
    """Signed perpendicular distance of points (N, >= 2) from the nearest image of the periodic
    45-degree line through `centre` in a square box of side L: the images lie at offsets
    k L / sqrt(2) (shifting by a box edge (L, 0) or (0, L) moves the line by -+L / sqrt(2)), so the
    offset along the normal (-1, 1) / sqrt(2) is wrapped to [-L / (2 sqrt 2), L / (2 sqrt 2))."""
    d = np.asarray(points, float)[:, :2] - centre
    s = (d[:, 1] - d[:, 0]) / math.sqrt(2.0)
    h = L / math.sqrt(2.0)
    return s - h * np.round(s / h)


def cut_periodic_void(packing: Packing, net: Network, void_axes: tuple[float, float],
                      angle: float = VOID_ANGLE) -> tuple[Packing, Network, dict]:
    """The periodic sample with its void (module docstring): the packing and network without the
    particles inside the ellipse (full axes void_axes, major axis at `angle` from +x, centred in
    the box) and the bonds meeting it (minimum image), renumbered in order; and what was removed."""
    lo, hi = (np.asarray(b, float) for b in packing.box)
    lengths = hi[:2] - lo[:2]
    centre = 0.5 * (lo[:2] + hi[:2])
    semi = 0.5 * np.asarray(void_axes, float)
    x = packing.positions[:, :2]
    # each particle at its image nearest the void (the void is well inside the box)
    near = centre + min_image(x - centre, lengths)
    inside = inside_ellipse(near, centre, semi, angle)
    b = net.bonds
    p0 = near[b[:, 0]]
    p1 = p0 + min_image(x[b[:, 1]] - x[b[:, 0]], lengths)
    crossing = segment_meets_ellipse(p0, p1, centre, semi, angle)
    touching = inside[b[:, 0]] | inside[b[:, 1]]
    sample, network, keep_angle = keep_subnetwork(packing, net, ~inside, ~crossing & ~touching)
    removed = {"particles_in_void": int(inside.sum()), "bonds_crossing_void": int((crossing | touching).sum()),
               "angles_removed": int((~keep_angle).sum())}
    return sample, network, removed


def band_types(packing: Packing, net: Network, band_width: float) -> tuple[np.ndarray, np.ndarray]:
    """Bond types (1: midpoint within band_width / 2 of the periodic 45-degree line through the
    box centre, breakable; 2: unbreakable) and angle types (1: both arms of type 1; else 2)."""
    lo, hi = (np.asarray(b, float) for b in packing.box)
    lengths = hi[:2] - lo[:2]
    if not math.isclose(lengths[0], lengths[1]):
        raise ValueError(f"the mode2 band needs a square box, got {lengths[0]:g} x {lengths[1]:g}")
    x = packing.positions[:, :2]
    b = net.bonds
    mid = x[b[:, 0]] + 0.5 * min_image(x[b[:, 1]] - x[b[:, 0]], lengths)
    in_band = np.abs(band_offset(mid, 0.5 * (lo[:2] + hi[:2]), float(lengths[0]))) < 0.5 * band_width
    n = packing.n
    band_keys = b[in_band, 0] * n + b[in_band, 1]  # bonds are stored with i < j
    a = net.angles.reshape(-1, 3)

    def arm(i: np.ndarray, j: np.ndarray) -> np.ndarray:
        return np.isin(np.minimum(i, j) * n + np.maximum(i, j), band_keys)

    angle_in_band = arm(a[:, 0], a[:, 1]) & arm(a[:, 1], a[:, 2])
    return np.where(in_band, 1, 2), np.where(angle_in_band, 1, 2)


def unbreakable_gamma(gamma: float, lambda_c: float, lambda_u: float = UNBREAKABLE_LAMBDA) -> float:
    """gamma' of the type-2 bonds: their Eq. 5 damping at r0 equals the band's (module docstring)."""
    return gamma * ((1.0 - 1.0 / lambda_c) / (1.0 - 1.0 / lambda_u)) ** 2


def style_lines(m, pair_lines: str) -> str:
    """Pair, bond and angle styles with the per-type coefficients of the module docstring."""
    gamma_u = unbreakable_gamma(m.gamma, m.lambda_c)
    return (f"pair_style      cr/repulsion\n{pair_lines}\n\n"
            f"bond_style      breakable/cr\n"
            f"bond_coeff      1 {m.lambda_c} {m.gamma}\n"
            f"bond_coeff      2 {UNBREAKABLE_LAMBDA} {gamma_u:.12g}\n"
            f"angle_style     breakable/cr\n"
            f"angle_coeff     1 {m.k_A} {m.theta_c_deg} {m.lambda_c}\n"
            f"angle_coeff     2 {m.k_A} {UNBREAKABLE_THETA_DEG} {UNBREAKABLE_LAMBDA}")


def run_mode2(cfg, rd, plugin_path) -> tuple[dict, ProgressSpec]:
    """Build the sample, write the inputs and schedule; returns (system facts, progress)."""
    t0 = time.perf_counter()
    m, sc = cfg.model, cfg.scenario
    # the unit's check (driver/scenarios/bpm_calibrate.py) has refused a sample without the void;
    # 2D: the run's periodic packing, 3D: the periodic slab of sc.thickness
    packing, net = fracture_sample(cfg, sc.thickness)
    sample, network, removed = cut_periodic_void(packing, net, tuple(sc.void_axes))
    btypes, atypes = band_types(sample, network, sc.band_width)
    write_data(rd.root / "system.data", sample, network, bond_type=btypes, angle_type=atypes)
    lo, hi = (np.asarray(b, float) for b in packing.box)
    centre = 0.5 * (lo + hi)
    types = sample.type_diameters()
    pair_lines, max_abar = pair_coeff_lines(types, m.gamma)
    steps = total_steps(sc.max_shear_strain, sc.strain_rate, m.timestep)
    # ghosts reach both arms of a band angle (comm_cutoff); the type-2 bonds never stretch that far
    common = common_values(cfg, plugin_path, comm_cutoff(m, float(np.max(network.r0)), max_abar), sc.thermo_every,
                           MODE2_RECORD, strain_rate=f"{sc.strain_rate:.12g}")
    setup = render("bpm_mode2.in", role="Fresh start from system.data (setup.lammps; in.lammps runs it whole).",
                   system=SYSTEM_FRESH.format(dimension=m.dimension, boundary="p p p"),
                   styles=style_lines(m, pair_lines), record_target="file thermo.dat", start="run             0",
                   **common)
    resume = render("bpm_mode2.in", role="Start from a checkpoint (resume.lammps: -var checkpoint FILE).",
                    system=SYSTEM_RESUME, styles="# styles and coefficients: from the checkpoint",
                    record_target="append thermo.dat", start="", **common)
    chunk = chunk_steps("bpm", sample.n, cfg.execution.chunk_steps)
    schedule = segments(steps, chunk, {})
    L = float(hi[0] - lo[0])
    system = {
        "n_particles": int(sample.n), "n_bonds": int(network.n_bonds), "n_angles": int(network.n_angles),
        "band_bonds": int(np.sum(btypes == 1)), "band_angles": int(np.sum(atypes == 1)),
        "max_r0": float(np.max(network.r0)), "type_diameters": types, **removed,
        "void_centre": centre[:2].tolist(), "void_semi_axes": (0.5 * np.asarray(sc.void_axes, float)).tolist(),
        "void_angle_deg": math.degrees(VOID_ANGLE), "band_width": sc.band_width, "box_length": L,
        "crack_period": L * math.sqrt(2.0), "strain_rate": sc.strain_rate,
        **({"thickness": float(hi[2] - lo[2])} if m.dimension == 3 else {}),
        "unbreakable_lambda_c": UNBREAKABLE_LAMBDA, "unbreakable_theta_c_deg": UNBREAKABLE_THETA_DEG,
        "unbreakable_gamma": unbreakable_gamma(m.gamma, m.lambda_c),
        "total_steps": steps, "chunk_steps": schedule["chunk"], "build_seconds": time.perf_counter() - t0}
    atomic_write_json(rd.root / "system.json", system)
    write_session(rd.root, setup, resume, schedule, cfg.execution.checkpoint_steps())
    return system, progress_spec(cfg, system)


def progress_spec(cfg, system: dict) -> ProgressSpec:
    """The progress fields of a mode-II run: the shear stress and the bonds broken."""
    return ProgressSpec(file="thermo.dat", total_steps=system["total_steps"], label=cfg.name,
                        columns={"tau": MODE2_RECORD.column("tau"),
                                 "broken": MODE2_RECORD.column("bonds_broken")})
