"""bond_style bcm/griffith against SPEC 1.2 (Eq. 1-7), on two or three cube cells.

Two cubes of side A share one square face of area S = A^2, with 4 (or 6) interface points.
The whole configuration and each cell's body frame are turned by random rotations, so no
result relies on axis-aligned geometry. Expected forces, energies and break steps are written
out here from the SPEC equations with the per-point split k / N_p.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from driver.engine import Lammps, LammpsError

A = 1e-3                       # cell side, m
RHO = 6000.0                   # kg/m^3 (SPEC 1.3)
MASS = RHO * A**3
S = A * A
MOMENTS = np.array([1.0, 1.3, 1.7]) * MASS * A * A / 6  # a deliberately asymmetric inertia
KN, KT, KNC, KTC, MU = 1e7, 0.8e7, 1e8, 8e7, 0.3
MRED = MASS / 2
PERIOD = 2 * np.pi * np.sqrt(MRED / KN)  # normal vibration of the bonded pair

FRAME = Rotation.random(random_state=5)  # n = FRAME e_x, tangents FRAME e_y, FRAME e_z
N = FRAME.apply([1.0, 0.0, 0.0])
T1 = FRAME.apply([0.0, 1.0, 0.0])
T2 = FRAME.apply([0.0, 0.0, 1.0])
X1 = np.array([1e-4, -2e-4, 3e-4])
X2 = X1 + A * N

SETUP = """
units si
atom_style hybrid bond sphere
boundary f f f
newton {newton}
comm_modify vel yes
special_bonds lj/coul 0 1 1
region box block -0.01 0.01 -0.01 0.01 -0.01 0.01
create_box 1 box bond/types 1 extra/bond/per/atom 2 extra/special/per/atom 4
fix props all property/atom d2_bcm_quat 4 d2_bcm_inertia 3 d2_bcm_angmom 3 ghost yes
"""


def wxyz(rot: Rotation) -> np.ndarray:
    x, y, z, w = rot.as_quat()
    return np.array([w, x, y, z])


def fnum(value) -> str:
    return repr(float(value))


def square_points(npts: int) -> np.ndarray:
    """Vertices of the shared face (and, for 6, two mid-edge points), reference state."""
    centre = X1 + 0.5 * A * N
    uv = [(-1, -1), (1, -1), (1, 1), (-1, 1)]
    if npts == 6:
        uv += [(0, -1), (0, 1)]
    return np.array([centre + 0.5 * A * (u * T1 + v * T2) for u, v in uv])


def geometry_line(t1, t2, area, normal, points) -> str:
    nums = [area, *normal, len(points), *np.asarray(points).ravel()]
    return f"{t1} {t2} " + " ".join(str(int(v)) if i == 4 else fnum(v) for i, v in enumerate(nums))


def alpha(e2: float) -> float:
    """SPEC 1.2 Eq. 2."""
    if e2 == 0:
        return 1.0
    le = np.log(np.sqrt(e2))
    return -le / np.sqrt(le**2 + np.pi**2)


def make_cells(lmp, tmp_path, centres, faces, *, en2=1.0, gc=1e9, en2c=0.001, energy=None,
               newton="on off", geometry=None, settings="", mu=MU):
    """Cells at `centres` (random body frames), bonded through `faces` [(t1, t2, points)];
    `settings`: further bond_style keywords."""
    geo = tmp_path / "interfaces.txt"
    if geometry is None:
        lines = ["# tag1 tag2 area nx ny nz npts points"]
        for t1, t2, pts in faces:
            n = centres[t2 - 1] - centres[t1 - 1]
            lines.append(geometry_line(t1, t2, S, n / np.linalg.norm(n), pts))
        geo.write_text("\n".join(lines) + "\n")
    else:
        geo.write_text(geometry)
    lmp.commands(SETUP.format(newton=newton))
    for c in centres:
        lmp.command("create_atoms 1 single " + " ".join(fnum(v) for v in c))
    style = f"bond_style bcm/griffith geometry {geo}" + (f" energy {energy}" if energy else "") + (
        f" {settings}" if settings else "")
    lmp.commands(f"""
        mass 1 {fnum(MASS)}
        set group all mass {fnum(MASS)} diameter {fnum(2 * A)}
        pair_style zero {fnum(3 * A)}
        pair_coeff * *
        {style}
        bond_coeff 1 {KN} {KT} {en2} {gc} {KNC} {KTC} {en2c} {mu}
    """)
    for t1, t2, _ in faces:
        lmp.command(f"create_bonds single/bond 1 {t1} {t2}")
    lmp.commands("""
        compute pl all property/local batom1 batom2
        compute bl all bond/local engpot force b1 b2 b3 b4 b5 b6 b7 b8 b9 b10 b11 b12 b13
        thermo_style custom step pe ebond ke
        thermo_modify norm no
    """)
    quats = lmp.numpy.extract_atom("d2_bcm_quat")
    moments = lmp.numpy.extract_atom("d2_bcm_inertia")
    for i in range(len(centres)):
        quats[i] = wxyz(Rotation.random(random_state=20 + i))
        moments[i] = MOMENTS


def make_pair(lmp, tmp_path, npts=4, **kw):
    make_cells(lmp, tmp_path, [X1, X2], [(1, 2, square_points(npts))], **kw)


def by_tag(lmp, name):
    ids = np.array(lmp.numpy.extract_atom("id"))
    arr = np.array(lmp.numpy.extract_atom(name)[: len(ids)])
    return arr[np.argsort(ids)]


def set_by_tag(lmp, name, values):
    """Per-atom values given in atom-ID order (atoms may have been sorted by a run)."""
    ids = np.array(lmp.numpy.extract_atom("id"))
    arr = lmp.numpy.extract_atom(name)
    values = np.asarray(values)
    for row, tag in enumerate(ids):
        arr[row] = values[tag - 1]


def place(lmp, delta, v2=(0.0, 0.0, 0.0)):
    """Cell 2 displaced by `delta` from its reference position (no rotation); run 0."""
    set_by_tag(lmp, "x", [X1, X2 + np.asarray(delta)])
    set_by_tag(lmp, "v", [np.zeros(3), np.asarray(v2, dtype=float)])
    lmp.command("run 0")
    return by_tag(lmp, "f"), by_tag(lmp, "torque")


def griffith(lmp, k):
    """f_BCM_GRIFFITH[k] (1-based)."""
    return lmp.extract_fix("BCM_GRIFFITH", 0, 1, k - 1)


def interfaces(lmp):
    """Rows of (tag1, tag2, engpot, force, state, area, energy, break step, time, E at break,
    W_damp, W_damp after the break, W_friction, W_switch, slip, closed points, their f_n)."""
    tags = np.atleast_2d(lmp.numpy.extract_compute("pl", 2, 2))
    vals = np.atleast_2d(lmp.numpy.extract_compute("bl", 2, 2))
    return np.hstack([tags, vals])


# ---------------------------------------------------------------- (a) intact stiffness

@pytest.mark.parametrize("npts", [4, 6])
def test_interface_stiffness_is_the_whole_interface_k(lmp, tmp_path, npts):
    make_pair(lmp, tmp_path, npts)
    lmp.command("run 0")  # the reference geometry is taken here
    f, tq = place(lmp, np.zeros(3))
    # nothing is pre-stretched: round-off of the body-frame anchors only
    assert np.abs(f).max() < 1e-14 * KN * A and lmp.get_thermo("ebond") < KN * (1e-14 * A) ** 2

    dn, dt = 2e-7, np.array([0.0, 1.5e-7, -0.7e-7])
    dtv = dt[1] * T1 + dt[2] * T2
    f, tq = place(lmp, dn * N + dtv)
    # SPEC 1.2 Eq. 1, 3 summed over N_p points with k / N_p each: whole-interface k
    expected = -(KN * dn * N + KT * dtv)
    np.testing.assert_allclose(f[1], expected, rtol=1e-9, atol=1e-12 * KN * dn)
    np.testing.assert_allclose(f[0], -f[1], rtol=0, atol=1e-15)
    energy = 0.5 * KN * dn**2 + 0.5 * KT * dtv @ dtv
    assert lmp.get_thermo("ebond") == pytest.approx(energy, rel=1e-9)
    assert griffith(lmp, 5) == pytest.approx(energy, rel=1e-9)
    assert (griffith(lmp, 1), griffith(lmp, 2)) == (1.0, 0.0)
    # every point carries the same force: torque on cell 2 about its centre
    arms = square_points(npts) + dn * N + dtv - (X2 + dn * N + dtv)
    np.testing.assert_allclose(tq[1], np.cross(arms, expected / npts).sum(0), rtol=1e-9,
                               atol=1e-12 * KN * dn * A)
    # no net torque about any point: angular momentum is conserved
    x = by_tag(lmp, "x")
    total = np.cross(x, f).sum(0) + tq.sum(0)
    assert np.abs(total).max() < 1e-12 * KN * dn * A

    # single(): the interface's energy, no central force; the extra values per interface
    row = interfaces(lmp)[0]
    assert tuple(row[:2]) == (1, 2)
    assert row[2] == pytest.approx(energy, rel=1e-9) and row[3] == 0.0
    assert row[4] == 1 and row[5] == pytest.approx(S, rel=1e-12)
    assert row[6] == pytest.approx(energy, rel=1e-9) and row[7] == -1


def test_forces_are_minus_the_gradient_of_the_energy(lmp, tmp_path):
    """Finite differences of ebond over translations and rotations of both cells: the
    interface forces and torques are exactly conservative."""
    make_pair(lmp, tmp_path)
    lmp.command("run 0")
    rng = np.random.default_rng(3)
    x0 = by_tag(lmp, "x") + rng.normal(scale=2e-7, size=(2, 3))

    def turned(q, rotvec):
        return wxyz(Rotation.from_rotvec(rotvec) * Rotation.from_quat(np.r_[q[1:], q[0]]))

    q0 = by_tag(lmp, "d2_bcm_quat")
    for i in range(2):
        q0[i] = turned(q0[i], rng.normal(scale=5e-4, size=3))

    def evaluate(x, q):
        set_by_tag(lmp, "x", x)
        set_by_tag(lmp, "d2_bcm_quat", q)
        lmp.command("run 0")
        return lmp.get_thermo("ebond"), by_tag(lmp, "f"), by_tag(lmp, "torque")

    e, f, tq = evaluate(x0, q0)
    assert e > 0
    hx, hr = 1e-10, 1e-7
    for i in range(2):
        for c in range(3):
            dx = np.zeros((2, 3))
            dx[i, c] = hx
            fd = -(evaluate(x0 + dx, q0)[0] - evaluate(x0 - dx, q0)[0]) / (2 * hx)
            assert f[i, c] == pytest.approx(fd, rel=1e-5, abs=1e-6 * np.abs(f).max())
            energies = []
            for sign in (1, -1):
                rv = np.zeros(3)
                rv[c] = sign * hr
                q = q0.copy()
                q[i] = turned(q0[i], rv)
                energies.append(evaluate(x0, q)[0])
            fd = -(energies[0] - energies[1]) / (2 * hr)
            assert tq[i, c] == pytest.approx(fd, rel=1e-5, abs=1e-6 * np.abs(tq).max())


def test_damping_force_follows_eq1_and_eq3(lmp, tmp_path):
    en2 = 0.25
    make_pair(lmp, tmp_path, en2=en2)
    lmp.command("run 0")
    v2 = 0.3 * N - 0.2 * T1 + 0.1 * T2  # no rotation: every point has the cells' relative velocity
    f, _ = place(lmp, np.zeros(3), v2=v2)
    c = 2 * alpha(en2) * np.sqrt(KN * MRED)  # summed over the points: 2 alpha sqrt(k_n m)
    np.testing.assert_allclose(f[1], -c * v2, rtol=1e-9)
    assert lmp.get_thermo("ebond") < KN * (1e-14 * A) ** 2  # damping is not in the energy


# ---------------------------------------------------------------- (b) Griffith threshold

@pytest.mark.parametrize("energy,factor", [(None, 1.0), ("stored", 1.0), ("rockable", 4.0),
                                           ("literal", 0.25)])
def test_griffith_breaks_at_the_first_step_past_the_threshold(lmp, tmp_path, energy, factor):
    """Constant-velocity pull: the stored energy E(s) = (k_n v_n^2 + k_t v_t^2) (s h)^2 / 2
    crosses 2 S G_c / factor between steps 40 and 41 (factor N_p for rockable, 1/N_p for
    literal, SPEC 1.2 Eq. 4-6)."""
    vn, vt = 0.02, 0.01
    h = float(PERIOD / 50)

    def stored(step):
        return 0.5 * (KN * vn**2 + KT * vt**2) * (step * h) ** 2

    gc = factor * stored(40.5) / (2 * S)
    make_pair(lmp, tmp_path, gc=gc, energy=energy)
    v = vn * N + vt * T1
    lmp.commands(f"""
        timestep {fnum(h)}
        group moving id 2
        fix pull moving move linear {fnum(v[0])} {fnum(v[1])} {fnum(v[2])}
        run 40
    """)
    assert griffith(lmp, 2) == 0.0
    assert lmp.get_thermo("ebond") == pytest.approx(stored(40), rel=1e-9)
    assert factor * stored(40) < 2 * S * gc
    lmp.command("run 1")
    assert griffith(lmp, 2) == 1.0 and griffith(lmp, 1) == 0.0
    row = interfaces(lmp)[0]
    assert row[4] == 0 and row[7] == 41
    assert row[8] == pytest.approx(41 * h, rel=1e-12)
    assert row[9] == pytest.approx(stored(41), rel=1e-9)  # stored energy at the break
    assert factor * row[9] >= 2 * S * gc
    assert griffith(lmp, 3) == pytest.approx(S, rel=1e-12)
    assert griffith(lmp, 4) == pytest.approx(2 * S * gc, rel=1e-12)  # W_f
    # broken in tension: every point opens, nothing is stored; lost at the switch: what the
    # springs stored less 2 S G_c, less the half kick of this step's intact force that the
    # break replaced, (h/2) F . v = stored(41) / 41
    assert lmp.get_thermo("ebond") == 0.0
    assert griffith(lmp, 8) == pytest.approx(stored(41) * (1 - 1 / 41) - 2 * S * gc, rel=1e-9)
    lmp.command("run 5")
    assert griffith(lmp, 2) == 1.0 and interfaces(lmp)[0][7] == 41  # broken for good


# ---------------------------------------------------------------- (c) after the break

def test_broken_interface_is_a_frictional_contact(lmp, tmp_path):
    make_pair(lmp, tmp_path, gc=1e-6)
    lmp.command("run 0")
    f, _ = place(lmp, 1e-7 * N)  # 1/2 k_n d^2 = 5e-8 J > 2 S G_c = 2e-12 J: breaks
    assert griffith(lmp, 2) == 1.0
    assert np.abs(f).max() == 0.0

    # no tension: pulled apart further, nothing
    f, _ = place(lmp, 3e-7 * N + 1e-7 * T1)
    assert np.abs(f).max() == 0.0 and lmp.get_thermo("ebond") == 0.0

    # compression: Eq. 1 with the contact stiffness (broken in tension: no shift)
    d = 2e-8
    f, _ = place(lmp, -d * N)
    np.testing.assert_allclose(f[1], KNC * d * N, rtol=1e-9)
    assert lmp.get_thermo("ebond") == pytest.approx(0.5 * KNC * d**2, rel=1e-9)

    # Coulomb (Eq. 7): the tangential spring starts at the contact onset, then caps at mu f_n
    # and the force opposes the slip; on reversal it unloads elastically first
    cap = MU * KNC * d
    step = 0.3 * cap / KTC
    shift, history = 0.0, []
    for direction in [1] * 6 + [-1] * 10:
        shift += direction * step
        f, _ = place(lmp, -d * N + shift * T1)
        history.append(f[1])
        fn = f[1] @ N
        assert fn == pytest.approx(KNC * d, rel=1e-9)
        assert np.linalg.norm(f[1] - fn * N) <= MU * fn * (1 + 1e-12)
    forces_t = np.array([h @ T1 for h in history])
    expected = []
    u = 0.0  # elastic tangential displacement, whole interface
    for direction in [1] * 6 + [-1] * 10:
        u = np.clip(u + direction * step, -cap / KTC, cap / KTC)
        expected.append(-KTC * u)
    np.testing.assert_allclose(forces_t, expected, rtol=1e-9, atol=1e-9 * cap)
    assert forces_t[5] == pytest.approx(-cap) and forces_t[-1] == pytest.approx(cap)
    assert griffith(lmp, 7) > 0  # sliding dissipated


def test_normal_force_is_continuous_when_a_compressed_interface_breaks(lmp, tmp_path):
    """Break by shear while compressed: the normal force keeps k_n d (SPEC 1.2, switch), the
    tangential one keeps k_t s up to the Coulomb limit; what the springs lose beyond 2 S G_c
    is reported as dissipated at the switch."""
    d, s_break = 1e-7, 2e-7
    gc = 0.5 * KT * (0.9 * s_break) ** 2 / (2 * S)  # tangential energy alone decides
    make_pair(lmp, tmp_path, gc=gc)
    lmp.command("run 0")
    f, _ = place(lmp, -d * N + 0.8 * s_break * T1)
    assert griffith(lmp, 2) == 0.0
    np.testing.assert_allclose(f[1], KN * d * N - KT * 0.8 * s_break * T1, rtol=1e-9)

    f, _ = place(lmp, -d * N + s_break * T1)
    assert griffith(lmp, 2) == 1.0
    fn = f[1] @ N
    assert fn == pytest.approx(KN * d, rel=1e-9)  # continuous across the switch
    ft = min(KT * s_break, MU * KN * d)
    np.testing.assert_allclose(f[1] - fn * N, -ft * T1, rtol=1e-9, atol=1e-9 * ft)
    before = 0.5 * KN * d**2 + 0.5 * KT * s_break**2
    after = 0.5 * (KN * d) ** 2 / KNC + 0.5 * ft**2 / KTC
    assert lmp.get_thermo("ebond") == pytest.approx(after, rel=1e-9)
    assert griffith(lmp, 8) == pytest.approx(before - after - 2 * S * gc, rel=1e-9)
    assert interfaces(lmp)[0][9] == pytest.approx(before, rel=1e-9)

    # the contact's reference moved to s = dn (1 - k_p / k_c) = -0.9 d: it opens there
    shift = -d * (1 - KN / KNC)
    f, _ = place(lmp, (shift + 0.05 * d) * N + s_break * T1)
    assert np.abs(f).max() == 0.0
    f, _ = place(lmp, (shift - 0.05 * d) * N + s_break * T1)
    assert f[1] @ N == pytest.approx(KNC * 0.05 * d, rel=1e-6)


# ---------------------------------------------------------------- (d) energy conservation

def three_cells():
    centres = [X1, X1 + A * N, X1 + A * N + A * T1]
    faces = []
    for t1, t2 in [(1, 2), (2, 3)]:
        c1, c2 = centres[t1 - 1], centres[t2 - 1]
        n = (c2 - c1) / A
        u = np.cross(n, T2) if abs(n @ T2) < 0.5 else np.cross(n, T1)
        u /= np.linalg.norm(u)
        w = np.cross(n, u)
        mid = 0.5 * (c1 + c2)
        faces.append((t1, t2, np.array([mid + 0.5 * A * (a * u + b * w)
                                        for a, b in [(-1, -1), (1, -1), (1, 1), (-1, 1)]])))
    return centres, faces


def totals(lmp, ncells):
    x, v, L = by_tag(lmp, "x"), by_tag(lmp, "v"), by_tag(lmp, "d2_bcm_angmom")
    energy = lmp.get_thermo("ke") + lmp.extract_fix("rig", 0, 0) + lmp.get_thermo("ebond")
    return energy, (MASS * v).sum(0), (np.cross(x, MASS * v) + L).sum(0)


def test_bonded_cells_conserve_energy_and_momenta(lmp, tmp_path):
    centres, faces = three_cells()
    make_cells(lmp, tmp_path, centres, faces)
    rng = np.random.default_rng(1)
    set_by_tag(lmp, "v", rng.normal(scale=0.5, size=(3, 3)))
    set_by_tag(lmp, "d2_bcm_angmom", rng.normal(scale=500 * MOMENTS[0], size=(3, 3)))
    lmp.commands(f"""
        fix rig all bcm/rigid
        timestep {fnum(PERIOD / 500)}
        run 0
    """)
    e0, p0, l0 = totals(lmp, 3)
    energies, stored = [], []
    for _ in range(20):
        lmp.command("run 500")
        e, p, l = totals(lmp, 3)
        energies.append(e)
        stored.append(lmp.get_thermo("ebond"))
        np.testing.assert_allclose(p, p0, rtol=0, atol=1e-12 * np.abs(p0).max())
        np.testing.assert_allclose(l, l0, rtol=0, atol=1e-12 * np.abs(l0).max())
    assert max(stored) > 0.05 * e0  # the interfaces do work hard
    assert np.abs(np.array(energies) - e0).max() / e0 < 1e-4
    assert griffith(lmp, 6) == 0.0  # e_n = 1: no damping


def test_broken_interface_energy_balance(lmp, tmp_path):
    """Cells meet on a broken interface (G_c = 0 breaks it at once) obliquely, slide with
    friction and part: kinetic energy in = kinetic out + damping + friction + stored."""
    make_pair(lmp, tmp_path, gc=0.0, en2c=0.25)
    rng = np.random.default_rng(2)
    lmp.commands("run 0")
    assert griffith(lmp, 2) == 1.0
    set_by_tag(lmp, "v", [np.zeros(3), -0.4 * N + 0.3 * T1 - 0.1 * T2])
    set_by_tag(lmp, "d2_bcm_angmom", rng.normal(scale=20 * MOMENTS[0], size=(2, 3)))
    lmp.commands(f"""
        fix rig all bcm/rigid
        timestep {fnum(PERIOD / 2000)}
        run 0
    """)
    e0, p0, l0 = totals(lmp, 2)
    lmp.command("run 20000")
    e, p, l = totals(lmp, 2)
    lost = griffith(lmp, 6) + griffith(lmp, 7) + griffith(lmp, 8)
    assert griffith(lmp, 6) > 0 and griffith(lmp, 7) > 0
    assert e < e0
    assert abs(e + lost - e0) / e0 < 2e-5
    np.testing.assert_allclose(p, p0, rtol=0, atol=1e-12 * np.abs(p0).max())
    np.testing.assert_allclose(l, l0, rtol=0, atol=1e-12 * np.abs(l0).max())


def test_energy_balance_closes_through_a_break(lmp, tmp_path):
    """Cells driven apart obliquely in compression and shear, spinning, damped: the interface
    breaks, then slides as a contact and parts. In = out + stored + W_f + dissipated."""
    make_pair(lmp, tmp_path, gc=0.005, en2=0.25, en2c=0.25)
    rng = np.random.default_rng(4)
    set_by_tag(lmp, "v", [np.zeros(3), -0.2 * N + 0.5 * T1])
    set_by_tag(lmp, "d2_bcm_angmom", rng.normal(scale=50 * MOMENTS[0], size=(2, 3)))
    lmp.commands(f"""
        fix rig all bcm/rigid
        timestep {fnum(PERIOD / 2000)}
        run 0
    """)
    e0, _, _ = totals(lmp, 2)
    lmp.command("run 6000")
    e, _, _ = totals(lmp, 2)
    assert griffith(lmp, 2) == 1.0
    accounted = sum(griffith(lmp, k) for k in (4, 5, 6, 7, 8))
    assert min(griffith(lmp, k) for k in (4, 6, 7)) > 0  # every channel took its share
    assert abs(e + accounted - e0) / e0 < 2e-6


# ---------------------------------------------------------------- (e) damping

def test_rebound_restitution_and_energy_balance(lmp, tmp_path):
    en2 = 0.25
    make_pair(lmp, tmp_path, en2=en2)
    v0 = 0.5
    set_by_tag(lmp, "v", [0.5 * v0 * N, -0.5 * v0 * N])
    h = float(PERIOD / 200)
    lmp.commands(f"""
        fix rig all bcm/rigid
        timestep {fnum(h)}
        run 0
    """)
    ke0 = lmp.get_thermo("ke")
    # linear spring-dashpot: back at zero overlap after pi / w_d, relative speed e_n v0 (Eq. 2)
    zeta = alpha(en2)
    w_d = np.sqrt(KN / MRED) * np.sqrt(1 - zeta**2)
    lmp.command(f"run {int(round(np.pi / w_d / h))}")
    v = by_tag(lmp, "v")
    assert (v[1] - v[0]) @ N == pytest.approx(np.sqrt(en2) * v0, rel=0.02)
    assert np.abs(by_tag(lmp, "omega")).max() < 1e-6  # symmetric points: no spin
    # the vibration decays; energy in = out + stored + dissipated
    lmp.command("run 6000")
    balance = (lmp.get_thermo("ke") + lmp.extract_fix("rig", 0, 0) + griffith(lmp, 5)
               + griffith(lmp, 6))
    assert griffith(lmp, 5) < 1e-6 * ke0
    assert balance == pytest.approx(ke0, rel=1e-6)
    assert griffith(lmp, 7) == 0.0 and griffith(lmp, 2) == 0.0


# ---------------------------------------------------------------- two ranks

MPI_INPUT = """
plugin load {plugin}
units si
{read_lattice}
boundary f f f
processors * 1 1
newton on off
comm_modify vel yes
special_bonds lj/coul 0 1 1
{read_data}
pair_style zero {cutoff}
pair_coeff * *
bond_style bcm/griffith geometry lattice.geo
bond_coeff 1 {kn} {kt} 0.25 {gc} {knc} {ktc} 0.25 {mu}
neighbor {skin} bin
neigh_modify every 1 delay 0 check yes
fix rig all bcm/rigid
timestep {dt}
compute ket all ke
variable kcm equal 0.5*mass(all)*(vcm(all,x)^2+vcm(all,y)^2+vcm(all,z)^2)
variable balance equal c_ket-v_kcm+f_rig+f_BCM_GRIFFITH[4]+f_BCM_GRIFFITH[5]+&
    f_BCM_GRIFFITH[6]+f_BCM_GRIFFITH[7]+f_BCM_GRIFFITH[8]
