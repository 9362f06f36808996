"""The BPM platen (SPEC 4.1, driver/bpm/platen.py): one sphere of diameter a (contact radius
R = a/2, mass m = 1) squeezed between the impact's fixed plane z = 0 (plane_fix) and the platen,
both with the impact's law (plane_law, the default particle's: k_n = 6000 u/a^2, e_n^2 = 0.001).

Two springs in series. The sphere starts touching both planes (z = R, platen at h0 = 2R); the
platen comes down by s. The overlaps are delta_1 = R - z (lower) and delta_2 = z + R - h
(upper), so delta_1 + delta_2 = 2R - h = s whatever z is. Quasi-statically the sphere carries no
net force, k delta_1 + f_d1 = k delta_2 + f_d2, and both dashpots see the same overlap rate
(the sphere goes down at v_p / 2, the platen at v_p: each overlap grows at v_p / 2, the upper
one only if the platen's velocity is in the relative velocity), so delta_1 = delta_2 = s / 2 and
    F_lower = F_platen = (k / 2) s + eta m v_p / 2,
the Hooke line of the two springs in series (stiffness k k / (k + k) = k / 2), shifted by the
damping force eta m v_p / 2 = alpha sqrt(k m) v_p (SPEC 1.2 Eq. 1-2). With velocity Verlet this
is also the exact discrete solution (the sphere moves by the same v_p dt / 2 every step), reached
once the start's transient has decayed (rate alpha sqrt(2k/m)); with damping off the transient
stays: the sphere oscillates about it with the amplitude (v_p / 2) / sqrt(2k/m).

Each test runs a few thousand steps of one atom, well under a second.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from driver.bpm.impact import DIAMETER, lj_units, plane_fix, plane_law, plane_law_args
from driver.bpm.particle_section import BPMParticle
from driver.bpm.platen import plane_measures, platen_hold, platen_lines
from driver.engine import Lammps

pytestmark = pytest.mark.lammps

LMP_STYLE_ATOM, LMP_TYPE_ARRAY = 1, 2  # the library interface's constants (lammps.constants)

R = 0.5 * DIAMETER  # the atoms' radius: each touches a plane as a sphere of diameter a
H0 = 2.0 * R  # the platen starts touching the sphere resting on (touching) the lower plane
SPEED = 0.01  # a / tau: s = 0.01 a in one tau, quasi-static (v_p / sqrt(2k/m) ~ 1e-4 a)
STEPS_PER_PERIOD = 200
COLUMNS = ("z", "vz", "f_low", "f_up", "h", "work", "contact_z", "springs_low", "springs_up")


def law_with(en2: float | None = None) -> dict:
    """The impact plane's law of the default particle (e_n^2 replaced if given)."""
    p = BPMParticle()
    contact = p.contact if en2 is None else p.contact.model_copy(update={"en2": en2})
    return plane_law(contact, lj_units(p.units))


def as_read(law: dict) -> tuple[float, float]:
    """k_n and eta_n as LAMMPS reads them (plane_law_args writes 12 significant digits)."""
    return float(f"{law['kn']:.12g}"), float(f"{law['eta_n']:.12g}")


def timestep(law: dict) -> float:
    return law["period"] / STEPS_PER_PERIOD


def sphere_commands(dt: float, z: float, v=(0.0, 0.0, 0.0)) -> str:
    """One sphere of diameter a and mass 1 at (0, 0, z), velocity v, integrated by fix nve."""
    return f"""
        units           lj
        atom_style      sphere
        atom_modify     map array
        boundary        m m m
        region          box block -2 2 -2 2 -1 4
        create_box      1 box
        create_atoms    1 single 0.0 0.0 {z!r}
        set             atom 1 diameter {DIAMETER!r} mass 1.0
        velocity        all set {v[0]!r} {v[1]!r} {v[2]!r} units box
        pair_style      zero 1.0
        pair_coeff      * *
        fix             integrate all nve
        timestep        {dt!r}
        thermo          0
    """


