"""angle_style breakable/cr against SPEC 2.2 Eq. 3-4, on three atoms.

The energy E = k_A S (dth^2/2 - dth^4/(4 theta_c^2)) is the integral of the torque of Eq. 3
(the style includes the radial terms from dS/dlambda, so forces are exactly -grad E).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest

from driver.bpm.datafile import write_references
from driver.engine import LammpsError

K_A, THETA_C_DEG, LAMBDA_C = 3.0, 10.0, 1.05
THETA_C = np.radians(THETA_C_DEG)
THETA0, R1_0, R2_0 = np.radians(70.0), 1.0, 1.12
VERTEX = np.array([0.1, -0.2, 0.3])
# orthonormal in-plane axes of the reference configuration (not aligned with the box)
E1 = np.array([2.0, 1.0, -2.0]) / 3.0
E2 = np.array([1.0, 2.0, 2.0]) / 3.0

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
create_atoms 1 single {p[0][0]} {p[0][1]} {p[0][2]}
create_atoms 1 single {p[1][0]} {p[1][1]} {p[1][2]}
create_atoms 1 single {p[2][0]} {p[2][1]} {p[2][2]}
mass 1 1.0
pair_style zero 3.0
pair_coeff * *
angle_style breakable/cr
angle_coeff 1 {k} {thc} {lam}
create_bonds single/angle 1 1 2 3
thermo_style custom step pe ebond eangle
thermo_modify norm no
"""

BONDS = """
bond_style breakable/cr
bond_coeff 1 {lam} 0.0
create_bonds single/bond 1 1 2
create_bonds single/bond 1 2 3
"""


# ---------------------------------------------------------------- SPEC expectations

def s_factor(l1, l2, lam=LAMBDA_C):
    """SPEC 2.2 Eq. 4."""
    eps, eps_c = max(l1, l2) - 1.0, lam - 1.0
    if eps <= 0:
        return 1.0
    return (1 - eps**2 / eps_c**2) ** 2 if eps < eps_c else 0.0


def torque(dth, s, k=K_A, thc=THETA_C):
    """SPEC 2.2 Eq. 3: magnitude k_A S (dth - dth^3 / theta_c^2)."""
    return k * s * (dth - dth**3 / thc**2)


def energy(dth, s, k=K_A, thc=THETA_C):
    """Integral of Eq. 3 over dth, zero at theta0."""
    return k * s * (dth**2 / 2 - dth**4 / (4 * thc**2))


def geometry(x):
    d1, d2 = x[0] - x[1], x[2] - x[1]
    r1, r2 = np.linalg.norm(d1), np.linalg.norm(d2)
    theta = np.arccos(np.clip(d1 @ d2 / (r1 * r2), -1, 1))
    return d1, d2, r1, r2, theta


def configuration(dth=0.0, l1=1.0, l2=1.0):
    """Positions (by tag) of atom 1, vertex 2, atom 3 for a given bend and arm stretches."""
    th = THETA0 + dth
    return np.array([VERTEX + l1 * R1_0 * E1,
                     VERTEX,
                     VERTEX + l2 * R2_0 * (np.cos(th) * E1 + np.sin(th) * E2)])


# ---------------------------------------------------------------- helpers
def give_references(lmp, positions, bonds, angles=()):
    """fix breakable/references with the reference geometry (SPEC 2.2) of `positions`: the
    styles take r0 and theta0 from the input only. The file is read when the fix is defined."""
    with tempfile.TemporaryDirectory() as folder:
        path = write_references(Path(folder) / "system.refs", positions, bonds, angles)
        lmp.command(f"fix references all breakable/references {path}")


def make_angle(lmp, newton="on off", bonds=False, k=K_A, thc=THETA_C_DEG, lam=LAMBDA_C,
               run=True):
    p = [[float(c) for c in row] for row in configuration()]
    lmp.commands(SETUP.format(p=p, newton=newton, k=k, thc=thc, lam=lam))
    if bonds:
        lmp.commands(BONDS.format(lam=lam))
    give_references(lmp, np.array(p), [(0, 1), (1, 2)] if bonds else [], [(0, 1, 2)])
    if run:
        lmp.command("run 0")


def by_tag(lmp, name):
    ids = lmp.numpy.extract_atom("id")
    arr = np.array(lmp.numpy.extract_atom(name)[: len(ids)])
    return arr[np.argsort(ids)]


