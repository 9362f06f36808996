"""bond_style breakable/cr against SPEC 2.2 Eq. 1, 2 and 5, on two atoms.

Expectations are written out here from the SPEC equations; the plugin's energy is only used
as the function whose finite-difference derivative must be its own force.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad

from driver.bpm.datafile import write_references
from driver.engine import Lammps, LammpsError

TWO23 = 2.0 ** (2.0 / 3.0)
DIRECTION = np.array([0.48, 0.6, 0.64])  # unit vector from atom 1 to atom 2
ORIGIN = np.array([-0.3, 0.2, 0.1])

SETUP = """
units lj
atom_style angle
boundary f f f
newton {newton}
comm_modify vel yes
special_bonds lj 0 1 1 coul 1 1 1
region box block -5 5 -5 5 -5 5
create_box 1 box bond/types 1 extra/bond/per/atom 4 angle/types 1 extra/angle/per/atom 6 &
    extra/special/per/atom 10
create_atoms 1 single {x1} {y1} {z1}
create_atoms 1 single {x2} {y2} {z2}
mass 1 1.0
{pair}
bond_style breakable/cr
bond_coeff 1 {coeffs}
create_bonds single/bond 1 1 2
thermo_style custom step pe ebond epair f_BREAKABLE_SPECIAL[1]
thermo_modify norm no
"""

WCA = "pair_style lj/cut 1.0\npair_coeff * * 1.0 {} 1.0\npair_modify shift yes".format(2 ** (-1 / 6))


def give_references(lmp, positions, bonds, angles=()):
    """fix breakable/references with the reference geometry (SPEC 2.2) of `positions`: the
    styles take r0 and theta0 from the input only. The file is read when the fix is defined."""
    with tempfile.TemporaryDirectory() as folder:
        path = write_references(Path(folder) / "system.refs", positions, bonds, angles)
        lmp.command(f"fix references all breakable/references {path}")


# ---------------------------------------------------------------- SPEC expectations

def f_bond(r, r0, lam, u=1.0, a=1.0):
    """SPEC 2.2 Eq. 2: bond force, positive = repulsive."""
    if r < r0:
        return 6 * TWO23 * u * r0**2 / (a**2 * r) * ((r0 / r) ** 12 - (r0 / r) ** 6)
    c1 = 36 * TWO23 * u / a**2
    c3 = -36 * TWO23 * (lam - 1) ** -2 * u * r0**-2 * a**-2
    return c1 * (r0 - r) + c3 * (r0 - r) ** 3


def e_bond(r, r0, lam, u=1.0, a=1.0):
    """Energy zero at r0 with F = -dE/dr: E(r) = integral from r to r0 of F_B."""
    val, _ = quad(f_bond, r, r0, args=(r0, lam, u, a), epsabs=1e-14, epsrel=1e-13)
    return val


def f_nonbonded(r, abar=1.0, u=1.0):
    """SPEC 2.2 Eq. 1."""
    return 12 * u / r * (abar**12 / r**12 - abar**6 / r**6) if r < abar else 0.0


def e_nonbonded(r, abar=1.0, u=1.0):
    val, _ = quad(f_nonbonded, r, abar, args=(abar, u), epsabs=1e-14, epsrel=1e-13)
    return val


# ---------------------------------------------------------------- helpers

def make_pair(lmp, r0=1.1, coeffs="1.05 0.0", pair="pair_style zero 2.0\npair_coeff * *",
              newton="on off", run=True):
    p1, p2 = ORIGIN, ORIGIN + r0 * DIRECTION
    lmp.commands(SETUP.format(x1=p1[0], y1=p1[1], z1=p1[2], x2=p2[0], y2=p2[1], z2=p2[2],
                              pair=pair, coeffs=coeffs, newton=newton))
    give_references(lmp, np.array([p1, p2]), [(0, 1)])
    if run:
        lmp.command("run 0")


def by_tag(lmp, name):
    ids = lmp.numpy.extract_atom("id")
    arr = np.array(lmp.numpy.extract_atom(name)[: len(ids)])
    return arr[np.argsort(ids)]


def place(lmp, r, v1=(0, 0, 0), v2=(0, 0, 0)):
    """Atom 2 at distance r from atom 1 along DIRECTION, with the given velocities; run 0."""
    p1, p2 = [float(c) for c in ORIGIN], [float(c) for c in ORIGIN + r * DIRECTION]
    v1, v2 = [float(c) for c in v1], [float(c) for c in v2]
    lmp.command(f"set atom 1 x {p1[0]!r} y {p1[1]!r} z {p1[2]!r} vx {v1[0]!r} vy {v1[1]!r} vz {v1[2]!r}")
    lmp.command(f"set atom 2 x {p2[0]!r} y {p2[1]!r} z {p2[2]!r} vx {v2[0]!r} vy {v2[1]!r} vz {v2[2]!r}")
    lmp.command("run 0")
    f = by_tag(lmp, "f")
    return lmp.get_thermo("ebond"), f


def broken_count(lmp):
    """f_BREAKABLE_SPECIAL[1]: global vector element 0 (style global = 0, type vector = 1)."""
    return lmp.extract_fix("BREAKABLE_SPECIAL", 0, 1, 0)


def bond_types(lmp):
    """bond_type of the single bond slot of atoms 1 and 2."""
    ids = lmp.numpy.extract_atom("id")
    bt = lmp.extract_atom("bond_type")
    nb = lmp.extract_atom("num_bond")
    out = {}
    for i, tag in enumerate(ids):
        assert nb[i] == 1
        out[int(tag)] = bt[i][0]
    return out[1], out[2]


# ---------------------------------------------------------------- force law

RATIOS = [0.9, 0.97, 1.01, 1.03, 1.049]


@pytest.mark.parametrize("coeffs,lam,u,a", [("1.05 0.0", 1.05, 1.0, 1.0),
                                            ("1.05 0.0 a 1.2 u 0.7", 1.05, 0.7, 1.2)])
def test_force_and_energy_follow_eq2(lmp, coeffs, lam, u, a):
    r0 = 1.1
    make_pair(lmp, r0, coeffs)
    for ratio in RATIOS:
        r = ratio * r0
        e, f = place(lmp, r)
        expected = f_bond(r, r0, lam, u, a)
        # force on atom 2 along the unit vector from 1 to 2 = F_B (repulsive > 0)
        np.testing.assert_allclose(f[1], expected * DIRECTION, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(f[0], -f[1], rtol=0, atol=1e-12)
        np.testing.assert_allclose(e, e_bond(r, r0, lam, u, a), rtol=1e-9, atol=1e-13)


def test_force_is_minus_derivative_of_reported_energy(lmp):
    r0, h = 1.1, 1e-6
    make_pair(lmp, r0)
    for ratio in RATIOS:
        r = ratio * r0
        _, f = place(lmp, r)
        ep, _ = place(lmp, r + h)
        em, _ = place(lmp, r - h)
        fd = -(ep - em) / (2 * h)
        assert f[1] @ DIRECTION == pytest.approx(fd, rel=1e-6, abs=1e-7)


def test_energy_and_force_vanish_at_reference_length(lmp):
    make_pair(lmp, 1.1)
    e, f = place(lmp, 1.1)
    assert abs(e) < 1e-12
    assert np.abs(f).max() < 1e-9


# ---------------------------------------------------------------- breaking

def test_breaks_just_past_lambda_c_r0(lmp):
    r0, lam = 1.1, 1.05
    make_pair(lmp, r0)
    e, f = place(lmp, lam * r0 * (1 - 1e-9))
    assert broken_count(lmp) == 0
    assert bond_types(lmp) == (1, 1)
    assert e > 0 and f[1] @ DIRECTION < 0  # still pulling back, nearly zero at lambda_c r0

    e, f = place(lmp, lam * r0 * (1 + 1e-9))
    assert broken_count(lmp) == 1
    assert bond_types(lmp) == (0, 0)
    assert e == 0.0 and np.abs(f).max() == 0.0

    # permanent, counted once, and the counter survives further runs
    e, f = place(lmp, r0)
    assert broken_count(lmp) == 1
    assert e == 0.0 and np.abs(f).max() == 0.0


def test_repulsion_acts_only_after_break(lmp):
    r0 = 1.1
    make_pair(lmp, r0, pair=WCA)
    r = 0.9  # compressed below abar = 1: bonded pairs feel no pair force
    e, f = place(lmp, r)
    assert lmp.get_thermo("epair") == 0.0
    np.testing.assert_allclose(f[1] @ DIRECTION, f_bond(r, r0, 1.05), rtol=1e-9)

    place(lmp, 1.05 * r0 * 1.001)
    assert broken_count(lmp) == 1

    e, f = place(lmp, r)
    assert e == 0.0
    assert lmp.get_thermo("epair") == pytest.approx(e_nonbonded(r), rel=1e-9)
    np.testing.assert_allclose(f[1] @ DIRECTION, f_nonbonded(r), rtol=1e-9)


def test_repulsion_switches_on_within_a_run(lmp):
    """Break mid-run and come back below abar without any reneighboring: the pair's special
    bits must be cleared in the neighbor list (pre_force path), not only at reneighboring."""
    r0 = 1.1
    make_pair(lmp, r0, pair=WCA)
    # atom 2 oscillates along the bond: r = r0 + 0.25 sin(2 pi t); breaks near r = 1.155,
    # ends (t = 0.75) at r = 0.85
    lmp.commands(f"""
        neigh_modify every 1000 delay 0 check no
        timestep 0.005
        group mover id 2
        variable d equal 0.25*sin(2*PI*time)
        variable w equal 0.25*2*PI*cos(2*PI*time)
        variable dx equal v_d*{DIRECTION[0]}
        variable dy equal v_d*{DIRECTION[1]}
        variable dz equal v_d*{DIRECTION[2]}
        variable vx equal v_w*{DIRECTION[0]}
        variable vy equal v_w*{DIRECTION[1]}
        variable vz equal v_w*{DIRECTION[2]}
        fix move mover move variable v_dx v_dy v_dz v_vx v_vy v_vz
        run 150
    """)
    x = by_tag(lmp, "x")
    r = np.linalg.norm(x[1] - x[0])
    assert r == pytest.approx(0.85, abs=1e-9)
    assert broken_count(lmp) == 1
    assert lmp.get_thermo("ebond") == 0.0
    assert lmp.get_thermo("epair") == pytest.approx(e_nonbonded(r), rel=1e-9)


# ---------------------------------------------------------------- restart

def reopen(plugin_path, restart):
    other = Lammps()
    other.command(f"plugin load {plugin_path}")
    other.commands(f"""
        read_restart {restart}
        comm_modify vel yes
        thermo_style custom step pe ebond epair
        thermo_modify norm no
    """)
    return other


def test_restart_keeps_reference_lengths_breaks_and_counts(lmp, plugin_path, tmp_path):
    r0 = 1.1
    make_pair(lmp, r0, pair=WCA)
    e_stretched, _ = place(lmp, 1.03 * r0)
    lmp.command(f"write_restart {tmp_path / 'intact.restart'}")
    place(lmp, 1.06 * r0)  # breaks
    place(lmp, r0)
    lmp.command(f"write_restart {tmp_path / 'broken.restart'}")

    other = reopen(plugin_path, tmp_path / "intact.restart")
    try:
        other.command("run 0")  # r0 comes back from the restart file (no references fix)
        assert other.get_thermo("ebond") == pytest.approx(e_stretched, rel=1e-12)
    finally:
        other.close()

    other = reopen(plugin_path, tmp_path / "broken.restart")
    try:
        other.command("run 0")
        assert broken_count(other) == 1
        assert bond_types(other) == (0, 0)
        # the special list rebuilt by read_restart must not revive the broken pair
        e, f = place(other, 0.9)
        assert e == 0.0
        assert other.get_thermo("epair") == pytest.approx(e_nonbonded(0.9), rel=1e-9)
    finally:
        other.close()


# ---------------------------------------------------------------- damping

def test_damping_force_follows_eq5(lmp):
    r0, lam, gamma = 1.1, 1.05, 50.0
    make_pair(lmp, r0, f"{lam} {gamma}")
    r = 1.03 * r0
    v1, v2 = np.array([0.3, 0.2, 0.0]), np.array([-0.1, 0.5, 0.1])
    e_damped, f = place(lmp, r, v1, v2)
    e_static, _ = place(lmp, r)
    assert e_damped == pytest.approx(e_static, rel=1e-12)  # damping is not in the energy

    rhat = -DIRECTION  # unit vector from atom 2 to atom 1
    conservative = f_bond(r, r0, lam) * rhat  # on atom 1, repulsive along rhat
    damping = -gamma * (1 - r / (lam * r0)) ** 2 * (rhat @ (v1 - v2)) * rhat
    np.testing.assert_allclose(f[0], conservative + damping, rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(f[1], -f[0], rtol=0, atol=1e-12)


# ---------------------------------------------------------------- single()

def test_single_through_compute_bond_local(lmp):
    r0 = 1.1
    make_pair(lmp, r0)
    lmp.command("compute bl all bond/local dist engpot force")
    r = 0.97 * r0
    place(lmp, r)
    dist, eng, force = lmp.numpy.extract_compute("bl", 2, 2)[0]
    assert dist == pytest.approx(r, rel=1e-12)
    assert eng == pytest.approx(e_bond(r, r0, 1.05), rel=1e-9)
    assert force == pytest.approx(f_bond(r, r0, 1.05), rel=1e-9)



def test_single_reports_the_damping_power(lmp):
    """single()'s extra value (compute bond/local b1): the power the bonded damping of Eq. 5
    dissipates, gamma w^2 (rhat . (v_i - v_j))^2, w = 1 - r / (lambda_c r0)."""
    r0, lam, gamma = 1.1, 1.05, 50.0
    make_pair(lmp, r0, f"{lam} {gamma}")
    lmp.command("compute bl all bond/local b1")
    v1, v2 = np.array([0.3, 0.2, 0.0]), np.array([-0.1, 0.5, 0.1])
    for r in (0.97 * r0, 1.03 * r0):
        place(lmp, r, v1, v2)
        power = lmp.numpy.extract_compute("bl", 2, 1)[0]
        assert power == pytest.approx(gamma * (1 - r / (lam * r0)) ** 2 * (DIRECTION @ (v1 - v2)) ** 2, rel=1e-12)


# ---------------------------------------------------------------- prerequisites

def test_init_style_requires_newton_bond_off(lmp):
    make_pair(lmp, newton="on", run=False)
    with pytest.raises(LammpsError, match="newton_bond off"):
        lmp.command("run 0")


@pytest.mark.parametrize("change,message", [
    ("special_bonds lj/coul 0 1 1", "special_bonds lj 0 1 1 coul 1 1 1"),
    ("comm_modify vel no", "comm_modify vel yes"),
])
def test_init_style_checks_prerequisites(lmp, change, message):
    make_pair(lmp, run=False)
    lmp.command(change)
    with pytest.raises(LammpsError, match=message):
        lmp.command("run 0")


@pytest.mark.parametrize("coeffs,message", [
    ("1.0 0.0", "lambda_c must be > 1"),
    ("1.05 -1", "gamma must be >= 0"),
    ("1.05 0 b 2", "unknown keyword b"),
    ("1.05 0 a", "needs a value"),
    ("1.05", "Incorrect args"),
])
def test_coeff_rejects_bad_input(lmp, coeffs, message):
    make_pair(lmp)
    with pytest.raises(LammpsError, match=message):
        lmp.command(f"bond_coeff 1 {coeffs}")
