"""BPM particle impact (SPEC 1.4-1.5, 3): the packing clipped to the parent, bond areas from
the Voronoi faces, free flight, a low-velocity rebound with its energy balance, and the plane's
contact law on a single sphere.

Geometry tests take about a second each (the 2200-particle packing is cached after its first
relaxation, ~3 s); the LAMMPS tests 2-15 s each on one core.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import solve_ivp

from analysis.bpm_impact import read_bpm_impact_thermo
from driver.bcm.polyhedra import build_shape
from driver.bpm.clipped import box_side, clip_packing, face_areas_of, parent_in_a, voronoi_cells
from driver.bpm.impact import alpha_of, lj_units, plane_fix, plane_law, run_impact
from driver.bpm.network import delaunay_network
from driver.bpm.packing import cached_packing
from driver.bpm.particle_section import BPMParticle, BPMUnits
from driver.config import parse_config
from driver.engine import Lammps
from driver.pipeline import execute
from driver.cache import cache_base
from driver.rundir import RunDir

D = 2e-3
A8 = D / 8  # about 320 particles in the parent


def units(a: float) -> dict:
    """The default units' scaling rules (driver/bpm/particle_section.py) at length a."""
    return {"length_a_m": a, "mass_m_kg": 6000.0 * a ** 3 / 1.2605, "energy_u_J": 1e10 * a ** 3 / 100.0}


def impact_config(out: Path, velocity: float, max_time: float, gamma: float = 50.0, gap: float = 1e-3,
                  shape: str = "truncated_pentakis_dodecahedron", **scenario) -> dict:
    return {"name": "bpm_impact", "seed": 1,
            "model": {"kind": "bpm", "dimension": 3, "gamma": gamma,
                      "particle": {"shape": shape, "diameter": D, "units": units(A8)}},
            "scenario": {"kind": "impact", "velocity": velocity, "max_time": max_time, "gap": gap, **scenario},
            "output": {"dir": str(out), "plots": False}}


def clipped(shape: str, diameter_kind: str, a: float = A8):
    parent = parent_in_a(shape, D, diameter_kind, a)
    packing = cached_packing(cache_base() / "packings", 3, box_side(parent, 2.0), 1, 0.66)
    part = clip_packing(packing, delaunay_network(packing, 1.25), parent)
    return parent, part


# ------------------------------------------------------------------------------ geometry
@pytest.mark.lammps
@pytest.mark.parametrize("shape,kind", [("truncated_pentakis_dodecahedron", "circumscribed"),
                                        ("cube", "equal_volume")])
def test_clipped_packing_lies_inside_and_fills_the_parent(shape, kind):
    parent, part = clipped(shape, kind)
    x, bonds = part.positions, part.network.bonds
    # the parent's size follows the BCM's diameter convention, in units of a
    size = parent.circumscribed_diameter if kind == "circumscribed" else parent.equal_volume_diameter
    assert size == pytest.approx(D / A8, rel=1e-9)
    assert parent.contains(x).all()
    # bonds stay inside: points along every bond segment are in the parent
    for t in np.linspace(0.0, 1.0, 7):
        assert parent.contains(x[bonds[:, 0]] + t * (x[bonds[:, 1]] - x[bonds[:, 0]])).all()
    assert part.facts["bonds_through_images_between_kept"] == 0
    cells = voronoi_cells(parent, x, bonds)
    assert cells.volume.sum() == pytest.approx(parent.volume, rel=0.02)
    assert (cells.volume > 0).all()
    # the packing's number density times the parent's volume (a surface term off the count)
    assert len(x) == pytest.approx(6 * 0.66 / math.pi * parent.volume, rel=0.1)
    # SPEC 2.1 network, cut: about 11 bonds per particle in the bulk, fewer at the free surface
    assert 8.5 < part.network.bonds_per_particle < 11.5
    assert cells.n_bonds_without_face <= 0.02 * len(bonds)
    assert (cells.bond_area >= 0).all()