def evaluate(lmp, x):
    """Energy of the angle and forces (by tag) with the atoms at x."""
    for tag, p in enumerate(x, start=1):
        p = [float(c) for c in p]
        lmp.command(f"set atom {tag} x {p[0]!r} y {p[1]!r} z {p[2]!r}")
    lmp.command("run 0")
    return lmp.get_thermo("eangle"), by_tag(lmp, "f")


def counters(lmp):
    """(bonds broken, angles broken) from fix BREAKABLE_SPECIAL's global vector."""
    return tuple(lmp.extract_fix("BREAKABLE_SPECIAL", 0, 1, i) for i in (0, 1))


def angle_types(lmp):
    ids = lmp.numpy.extract_atom("id")
    at = lmp.extract_atom("angle_type")
    na = lmp.extract_atom("num_angle")
    types = {}
    for i, tag in enumerate(ids):
        assert na[i] == 1
        types[int(tag)] = at[i][0]
    return tuple(types[t] for t in (1, 2, 3))


# (dth, l1, l2): small/large bends, arms compressed, one or the other stretched. None sits
# on l = 1 exactly, where S (C1 there, not C2) would spoil a finite difference.
CONFIGS = [
    (np.radians(2.0), 0.99, 0.995),
    (np.radians(-8.0), 0.97, 0.98),
    (np.radians(5.0), 1.03, 0.97),
    (np.radians(-6.0), 1.01, 1.04),
    (np.radians(9.5), 1.045, 1.02),
]


# ---------------------------------------------------------------- force law

@pytest.mark.parametrize("dth,l1,l2", CONFIGS)
def test_energy_follows_eq3_and_forces_are_its_gradient(lmp, dth, l1, l2):
    make_angle(lmp)
    x = configuration(dth, l1, l2)
    e, f = evaluate(lmp, x)
    assert e == pytest.approx(energy(dth, s_factor(l1, l2)), rel=1e-9, abs=1e-14)

    rng = np.random.default_rng(7)
    h = 1e-6
    scale = np.abs(f).max()
    for atom in range(3):
        for _ in range(3):
            u = rng.normal(size=3)
            u /= np.linalg.norm(u)
            xp, xm = x.copy(), x.copy()
            xp[atom] += h * u
            xm[atom] -= h * u
            fd = -(evaluate(lmp, xp)[0] - evaluate(lmp, xm)[0]) / (2 * h)
            assert f[atom] @ u == pytest.approx(fd, abs=1e-6 * scale + 1e-9)


@pytest.mark.parametrize("dth,l1,l2", CONFIGS)
def test_torque_follows_eq3(lmp, dth, l1, l2):
    make_angle(lmp)
    x = configuration(dth, l1, l2)
    _, f = evaluate(lmp, x)
    d1, d2, r1, r2, theta = geometry(x)
    u1, u2 = d1 / r1, d2 / r2
    c, s = np.cos(theta), np.sin(theta)
    t1 = -(u2 - c * u1) / s  # direction in which moving atom 1 opens the angle
    t3 = -(u1 - c * u2) / s
    expected = -torque(dth, s_factor(l1, l2))  # restoring
    assert (f[0] @ t1) * r1 == pytest.approx(expected, rel=1e-9)
    assert (f[2] @ t3) * r2 == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize("dth_deg", [25.0, -40.0, 50.0])
def test_large_bends_take_the_exact_path(lmp, dth_deg):
    """Bends beyond the kernel's polynomial range (|sin dth| >= 0.3) are evaluated exactly:
    energy per Eq. 3 and torque per Eq. 3, with theta_c = 60 degrees so they stay intact."""
    thc_deg = 60.0
    thc = np.radians(thc_deg)
    make_angle(lmp, thc=thc_deg)
    dth = np.radians(dth_deg)
    x = configuration(dth, 0.99, 0.98)
    e, f = evaluate(lmp, x)
    assert e == pytest.approx(energy(dth, 1.0, thc=thc), rel=1e-9)
    d1, d2, r1, r2, theta = geometry(x)
    u1, u2 = d1 / r1, d2 / r2
    t1 = -(u2 - np.cos(theta) * u1) / np.sin(theta)
    assert (f[0] @ t1) * r1 == pytest.approx(-torque(dth, 1.0, thc=thc), rel=1e-9)
    h = 1e-6
    for atom in range(3):
        u = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
        xp, xm = x.copy(), x.copy()
        xp[atom] += h * u
        xm[atom] -= h * u
        fd = -(evaluate(lmp, xp)[0] - evaluate(lmp, xm)[0]) / (2 * h)
        assert f[atom] @ u == pytest.approx(fd, abs=1e-6 * np.abs(f).max() + 1e-9)


