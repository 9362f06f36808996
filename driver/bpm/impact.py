"""BPM particle impact on a rigid plane (SPEC 1.4, 3): clip, bond, place, run to a settled outcome.

The particle: the run's jammed packing (cached; side from the parent, driver/bpm/clipped.py)
clipped to the parent shape (model.particle: shape, diameter, diameter_kind, as the BCM), its
Delaunay bonds and angles between kept particles (SPEC 2.1), its Voronoi cells clipped to the
parent (bond areas, particle volumes). Oriented at random (random axis and angle from the seed,
driver/bcm/placement.py, the BCM's stream [seed, 1]) about its centroid, then lifted so its
lowest sphere (radius a/2) is `gap` diameters above the plane z = 0, and given v_0 towards it.

Units. LAMMPS runs in LJ units (a = m = u = 1, the plugins' units); model.particle.units give
them in SI (tau = a sqrt(m / u)). Converted here: v_0 (m/s) -> v_0 tau / a; times (s) -> / tau;
the plane's k_n, k_t (N/m) -> k a^2 / u. The analysis converts the measures back to SI.

The plane: LAMMPS's `fix wall/gran granular` with a Hooke normal spring, the damping of SPEC 1.2
Eq. 1-2 (2 alpha sqrt(k_n m) v_n with the particle's mass: `damping mass_velocity`, eta =
2 alpha sqrt(k_n / m)), f_n clamped at >= 0 (`limit_damping`), a tangential spring with history
and Coulomb's cap mu f_n (`linear_history`, no tangential damping); each particle touches it as
a sphere of diameter a (contact radius a / 2, the atoms' radius). Point particles do not
rotate (`fix nve`): the friction's torque is not integrated.
"""

from __future__ import annotations

import io
import math
import time
from pathlib import Path

import numpy as np

from driver.bcm.placement import random_rotation
from driver.bpm.clipped import box_side, clip_packing, parent_in_a, voronoi_cells
from driver.bpm.datafile import write_references
from driver.bpm.input_blocks import SYSTEM_RESUME, comm_cutoff, common_values, periodic_dumps, styles, write_dumps
from driver.bpm.network import Network, delaunay_network, repulsion_at_break
from driver.bpm.packing import cached_packing
from driver.cache import cache_base
from driver.runner import ProgressSpec
from driver.schedule import chunk_steps, settle, settle_windows, write_session
from driver.templates import render
from runfiles.atomic import atomic_save, atomic_write_json
from runfiles.records import BPM_IMPACT_RECORD

# the plane has "loaded" the particle once it has given back this fraction of the incoming
# momentum (the BCM impact's rule, driver/bcm/impact.py)
LOADED_FRACTION = 0.5
#: the input's running integrals and the powers they integrate (lammps_inputs/bpm_impact.in),
#: saved with each checkpoint and restored as the base a resumed run adds to (its first sample,
#: the checkpoint's step, is the saved power, taken off)
INTEGRALS = ("wall_work", "damp_pair", "damp_bond", "wall_pw", "damp_pair_pw", "damp_bond_pw")
#: particle diameter and mass in LJ units (SPEC 2.1, 3D)
DIAMETER = 1.0


def alpha_of(en2: float) -> float:
    """SPEC 1.2, Eq. 2: alpha = -ln(e_n) / sqrt(ln(e_n)^2 + pi^2), alpha = 1 at e_n = 0."""
    if en2 <= 0.0:
        return 1.0
    ln_e = 0.5 * math.log(en2)
    return -ln_e / math.sqrt(ln_e ** 2 + math.pi ** 2)


def lj_units(units) -> dict:
    """a (m), m (kg), u (J), tau (s) of a model.particle.units section."""
    a, m, u = units.length_a_m, units.mass_m_kg, units.energy_u_J
    return {"a": a, "m": m, "u": u, "tau": a * math.sqrt(m / u)}


def plane_law(contact, un: dict) -> dict:
    """The plane's contact law in LJ units: k_n, k_t (k a^2 / u), eta = 2 alpha sqrt(k_n / m)
    (m = 1), mu; and its period 2 pi sqrt(m / k_n) (a sphere on the plane)."""
    kn = contact.kn * un["a"] ** 2 / un["u"]
    kt = contact.kt * un["a"] ** 2 / un["u"]
    return {"kn": kn, "kt": kt, "eta_n": 2.0 * alpha_of(contact.en2) * math.sqrt(kn), "mu": contact.mu,
            "alpha": alpha_of(contact.en2), "period": 2.0 * math.pi / math.sqrt(kn)}