@pytest.mark.parametrize("lattice", ["sc", "fcc"])
def test_bond_areas_on_a_lattice_clipped_to_a_cube(lattice):
    """Simple cubic, spacing s: every face a square s^2. fcc, nearest distance d: the cells are
    rhombic dodecahedra of volume d^3 / sqrt 2 and inradius d / 2, so each of their 12 faces
    has area 3 V / (12 d / 2) = sqrt(2) d^2 / 4."""
    from driver.bcm.tessellation import clipped_voronoi

    n = 6 if lattice == "sc" else 4
    if lattice == "sc":
        s = 1.0
        g = (np.arange(n) + 0.5) * s
        x = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
        nn, expected, side = s, s * s, n * s
    else:
        c = math.sqrt(2.0)  # cubic cell of the fcc lattice with nearest distance 1
        basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]]) * c
        cells = np.stack(np.meshgrid(*[np.arange(n)] * 3, indexing="ij"), -1).reshape(-1, 3) * c
        x = (cells[:, None, :] + basis[None]).reshape(-1, 3) + 0.25 * c
        nn, expected, side = 1.0, math.sqrt(2.0) / 4.0, n * c
    cube = build_shape("cube", side=side)  # centred at the origin
    x = x - side / 2
    d = np.linalg.norm(x[:, None] - x[None], axis=2)
    i, j = np.nonzero(np.triu(np.isclose(d, nn), 1))
    bonds = np.column_stack([i, j])
    tess = clipped_voronoi(cube, x)
    area = face_areas_of(tess.iface_cells, tess.iface_area, bonds, len(x))
    # interior: both cells (radius sqrt(3)/2 s, resp. d / sqrt 2) clear of the cube's faces
    clear = np.all(np.abs(x) < side / 2 - 0.9 * nn, axis=1)
    interior = clear[i] & clear[j]
    assert interior.sum() > 20
    np.testing.assert_allclose(area[interior], expected, rtol=1e-9)
    assert tess.volume.sum() == pytest.approx(side ** 3, rel=1e-12)
    if lattice == "sc":
        np.testing.assert_allclose(area, expected, rtol=1e-9)  # boundary faces too: the cells are cubes


# ------------------------------------------------------------------------- LAMMPS runs
def test_free_flight_keeps_its_kinetic_energy(tmp_path, plugin_path, monkeypatch):
    """Far above the plane the bonded particle translates rigidly: no force, no break."""
    cfg = parse_config(impact_config(tmp_path / "flight", velocity=4.5, max_time=1e-3, gap=0.5))
    rd = RunDir(cfg.run_dir())
    rd.root.mkdir(parents=True)
    (rd.root / "dumps").mkdir()
    system, _ = run_impact(cfg, rd, Path(plugin_path))
    monkeypatch.chdir(rd.root)
    lmp = Lammps()
    try:
        lmp.command("include setup.lammps")
        lmp.command("run 2000")
    finally:
        lmp.close()
    th = read_bpm_impact_thermo(rd.root / "thermo.dat", system["units"])
    wk = 0.5 * system["mass"] * 4.5 ** 2
    assert th.kinetic.iloc[0] == pytest.approx(wk, rel=1e-9)
    assert np.abs(th.kinetic / wk - 1).max() < 1e-9
    assert (th.elastic.abs() < 1e-9 * wk).all()
    assert th.bonds_broken.iloc[-1] == 0 and th.angles_broken.iloc[-1] == 0
    assert th.wall_contacts.max() == 0


@pytest.fixture(scope="module")
def rebound(shared_runs, plugin_path) -> Path:
    """Read only (built once per session): a test that changes it copies it."""
    return shared_runs.get("bpm_impact_rebound", lambda out: execute(
        parse_config(impact_config(out, velocity=0.5, max_time=2e-4)), show_progress=False))


