"""fix bcm/rigid: rigid cells with a full inertia tensor, against rigid-body mechanics.

Expectations: the torque-free asymmetric top keeps its rotational energy sum L_b^2 / (2 I) and
its space-frame angular momentum, and follows Euler's equations (integrated here with scipy);
free translation is exact; a constant torque about a principal axis gives L = tau t and the
turn angle tau t^2 / (2 I). Each with the orientation in either layout (atom_style bpm/sphere's
quaternion, or the array d2_bcm_quat of files up to main fc0b266: plugins/doc/fix_bcm_rigid.md);
the command bcm_orient, which sets the former from a data file's array.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from driver.engine import LammpsError

SCALE = 1e-12  # principal moments (1, 2, 3) * SCALE, kg m^2 (a 1 mm cell of 6 g/cm^3)
MASS = 6e-6
MOMENTS = np.array([1.0, 2.0, 3.0]) * SCALE

SETUP = """
units si
atom_style {atom_style}
boundary f f f
newton on off
comm_modify vel yes
region box block -0.05 0.05 -0.05 0.05 -0.05 0.05
create_box 1 box bond/types 1 extra/bond/per/atom 2
fix props all property/atom {arrays} d2_bcm_inertia 3 d2_bcm_angmom 3 ghost yes
create_atoms 1 single 0.001 -0.002 0.003
{type_mass}
set atom 1 mass {mass} diameter 0.002
pair_style zero 0.003
pair_coeff * *
thermo_style custom step ke
thermo_modify norm no
"""


def wxyz(rot: Rotation) -> np.ndarray:
    x, y, z, w = rot.as_quat()
    return np.array([w, x, y, z])


def from_wxyz(q) -> Rotation:
    return Rotation.from_quat([q[1], q[2], q[3], q[0]])


@pytest.fixture(params=["bpm", "legacy"])
def layout(request) -> str:
    """Where the orientation lives: atom_style bpm/sphere's quaternion or d2_bcm_quat."""
    return request.param


def make_cell(lmp, quat, moments=MOMENTS, angmom=(0.0, 0.0, 0.0), vel=(0.0, 0.0, 0.0),
              layout="bpm"):
    if layout == "bpm":  # per-atom masses only: no type mass
        lmp.commands(SETUP.format(mass=MASS, atom_style="bpm/sphere", arrays="", type_mass=""))
    else:
        lmp.commands(SETUP.format(mass=MASS, atom_style="hybrid bond sphere", arrays="d2_bcm_quat 4",
                                  type_mass=f"mass 1 {MASS}"))
    orientation(lmp)[0] = quat
    lmp.numpy.extract_atom("d2_bcm_inertia")[0] = moments
    lmp.numpy.extract_atom("d2_bcm_angmom")[0] = angmom
    lmp.numpy.extract_atom("v")[0] = vel


def orientation(lmp) -> np.ndarray:
    """The per-atom orientations of whichever layout the cell has."""
    quat = lmp.numpy.extract_atom("quat")
    return quat if quat is not None else lmp.numpy.extract_atom("d2_bcm_quat")


def state(lmp):
    out = {name: np.array(lmp.numpy.extract_atom(name)[0]) for name in ("x", "v", "omega", "d2_bcm_angmom")}
    return {**out, "quat": np.array(orientation(lmp)[0])}


def rot_energy(lmp):
    return lmp.extract_fix("rig", 0, 0)


def euler_reference(quat, angmom_space, moments, t):
    """Torque-free rigid body: dL_b/dt = L_b x w_b, dR/dt = R [w_b]x, w_b = L_b / I."""
    r0 = from_wxyz(quat)
    y0 = np.concatenate([r0.as_matrix().ravel(), r0.inv().apply(angmom_space)])

    def rhs(_, y):
        R = y[:9].reshape(3, 3)
        lb = y[9:]
        wb = lb / moments
        wx = np.array([[0, -wb[2], wb[1]], [wb[2], 0, -wb[0]], [-wb[1], wb[0], 0]])
        return np.concatenate([(R @ wx).ravel(), np.cross(lb, wb)])

    sol = solve_ivp(rhs, (0.0, t), y0, method="DOP853", rtol=1e-12, atol=1e-14)
    return sol.y[:9, -1].reshape(3, 3)


# ---------------------------------------------------------------- free rotation