variable xmin equal bound(all,xmin)
thermo_style custom step v_balance f_BCM_GRIFFITH[*]
{thermo_modify}
run 0
print "START ${{balance}}"
run {steps}
print "RESULT ${{balance}} ${{xmin}} $(f_BCM_GRIFFITH[1]) $(f_BCM_GRIFFITH[2]) &
    $(f_BCM_GRIFFITH[5]:%.17g) $(f_BCM_GRIFFITH[6]:%.17g) $(f_BCM_GRIFFITH[7]:%.17g)"
"""


def lattice_faces(index: dict, centres: dict) -> tuple[list[str], list[tuple[int, int]]]:
    """The shared faces of cube cells on a lattice with spacing A (index: lattice site -> tag,
    centres: tag -> centre): the geometry file's lines (4 corner points, in the space frame)
    and the bonds (tag pairs, the first cell the one nearer the origin)."""
    lines, bonds = [], []
    for ijk, t in index.items():
        for d in range(3):
            nb = tuple(c + (k == d) for k, c in enumerate(ijk))
            if nb not in index:
                continue
            n, u, w = np.eye(3)[d], np.eye(3)[(d + 1) % 3], np.eye(3)[(d + 2) % 3]
            mid = centres[t] + 0.5 * A * n
            pts = [mid + 0.5 * A * (a * u + b * w) for a, b in [(-1, -1), (1, -1), (1, 1), (-1, 1)]]
            lines.append(geometry_line(t, index[nb], S, n, pts))
            bonds.append((t, index[nb]))
    return lines, bonds


# The two layouts of a cell's orientation (plugins/doc/fix_bcm_rigid.md): atom_style
# bpm/sphere's quaternion, sent to ghosts by LAMMPS with x, v and omega ("bpm", the driver's),
# or the array d2_bcm_quat that fix bcm/rigid sends itself ("legacy", files up to main fc0b266):
# the atom style line and the commands that read lattice.data (MPI_INPUT's keys)
LAYOUTS = {
    "legacy": dict(read_lattice="atom_style hybrid bond sphere", read_data=(
        "fix props all property/atom d2_bcm_quat 4 d2_bcm_inertia 3 d2_bcm_angmom 3 ghost yes\n"
        "read_data lattice.data fix props NULL Cells")),
    "bpm": dict(read_lattice="atom_style bpm/sphere", read_data=(
        "fix props all property/atom d2_bcm_inertia 3 d2_bcm_angmom 3 ghost yes\n"
        "fix orient0 all property/atom d2_bcm_quat0 4\n"
        "read_data lattice.data fix props NULL Cells fix orient0 NULL Orientations\n"
        "bcm_orient d2_bcm_quat0\nunfix orient0")),
}


def write_lattice(tmp_path, shape, drift, burst=0.0, seed=0, layout="legacy"):
    """Cube cells on a lattice with spacing A, every face bonded; random body frames,
    velocities and spins on top of a common drift and of a radial burst of speed `burst`.
    The data file's layout: LAYOUTS (the same cells either way)."""
    rng = np.random.default_rng(seed)
    index = {ijk: t for t, ijk in enumerate(np.ndindex(*shape), start=1)}
    centres = {t: X1 + A * np.array(ijk, dtype=float) for ijk, t in index.items()}
    lines, bonds = lattice_faces(index, centres)
    (tmp_path / "lattice.geo").write_text("\n".join(lines) + "\n")
    lo, hi = X1 - 3 * A, X1 + A * (np.array(shape) + 4)
    out = [f"BCM cube lattice\n\n{len(index)} atoms\n1 atom types\n{len(bonds)} bonds\n"
           "1 bond types\n"]
    out += [f"{fnum(lo[k])} {fnum(hi[k])} {c}lo {c}hi" for k, c in enumerate("xyz")]
    density = MASS / (np.pi / 6 * (2 * A) ** 3)
    if layout == "legacy":
        out += ["\nAtoms # hybrid\n"]
        out += [f"{t} 1 " + " ".join(fnum(c) for c in x) + f" 1 {fnum(2 * A)} {fnum(density)}"
                for t, x in centres.items()]
    else:
        out += ["\nAtoms # bpm/sphere\n"]
        out += [f"{t} 1 1 {fnum(2 * A)} {fnum(density)} " + " ".join(fnum(c) for c in x)
                for t, x in centres.items()]
    out += ["\nVelocities\n"]
    middle = np.mean(list(centres.values()), axis=0)
    for t, x in centres.items():
        radial = burst * (x - middle) / np.linalg.norm(x - middle)
        v = drift + radial + rng.normal(scale=0.5, size=3)
        out.append(f"{t} " + " ".join(fnum(c) for c in v) + " 0 0 0")
    out += ["\nBonds\n"] + [f"{b} 1 {t1} {t2}" for b, (t1, t2) in enumerate(bonds, start=1)]
    quats = {t: wxyz(Rotation.random(random_state=100 + t)) for t in centres}
    out += ["\nCells\n"]
    for t in centres:
        values = [*(quats[t] if layout == "legacy" else []), *MOMENTS,
                  *rng.normal(scale=100 * MOMENTS[0], size=3)]
        out.append(f"{t} " + " ".join(fnum(v) for v in values))
    if layout != "legacy":
        out += ["\nOrientations\n"] + [f"{t} " + " ".join(fnum(v) for v in q) for t, q in quats.items()]
    (tmp_path / "lattice.data").write_text("\n".join(out) + "\n")