def test_momentum_conservation_random_configuration(lmp):
    make_angle(lmp)
    rng = np.random.default_rng(3)
    x = configuration(np.radians(4.0), 1.035, 1.01) + rng.normal(scale=0.01, size=(3, 3))
    _, f = evaluate(lmp, x)
    _, _, r1, r2, _ = geometry(x)
    assert max(r1 / R1_0, r2 / R2_0) > 1.0  # S < 1: the radial terms are in play
    scale = np.abs(f).max()
    assert scale > 0.1
    np.testing.assert_allclose(f.sum(axis=0), 0.0, atol=1e-12 * scale)
    np.testing.assert_allclose(np.cross(x, f).sum(axis=0), 0.0, atol=1e-12 * scale)


def test_single_through_compute_angle_local(lmp):
    make_angle(lmp)
    lmp.command("compute al all angle/local theta eng")
    dth, l1, l2 = CONFIGS[2]
    evaluate(lmp, configuration(dth, l1, l2))
    theta, eng = lmp.numpy.extract_compute("al", 2, 2)[0]
    assert theta == pytest.approx(np.degrees(THETA0 + dth), rel=1e-9)
    assert eng == pytest.approx(energy(dth, s_factor(l1, l2)), rel=1e-9)


# ---------------------------------------------------------------- breaking

@pytest.mark.parametrize("sign", [1, -1])
def test_breaks_at_theta_c(lmp, sign):
    make_angle(lmp)
    e, _ = evaluate(lmp, configuration(sign * THETA_C * (1 - 1e-9)))
    assert counters(lmp) == (0, 0)
    assert angle_types(lmp) == (1, 1, 1)
    assert e == pytest.approx(energy(THETA_C, 1.0), rel=1e-6)

    e, f = evaluate(lmp, configuration(sign * THETA_C * (1 + 1e-9)))
    assert counters(lmp) == (0, 1)
    assert angle_types(lmp) == (0, 0, 0)
    assert e == 0.0 and np.abs(f).max() == 0.0

    e, f = evaluate(lmp, configuration(0.5 * sign * THETA_C))  # permanent, counted once
    assert counters(lmp) == (0, 1)
    assert e == 0.0 and np.abs(f).max() == 0.0


def test_breaks_with_its_bond_in_the_same_step(lmp):
    """The bond breaks (Eq. 2) and takes the angle with it at the end of the same step; in
    that step the angle already exerts nothing (S = 0 past lambda_c, Eq. 4)."""
    make_angle(lmp, bonds=True)
    evaluate(lmp, configuration(0.0, 1.0, LAMBDA_C * (1 - 1e-9)))
    assert counters(lmp) == (0, 0)
    assert angle_types(lmp) == (1, 1, 1)

    e, _ = evaluate(lmp, configuration(np.radians(3.0), 1.0, LAMBDA_C * (1 + 1e-9)))
    assert counters(lmp) == (1, 1)
    assert angle_types(lmp) == (0, 0, 0)
    assert e == 0.0


def test_stretched_arm_without_bond_softens_but_does_not_break(lmp):
    """Breaking by stretch is the bond's decision: with no bond style, an arm past lambda_c
    only makes S = 0 (Eq. 4): no energy, no force, and the angle acts again once the arm
    comes back."""
    make_angle(lmp)
    e, f = evaluate(lmp, configuration(np.radians(4.0), LAMBDA_C * (1 + 1e-9), 1.0))
    assert counters(lmp) == (0, 0)
    assert angle_types(lmp) == (1, 1, 1)
    assert e == 0.0 and np.abs(f).max() == 0.0
    e, _ = evaluate(lmp, configuration(np.radians(4.0), 1.0, 1.0))
    assert e == pytest.approx(energy(np.radians(4.0), 1.0), rel=1e-9)


# ---------------------------------------------------------------- prerequisites

def test_init_style_requires_newton_bond_off(lmp):
    make_angle(lmp, newton="on", run=False)
    with pytest.raises(LammpsError, match="newton_bond off"):
        lmp.command("run 0")


@pytest.mark.parametrize("coeffs,message", [
    ("3.0 0 1.05", r"theta_c must be in \(0, 180\]"),
    ("3.0 10 1.0", "lambda_c must be > 1"),
    ("-1 10 1.05", "k_A must be >= 0"),
    ("3.0 10", "Incorrect args"),
])
def test_coeff_rejects_bad_input(lmp, coeffs, message):
    make_angle(lmp, run=False)
    with pytest.raises(LammpsError, match=message):
        lmp.command(f"angle_coeff 1 {coeffs}")