def plane_law_args(law: dict, clamp: bool = True) -> str:
    """The contact law of plane_law as the `granular` arguments of `fix wall/gran` (module
    docstring); `fix wall/gran/region` takes the same ones (one parser, FixWallGran's
    constructor: the BPM platen, driver/bpm/platen.py). clamp=False drops `limit_damping`
    (f_n may pull: the plain spring-dashpot, for tests only)."""
    return (f"granular hooke {law['kn']:.12g} {law['eta_n']:.12g} "
            f"tangential linear_history {law['kt']:.12g} 0.0 {law['mu']:.12g} damping mass_velocity"
            f"{' limit_damping' if clamp else ''}")


def plane_fix(law: dict, group: str = "all", fix_id: str = "plane", clamp: bool = True) -> str:
    """The plane z = 0 as `fix wall/gran` (module docstring) with the law of plane_law; its
    per-atom output (`contacts`): [1] touching, [2-4] the plane's force on the particle.
    clamp=False drops `limit_damping` (plane_law_args)."""
    return f"fix             {fix_id} {group} wall/gran {plane_law_args(law, clamp)} zplane 0.0 NULL contacts"


def write_sphere_data(path: Path, x: np.ndarray, net: Network, box: tuple[np.ndarray, np.ndarray],
                      grain: np.ndarray | None = None) -> None:
    """Data file for `atom_style hybrid angle sphere` (id type x y z molecule diameter density),
    diameter a, density 6 / pi (mass m = 1), molecule the particle's grain (a bed's,
    driver/bpm/bed.py; 0 for one particle); and its reference file (driver/bpm/datafile.py)."""
    n = len(x)
    lo, hi = box
    mol = np.zeros(n, dtype=int) if grain is None else np.asarray(grain, dtype=int)
    out = io.StringIO()
    out.write(f"LAMMPS data file: BPM {'particle' if grain is None else 'bed'}, {n} atoms (driver.bpm)\n\n"
              f"{n} atoms\n{net.n_bonds} bonds\n{net.n_angles} angles\n\n1 atom types\n1 bond types\n"
              "1 angle types\n\n")
    for k, ax in enumerate("xyz"):
        out.write(f"{lo[k]:.17g} {hi[k]:.17g} {ax}lo {ax}hi\n")
    out.write("\nMasses\n\n1 1.0\n\nAtoms # hybrid\n\n")
    density = 6.0 / math.pi / DIAMETER ** 3
    out.writelines(f"{i + 1} 1 {p[0]!r} {p[1]!r} {p[2]!r} {g} {DIAMETER!r} {density!r}\n"
                   for i, (p, g) in enumerate(zip(x.tolist(), mol.tolist())))
    if net.n_bonds:
        out.write("\nBonds\n\n")
        out.writelines(f"{k + 1} 1 {i + 1} {j + 1}\n" for k, (i, j) in enumerate(net.bonds.tolist()))
    if net.n_angles:
        out.write("\nAngles\n\n")
        out.writelines(f"{k + 1} 1 {i + 1} {v + 1} {j + 1}\n" for k, (i, v, j) in enumerate(net.angles.tolist()))
    atomic_save(path, lambda p: Path(p).write_text(out.getvalue()))
    write_references(path.with_suffix(".refs"), x, net.bonds, net.angles)


def write_voronoi_tables(root: Path, bonds: np.ndarray, bond_area: np.ndarray, volume: np.ndarray,
                         clipped_to: str) -> None:
    """bond_areas.txt (bond i j, 1-based ids, and its Voronoi face area, a^2) and
    particle_volumes.txt (each particle's Voronoi volume, a^3, id order) of cells clipped to
    `clipped_to` (the analysis reads them: W_f's areas, fragment volumes)."""
    atomic_save(root / "bond_areas.txt", lambda f: np.savetxt(
        f, np.column_stack([bonds + 1, bond_area]), fmt=["%d", "%d", "%.17g"],
        header=f"id1 id2 area_a2 (Voronoi face between the two particles, clipped to {clipped_to})"))
    atomic_save(root / "particle_volumes.txt", lambda f: np.savetxt(
        f, volume, fmt="%.17g", header=f"Voronoi volume of each particle (a^3, id order), clipped to {clipped_to}"))


def build_particle(cfg, seed: int, gap: float | None = None) -> dict:
    """The clipped, bonded, oriented and placed particle (LJ units) and its facts; its lowest
    sphere `gap` m above the plane (default: scenario.gap diameters, the impact's)."""
    m, p = cfg.model, cfg.model.particle
    un = lj_units(p.units)
    parent = parent_in_a(p.shape, p.diameter, p.diameter_kind, un["a"])
    L = box_side(parent, p.margin)
    packing = cached_packing(cache_base() / "packings", 3, L, seed, m.packing_fraction, m.packing or "contact")
    net = delaunay_network(packing, m.bond_max_length)
    clipped = clip_packing(packing, net, parent)
    cells = voronoi_cells(parent, clipped.positions, clipped.network.bonds)
    rotation = random_rotation(np.random.default_rng([seed, 1]))  # the BCM impact's orientation stream
    x = clipped.positions @ rotation.T
    gap = (cfg.scenario.gap * p.diameter if gap is None else gap) / un["a"]
    x[:, 2] += gap + 0.5 * DIAMETER - x[:, 2].min()
    return {"positions": x, "network": clipped.network, "cells": cells, "parent": parent, "rotation": rotation,
            "facts": clipped.facts, "units": un}