def record_command(path: Path, names: list[str]) -> str:
    """Every step's values of the equal-style expressions `names`, to full precision."""
    return f"fix             rec all ave/time 1 1 1 {' '.join(names)} file {path} format ' %.17g'"


def read_record(path: Path, columns) -> dict:
    data = np.loadtxt(path, comments="#", ndmin=2)
    return {"step": data[:, 0].astype(int), **{c: data[:, k + 1] for k, c in enumerate(columns)}}


def squeeze(tmp_path: Path, law: dict, steps: int | list[int], hold_after: int | None = None,
            speed: float = SPEED, hold_between: bool = False, name: str = "record") -> dict:
    """The sphere between the lower plane and the platen from step 0; runs of `steps`
    (a list: several runs, `run N pre no` after the first; hold_between: the platen held with
    platen_hold after the first run). Returns every step's record (COLUMNS)."""
    path = tmp_path / f"{name}.txt"
    runs = [steps] if isinstance(steps, int) else steps
    with Lammps() as lmp:
        lmp.commands(sphere_commands(timestep(law), R))
        lmp.commands("\n".join([plane_fix(law), *plane_measures(law),
                                *platen_lines(law, "platen", H0, speed, hold_after)]))
        lmp.commands("""
            variable z equal z[1]
            variable vz equal vz[1]
            compute contact_z all reduce max f_platen[7]
        """)
        lmp.command(record_command(path, ["v_z", "v_vz", "c_plane_f[4]", "c_platen_f[4]", "v_platen_z",
                                          "v_platen_work", "c_contact_z", "c_plane_springs", "c_platen_springs"]))
        for k, n in enumerate(runs):
            if k == 1 and hold_between:
                lmp.commands("\n".join(platen_hold("platen")))
            lmp.command(f"run {n}" + (" pre no" if k else ""))
    return read_record(path, COLUMNS)


def energies(rec: dict, law: dict) -> dict:
    """Elastic energy of the two planes' springs from the overlaps (LAMMPS reports none; the
    measures' c_plane_springs and c_platen_springs are checked against it),
    full-step kinetic energy, the half-step one 1/2 m v(n-1/2) v(n+1/2) = KE - dt^2 F^2 / (8m)
    (F the sphere's total force, m = 1), and the damping's dissipation: minus the trapezoid
    work of the non-elastic parts of the two forces over the relative displacements."""
    k, _ = as_read(law)
    dt = timestep(law)
    d1 = np.clip(R - rec["z"], 0.0, None)
    d2 = np.clip(rec["z"] + R - rec["h"], 0.0, None)
    elastic_low, elastic_up = 0.5 * k * d1 ** 2, 0.5 * k * d2 ** 2
    ke = 0.5 * rec["vz"] ** 2
    force = rec["f_low"] + rec["f_up"]
    fd1 = rec["f_low"] - k * d1
    fd2 = rec["f_up"] + k * d2
    dz, dh = np.diff(rec["z"]), np.diff(rec["h"])
    trap = lambda f: 0.5 * (f[:-1] + f[1:])  # noqa: E731
    damping = np.concatenate([[0.0], -np.cumsum(trap(fd1) * dz + trap(fd2) * (dz - dh))])
    return {"elastic": elastic_low + elastic_up, "elastic_low": elastic_low, "elastic_up": elastic_up, "ke": ke,
            "ke_half": ke - dt ** 2 * force ** 2 / 8.0, "damping": damping}


def steps_to(s: float, law: dict, speed: float = SPEED) -> int:
    return math.ceil(s / (speed * timestep(law)))


