"""BPM mode-I toughness test (SPEC 2.3): a square sample with an elliptic void, free boundaries,
pulled perpendicular to the void's major axis at a fixed rate; in 3D a thin slab, periodic in z.

The sample is the periodic packing of the run (driver/bpm/packing.py) and its Delaunay network
(driver/bpm/network.py); in 3D the periodic slab L x L x T of driver/bpm/slab.py (T the
scenario's `thickness`). It is made free in x and y by cutting it out of its periodic box: every bond
whose two ends are closer through a periodic image than directly is deleted (with the angles
on it), and LAMMPS runs in a non-periodic, shrink-wrapped box (`boundary s s p`). Then the void:
an ellipse of full axes (void_axes[0], void_axes[1]) centred in the box, major axis along x;
the particles whose centre lies inside it are removed, and every bond whose segment meets the
ellipse (interior or boundary) is deleted, with the angles that have it as an arm (SPEC 2.1: an
angle exists only on two intact bonds). In 3D the same test on the (x, y) projection cuts an
elliptic cylinder along z (SPEC 2.3: the void through the thin periodic dimension), and z stays
periodic: bonds through the z faces are kept.

Pull: the particles of two grips, strips of `grip_width` at the top and bottom of the sample,
move at +v and -v along y (fix move linear, x integrated freely: free-slip grips, so the
far field is uniaxial tension), v = edot L / 2 so that the nominal strain displacement / L grows
at edot. Stress: the force the sample exerts on the grips over the cross-section,
sigma = (F_bottom,y - F_top,y) / (2 W T), W = L the sample width; T the slab thickness in 3D,
1 in 2D (force per unit length, the units of the 2D moduli of driver/bpm/moduli.py).
"""

from __future__ import annotations

import time

import numpy as np

from driver.bpm.cuts import inside_ellipse, keep_subnetwork, segment_meets_ellipse
from driver.bpm.datafile import write_data
from driver.bpm.input_blocks import (SYSTEM_FRESH, SYSTEM_RESUME, comm_cutoff, common_values, pair_coeff_lines,
                                     styles)
from driver.bpm.network import Network
from driver.bpm.packing import Packing
from driver.bpm.slab import fracture_sample
from driver.runner import ProgressSpec
from driver.schedule import chunk_steps, segments, total_steps, write_session
from driver.templates import render
from runfiles.atomic import atomic_write_json
from runfiles.records import MODE1_RECORD


def cut_sample(packing: Packing, net: Network, void_axes: tuple[float, float] | None
               ) -> tuple[Packing, Network, dict]:
    """The free (non-periodic) sample with its void (module docstring): the packing and network
    without the removed particles, bonds and angles, renumbered in order; and what was removed.

    void_axes: full axes (x, y) of the ellipse, in a; None cuts no void."""
    lo, hi = (np.asarray(b, float) for b in packing.box)
    L = hi[:2] - lo[:2]
    x = packing.positions
    centre = 0.5 * (lo[:2] + hi[:2])
    semi = None if void_axes is None else 0.5 * np.asarray(void_axes, float)
    inside = np.zeros(packing.n, bool) if semi is None else inside_ellipse(x, centre, semi)
    b = net.bonds
    direct = x[b[:, 1], :2] - x[b[:, 0], :2]
    periodic = np.any(np.abs(direct) > 0.5 * L, axis=1)  # joined through an image
    crossing = (np.zeros(len(b), bool) if semi is None
                else segment_meets_ellipse(x[b[:, 0]], x[b[:, 1]], centre, semi) & ~periodic)
    keep_bond = ~periodic & ~crossing & ~inside[b[:, 0]] & ~inside[b[:, 1]]
    sample, network, keep_angle = keep_subnetwork(packing, net, ~inside, keep_bond)
    removed = {"particles_in_void": int(inside.sum()), "bonds_across_box": int(periodic.sum()),
               "bonds_crossing_void": int((crossing | ((inside[b[:, 0]] | inside[b[:, 1]]) & ~periodic)).sum()),
               "angles_removed": int((~keep_angle).sum())}
    return sample, network, removed


def pull_velocity(strain_rate: float, L: float) -> float:
    """Speed of each grip: the grips separate at 2 v = edot L (nominal strain rate edot)."""
    return 0.5 * strain_rate * L