def build_system(cfg, rd, gap: float | None = None) -> dict:
    """Particle (its lowest sphere `gap` m above the plane z = 0: build_particle) -> data,
    references and bond-area files; the run's facts (system.json) but the impact's velocity
    (run_impact adds it; the crush, driver/bpm/crush.py, shares the rest)."""
    m, p, sc = cfg.model, cfg.model.particle, cfg.scenario
    t0 = time.perf_counter()
    part = build_particle(cfg, cfg.seed, gap)
    x, net, cells, un = part["positions"], part["network"], part["cells"], part["units"]
    lo = np.array([x[:, 0].min() - 2.0, x[:, 1].min() - 2.0, -1.0])
    hi = np.array([x[:, 0].max() + 2.0, x[:, 1].max() + 2.0, x[:, 2].max() + 2.0])
    write_sphere_data(rd.root / "system.data", x, net, (lo, hi))
    write_voronoi_tables(rd.root, net.bonds, cells.bond_area, cells.volume, "the parent")
    law = plane_law(p.contact, un)
    dt = min(m.timestep, law["period"] / sc.steps_per_period)
    n = len(x)
    A0 = float(cells.bond_area.sum())
    system = {
        **part["facts"], "n_particles": n, "n_bonds": int(net.n_bonds), "n_angles": int(net.n_angles),
        "max_r0": float(net.r0.max()), "units": un, "a_m": un["a"], "m_kg": un["m"], "u_J": un["u"],
        "tau_s": un["tau"], "parent_volume_a3": float(part["parent"].volume),
        "voronoi_volume_a3": float(cells.volume.sum()),
        "parent_volume_m3": float(part["parent"].volume) * un["a"] ** 3,
        "mass": n * un["m"], "density": n * un["m"] / (float(part["parent"].volume) * un["a"] ** 3),
        "A0_a2": A0, "A0": A0 * un["a"] ** 2, "bonds_without_face": cells.n_bonds_without_face,
        "rotation": part["rotation"].tolist(), "plane": law, "timestep": dt, "timestep_s": dt * un["tau"],
        "timestep_rule": (f"dt = min(model.timestep = {m.timestep:g}, 2 pi sqrt(m / k_n) / {sc.steps_per_period:g}) "
                          f"tau, k_n = {law['kn']:.6g} u/a^2"),
        "contact_radius": 0.5 * DIAMETER, "centres_z": [float(x[:, 2].min()), float(x[:, 2].max())],
        "build_seconds": time.perf_counter() - t0}
    n_in, u_max, u_sum = repulsion_at_break(net.r0, DIAMETER, m.lambda_c)
    system.update(bonds_breaking_in_repulsion=n_in, repulsion_energy_per_break_max=u_max,
                  repulsion_energy_if_all_break=u_sum, repulsion_energy_if_all_break_J=u_sum * un["u"])
    return system


SYSTEM_FRESH = """units           lj
dimension       3
boundary        m m m
atom_style      hybrid angle sphere
atom_modify     map array
# newton bond off: every atom holds all its bonds and angles (breakable styles, SPEC 2.2).
newton          on off
special_bonds   lj 0 1 1 coul 1 1 1
read_data       system.data"""


def _dump_commands(name: str) -> str:
    return write_dumps(f"dumps/atoms.{name}.lammpstrj", f"dumps/bonds.{name}.lammpstrj", 3)