# ------------------------------------------------------------------------------ (a) the Hooke line
@pytest.mark.parametrize("en2", [None, 1.0], ids=["default", "undamped"])
def test_force_follows_two_springs(tmp_path, en2):
    """Load on both planes against the platen's displacement s (module docstring): with the
    default damping, once the start's transient has gone (t > 0.3 tau, 24 decay times), both are
    (k/2) s + eta m v_p / 2 to 1e-9 (measured 2e-12), and the overlaps are s/2 each: the
    platen's velocity is in the relative velocity (without it the upper dashpot would pull and
    the shift would be 0). Undamped, both stay within the oscillation's amplitude
    k (v_p/2) / sqrt(2k/m) of (k/2) s (measured: 1.0002 times it)."""
    law = law_with(en2)
    k, eta = as_read(law)
    rec = squeeze(tmp_path, law, steps_to(0.01, law))
    s = H0 - rec["h"]
    lower, upper = rec["f_low"], -rec["f_up"]
    assert np.all(lower >= 0.0) and np.all(upper >= 0.0)
    if en2 is None:
        late = rec["step"] * timestep(law) > 0.3
        line = 0.5 * k * s[late] + 0.5 * eta * SPEED
        np.testing.assert_allclose(lower[late], line, rtol=1e-9)
        np.testing.assert_allclose(upper[late], line, rtol=1e-9)
        np.testing.assert_allclose(R - rec["z"][late], 0.5 * s[late], rtol=1e-9)
        assert 0.5 * eta * SPEED > 1e-2 * upper[-1]  # the shift is well resolved
    else:
        amplitude = k * 0.5 * SPEED / math.sqrt(2.0 * k)
        for f in (lower, upper):
            assert np.max(np.abs(f - 0.5 * k * s)) < 1.02 * amplitude
        assert np.polyfit(s, 0.5 * (lower + upper), 1)[0] == pytest.approx(0.5 * k, rel=1e-3)


# ------------------------------------------------------------------------------ (b) the work
def test_platen_work_is_the_trapezoid_over_its_displacement(tmp_path):
    """v_platen_work at every step (the running sum less the half step to come) is
    sum (F_n + F_n+1)/2 (h_n+1 - h_n) of the recorded force and height."""
    law = law_with()
    rec = squeeze(tmp_path, law, steps_to(0.005, law))
    trapezoid = np.concatenate([[0.0], np.cumsum(0.5 * (rec["f_up"][:-1] + rec["f_up"][1:]) * np.diff(rec["h"]))])
    assert rec["work"][-1] > 0.0
    np.testing.assert_allclose(rec["work"], trapezoid, rtol=1e-12, atol=1e-14 * rec["work"][-1])


@pytest.mark.parametrize("en2", [1.0, None], ids=["undamped", "default"])
def test_platen_work_balance(tmp_path, en2):
    """W_p against the energy of the sphere and of the two planes' springs, at every step.
    The springs' energy of the measures (c_plane_springs, c_platen_springs) is the one of the
    overlaps. Undamped (no slip: the load is normal): W_p = Delta(elastic + KE) to 1e-6 of W_p
    (measured 6e-9: dt^2 Delta F^2 / 8m), and exactly with the half-step kinetic energy (module
    docstring of driver/bpm/platen.py; 1e-10 asserted, 2e-14 measured). Damped: the deficit
    W_p - Delta(elastic + KE) is the damping's dissipation (1e-9 asserted, 2e-14 measured with
    the half-step KE), > 0, about eta m v_p^2 t / 2 (two dashpots at v_p / 2; measured 1.002
    times that, the start's transient)."""
    law = law_with(en2)
    k, eta = as_read(law)
    rec = squeeze(tmp_path, law, steps_to(0.01, law))
    e = energies(rec, law)
    w = rec["work"]
    total = e["elastic"] + e["ke"] - e["elastic"][0] - e["ke"][0]
    half = e["elastic"] + e["ke_half"] - e["elastic"][0] - e["ke_half"][0]
    assert w[-1] > 0.0
    for side in ("low", "up"):
        np.testing.assert_allclose(rec[f"springs_{side}"], e[f"elastic_{side}"], rtol=1e-9, atol=1e-15)
    if en2 is not None:
        assert abs(w[-1] - total[-1]) < 1e-6 * w[-1]
        np.testing.assert_allclose(w, half, rtol=0, atol=1e-10 * w[-1])
        assert np.max(np.abs(e["damping"])) < 1e-12 * w[-1]
    else:
        deficit = w - half
        np.testing.assert_allclose(deficit, e["damping"], rtol=0, atol=1e-9 * w[-1])
        assert e["damping"][-1] > 0.0
        assert abs((w - total)[-1] - e["damping"][-1]) < 1e-6 * w[-1]
        t = rec["step"][-1] * timestep(law)
        assert e["damping"][-1] == pytest.approx(0.5 * eta * SPEED ** 2 * t, rel=0.05)


