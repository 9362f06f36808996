"""Pairing the two models at equal damage potential (issue 13, `grid.omega`).

omega = W_k^- / (2 A_0 G_c) (SPEC 1.5) with W_k^- = M v_0^2 / 2, so a run reaches a target omega
at v_0 = sqrt(4 omega A_0 G_c / M). A_0 (the bonded area) and M belong to each model's particle
and change with its resolution and seed, so every (model, seed) gets its own v_0. They are
taken from the particle as the run builds it (the same cached tessellation or packing, no
LAMMPS): the run's own analysis then finds omega equal to the target, with the material's G_c
(driver/compare/stats.py common_measures).
"""

from __future__ import annotations

import math

from driver.config import RunConfig


def particle_area_mass(cfg: RunConfig) -> tuple[float, float]:
    """(A_0 in m^2, M in kg) of an impact run's particle, built as its run builds it."""
    from driver.cache import cache_base  # noqa: PLC0415

    if cfg.model.kind == "bcm":
        from driver.bcm.impact import bonded_interfaces  # noqa: PLC0415
        from driver.bcm.particle import particle_tessellation  # noqa: PLC0415

        m = cfg.model
        tess = particle_tessellation(m, cfg.seed, cache_base() / "tessellations")
        areas = tess.iface_area[bonded_interfaces(tess.iface_area, m.min_interface_area)]
        # driver/bcm/impact.py build_system: A0 over the bonded faces, M = rho_s V (particle.py)
        return float(areas.sum()), float(m.density * tess.volume.sum())
    from driver.bpm.impact import build_particle  # noqa: PLC0415

    part = build_particle(cfg, cfg.seed)
    un = part["units"]
    # driver/bpm/impact.py build_system: A0 the Voronoi faces of the bonds, M = n m
    return float(part["cells"].bond_area.sum()) * un["a"] ** 2, len(part["positions"]) * un["m"]


def velocity_for_omega(omega: float, A0: float, mass: float, G_c: float) -> float:
    """v_0 at which W_k^- / (2 A_0 G_c) = omega (module docstring)."""
    return math.sqrt(4.0 * omega * A0 * G_c / mass)