def run_lmp(tmp_path, nprocs, text, eval_both=False):
    """`lmp` on nprocs ranks; eval_both: BRITTLE_EVAL_BOTH=1 (every rank evaluates the
    interfaces of its cells, copies included: the path before issue 27's evaluation once)."""
    import os  # noqa: PLC0415
    import subprocess  # noqa: PLC0415

    from driver.engine import venv_bin  # noqa: PLC0415

    name = f"{nprocs}{'b' if eval_both else ''}"
    inp = tmp_path / f"in.{name}"
    inp.write_text(text)
    cmd = [venv_bin("mpiexec"), "-n", str(nprocs), venv_bin("lmp"), "-in", inp.name,
           "-log", f"log.{name}", "-screen", "none", "-nocite"]
    env = dict(os.environ, BRITTLE_EVAL_BOTH="1" if eval_both else "0")
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=300, env=env)
    log = (tmp_path / f"log.{name}").read_text()
    assert proc.returncode == 0, log[-2000:] + proc.stderr
    start = [ln for ln in log.splitlines() if ln.startswith("START")][-1]
    result = [ln for ln in log.splitlines() if ln.startswith("RESULT")][-1]
    return float(start.split()[1]), np.array([float(t) for t in result.split()[1:]])


def drift_input(plugin_path, layout):
    """MPI_INPUT of test_two_ranks_follow_one_rank's drifting block (lattice.data written)."""
    return MPI_INPUT.format(plugin=plugin_path, cutoff=fnum(2 * A), skin=fnum(0.2 * A),
                            kn=KN, kt=KT, gc=0.1, knc=KNC, ktc=KTC, mu=MU,
                            dt=fnum(PERIOD / 400), steps=4000, thermo_modify="", **LAYOUTS[layout])