def test_free_asymmetric_top_conserves_energy_and_angular_momentum(lmp, layout):
    quat = wxyz(Rotation.random(random_state=4))
    angmom = np.array([0.3, -0.5, 0.7]) * 1e-9  # non-principal: the body tumbles
    vel = np.array([0.1, -0.2, 0.05])
    make_cell(lmp, quat, angmom=angmom, vel=vel, layout=layout)
    dt, nsteps = 2e-6, 10000
    lmp.commands(f"""
        fix rig all bcm/rigid
        timestep {dt}
        run 0
    """)
    lb = from_wxyz(quat).inv().apply(angmom)
    e_expected = 0.5 * np.sum(lb**2 / MOMENTS)
    assert rot_energy(lmp) == pytest.approx(e_expected, rel=1e-13)
    s0 = state(lmp)
    # omega = R I^-1 R^T L
    np.testing.assert_allclose(s0["omega"], from_wxyz(quat).apply(lb / MOMENTS), rtol=1e-12)
    wmax = np.linalg.norm(lb / MOMENTS)
    assert wmax * dt < 2e-3  # the test resolves the tumbling

    lmp.command(f"run {nsteps}")
    s1 = state(lmp)
    t = nsteps * dt
    assert abs(rot_energy(lmp) - e_expected) / e_expected < 1e-6
    np.testing.assert_allclose(s1["d2_bcm_angmom"], angmom, rtol=0, atol=0)  # L is left as is
    # free translation is exact
    np.testing.assert_allclose(s1["x"], s0["x"] + vel * t, rtol=1e-11)  # round-off of 1e4 sums
    np.testing.assert_allclose(s1["v"], vel, rtol=0, atol=0)
    assert np.linalg.norm(s1["quat"]) == pytest.approx(1.0, abs=1e-14)

    # orientation follows Euler's equations of the free asymmetric top
    R_ref = euler_reference(quat, angmom, MOMENTS, t)
    R = from_wxyz(s1["quat"]).as_matrix()
    assert np.abs(R - R_ref).max() < 1e-6
    lb_end = from_wxyz(s1["quat"]).inv().apply(angmom)
    np.testing.assert_allclose(s1["omega"], from_wxyz(s1["quat"]).apply(lb_end / MOMENTS),
                               rtol=1e-12)


def test_rotation_about_a_principal_axis_is_exact(lmp, layout):
    """L along body axis 2 (I = 2 SCALE): steady rotation at w = L / I."""
    quat = wxyz(Rotation.random(random_state=9))
    axis = from_wxyz(quat).apply([0.0, 1.0, 0.0])
    L = 4e-10
    make_cell(lmp, quat, angmom=L * axis, layout=layout)
    dt, nsteps = 1e-5, 1000
    lmp.commands(f"fix rig all bcm/rigid\ntimestep {dt}\nrun {nsteps}")
    s = state(lmp)
    turned = from_wxyz(s["quat"]) * from_wxyz(quat).inv()
    np.testing.assert_allclose(turned.as_rotvec(), axis * (L / MOMENTS[1]) * nsteps * dt,
                               rtol=1e-10, atol=1e-13)


# ---------------------------------------------------------------- torque

def test_constant_torque_about_a_principal_axis(lmp, layout):
    """tau along body axis 3: L = tau t, omega = tau t / I3, turn angle tau t^2 / (2 I3)."""
    quat = wxyz(Rotation.random(random_state=2))
    axis = from_wxyz(quat).apply([0.0, 0.0, 1.0])
    tau = 3e-9
    make_cell(lmp, quat, layout=layout)
    lmp.command("fix ext all external pf/callback 1 1")

    def apply_torque(caller, step, nlocal, ids, x, fexternal):
        lmp.numpy.extract_atom("torque")[:nlocal] = tau * axis

    lmp.set_fix_external_callback("ext", apply_torque, None)
    dt, nsteps = 1e-5, 2000
    lmp.commands(f"fix rig all bcm/rigid\ntimestep {dt}\nrun {nsteps}")
    t = nsteps * dt
    s = state(lmp)
    np.testing.assert_allclose(s["d2_bcm_angmom"], tau * t * axis, rtol=1e-12, atol=1e-22)
    np.testing.assert_allclose(s["omega"], tau * t / MOMENTS[2] * axis, rtol=1e-12, atol=1e-12)
    turned = from_wxyz(s["quat"]) * from_wxyz(quat).inv()
    # the half-kick / drift sequence turns by exactly sum of h tau (n + 1/2) h / I3
    np.testing.assert_allclose(turned.as_rotvec(), axis * tau * t**2 / (2 * MOMENTS[2]),
                               rtol=1e-9, atol=1e-13)
    assert rot_energy(lmp) == pytest.approx((tau * t) ** 2 / (2 * MOMENTS[2]), rel=1e-12)