# ------------------------------------------------------------------------------ (c) the same law
def upper_wall_forces(tmp_path: Path, law: dict, wall: str, z: float, v, steps: int, speed: float = 0.0):
    """One sphere against an upper plane at height 3 (no lower plane): `wall` = "zplane" (fix
    wall/gran ... zplane NULL 3, at rest) or "platen" (moving down at `speed`). Every step's
    position, velocity and the plane's force on the sphere."""
    path = tmp_path / f"{wall}.txt"
    with Lammps() as lmp:
        lmp.commands(sphere_commands(timestep(law), z, v))
        if wall == "zplane":
            lmp.command(f"fix             up all wall/gran {plane_law_args(law)} zplane NULL 3.0 contacts")
        else:
            lmp.commands("\n".join(platen_lines(law, "up", 3.0, speed)))
        names = []
        for q in ("x", "y", "z", "vx", "vy", "vz"):
            lmp.command(f"variable {q} equal {q}[1]")
            names.append(f"v_{q}")
        lmp.command("compute force all reduce sum f_up[2] f_up[3] f_up[4]")  # one sphere
        names += ["c_force[1]", "c_force[2]", "c_force[3]"]
        lmp.command(record_command(path, names))
        lmp.command(f"run {steps}")
    return read_record(path, ("x", "y", "z", "vx", "vy", "vz", "fx", "fy", "fz"))


def test_platen_at_rest_is_the_zplane_plane(tmp_path):
    """The platen at rest and `fix wall/gran ... zplane NULL h` with the same law: a sphere
    pressed 0.004 a into it, pushed towards it and sliding along it (the tangential spring reaches
    Coulomb's cap), until it has bounced off: the same forces and trajectory, to round-off
    (measured: bit-identical)."""
    law = law_with()
    args = (3.0 - R + 0.004, (0.3, -0.2, 0.05), 400)
    a = upper_wall_forces(tmp_path, law, "zplane", *args)
    b = upper_wall_forces(tmp_path, law, "platen", *args)
    touching = a["fz"] != 0.0
    assert touching[:20].all() and not touching[-20:].any()  # it bounced off
    ft, fn = np.hypot(a["fx"], a["fy"]), -a["fz"]
    assert np.any(np.isclose(ft[touching], law["mu"] * fn[touching], rtol=1e-9))  # it slid
    for q in a:
        np.testing.assert_allclose(b[q], a[q], rtol=1e-12, atol=1e-15, err_msg=q)


def test_moving_platen_is_the_plane_seen_from_the_sphere(tmp_path):
    """Galilean check of the relative velocity, normal and tangential: a sphere meeting the
    platen coming down at V has the forces of a sphere meeting the plane at rest with V added to
    its velocity (it starts 0.002 a from the plane, so the first force is one of a moving
    platen)."""
    law, V = law_with(), 0.2
    z = 3.0 - R - 0.002
    a = upper_wall_forces(tmp_path, law, "zplane", z, (0.3, -0.2, 0.1), 400)
    b = upper_wall_forces(tmp_path, law, "platen", z, (0.3, -0.2, 0.1 - V), 400, speed=V)
    assert (a["fz"] != 0.0).sum() > 50
    scale = np.max(np.abs(a["fz"]))
    for q in ("fx", "fy", "fz"):
        np.testing.assert_allclose(b[q], a[q], rtol=0, atol=1e-9 * scale, err_msg=q)