def render_inputs(cfg, plugin_path: Path, system: dict) -> tuple[str, str, dict]:
    """(setup.lammps, resume.lammps, schedule) of a BPM impact run."""
    m, p, sc = cfg.model, cfg.model.particle, cfg.scenario
    un, law, dt = system["units"], system["plane"], system["timestep"]
    tau = un["tau"]
    chunk = chunk_steps("bpm", system["n_particles"], cfg.execution.chunk_steps)
    window, chunk = settle_windows(max(1, math.ceil(sc.settle_window / tau / dt)), chunk)
    max_windows = max(1, math.ceil(sc.max_time / tau / (window * dt)))
    v0 = system["velocity_lj"]
    periodic = "compute         bl all property/local batom1 batom2 btype"
    if sc.dump_every > 0:
        periodic += "\n" + periodic_dumps(3, sc.dump_every)
    # one particle type: a single repulsion pair, of cut-off DIAMETER
    common = common_values(
        cfg, plugin_path, comm_cutoff(m, system["max_r0"], DIAMETER), sc.thermo_every, BPM_IMPACT_RECORD,
        a_m=f"{un['a']:.6g}", m_kg=f"{un['m']:.6g}", u_J=f"{un['u']:.6g}", tau_s=f"{tau:.17g}",
        timestep=f"{dt:.12g}", steps_per_period=f"{sc.steps_per_period:g}", kn=f"{law['kn']:.12g}",
        kt=f"{law['kt']:.12g}", eta_n=f"{law['eta_n']:.12g}", mu=f"{law['mu']:.12g}", plane_fix=plane_fix(law),
        periodic_dumps=periodic, window_steps=window, max_windows=max_windows, ke_tolerance=sc.ke_tolerance)
    setup = render(
        "bpm_impact.in", role="Fresh start from system.data (setup.lammps; in.lammps runs it whole).",
        system=SYSTEM_FRESH, styles=styles(m, f"pair_coeff      1 1 1.0 {DIAMETER!r} {m.gamma:.12g}"),
        velocity=f"velocity        all set 0.0 0.0 {-v0!r} units box",
        record_target="file thermo.dat", step0=0,
        start=("run             0\n" + _dump_commands("start") +
               "\nvariable        nb_prev equal ${nb}\nvariable        ke_prev equal ${kin}"
               "\nvariable        loaded_prev equal 0\nvariable        reached_prev equal 0"),
        **common)
    # a resumed run carries the work integrals on from the totals saved with the checkpoint (INTEGRALS)
    resume = render(
        "bpm_impact.in", role="Start from a checkpoint (resume.lammps: -var checkpoint FILE).",
        system=SYSTEM_RESUME, styles="# pair, bond and angle styles with their coefficients: from the checkpoint",
        velocity="# velocities: from the checkpoint", record_target="append thermo.dat", step0="$(step)",
        start="# the settle rule's last values (nb_prev, ke_prev, loaded_prev, reached_prev): from the checkpoint's "
              "record", **common)
    schedule = settle(
        window, chunk, max_windows,
        check=["variable        nb_now equal ${nb}", "variable        ke_now equal ${kin}",
               f"variable        loaded_now equal \"v_loaded_prev || (vcm(all,z) >= "
               f"{-(1.0 - LOADED_FRACTION) * v0!r})\"",
               "variable        loaded_now equal ${loaded_now}",
               f"variable        reached_now equal \"v_reached_prev || (c_wall[1] > 0) || (vcm(all,z) > "
               f"{-(1.0 - 1e-6) * v0!r})\"",
               "variable        reached_now equal ${reached_now}",
               f'variable        settled equal "(v_loaded_now > 0) && (v_nb_now == v_nb_prev) && '
               f'(abs(v_ke_now - v_ke_prev) <= {sc.ke_tolerance}*v_ke_prev) && '
               f'(v_wall_energy <= {sc.ke_tolerance}*v_ke_now)"'],
        settled_variable="settled",
        advance=["variable        nb_prev equal ${nb_now}", "variable        ke_prev equal ${ke_now}",
                 "variable        loaded_prev equal ${loaded_now}", "variable        reached_prev equal ${reached_now}"],
        end=_dump_commands("end").splitlines(),
        never=("reached_now", f"the particle did not reach the plane within max_time = {sc.max_time:g} s (gap "
                          f"{sc.gap * p.diameter:g} m at {sc.velocity:g} m/s needs {sc.gap * p.diameter / sc.velocity:g} s "
                          "of flight): raise scenario.max_time"))
    return setup, resume, schedule


def run_impact(cfg, rd, plugin_path: Path):
    """Build the particle and write the run's inputs; returns (system facts, progress spec)."""
    system = build_system(cfg, rd)
    un = system["units"]
    system.update(initial_velocity=cfg.scenario.velocity, velocity_lj=cfg.scenario.velocity * un["tau"] / un["a"])
    setup, resume, schedule = render_inputs(cfg, plugin_path, system)
    system.update(window_steps=schedule["window"], chunk_steps=schedule["chunk"],
                  max_windows=schedule["max_windows"], max_steps=schedule["window"] * schedule["max_windows"])
    atomic_write_json(rd.root / "system.json", system)
    write_session(rd.root, setup, resume, schedule, cfg.execution.checkpoint_steps(),
                  checkpoint_variables=["nb_prev", "ke_prev", "loaded_prev", "reached_prev", *INTEGRALS],
                  restore_as={name: f"{name}_base" for name in INTEGRALS})
    return system, progress_spec(cfg, system)


def progress_spec(cfg, system: dict) -> ProgressSpec:
    """The progress fields of a BPM impact: the time and the bonds broken."""
    return ProgressSpec(file="thermo.dat", total_steps=system["max_steps"], label=cfg.name,
                        columns={name: BPM_IMPACT_RECORD.column(name) for name in ("time", "bonds_broken")})
