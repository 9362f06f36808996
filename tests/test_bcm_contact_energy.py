"""The BCM contact law is continuous when the number of points of a contact changes (SPEC 1.2,
last bullet): fix bcm/wall and pair_style bcm/contact conserve energy, with damping and
friction off, through contacts that start on an edge (2 points) and roll onto a face (3-4
points) and leave again.

The law is a fixed stiffness per point (plugins/src/bcm_contact_law.h): a point enters and
leaves at zero overlap, so the springs' energy is a continuous function of the positions and
velocity Verlet conserves kinetic + stored energy to O(h^2). The law it replaces shared the
contact's k_n over its current N points, so that N changing at finite overlap re-scaled every
loaded spring: these two runs created and destroyed a few per cent of the energy with it.

Energies: translational (compute ke) + rotational (fix bcm/rigid's scalar) + the springs'
stored energy, every step, through fix ave/time. Time steps are 1/1000 of the period of the
stiffest mode of the face contact (rocking for the cubes), so velocity Verlet's own energy
error during the contact stays near 1e-6.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_bcm_contact import (
    A,
    KN,
    KT,
    MASS,
    RM,
    quat_axis_angle,
    rigid_props,
    setup_cells,
    space_vertices,
)

DRIFT = 1e-4          # the bound on the relative energy drift
V0 = 0.5              # approach speed (m/s)
TILT = 1e-5           # rad: the far edge starts 2 A sin(TILT) = 1e-9 m above the near one,
                      # about half the overlap the impact reaches: the face lands mid-contact
MOMENT = MASS * (2 * (A + RM)) ** 2 / 6


def read_series(path):
    """fix ave/time file: step, energy, points (one row a step)."""
    rows = [ln.split() for ln in path.read_text().splitlines() if ln and not ln.startswith("#")]
    return np.array(rows, dtype=float)


def drift(series, e0):
    """(largest relative deviation of the energy over the run, relative deviation at the end)."""
    e = series[:, 1]
    return float(np.abs(e - e0).max() / e0), float(abs(e[-1] - e0) / e0)


def test_wall_edge_rolls_onto_face_conserves_energy(lmp, tmp_path):
    """A cube dropped on the plane tilted by TILT about x: its lowest edge (2 vertices) lands
    first, the contact force there turns it onto its face (4 vertices), and it bounces off.
    e_n = 1 (no damping), mu = 0."""
    q = quat_axis_angle([1, 0, 0], TILT)
    lowest = space_vertices((0, 0, 0), q)[:, 2].min()
    # stiffest mode of the cube flat on 4 springs k_n at its corners (+-A, +-A): rocking,
    # omega^2 = 4 k_n A^2 / I = 6 k_n / m (translation: 4 k_n / m)
    period = 2 * math.pi / math.sqrt(4 * KN * A**2 / MOMENT)
    dt = period / 1000
    xc = (0.0, 0.0, RM - lowest + 20 * V0 * dt)
    cells = [dict(x=xc, q=q, v=(0.0, 0.0, -V0))]
    out = tmp_path / "energy.txt"
    extra = (f"fix wall all bcm/wall cells {{cells}} rm {RM!r} plane zlo 0.0 {KN!r} {KT!r} "
             "1.0 0.0\n"
             "fix move all bcm/rigid\n"
             "compute ke all ke\n"
             "compute nv all reduce max f_wall\n"
             "variable e equal c_ke+f_move+f_wall[4]\n"
             f"fix series all ave/time 1 1 1 v_e c_nv file {out}\n"
             "thermo_style custom step f_wall[1] f_wall[3] f_wall[4] f_wall[5] f_wall[6] "
             "f_wall[7] f_wall[8]\n")
    setup_cells(lmp, tmp_path, cells, pair=False, dt=dt, extra=extra)
    rigid_props(lmp, cells)
    e0 = 0.5 * MASS * V0**2
    lmp.command("run 3000")
    th = lmp.lmp.last_thermo()
    assert th["f_wall[1]"] == 0  # it left the plane
    series = read_series(out)
    touched = set(series[:, 2].astype(int))
    assert {2, 4} <= touched, touched  # an edge, then the face
    # the edge came first: 2 vertices before any third
    first = series[series[:, 2] > 0, 2]
    assert first[0] == 2
    rel_max, rel_end = drift(series, e0)
    assert rel_max < DRIFT and rel_end < DRIFT, (rel_max, rel_end)
    # nothing dissipated: no damping, no friction, no change-of-N term (identically zero)
    for k in (3, 5, 6, 7):
        assert th[f"f_wall[{k}]"] == 0, k
    # the work of the wall's forces is the change of the kinetic energy
    assert th["f_wall[8]"] == pytest.approx(series[-1, 1] - e0, abs=DRIFT * e0)


def test_pair_edge_then_face_conserves_energy(lmp, tmp_path):
    """Cube B over cube A, offset (0.3 A, 0.2 A) and tilted by TILT about x, the two closing
    at V0: B's lower edge meets A's top face (2 points: a vertex of B on A's face and the
    crossing of that edge with an edge of A), B turns flat (4 points: the corners of the
    overlap rectangle), and they part. e_n = 1 (no damping), mu = 0."""
    qb = quat_axis_angle([1, 0, 0], TILT)
    xb = np.array([0.3 * A, 0.2 * A, 0.0])
    # 4 points k_n at the corners of the overlap rectangle, both cubes free: the relative
    # rocking is the stiffest mode, omega^2 < 4 k_n A^2 (2 / I)
    period = 2 * math.pi / math.sqrt(8 * KN * A**2 / MOMENT)
    dt = period / 1000
    xb[2] = A + 2 * RM + 20 * V0 * dt - space_vertices(np.zeros(3), qb)[:, 2].min()
    cells = [dict(x=(0.0, 0.0, 0.0), q=(1.0, 0.0, 0.0, 0.0), v=(0.0, 0.0, 0.5 * V0)),
             dict(x=xb, q=qb, v=(0.0, 0.0, -0.5 * V0))]
    out = tmp_path / "energy.txt"
    extra = ("fix move all bcm/rigid\n"
             "compute ke all ke\n"
             "variable e equal c_ke+f_move+c_cp\n"
             f"fix series all ave/time 1 1 1 v_e c_cp[1] file {out}\n"
             "thermo_style custom step c_cp c_cp[1] c_cp[2] c_cp[4] c_cp[5] c_cp[6] c_cp[7]\n")
    lmp_coeff = f"pair_coeff * * {KN!r} {KT!r} 1.0 0.0\n"
    setup_cells(lmp, tmp_path, cells, dt=dt, extra=lmp_coeff + extra)
    rigid_props(lmp, cells)
    e0 = 0.5 * (2 * MASS) * (0.5 * V0) ** 2
    lmp.command("run 3000")
    th = lmp.lmp.last_thermo()
    assert th["c_cp[2]"] == 0  # they parted
    series = read_series(out)
    points = series[:, 2].astype(int)
    assert {2, 4} <= set(points), set(points)  # edge to face, then face to face
    assert points[points > 0][0] == 2
    rel_max, rel_end = drift(series, e0)
    assert rel_max < DRIFT and rel_end < DRIFT, (rel_max, rel_end)
    for k in (4, 5, 6):
        assert th[f"c_cp[{k}]"] == 0, k
    assert th["c_cp[7]"] == pytest.approx(series[-1, 1] - e0, abs=DRIFT * e0)
