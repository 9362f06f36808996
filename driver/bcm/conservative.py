"""The LAMMPS setup of a BCM particle with every loss switched off (e_n^2 = 1 for interfaces
and contacts, mu = 0, G_c = 1e12 J/m^2: nothing damps, slides or breaks), for energy
conservation checks: the time-step study (bench/timestep_study.py) and the tests
(tests/test_bcm_impact.py, tests/test_bcm_timestep.py). Format keys: dir (the folder of
system.data, cells.txt, interfaces.txt), cutoff, rm, kn_c, kt_c, kn, kt, skin, dt. It defines
ket (translational kinetic energy); f_integrate adds the rotational part. intact_particle
writes the particle's files and gives those keys (but dt); impulse sets the cells moving."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from driver.bcm.lammps_files import read_cells, write_particle

CONSERVATIVE_SETUP = """
units           si
dimension       3
boundary        m m m
atom_style      bpm/sphere
atom_modify     map array
newton          on off
special_bonds   lj 0 1 1 coul 1 1 1
""" + read_cells("{dir}/system.data") + """
comm_modify     vel yes cutoff {cutoff!r}
pair_style      bcm/contact cells {dir}/cells.txt rm {rm!r}
pair_coeff      * * {kn_c!r} {kt_c!r} 1.0 0.0
bond_style      bcm/griffith geometry {dir}/interfaces.txt
bond_coeff      1 {kn!r} {kt!r} 1.0 1e12 {kn_c!r} {kt_c!r} 1.0 0.0
neighbor        {skin!r} bin
neigh_modify    delay 0 every 1 check yes
timestep        {dt!r}
fix             integrate all bcm/rigid
compute         ket all ke
compute         cpair all pair bcm/contact
"""


def intact_particle(work: Path, model, seed: int, rng: np.random.Generator, gap: float,
                    orient: bool = True) -> dict:
    """Writes system.data, interfaces.txt and cells.txt of the particle of `model` (a BCMModel)
    with every face glued, placed as the impact places it (lowest rounded point `gap` above the
    plane z = 0; `rng` draws the orientation, orient=False keeps the tessellation's frame).
    Returns its masses (tag order), the shortest contact period of the time-step rule and
    `setup`, the format keys of CONSERVATIVE_SETUP but dt (the impact's input settings)."""
    from driver.bcm.particle import build_particle, contact_timestep, particle_tessellation  # noqa: PLC0415
    from driver.cache import cache_base  # noqa: PLC0415

    tess = particle_tessellation(model, seed, cache_base() / "tessellations")
    part = build_particle(tess, model.density, model.rounding, rng, plane_z=0.0, gap=gap, orient=orient)
    work.mkdir(parents=True, exist_ok=True)
    write_particle(work, tess, part, np.ones(len(tess.iface_area), bool), model.diameter)
    _, period = contact_timestep(part.masses, max(model.contact.kn, model.interface.kn), 1.0)
    skin = 0.1 * tess.mean_cell_size
    setup = dict(dir=work, cutoff=float(2.0 * part.bound_radius.max() * 1.05 + skin), rm=float(part.r_m),
                 skin=float(skin), kn=model.interface.kn, kt=model.interface.kt, kn_c=model.contact.kn,
                 kt_c=model.contact.kt)
    return {"masses": part.masses, "period": period, "setup": setup}


def impulse(lmp, rng: np.random.Generator, v_rms: float) -> np.ndarray:
    """Random cell velocities of rms v_rms drawn from `rng`, less their net momentum and net
    angular momentum (the particle vibrates in place); returns the masses in atom order."""
    x = np.asarray(lmp.numpy.extract_atom("x"))[:, :3]
    m = np.asarray(lmp.numpy.extract_atom("rmass"))
    v = rng.normal(0.0, v_rms, size=(len(m), 3))
    v -= (m[:, None] * v).sum(0) / m.sum()
    r = x - (m[:, None] * x).sum(0) / m.sum()
    inertia = (m[:, None, None] * ((r * r).sum(1)[:, None, None] * np.eye(3) - r[:, :, None] * r[:, None, :])).sum(0)
    w = np.linalg.solve(inertia, (m[:, None] * np.cross(r, v)).sum(0))
    lmp.numpy.extract_atom("v")[:] = v - np.cross(w, r)
    return m