def test_low_velocity_impact_rebounds_unbroken(rebound):
    s = json.loads((rebound / "results" / "summary.json").read_text())
    assert s["broken_bonds"] == 0 and s["bonds_broken_logged"] == 0 and s["angles_broken"] == 0
    assert s["n_fragments"] == 1 and s["D_w"] == 0.0
    assert s["settled"]
    th = pd.read_parquet(rebound / "results" / "energies.parquet")
    assert th.vcm_z.iloc[-1] > 0  # going up
    assert th.wall_contacts.max() > 0 and th.wall_contacts.iloc[-1] == 0
    assert 0 < s["e_k2"] < 1
    # the loss channels, each measured: the plane's, the damping of Eq. 5 on pairs and bonds
    assert s["W_c_wall"] > 0 and s["W_c_pair_damping"] >= 0 and s["W_c_bond_damping"] > 0
    assert s["W_c_measured"] == pytest.approx(s["W_c_wall"] + s["W_c_pair_damping"] + s["W_c_bond_damping"])
    # W_k^- = W_k^+ + E_el + W_c_measured + W_f_held (nothing broke: W_f_held = 0)
    assert s["W_f_held"] == 0.0
    assert abs(s["balance_residual"]) < 1e-3, s["balance_residual"]
    assert s["W_c"] == pytest.approx(s["W_k_minus"] - s["W_k_plus"], rel=1e-12)
    frag = pd.read_parquet(rebound / "results" / "fragments.parquet").iloc[0]
    assert frag.volume == pytest.approx(json.loads((rebound / "system.json").read_text())["parent_volume_m3"],
                                        rel=1e-9)


def test_energy_balance_without_pair_damping(tmp_path, plugin_path):
    """gamma = 0: the plane is the only sink, and the particle still rings at the end (elastic
    energy left), yet the balance closes to 1e-3."""
    out = tmp_path / "undamped"
    execute(parse_config(impact_config(out, velocity=0.5, max_time=6e-5, gamma=0.0)), show_progress=False)
    s = json.loads((out / "results" / "summary.json").read_text())
    assert s["broken_bonds"] == 0
    assert s["W_c_pair_damping"] == 0.0 and s["W_c_bond_damping"] == 0.0
    assert s["W_c_wall"] > 0.01 * s["W_k_minus"]
    assert abs(s["balance_residual"]) < 1e-3, s["balance_residual"]


# ---------------------------------------------------------------- the plane on one sphere
def clamped_restitution(en2: float) -> float:
    """Rebound speed over impact speed of a mass m on the spring-dashpot of SPEC 1.2 Eq. 1-2
    (k, 2 alpha sqrt(k m)), the force clamped at >= 0: integrated independently (scipy); the
    sphere leaves when the force reaches zero (from then on nothing acts on it)."""
    k, m = 1.0, 1.0
    c = 2.0 * alpha_of(en2) * math.sqrt(k * m)

    def rhs(t, y):  # y = (overlap, overlap rate)
        return [y[1], -(k * y[0] + c * y[1]) / m]

    def released(t, y):
        return k * y[0] + c * y[1]
    released.terminal, released.direction = True, -1
    sol = solve_ivp(rhs, (0.0, 50.0), [0.0, 1.0], events=released, rtol=1e-12, atol=1e-14,
                    first_step=1e-9)
    return -float(sol.y_events[0][0][1])


def drop_sphere(en2: float, clamp: bool = True, steps_per_period: int = 1000, v0: float = 0.05) -> float:
    """Rebound speed over impact speed of one sphere of diameter a dropped on the plane_fix plane."""
    from driver.bcm.section import FrictionalContact

    un = lj_units(BPMUnits(**units(A8)))
    law = plane_law(FrictionalContact(kn=1e8, kt=8e7, en2=en2, mu=0.3), un)
    dt = law["period"] / steps_per_period
    lmp = Lammps()
    try:
        lmp.commands(f"""
            units lj
            atom_style sphere
            boundary m m m
            region box block -2 2 -2 2 -1 3
            create_box 1 box
            create_atoms 1 single 0.0 0.0 {0.5 + 2 * v0 * dt!r}
            set atom 1 diameter 1.0 mass 1.0
            velocity all set 0.0 0.0 {-v0!r}
            pair_style zero 1.0
            pair_coeff * *
            fix integrate all nve
            {plane_fix(law, clamp=clamp)}
            timestep {dt!r}
            thermo 0
            run {10 * steps_per_period}
        """)
        return float(lmp.numpy.extract_atom("v")[0, 2]) / v0
    finally:
        lmp.close()