# ------------------------------------------------------------------------------ (d) the hold
def test_hold(tmp_path):
    """Held 600 steps after the start: the platen stays where it stopped (its variable and the
    contact point), its work stops growing, and the sphere relaxes to the static force
    (k/2) s_hold on both planes; the work is the springs' energy plus what the dashpots took.
    A hold decided between runs (platen_hold after 599 steps, then `run N pre no`) gives the
    same numbers."""
    law = law_with()
    k, _ = as_read(law)
    dt = timestep(law)
    rec = squeeze(tmp_path, law, 3000, hold_after=600)
    held = rec["step"] >= 600
    h_hold = H0 - SPEED * dt * 600
    assert rec["h"][held] == pytest.approx(np.full(held.sum(), h_hold), abs=1e-15)
    np.testing.assert_allclose(rec["contact_z"][held], h_hold, rtol=0, atol=1e-14)
    assert np.all(np.diff(rec["h"][~held]) < 0.0)
    np.testing.assert_allclose(rec["work"][held], rec["work"][600], rtol=1e-14)
    static = 0.5 * k * (H0 - h_hold)
    assert rec["f_low"][-1] == pytest.approx(static, rel=1e-9)
    assert -rec["f_up"][-1] == pytest.approx(static, rel=1e-9)
    assert abs(rec["vz"][-1]) < 1e-12
    e = energies(rec, law)
    assert rec["work"][-1] == pytest.approx(e["elastic"][-1] + e["ke_half"][-1] + e["damping"][-1], rel=1e-9)
    assert e["damping"][-1] > 0.0

    runtime = squeeze(tmp_path, law, [599, 2401], hold_between=True, name="runtime")
    for q in ("h", "f_low", "f_up", "work"):  # measured: bit-identical
        np.testing.assert_allclose(runtime[q], rec[q], rtol=1e-12, atol=1e-15 * static, err_msg=q)


def test_next_run_sets_up_with_the_platen_at_rest(tmp_path):
    """LAMMPS's caveat (module docstring of driver/bpm/platen.py): the set-up force of a `run`
    after the first sees the platen at rest (Region::init resets its velocity), so the platen's
    force on a sphere it loads changes by eta m v_p, the damping of its speed; with `run N pre
    no` the velocity is kept (only the set-up's full-step sphere velocity differs, O(dt))."""
    law = law_with()
    _, eta = as_read(law)
    changes = {}
    for pre in ("yes", "no"):
        with Lammps() as lmp:
            lmp.commands(sphere_commands(timestep(law), R))
            lmp.commands("\n".join([plane_fix(law), *platen_lines(law, "platen", H0, SPEED)]))
            lmp.command("run 1000")
            before = float(lmp.numpy.extract_fix("platen", LMP_STYLE_ATOM, LMP_TYPE_ARRAY)[0, 3])
            lmp.command(f"run 0 pre {pre}")
            changes[pre] = float(lmp.numpy.extract_fix("platen", LMP_STYLE_ATOM, LMP_TYPE_ARRAY)[0, 3]) - before
    assert changes["yes"] == pytest.approx(eta * SPEED, rel=1e-6)  # measured: 3e-14
    assert abs(changes["no"]) < 1e-6 * eta * SPEED  # measured: 0


def test_platen_acts_on_its_group_only(tmp_path):
    """Two spheres pressed 0.001 a into the platen at rest, the platen's fix on a group holding
    the first: the second feels nothing (the first k_n 0.001); with `all`, both feel k_n 0.001."""
    law = law_with()
    k, _ = as_read(law)
    forces = {}
    for group in ("one", "all"):
        with Lammps() as lmp:
            lmp.commands(sphere_commands(timestep(law), 3.0 - R + 0.001))
            lmp.commands("""
                create_atoms    1 single 1.5 0.0 2.501
                set             atom 2 diameter 1.0 mass 1.0
                group           one id 1
            """)
            lmp.commands("\n".join(platen_lines(law, "up", 3.0, 0.0, group=group)))
            lmp.command("run 0")
            forces[group] = lmp.numpy.extract_fix("up", LMP_STYLE_ATOM, LMP_TYPE_ARRAY)[:, 3].copy()
    np.testing.assert_allclose(forces["one"], [-k * 0.001, 0.0], rtol=1e-9, atol=0)
    np.testing.assert_allclose(forces["all"], [-k * 0.001, -k * 0.001], rtol=1e-9)