# ---------------------------------------------------------------- prerequisites

def test_requires_the_per_atom_arrays(lmp):
    lmp.commands("""
        units si
        atom_style hybrid bond sphere
        region box block -0.05 0.05 -0.05 0.05 -0.05 0.05
        create_box 1 box bond/types 1 extra/bond/per/atom 2
        create_atoms 1 single 0 0 0
        mass 1 1.0
        pair_style zero 0.1
        pair_coeff * *
        fix rig all bcm/rigid
    """)
    with pytest.raises(LammpsError, match="d2_bcm_quat"):
        lmp.command("run 0")


@pytest.mark.parametrize("moments,quat,message", [
    ((1e-12, 0.0, 1e-12), (1.0, 0.0, 0.0, 0.0), "zero or negative principal moment"),
    ((1e-12, 1e-12, 1e-12), (0.0, 0.0, 0.0, 0.0), "no orientation"),
])
def test_rejects_bad_cells(lmp, moments, quat, message, layout):
    make_cell(lmp, np.array(quat), moments=np.array(moments), layout=layout)
    lmp.command("fix rig all bcm/rigid")
    with pytest.raises(LammpsError, match=message):
        lmp.command("run 0")


def test_rejects_arguments(lmp):
    make_cell(lmp, wxyz(Rotation.identity()))
    with pytest.raises(LammpsError, match="takes no arguments"):
        lmp.command("fix rig all bcm/rigid 1.0")


def test_two_orientations_are_rejected(lmp):
    """atom_style bpm/sphere has its own quaternion: a d2_bcm_quat beside it is an error."""
    lmp.commands(SETUP.format(mass=MASS, atom_style="bpm/sphere", arrays="d2_bcm_quat 4", type_mass=""))
    lmp.numpy.extract_atom("d2_bcm_inertia")[0] = MOMENTS
    lmp.command("fix rig all bcm/rigid")
    with pytest.raises(LammpsError, match="second orientation"):
        lmp.command("run 0")


# ---------------------------------------------------------------- bcm_orient

ORIENT_SETUP = """
units si
atom_style {atom_style}
region box block -0.05 0.05 -0.05 0.05 -0.05 0.05
create_box 1 box bond/types 1 extra/bond/per/atom 2
fix q0 all property/atom d2_bcm_quat0 {cols}
create_atoms 1 random 5 7 box
"""


def test_bcm_orient_copies_the_array_bit_for_bit(lmp):
    lmp.commands(ORIENT_SETUP.format(atom_style="bpm/sphere", cols=4))
    quats = np.random.default_rng(3).normal(size=(5, 4))  # not normalised: copied as they are
    lmp.numpy.extract_atom("d2_bcm_quat0")[:] = quats
    lmp.command("bcm_orient d2_bcm_quat0")
    np.testing.assert_array_equal(lmp.numpy.extract_atom("quat")[:5], quats)


@pytest.mark.parametrize("atom_style,cols,command,message", [
    ("hybrid bond sphere", 4, "bcm_orient d2_bcm_quat0", "atom style with a quaternion"),
    ("bpm/sphere", 4, "bcm_orient d2_bcm_other", "no per-atom array d2_bcm_other"),
    ("bpm/sphere", 3, "bcm_orient d2_bcm_quat0", "with 4 columns"),
    ("bpm/sphere", 4, "bcm_orient bcm_quat0", "not a per-atom array"),
    ("bpm/sphere", 4, "bcm_orient", "Illegal bcm_orient command"),
    ("bpm/sphere", 4, "bcm_orient d2_bcm_quat0", "atom 1 has no orientation"),  # zeros
])
def test_bcm_orient_rejects(lmp, atom_style, cols, command, message):
    lmp.commands(ORIENT_SETUP.format(atom_style=atom_style, cols=cols))
    with pytest.raises(LammpsError, match=message):
        lmp.command(command)