@pytest.mark.parametrize("en2", [0.001, 0.25, 0.9])
def test_single_sphere_restitution_unclamped_is_e_n(plugin_path, en2):
    """Without the clamp the contact is the linear spring-dashpot, whose restitution is e_n
    exactly when its damping ratio is Eq. 2's alpha: the damping is 2 alpha sqrt(k_n m). 4000
    steps per period: the small rebound of e_n^2 = 0.001 is 1.4 % off at 1000 (0.3 % at 4000)."""
    assert drop_sphere(en2, clamp=False, steps_per_period=4000) == pytest.approx(math.sqrt(en2), rel=0.01)


@pytest.mark.parametrize("en2", [0.001, 0.25, 0.9])
def test_single_sphere_restitution(plugin_path, en2):
    """One sphere of diameter a dropped on the plane with the impact's law (plane_fix), 1000
    steps per contact period. The damping acts on half-step velocities and the release falls
    between steps: at the impact runs' 50 steps per period e is 4.5 % (e_n^2 = 0.001), 2.3 %
    (0.25) and 0.4 % (0.9) above the clamped law's; at 200, 3.7 %, 0.9 %, 0.05 % below; at 1000,
    within 0.2 % (measured; README, BPM impact)."""
    e = drop_sphere(en2)
    assert e == pytest.approx(clamped_restitution(en2), rel=0.01)
    if en2 >= 0.9:  # light damping: the clamp releases late, e is close to e_n
        assert e == pytest.approx(math.sqrt(en2), rel=0.02)


def test_two_dimensional_model_is_refused():
    from driver.schema import ConfigError

    cfg = impact_config(Path("/tmp/never"), velocity=1.0, max_time=1e-5)
    cfg["model"]["dimension"] = 2
    with pytest.raises((ConfigError, ValueError), match="3D only"):
        parse_config(cfg)


def test_default_particle_is_filled_in():
    cfg = impact_config(Path("/tmp/never"), velocity=1.0, max_time=1e-5)
    del cfg["model"]["particle"]
    parsed = parse_config(cfg)
    assert parsed.model.particle == BPMParticle()


def test_particle_section_is_refused_elsewhere():
    cfg = {"model": {"kind": "bpm", "dimension": 3, "particle": {}}, "scenario": {"kind": "shear"}}
    with pytest.raises((ValueError,), match="scenario impact"):
        parse_config(cfg)


def test_units_take_the_calibration_dict():
    """calibration.json `bpm.units` (driver/calibration/solve.py: BpmUnits.as_dict) fits as it is."""
    from driver.calibration.solve import BpmUnits as Calibrated

    cal = Calibrated(a=1e-4, m=5e-9, u=2e-4).as_dict()
    assert lj_units(BPMUnits(**cal))["tau"] == pytest.approx(cal["time_tau_s"], rel=1e-12)
    with pytest.raises(ValueError, match="disagrees"):
        BPMUnits(**{**cal, "time_tau_s": 2 * cal["time_tau_s"]})


@pytest.mark.mpi
def test_two_ranks_agree_with_one(rebound, tmp_path):
    """The rebound on 2 MPI ranks: the plane, the pair and bond damping integrals and the
    balance agree with the 1-rank run (measured: kinetic energy bit-identical at the end,
    bond damping to 2e-5 from the summation order)."""
    two = tmp_path / "r2"
    execute(parse_config(impact_config(two, velocity=0.5, max_time=2e-4)), np_ranks=2, show_progress=False)
    a = json.loads((rebound / "results" / "summary.json").read_text())
    b = json.loads((two / "results" / "summary.json").read_text())
    assert a["end_step"] == b["end_step"]
    assert b["W_k_plus"] == pytest.approx(a["W_k_plus"], rel=1e-9)
    for key in ("W_c_wall", "W_c_bond_damping"):
        assert b[key] == pytest.approx(a[key], rel=1e-4)
    assert abs(b["balance_residual"]) < 1e-3
    # the wheel's MPICH ran with the driver's setting (driver/mpi_launch.py), recorded with the run
    from driver.mpi_launch import settings  # noqa: PLC0415

    assert json.loads((two / "provenance.json").read_text())["mpi_settings"] == settings()