@pytest.mark.mpi
@pytest.mark.parametrize("eval_both,layout", [(False, "bpm"), (True, "bpm"), (False, "legacy")],
                         ids=["once", "both", "once-legacy"])
def test_two_ranks_follow_one_rank(plugin_path, tmp_path, eval_both, layout):
    """A 6x2x2 block of bonded cells drifts across the boundary between two ranks while it
    vibrates, breaks part of its interfaces and slides on them: an interface across the ranks
    is evaluated by the owner of its cell with the smaller ID, which sends its state to the
    other rank's copy at every re-neighbouring ("once", the default), or by both owners of its
    cells ("both", BRITTLE_EVAL_BOTH=1); its state migrates with the cells, and each interface
    is counted once. The two-rank run follows the one-rank run, and the energy balance
    (kinetic energy about the centre of mass) closes in both. Orientations of ghost cells
    reach them in LAMMPS's communication ("bpm") or in fix bcm/rigid's ("legacy")."""
    write_lattice(tmp_path, (6, 2, 2), drift=np.array([120.0, 0.0, 0.0]), layout=layout)
    text = drift_input(plugin_path, layout)
    start1, one = run_lmp(tmp_path, 1, text)
    start2, two = run_lmp(tmp_path, 2, text, eval_both)
    middle = X1[0] + 3.5 * A  # of the box, in x: the boundary between the two ranks
    assert one[1] > middle  # the whole block crossed it
    assert 0 < one[3] < 40  # some of the 40 interfaces broke, not all
    np.testing.assert_array_equal(two[2:4], one[2:4])
    np.testing.assert_allclose(two, one, rtol=1e-8)
    for start, result in [(start1, one), (start2, two)]:
        assert result[0] == pytest.approx(start, rel=1e-4)