def run_mode1(cfg, rd, plugin_path) -> tuple[dict, ProgressSpec]:
    """Build the sample, write the inputs and schedule; returns (system facts, progress)."""
    t0 = time.perf_counter()
    m, sc = cfg.model, cfg.scenario
    # the unit's check (driver/scenarios/bpm_calibrate.py) has refused a sample without the void
    packing, net = fracture_sample(cfg, sc.thickness)
    sample, network, removed = cut_sample(packing, net, tuple(sc.void_axes))
    # the remaining bonds are all shorter than half the box, so write_data's minimum-image
    # references equal the direct ones of the free sample
    write_data(rd.root / "system.data", sample, network)
    lo, hi = (np.asarray(b, float) for b in packing.box)
    centre = 0.5 * (lo + hi)
    types = sample.type_diameters()
    pair_lines, max_abar = pair_coeff_lines(types, m.gamma)
    v = pull_velocity(sc.strain_rate, m.L)
    steps = total_steps(sc.max_pull_strain, sc.strain_rate, m.timestep)
    y_top, y_bottom = hi[1] - sc.grip_width, lo[1] + sc.grip_width
    width = float(hi[0] - lo[0])
    # the cross-section the grips pull on: W T in 3D, W (per unit length) in 2D
    thickness = float(hi[2] - lo[2]) if m.dimension == 3 else 1.0
    common = common_values(cfg, plugin_path, comm_cutoff(m, float(np.max(network.r0)), max_abar), sc.thermo_every,
                           MODE1_RECORD, velocity=f"{v:.12g}", width=f"{width:.12g}",
                           area=f"{width * thickness:.12g}")
    groups = (f"region          top_grip block INF INF {y_top:.12g} INF INF INF\n"
              f"region          bottom_grip block INF INF INF {y_bottom:.12g} INF INF\n"
              "group           top region top_grip\ngroup           bottom region bottom_grip\n"
              "group           grips union top bottom\ngroup           sample subtract all grips")
    setup = render("bpm_mode1.in", role="Fresh start from system.data (setup.lammps; in.lammps runs it whole).",
                   system=("# free sample: shrink-wrapped in x and y, periodic z (2D requires it; 3D: the thin slab)\n"
                           + SYSTEM_FRESH.format(dimension=m.dimension, boundary="s s p")),
                   styles=styles(m, pair_lines), groups=groups,
                   record_target="file thermo.dat", start="run             0", **common)
    resume = render("bpm_mode1.in", role="Start from a checkpoint (resume.lammps: -var checkpoint FILE).",
                    system=SYSTEM_RESUME, styles="# styles and coefficients: from the checkpoint",
                    groups="# groups top, bottom, grips, sample: from the checkpoint",
                    record_target="append thermo.dat", start="", **common)
    chunk = chunk_steps("bpm", sample.n, cfg.execution.chunk_steps)
    schedule = segments(steps, chunk, {})
    system = {
        "n_particles": int(sample.n), "n_bonds": int(network.n_bonds), "n_angles": int(network.n_angles),
        "max_r0": float(np.max(network.r0)), "type_diameters": types, **removed,
        "void_centre": centre[:2].tolist(), "void_semi_axes": (0.5 * np.asarray(sc.void_axes, float)).tolist(),
        "width": width, "height": float(hi[1] - lo[1]), "grip_width": sc.grip_width,
        **({"thickness": thickness} if m.dimension == 3 else {}),
        "n_top": int(np.sum(sample.positions[:, 1] > y_top)),
        "n_bottom": int(np.sum(sample.positions[:, 1] < y_bottom)),
        "grip_velocity": v, "total_steps": steps, "chunk_steps": schedule["chunk"],
        "build_seconds": time.perf_counter() - t0}
    atomic_write_json(rd.root / "system.json", system)
    write_session(rd.root, setup, resume, schedule, cfg.execution.checkpoint_steps())
    return system, progress_spec(cfg, system)


def progress_spec(cfg, system: dict) -> ProgressSpec:
    """The progress fields of a mode-I run: the stress and the bonds broken."""
    return ProgressSpec(file="thermo.dat", total_steps=system["total_steps"], label=cfg.name,
                        columns={"stress": MODE1_RECORD.column("stress"),
                                 "broken": MODE1_RECORD.column("bonds_broken")})