def test_interrupted_and_resumed_rebound_keeps_its_integrals(tmp_path, plugin_path):
    """SIGINT at the middle of the rebound, then --resume: the plane's work and the damping
    integrals carry on from the totals saved with the checkpoint, so the channels and the
    balance equal the uninterrupted run's."""
    import signal

    import yaml
    from test_resume import cli_run, run_and_signal

    from driver.rundir import latest_checkpoint

    cfg = impact_config(tmp_path / "unused", velocity=0.5, max_time=2e-4)
    cfg["execution"] = {"chunk_steps": 500}
    del cfg["output"]["dir"]
    path = tmp_path / "rebound.yaml"
    path.write_text(yaml.safe_dump(cfg))
    ref, out = tmp_path / "ref", tmp_path / "run"
    done = cli_run(str(path), "-o", str(ref))
    assert done.returncode == 0, done.stderr[-3000:]
    code, _, err = run_and_signal(path, out, 5000, signal.SIGINT)
    assert code == 130, err[-2000:]
    assert 0 < latest_checkpoint(out)["step"] < 10213
    resumed = cli_run(str(path), "-o", str(out), "--resume")
    assert resumed.returncode == 0, resumed.stderr[-3000:]
    a = json.loads((ref / "results" / "summary.json").read_text())
    b = json.loads((out / "results" / "summary.json").read_text())
    assert b["end_step"] == a["end_step"] and b["W_k_plus"] == pytest.approx(a["W_k_plus"], rel=1e-12)
    for key in ("W_c_wall", "W_c_bond_damping", "balance_residual"):
        assert b[key] == pytest.approx(a[key], rel=1e-9, abs=1e-15)


def test_breaking_impact_measures(tmp_path, plugin_path):
    """An impact that breaks (lambda_c 1.02 at 30 m/s): the end's bond dump and the break log
    agree (count, broken area A), W_f_held is the log's energy, fragments hold the whole mass and
    volume, the balance closes with fracture among the channels."""
    out = tmp_path / "break"
    cfg = impact_config(out, velocity=30.0, max_time=3e-5)
    cfg["model"]["lambda_c"] = 1.02
    execute(parse_config(cfg), show_progress=False)
    s = json.loads((out / "results" / "summary.json").read_text())
    system = json.loads((out / "system.json").read_text())
    assert s["broken_bonds"] > 50 and s["broken_bonds"] == s["bonds_broken_logged"]
    assert s["A_logged"] == pytest.approx(s["A"], rel=1e-12) and 0 < s["D_w"] < 1
    assert s["W_f"] == pytest.approx(2 * s["A"] * 1.0, rel=1e-12)  # G_c = 1 J/m^2 (default)
    from analysis.breaks import read_break_log

    log = read_break_log(out / "breaks.dat")
    assert s["W_f_held"] == pytest.approx(log.energy.sum() * system["u_J"], rel=1e-12) and s["W_f_held"] > 0
    frags = pd.read_parquet(out / "results" / "fragments.parquet")
    assert len(frags) == s["n_fragments"] > 1
    assert frags.mass.sum() == pytest.approx(system["mass"], rel=1e-12)
    assert frags.volume.sum() == pytest.approx(system["parent_volume_m3"], rel=1e-9)
    tol = 1e-9 * system["a_m"]  # two- and three-particle fragments: extents of zero width, to round-off
    assert (frags.a >= frags.b - tol).all() and (frags.b >= frags.c - tol).all() and (frags.c >= system["a_m"] - tol).all()
    th = pd.read_parquet(out / "results" / "energies.parquet")
    assert th.broken_area.iloc[-1] == pytest.approx(s["A"], rel=1e-12)
    assert abs(s["balance_residual"]) < 1e-3, s["balance_residual"]