@pytest.mark.mpi
def test_orientation_layouts_agree_to_the_bit(plugin_path, tmp_path):
    """The drifting block of test_two_ranks_follow_one_rank on two ranks, its orientations in
    atom_style bpm/sphere's quaternion (sent with LAMMPS's positions and velocities) or in
    d2_bcm_quat (sent by fix bcm/rigid): the same values reach the ghosts, so every result is
    the same to the last printed digit."""
    results = []
    for layout in ("bpm", "legacy"):
        (tmp_path / layout).mkdir()
        write_lattice(tmp_path / layout, (6, 2, 2), drift=np.array([120.0, 0.0, 0.0]), layout=layout)
        results.append(run_lmp(tmp_path / layout, 2, drift_input(plugin_path, layout)))
    assert 0 < results[0][1][3] < 40  # interfaces broke: the runs left the elastic regime
    assert results[0][0] == results[1][0]
    np.testing.assert_array_equal(results[0][1], results[1][1])


@pytest.mark.mpi
def test_fragments_part_across_ranks(plugin_path, tmp_path):
    """A burst breaks every interface and the cells fly apart, farther than the
    communication cutoff: the broken bonds stay in the topology, so LAMMPS must be told to
    skip bonds whose partner is not a ghost (thermo_modify lost/bond ignore). Two ranks
    follow one rank."""
    write_lattice(tmp_path, (6, 2, 2), drift=np.zeros(3), burst=20.0, layout="bpm")
    text = MPI_INPUT.format(plugin=plugin_path, cutoff=fnum(2 * A), skin=fnum(0.2 * A),
                            kn=KN, kt=KT, gc=0.1, knc=KNC, ktc=KTC, mu=MU,
                            dt=fnum(PERIOD / 400), steps=20000,
                            thermo_modify="thermo_modify lost/bond ignore", **LAYOUTS["bpm"])
    text = text.replace("boundary f f f", "boundary m m m")
    start1, one = run_lmp(tmp_path, 1, text)
    start2, two = run_lmp(tmp_path, 2, text)
    assert (one[2], one[3]) == (0, 44)
    np.testing.assert_allclose(two, one, rtol=1e-8)
    assert one[0] == pytest.approx(start1, rel=1e-6)


# ---------------------------------------------------------------- restart

def test_restart_keeps_reference_state_and_counters(lmp, plugin_path, tmp_path):
    make_pair(lmp, tmp_path, gc=1.0)  # 2 S G_c = 2e-6 J
    lmp.command("run 0")
    place(lmp, 1e-7 * N + 0.5e-7 * T1)  # stretched, intact
    stretched = lmp.get_thermo("ebond")
    assert stretched > 0 and griffith(lmp, 1) == 1.0
    lmp.command(f"write_restart {tmp_path / 'intact.restart'}")
    place(lmp, 1e-6 * N)  # breaks
    lost = griffith(lmp, 8)
    assert griffith(lmp, 2) == 1.0
    lmp.command(f"write_restart {tmp_path / 'broken.restart'}")

    for name, check in [("intact", "intact"), ("broken", "broken")]:
        other = Lammps()
        try:
            other.command(f"plugin load {plugin_path}")
            other.commands(f"""
                read_restart {tmp_path / (name + '.restart')}
                fix props all property/atom d2_bcm_quat 4 d2_bcm_inertia 3 d2_bcm_angmom 3 ghost yes
                comm_modify vel yes
                thermo_style custom step ebond
                thermo_modify norm no
                run 0
            """)
            if check == "intact":
                # the body-frame geometry comes back: the stretched state is not the reference
                assert other.get_thermo("ebond") == pytest.approx(stretched, rel=1e-12)
                assert griffith(other, 1) == 1.0
            else:
                assert (griffith(other, 1), griffith(other, 2)) == (0.0, 1.0)
                assert griffith(other, 8) == pytest.approx(lost, rel=1e-12)
                f, _ = place(other, -2e-8 * N)  # a contact now
                np.testing.assert_allclose(f[1], KNC * 2e-8 * N, rtol=1e-9)
        finally:
            other.close()


# ---------------------------------------------------------------- (f) bad input

def test_missing_geometry_file(lmp, tmp_path):
    lmp.commands(SETUP.format(newton="on off"))
    with pytest.raises(LammpsError, match="cannot open geometry file"):
        lmp.command(f"bond_style bcm/griffith geometry {tmp_path / 'absent.txt'}")


@pytest.mark.parametrize("args,message", [
    ("geometry {geo} flavour stored", "unknown keyword flavour"),
    ("geometry {geo} energy kinetic", "unknown energy convention kinetic"),
    ("energy stored", "requires `geometry FILE`"),
    ("geometry", "needs a value"),
])
def test_bad_settings(lmp, tmp_path, args, message):
    geo = tmp_path / "g.txt"
    geo.write_text(geometry_line(1, 2, S, N, square_points(4)) + "\n")
    lmp.commands(SETUP.format(newton="on off"))
    with pytest.raises(LammpsError, match=message):
        lmp.command("bond_style bcm/griffith " + args.format(geo=geo))


@pytest.mark.parametrize("line,message", [
    (geometry_line(1, 2, S, N, np.zeros((17, 3))), "17 points, more than the 16"),
    (geometry_line(2, 1, S, N, square_points(4)), "tag1 < tag2"),
    (geometry_line(1, 2, S, 2 * N, square_points(4)), "normal has length"),
    (geometry_line(1, 2, -S, N, square_points(4)), "area must be > 0"),
    (geometry_line(1, 2, S, N, square_points(4)).rsplit(" ", 1)[0], "numbers for 4 points"),
    (geometry_line(1, 2, S, N, square_points(4)[:2]), "at least 3"),
])
def test_bad_geometry_lines(lmp, tmp_path, line, message):
    geo = tmp_path / "g.txt"
    geo.write_text("# header\n" + line + "\n")
    lmp.commands(SETUP.format(newton="on off"))
    with pytest.raises(LammpsError, match=message):
        lmp.command(f"bond_style bcm/griffith geometry {geo}")


def test_geometry_must_fit_the_cells(lmp, tmp_path):
    flipped = geometry_line(1, 2, S, -N, square_points(4)) + "\n"
    make_pair(lmp, tmp_path, geometry=flipped)
    with pytest.raises(LammpsError, match="normal must point from cell tag1 to cell tag2"):
        lmp.command("run 0")


def test_every_bond_needs_its_interface(lmp, tmp_path):
    other = geometry_line(1, 3, S, N, square_points(4)) + "\n"
    make_pair(lmp, tmp_path, geometry=other)
    with pytest.raises(LammpsError, match="bond 1-2 has no interface"):
        lmp.command("run 0")


def test_requires_newton_bond_off(lmp, tmp_path):
    make_pair(lmp, tmp_path, newton="on")
    with pytest.raises(LammpsError, match="newton_bond off"):
        lmp.command("run 0")


@pytest.mark.parametrize("coeffs,message", [
    ("0 1 1 1 1 1 1 0.3", "kn must be > 0"),
    ("1 1 1.5 1 1 1 1 0.3", "en2 must be in"),
    ("1 1 1 -1 1 1 1 0.3", "Gc must be >= 0"),
    ("1 1 1 1 1 1 1", "Incorrect args"),
])
def test_bad_coefficients(lmp, tmp_path, coeffs, message):
    make_pair(lmp, tmp_path)
    with pytest.raises(LammpsError, match=message):
        lmp.command(f"bond_coeff 1 {coeffs}")
