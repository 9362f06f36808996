"""pair_style bcm/contact and fix bcm/wall against SPEC 1.2 (Eq. 1, 2, 7) on cubes.

Every expectation is computed here from the geometry (closest points of the cores written out
with numpy) and the SPEC force law; the styles are only run and read. Cells are cubes of core
half-side A with rounding radius RM; forces in N, lengths in m (units si).

The law is the per-point one of plugins/src/bcm_contact_law.h: k_n and k_t are the stiffnesses
of ONE contact point, so a contact of N points at equal overlaps carries N k_n delta (a face
of a cube: 4 points), and each point's damping is 2 alpha sqrt(k_n m / N) (the contact's
reduced mass shared by its points, so that N points moving together have the damping ratio
alpha). The expectations below that count points were written for the former law, which
shared k_n, k_t and the damping over the N points (k_n delta in total whatever N), and were
changed to the per-point law (see each test). Energy conservation when N changes:
tests/test_bcm_contact_energy.py.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from analysis.rotations import quat_to_matrix
from driver.engine import LammpsError

A = 5.0e-5            # core half-side of the test cubes
RM = 2.0e-6           # rounding radius r_m
KN, KT, EN2, MU = 1.0e8, 8.0e7, 0.25, 0.3
MASS = 6000.0 * (2 * (A + RM)) ** 3
DELTA = 1.0e-7        # overlap of the static tests


# ---------------------------------------------------------------- cells file

def write_cells_file(path, cells: dict[int, tuple[np.ndarray, list[list[int]]]]) -> None:
    """The cells file read by pair_style bcm/contact and fix bcm/wall (format: see
    plugins/doc/pair_bcm_contact.md): `bcm/cells NCELLS`, then per cell `TAG NV NF`, NV lines
    of body-frame vertices, NF lines `K i0 .. i(K-1)` (0-based, counter-clockwise seen from
    outside)."""
    lines = ["# BCM cell cores, body frame (m)", f"bcm/cells {len(cells)}"]
    for tag, (verts, faces) in cells.items():
        lines.append(f"{tag} {len(verts)} {len(faces)}")
        lines += [" ".join(f"{c:.17g}" for c in v) for v in verts]
        lines += [f"{len(f)} " + " ".join(str(k) for k in f) for f in faces]
    path.write_text("\n".join(lines) + "\n")


def cube(a=A):
    """Vertices (+-a)^3 and faces counter-clockwise seen from outside."""
    verts = np.array([[x, y, z] for x in (-a, a) for y in (-a, a) for z in (-a, a)])
    idx = {tuple(np.sign(v).astype(int)): k for k, v in enumerate(verts)}

    def face(axis, s):
        # corners of the face x[axis] = s a, ordered counter-clockwise about s e_axis
        u, w = (axis + 1) % 3, (axis + 2) % 3
        loop = []
        for cu, cw in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            key = [0, 0, 0]
            key[axis], key[u], key[w] = s, cu, cw
            loop.append(idx[tuple(key)])
        return loop if s > 0 else loop[::-1]

    return verts, [face(ax, s) for ax in range(3) for s in (-1, 1)]


# ---------------------------------------------------------------- rotations (bcm_rigid.h)

def quat_axis_angle(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    return np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * axis])


def quat_mul(p, q):
    w1, x1, y1, z1 = p
    w2, x2, y2, z2 = q
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def rot(q):
    """Rotation matrix (body -> space) of the unit quaternion q = (w, x, y, z)."""
    return quat_to_matrix(q)


def quat_from_to(a, b):
    """Unit quaternion turning unit vector a onto unit vector b."""
    a, b = np.asarray(a, float) / np.linalg.norm(a), np.asarray(b, float) / np.linalg.norm(b)
    axis = np.cross(a, b)
    if np.linalg.norm(axis) < 1e-12:
        axis = np.cross(a, [1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.cross(a, [0.0, 1.0, 0.0])
    return quat_axis_angle(axis, math.acos(np.clip(np.dot(a, b), -1, 1)))


IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
VERTEX_DOWN = quat_from_to([1, 1, 1], [0, 0, -1])   # cube with the vertex (a, a, a) at the bottom
VERTEX_UP = quat_from_to([1, 1, 1], [0, 0, 1])
EDGE_UP = quat_axis_angle([1, 0, 0], math.pi / 4)   # cube with its top edge along x


def space_vertices(x, q, a=A):
    return np.asarray(x) + cube(a)[0] @ rot(q).T


def cube_edges():
    verts, faces = cube()
    edges = set()
    for f in faces:
        for k in range(4):
            edges.add(tuple(sorted((f[k], f[(k + 1) % 4]))))
    return sorted(edges)


def segment_closest(p0, p1, q0, q1):
    """Points of two segments: the closest pair when it lies inside both (the case the tests
    use, checked by them), otherwise a clamped pair (an upper bound of the distance)."""
    u, w, r = p1 - p0, q1 - q0, p0 - q0
    uu, ww, uw, ur, wr = u @ u, w @ w, u @ w, u @ r, w @ r
    den = uu * ww - uw * uw
    s = np.clip((uw * wr - ww * ur) / den, 0, 1) if den > 1e-30 else 0.0
    t = np.clip((wr + s * uw) / ww, 0, 1)
    s = np.clip((t * uw - ur) / uu, 0, 1)
    return p0 + s * u, q0 + t * w, s, t


# ---------------------------------------------------------------- LAMMPS set-up

SETUP = """
units si
atom_style hybrid bond sphere
atom_modify map array
boundary f f f
newton {newton}
comm_modify vel yes
region box block -1e-3 1e-3 -1e-3 1e-3 -1e-3 1e-3
create_box 1 box bond/types 1 extra/bond/per/atom 2 extra/special/per/atom 4
fix props all property/atom d2_bcm_quat 4 d2_bcm_inertia 3 d2_bcm_angmom 3 ghost yes
special_bonds lj 0 1 1
timestep {dt}
"""


def setup_cells(lmp, tmp_path, cells, pair=True, newton="on", dt=1e-9, extra=""):
    """cells: list of dicts with x, q and optional v, omega, a (half-side), mass.
    Tags are 1..n in order; every cell is a cube."""
    path = tmp_path / "cells.txt"
    write_cells_file(path, {k + 1: cube(c.get("a", A)) for k, c in enumerate(cells)})
    lmp.commands(SETUP.format(newton=newton, dt=dt))
    for c in cells:
        lmp.command("create_atoms 1 single {} {} {}".format(*c["x"]))
    for k, c in enumerate(cells):
        rad = math.sqrt(3) * c.get("a", A) + RM
        lmp.command(f"set atom {k + 1} diameter {2 * rad * 1.001!r}")
        lmp.command(f"set atom {k + 1} mass {c.get('mass', MASS)!r}")
    lmp.command("mass 1 1.0")
    quat = lmp.numpy.extract_atom("d2_bcm_quat")
    v = lmp.numpy.extract_atom("v")
    omega = lmp.numpy.extract_atom("omega")
    tags = lmp.numpy.extract_atom("id")
    for idx, tag in enumerate(tags):
        c = cells[tag - 1]
        quat[idx] = c["q"]
        v[idx] = c.get("v", (0.0, 0.0, 0.0))
        omega[idx] = c.get("omega", (0.0, 0.0, 0.0))
    if pair:
        lmp.command(f"pair_style bcm/contact cells {path} rm {RM!r}")
        lmp.command(f"pair_coeff * * {KN!r} {KT!r} {EN2!r} {MU!r}")
        lmp.command("compute cp all pair bcm/contact")
        lmp.command("thermo_style custom step pe c_cp[1] c_cp[2] c_cp[3]")
    else:
        lmp.command("pair_style zero 1e-4 nocoeff")
        lmp.command("pair_coeff * *")
    lmp.commands(extra.format(cells=path))
    return path


def per_tag(lmp, name):
    arr = np.array(lmp.numpy.extract_atom(name), dtype=float)
    tags = np.array(lmp.numpy.extract_atom("id"))
    out = np.empty_like(arr)
    out[tags - 1] = arr
    return out


def rerun(lmp):
    """Forces again after a change: one step (no integrator: nothing moves), since the
    computes of thermo keep their values for the step at which they were taken."""
    lmp.command("run 1")


def contact_counts(lmp):
    th = lmp.lmp.last_thermo()
    return int(th["c_cp[1]"]), int(th["c_cp[2]"])


def alpha(en2):
    """SPEC 1.2 Eq. 2."""
    if en2 == 0:
        return 1.0
    ln_e = 0.5 * math.log(en2)
    return -ln_e / math.sqrt(ln_e**2 + math.pi**2)


def assert_vec(actual, expected, scale, rel=1e-9):
    assert np.allclose(actual, expected, rtol=0, atol=rel * scale), (actual, expected)


# ---------------------------------------------------------------- cells file checks

def test_cells_file_rejects_bad_geometry(lmp, tmp_path):
    verts, faces = cube()
    path = tmp_path / "bad.txt"
    write_cells_file(path, {1: (verts, [f[::-1] for f in faces])})  # clockwise faces
    lmp.commands(SETUP.format(newton="on", dt=1e-9))
    with pytest.raises(LammpsError, match="counter-clockwise"):
        lmp.command(f"pair_style bcm/contact cells {path} rm {RM}")
    write_cells_file(path, {1: (verts, faces[:-1])})  # open surface
    with pytest.raises(LammpsError, match="one face only"):
        lmp.command(f"pair_style bcm/contact cells {path} rm {RM}")


def test_missing_cell_and_small_radius_are_errors(lmp, tmp_path):
    path = setup_cells(lmp, tmp_path, [dict(x=(0, 0, 0), q=IDENTITY)])
    write_cells_file(path, {7: cube()})
    lmp.command(f"pair_style bcm/contact cells {path} rm {RM!r}")
    lmp.command(f"pair_coeff * * {KN} {KT} {EN2} {MU}")
    with pytest.raises(LammpsError, match="cell 1 has no geometry"):
        lmp.command("run 0")
    write_cells_file(path, {1: cube()})
    lmp.command(f"pair_style bcm/contact cells {path} rm {RM!r}")
    lmp.command(f"pair_coeff * * {KN} {KT} {EN2} {MU}")
    lmp.command(f"set atom 1 diameter {2 * math.sqrt(3) * A!r}")
    with pytest.raises(LammpsError, match="radius smaller"):
        lmp.command("run 0")


# ---------------------------------------------------------------- pair: geometry of contacts

def stacked(gap, dx=0.0, dy=0.0, qb=IDENTITY):
    return [dict(x=(0.0, 0.0, 0.0), q=IDENTITY), dict(x=(dx, dy, 2 * A + gap), q=qb)]


@pytest.mark.parametrize("dx,dy", [(0.0, 0.0), (0.3 * A, -0.2 * A)])
def test_face_face_four_points_kn_each(lmp, tmp_path, dx, dy):
    setup_cells(lmp, tmp_path, stacked(2 * RM - DELTA, dx, dy))
    lmp.command("run 0")
    f, tq = per_tag(lmp, "f"), per_tag(lmp, "torque")
    # SPEC Eq. 1, k_n per point: 4 corners at overlap delta (was k_n delta, k_n shared by 4)
    fz = 4 * KN * DELTA
    assert_vec(f[1], [0, 0, fz], fz)
    assert_vec(f[0], [0, 0, -fz], fz)
    assert contact_counts(lmp) == (4, 1)
    # overlap rectangle of the two faces, at mid-gap: the four contact points
    xs, ys = (max(-A, dx - A), min(A, dx + A)), (max(-A, dy - A), min(A, dy + A))
    centre = np.array([np.mean(xs), np.mean(ys), A + (2 * RM - DELTA) / 2])
    assert_vec(tq[0], np.cross(centre, f[0]), fz * A)
    assert_vec(tq[1], np.cross(centre - [dx, dy, 2 * A + 2 * RM - DELTA], f[1]), fz * A)
    if dx == dy == 0:
        assert_vec(tq[0], [0, 0, 0], fz * A)
    # stored energy: 4 springs k_n at overlap delta (was 4 springs k_n/4)
    assert lmp.lmp.last_thermo()["PotEng"] == pytest.approx(4 * 0.5 * KN * DELTA**2, rel=1e-9)


def test_face_face_turned_square_gives_octagon(lmp, tmp_path):
    qb = quat_axis_angle([0, 0, 1], math.pi / 4)
    setup_cells(lmp, tmp_path, stacked(2 * RM - DELTA, qb=qb))
    lmp.command("run 0")
    f, tq = per_tag(lmp, "f"), per_tag(lmp, "torque")
    assert contact_counts(lmp) == (8, 1)
    # the 8 corners of the octagon, k_n each (was k_n delta in total)
    assert_vec(f[1], [0, 0, 8 * KN * DELTA], 8 * KN * DELTA)
    assert_vec(tq[0], [0, 0, 0], 8 * KN * DELTA * A)


@pytest.mark.parametrize("theta", [1e-7, 5e-4, 2e-3, 0.05])
def test_face_face_nearly_aligned_keeps_its_patch(lmp, tmp_path, theta):
    """B turned by a small angle about the common normal: the overlap polygon has its corners
    near the squares' corners and edges that cross at a grazing angle (two crossings closer
    than the merge distance are one point); each point carries k_n delta (was: the patch
    carried k_n delta in total, whatever the points), without torque."""
    qb = quat_axis_angle([0, 0, 1], theta)
    setup_cells(lmp, tmp_path, stacked(2 * RM - DELTA, qb=qb))
    lmp.command("run 0")
    f, tq = per_tag(lmp, "f"), per_tag(lmp, "torque")
    npts, npairs = contact_counts(lmp)
    assert npairs == 1 and 4 <= npts <= 8
    assert_vec(f[1], [0, 0, npts * KN * DELTA], npts * KN * DELTA, rel=1e-6)
    assert_vec(tq[0], [0, 0, 0], npts * KN * DELTA * A, rel=1e-3)


@pytest.mark.parametrize("theta", [0.0, 1e-4])
def test_parallel_ridges_two_points(lmp, tmp_path, theta):
    """Edge on edge, parallel (or within 1e-4 rad): a line contact, carried by its two ends."""
    qb = quat_mul(quat_axis_angle([0, 0, 1], theta), EDGE_UP)
    dx = 0.4 * A
    xb = np.array([dx, 0.0, 2 * math.sqrt(2) * A + 2 * RM - DELTA])
    setup_cells(lmp, tmp_path, [dict(x=(0, 0, 0), q=EDGE_UP), dict(x=xb, q=qb)])
    lmp.command("run 0")
    f, tq = per_tag(lmp, "f"), per_tag(lmp, "torque")
    assert contact_counts(lmp) == (2, 1)
    # turned ridges: the end points' normals lean by (lateral offset) / (2 r_m), < 1e-3 here;
    # two points k_n each (was k_n delta in total)
    rel = 1e-9 if theta == 0 else 1e-3
    fz = 2 * KN * DELTA
    assert_vec(f[1], [0, 0, fz], fz, rel=rel)
    # the ends of the overlap of the ridges: x = dx - A and x = A, at mid-gap
    centre = np.array([dx / 2, 0.0, math.sqrt(2) * A + (2 * RM - DELTA) / 2])
    assert_vec(tq[0], np.cross(centre, f[0]), fz * A, rel=rel)


def test_rounding_contact_starts_at_two_rm(lmp, tmp_path):
    setup_cells(lmp, tmp_path, stacked(2 * RM * (1 + 1e-6)))
    lmp.command("run 0")
    assert contact_counts(lmp) == (0, 0)
    assert np.all(per_tag(lmp, "f") == 0)
    x = lmp.numpy.extract_atom("x")
    x[np.array(lmp.numpy.extract_atom("id")) == 2, 2] = 2 * A + 2 * RM * (1 - 1e-6)
    rerun(lmp)
    assert contact_counts(lmp) == (4, 1)
    # 4 corners, k_n each (was k_n in total)
    assert per_tag(lmp, "f")[1, 2] == pytest.approx(4 * KN * 2 * RM * 1e-6, rel=1e-6)


def test_vertex_face_force_at_vertex(lmp, tmp_path):
    gap = 2 * RM - DELTA
    xb = np.array([0.2 * A, -0.3 * A, A + gap + math.sqrt(3) * A])
    setup_cells(lmp, tmp_path, [dict(x=(0, 0, 0), q=IDENTITY), dict(x=xb, q=VERTEX_DOWN)])
    lmp.command("run 0")
    f, tq = per_tag(lmp, "f"), per_tag(lmp, "torque")
    vertex = space_vertices(xb, VERTEX_DOWN)[np.argmin(space_vertices(xb, VERTEX_DOWN)[:, 2])]
    assert vertex[2] - A == pytest.approx(gap, rel=1e-9)
    p = vertex - [0, 0, gap / 2]
    fb = np.array([0, 0, KN * DELTA])
    assert contact_counts(lmp) == (1, 1)
    assert_vec(f[1], fb, KN * DELTA)
    assert_vec(tq[1], np.cross(p - xb, fb), KN * DELTA * A)
    assert_vec(tq[0], np.cross(p, -fb), KN * DELTA * A)


def test_edge_edge_force_along_common_normal(lmp, tmp_path):
    qa = quat_mul(quat_axis_angle([0, 1, 0], math.radians(5)), EDGE_UP)
    qb = quat_mul(quat_axis_angle([0, 0, 1], math.radians(30)),
                  quat_axis_angle([0, 1, 0], math.pi / 4))   # bottom edge along y, turned
    xa = np.zeros(3)
    xb = np.array([0.1 * A, -0.15 * A, 2 * math.sqrt(2) * A + 2 * RM])

    def closest(xb):
        va, vb = space_vertices(xa, qa), space_vertices(xb, qb)
        best = None
        for ea in cube_edges():
            for eb in cube_edges():
                pa, pb, s, t = segment_closest(va[ea[0]], va[ea[1]], vb[eb[0]], vb[eb[1]])
                d = np.linalg.norm(pa - pb)
                if best is None or d < best[0]:
                    best = (d, pa, pb, s, t)
        return best

    d0, pa, pb, s, t = closest(xb)
    assert 0.05 < s < 0.95 and 0.05 < t < 0.95  # a genuine edge-edge crossing
    n = (pa - pb) / d0  # from B to A
    xb = xb + n * (d0 - (2 * RM - DELTA))  # bring the edges to overlap DELTA
    d1, pa, pb, _, _ = closest(xb)
    assert d1 == pytest.approx(2 * RM - DELTA, rel=1e-9)
    setup_cells(lmp, tmp_path, [dict(x=xa, q=qa), dict(x=xb, q=qb)])
    lmp.command("run 0")
    f, tq = per_tag(lmp, "f"), per_tag(lmp, "torque")
    fa = KN * DELTA * n
    p = (pa + pb) / 2
    assert contact_counts(lmp) == (1, 1)
    assert_vec(f[0], fa, KN * DELTA)
    assert_vec(f[1], -fa, KN * DELTA)
    assert_vec(tq[0], np.cross(p - xa, fa), KN * DELTA * A)
    assert_vec(tq[1], np.cross(p - xb, -fa), KN * DELTA * A)


def test_vertex_edge_and_vertex_vertex(lmp, tmp_path):
    # B's bottom vertex beside A's top edge (x axis at height sqrt(2) A): closest point on the edge
    d = 2 * RM - DELTA
    theta = math.atan(0.3)
    vertex = np.array([0.1 * A, d * math.sin(theta), math.sqrt(2) * A + d * math.cos(theta)])
    xb = vertex + [0, 0, math.sqrt(3) * A]
    setup_cells(lmp, tmp_path, [dict(x=(0, 0, 0), q=EDGE_UP), dict(x=xb, q=VERTEX_DOWN)])
    lmp.command("run 0")
    f = per_tag(lmp, "f")
    n = np.array([0, math.sin(theta), math.cos(theta)])
    assert contact_counts(lmp) == (1, 1)
    assert_vec(f[1], KN * DELTA * n, KN * DELTA)


def test_vertex_vertex(lmp, tmp_path):
    d = 2 * RM - DELTA
    n = np.array([0.1, -0.05, 1.0])
    n /= np.linalg.norm(n)
    top = np.array([0, 0, math.sqrt(3) * A])
    xb = top + d * n + [0, 0, math.sqrt(3) * A]
    setup_cells(lmp, tmp_path, [dict(x=(0, 0, 0), q=VERTEX_UP), dict(x=xb, q=VERTEX_DOWN)])
    lmp.command("run 0")
    f, tq = per_tag(lmp, "f"), per_tag(lmp, "torque")
    assert contact_counts(lmp) == (1, 1)
    assert_vec(f[1], KN * DELTA * n, KN * DELTA)
    p = top + d / 2 * n
    assert_vec(tq[0], np.cross(p, -KN * DELTA * n), KN * DELTA * A)


# ---------------------------------------------------------------- pair: force law

def test_normal_damping_and_clamp(lmp, tmp_path):
    w = 0.05  # approach speed
    cells = stacked(2 * RM - DELTA)
    cells[1]["v"] = (0.0, 0.0, -w)
    setup_cells(lmp, tmp_path, cells)
    lmp.command("run 0")
    meff = MASS / 2
    # SPEC Eq. 1 at each of the 4 corners: k_n delta + 2 alpha sqrt(k_n meff / 4) w (the
    # reduced mass shared by the points); in total the face contact 4 k_n with the damping
    # ratio alpha (was k_n delta + 2 alpha sqrt(k_n meff) w in total: k_n shared by the 4)
    expected = 4 * (KN * DELTA + 2 * alpha(EN2) * math.sqrt(KN * meff / 4) * w)
    assert per_tag(lmp, "f")[1, 2] == pytest.approx(expected, rel=1e-9)
    # separating fast: the damping would pull, the force is clamped at zero (per point);
    # 2 alpha sqrt(k_n meff / 4) v > k_n delta from v = 80 m/s (was from 40 m/s with the
    # damping shared by the 4 points, twice the stiffness's share)
    v = lmp.numpy.extract_atom("v")
    v[np.array(lmp.numpy.extract_atom("id")) == 2, 2] = 200.0
    rerun(lmp)
    assert np.all(per_tag(lmp, "f") == 0)


def test_coulomb_friction_pair(lmp, tmp_path):
    vs, dt = 0.1, 1e-8
    cells = stacked(2 * RM - DELTA)
    cells[1]["v"] = (vs, 0.0, 0.0)  # B slides along x; positions stay (no integrator)
    setup_cells(lmp, tmp_path, cells, dt=dt)
    lmp.command("run 3")
    fb = per_tag(lmp, "f")[1]
    # below the Coulomb limit: the 4 corners' tangential springs k_t stretched by 3 v dt
    # (was one spring k_t shared by the 4)
    assert fb[0] == pytest.approx(-4 * KT * 3 * vs * dt, rel=1e-9)
    assert fb[2] == pytest.approx(4 * KN * DELTA, rel=1e-9)
    lmp.command("run 60")  # the springs would exceed mu f_n: sliding
    fb = per_tag(lmp, "f")[1]
    assert fb[0] == pytest.approx(-MU * 4 * KN * DELTA, rel=1e-9)
    assert abs(fb[1]) < 1e-12


def test_dropped_springs_are_booked_between_runs(lmp, tmp_path):
    """A point whose pair of features changes loses its tangential spring (its history is
    keyed by the features): the energy that spring held is booked in [6] (found in a bed: a
    vertex sliding along an edge onto the next one, 1e-8 J lost unbooked). Here the 4 corners
    of an aligned face contact (vertex-face points) are loaded below the Coulomb limit, then B
    is turned by 45 degrees about the normal between two runs: its 8 points are edge
    crossings, none of the 4 keys is carried on. The setup of the next run drops them: k_t
    |u|^2 / 2 each (no step, no work), booked once (not again at the next step)."""
    vs, dt, nsteps = 0.1, 1e-8, 3
    cells = stacked(2 * RM - DELTA)
    cells[1]["v"] = (vs, 0.0, 0.0)  # B slides along x; positions stay (no integrator)
    setup_cells(lmp, tmp_path, cells, dt=dt)
    lmp.command("thermo_style custom step pe c_cp[1] c_cp[2] c_cp[3] c_cp[6]")
    lmp.command(f"run {nsteps}")
    assert contact_counts(lmp) == (4, 1)
    assert lmp.lmp.last_thermo()["c_cp[6]"] == 0.0  # every spring carried on
    # each corner's spring: A's material point relative to B's, -nsteps vs dt along x
    u = nsteps * vs * dt
    assert lmp.lmp.last_thermo()["PotEng"] == pytest.approx(
        4 * (0.5 * KN * DELTA**2 + 0.5 * KT * u**2), rel=1e-9)
    quat = lmp.numpy.extract_atom("d2_bcm_quat")
    quat[np.array(lmp.numpy.extract_atom("id")) == 2] = quat_axis_angle([0, 0, 1], math.pi / 4)
    lmp.command("run 1")  # (thermo's computes keep their values of a step: run 0 would not do)
    th = lmp.lmp.last_thermo()
    assert int(th["c_cp[1]"]) == 8
    assert th["c_cp[6]"] == pytest.approx(4 * 0.5 * KT * u**2, rel=1e-9)
    lmp.command("run 2")  # booked once
    assert lmp.lmp.last_thermo()["c_cp[6]"] == pytest.approx(4 * 0.5 * KT * u**2, rel=1e-9)


def test_dropped_spring_is_booked_during_a_run(lmp, tmp_path):
    """B turned by 45 degrees on A, its vertex on A's face just inside A's edge, moved along x
    (fix move: positions advance, A stays): the vertex-face point of that vertex goes over the
    edge during the run and becomes edge crossings. Its spring, loaded by the sliding (capped
    at the Coulomb limit if it gets there), is booked at that step: k_t |u|^2 / 2 plus the work
    k_t u . Delta / 2 that the cells did against its last force over the half kick opening the
    step (velocity Verlet's quadrature, as [7] counts it), Delta = -vs dt along x."""
    vs, dt = 0.5, 1e-8
    qb = quat_axis_angle([0, 0, 1], math.pi / 4)
    xb = A - math.sqrt(2) * A - 2e-8  # B's vertex at x = A - 2e-8 over A's face
    cells = [dict(x=(0.0, 0.0, 0.0), q=IDENTITY), dict(x=(xb, 0.0, 2 * A + 2 * RM - DELTA), q=qb)]
    out = tmp_path / "series.txt"
    extra = ("group b id 2\n"
             f"fix push b move linear {vs!r} 0.0 0.0\n"
             f"fix series all ave/time 1 1 1 c_cp[1] c_cp[6] file {out}\n")
    setup_cells(lmp, tmp_path, cells, dt=dt, extra=extra)
    lmp.command("run 200")
    rows = np.array([ln.split() for ln in out.read_text().splitlines() if ln and ln[0] != "#"],
                    dtype=float)
    booked = rows[rows[:, 2] > 0]
    assert len(booked), "no spring booked: the vertex never left the face, or [6] books nothing"
    k = int(booked[0, 0])
    assert k > 1
    assert np.all(rows[rows[:, 0] < k, 2] == 0)
    # the spring written at step k - 1: (k - 1) steps of -vs dt, or capped at mu f_n / k_t
    u = min((k - 1) * vs * dt, MU * KN * DELTA / KT)
    expected = 0.5 * KT * (u**2 + u * vs * dt)
    assert booked[0, 2] == pytest.approx(expected, rel=1e-6)


@pytest.mark.parametrize("newton", ["on", "off"])
def test_forces_conserve_momentum(lmp, tmp_path, newton):
    """The offset face-face contact, turned as a whole, with velocities and spins (damping
    and friction at four points): total force and torque about the origin vanish."""
    g = quat_axis_angle([1, 2, 3], 0.7)
    cells = stacked(2 * RM - DELTA, 0.3 * A, -0.2 * A, qb=quat_axis_angle([0, 0, 1], 0.2))
    spin = [(100.0, -50.0, 20.0), (-30.0, 80.0, 10.0)]
    vel = [(0.01, 0.02, -0.03), (-0.02, 0.01, -0.05)]
    for c, w, v in zip(cells, spin, vel):
        c["x"] = rot(g) @ np.asarray(c["x"])
        c["q"] = quat_mul(g, c["q"])
        c["v"], c["omega"] = v, w
    setup_cells(lmp, tmp_path, cells, newton=newton)
    lmp.command("run 2")
    assert contact_counts(lmp)[1] == 1
    f, tq, x = per_tag(lmp, "f"), per_tag(lmp, "torque"), per_tag(lmp, "x")
    scale = np.abs(f).max()
    assert scale > 0.5 * KN * DELTA
    assert_vec(f[0] + f[1], [0, 0, 0], scale, rel=1e-12)
    ang = tq[0] + tq[1] + np.cross(x[0], f[0]) + np.cross(x[1], f[1])
    assert_vec(ang, [0, 0, 0], scale * A, rel=1e-12)


def test_bonded_cells_have_no_contact(lmp, tmp_path):
    setup_cells(lmp, tmp_path, stacked(2 * RM - DELTA), extra="bond_style zero\nbond_coeff 1\n"
                "create_bonds single/bond 1 1 2")
    lmp.command("run 0")
    assert contact_counts(lmp) == (0, 0)
    assert np.all(per_tag(lmp, "f") == 0)


# ---------------------------------------------------------------- fix bcm/wall

def wall_cmd(en2=EN2, mu=MU):
    return (f"fix wall all bcm/wall cells {{cells}} rm {RM!r} plane zlo 0.0 {KN!r} {KT!r} {en2!r} "
            f"{mu!r}\nfix_modify wall energy yes\n"
            "thermo_style custom step pe f_wall[1] f_wall[2] f_wall[3] f_wall[4]\n")


WALL = wall_cmd()


def wall_values(lmp):
    th = lmp.lmp.last_thermo()
    return [th[f"f_wall[{k}]"] for k in range(1, 5)]


def touching(lmp):
    return lmp.numpy.extract_fix("wall", 1, 1)


@pytest.mark.parametrize("q,npts", [(IDENTITY, 4), (EDGE_UP, 2), (VERTEX_DOWN, 1)])
def test_wall_resting_cube(lmp, tmp_path, q, npts):
    d = DELTA
    lowest = space_vertices((0, 0, 0), q)[:, 2].min()
    xc = np.array([0.0, 0.0, RM - d - lowest])
    setup_cells(lmp, tmp_path, [dict(x=xc, q=q)], pair=False, extra=WALL)
    lmp.command("run 0")
    f, tq = per_tag(lmp, "f")[0], per_tag(lmp, "torque")[0]
    # k_n per touching vertex (was the cell's k_n shared by its touching vertices: k_n d)
    fz = npts * KN * d
    assert_vec(f, [0, 0, fz], fz)
    assert_vec(tq, [0, 0, 0], fz * A)
    n, fn, diss, stored = wall_values(lmp)
    assert (n, touching(lmp)[0]) == (1, npts)
    assert fn == pytest.approx(fz, rel=1e-9)
    assert stored == pytest.approx(npts * 0.5 * KN * d * d, rel=1e-9)
    assert lmp.lmp.last_thermo()["PotEng"] == pytest.approx(stored, rel=1e-12)  # fix_modify energy
    assert diss == 0


def test_wall_vertex_torque(lmp, tmp_path):
    q = quat_mul(quat_axis_angle([1, 0, 0], math.radians(30)),
                 quat_axis_angle([0, 1, 0], math.radians(20)))
    verts = space_vertices((0, 0, 0), q)
    order = np.argsort(verts[:, 2])
    assert verts[order[1], 2] - verts[order[0], 2] > 2 * RM  # one vertex only
    d = DELTA
    xc = np.array([0.0, 0.0, RM - d - verts[order[0], 2]])
    setup_cells(lmp, tmp_path, [dict(x=xc, q=q)], pair=False, extra=WALL)
    lmp.command("run 0")
    f, tq = per_tag(lmp, "f")[0], per_tag(lmp, "torque")[0]
    vertex = verts[order[0]] + xc
    p = vertex - [0, 0, (vertex[2] + RM) / 2]
    assert_vec(f, [0, 0, KN * d], KN * d)
    assert_vec(tq, np.cross(p - xc, f), KN * d * A)


def test_wall_coulomb_sliding_and_dissipation(lmp, tmp_path):
    vs, dt, d = 0.1, 1e-8, DELTA
    cells = [dict(x=(0, 0, A + RM - d), q=IDENTITY, v=(vs, 0.0, 0.0))]
    setup_cells(lmp, tmp_path, cells, pair=False, dt=dt, extra=WALL)
    lmp.command("run 50")
    f = per_tag(lmp, "f")[0]
    # 4 touching vertices, each with k_n, k_t and its own Coulomb limit mu f_n,point (were k_n,
    # k_t shared by the 4, the same limit in total): the point's values, then the cell's
    fp = KN * d
    fn = 4 * fp
    assert f[0] == pytest.approx(-MU * fn, rel=1e-9)  # SPEC Eq. 7, opposing the slip
    assert f[2] == pytest.approx(fn, rel=1e-9)
    # each spring saturates at u = mu f_n,point / k_t; the slip beyond it dissipates mu f_n
    # per length
    u_sat = MU * fp / KT
    slip = 50 * vs * dt - u_sat
    n, fnw, diss, stored = wall_values(lmp)
    assert diss == pytest.approx(MU * fn * slip, rel=1e-3)
    # exactly: the force f_k = min(k_t k v dt, mu f_n) of a point does work
    # (f_k-1 + f_k) v dt / 2 over step k (the half kicks of velocity Verlet); what the
    # saturated spring keeps is not lost
    f_t = np.minimum(KT * vs * dt * np.arange(51), MU * fp)
    work = np.sum(0.5 * (f_t[1:] + f_t[:-1])) * vs * dt
    assert diss == pytest.approx(4 * (work - 0.5 * KT * u_sat**2), rel=1e-9)
    assert stored == pytest.approx(4 * (0.5 * fp * d + 0.5 * KT * u_sat**2), rel=1e-9)


def rigid_props(lmp, cells):
    """Principal moments of the cubes (side 2(A + RM) of mass MASS) and angular momenta."""
    inertia = lmp.numpy.extract_atom("d2_bcm_inertia")
    angmom = lmp.numpy.extract_atom("d2_bcm_angmom")
    tags = lmp.numpy.extract_atom("id")
    side = 2 * (A + RM)
    moment = MASS * side**2 / 6
    for idx, tag in enumerate(tags):
        inertia[idx] = moment
        angmom[idx] = moment * np.asarray(cells[tag - 1].get("omega", (0, 0, 0)))
    return moment


def test_wall_drop_restitution(lmp, tmp_path):
    """A cube dropped flat: its 4 corners touch together, a contact of stiffness 4 k_n whose
    points' damping 4 x 2 alpha sqrt(k_n m / 4) = 2 alpha sqrt(4 k_n m) gives it the damping
    ratio alpha (was k_n and 2 alpha sqrt(k_n m) shared by the 4: the same ratio, so the same
    rebound, at half the contact's duration now)."""
    v0 = 1.0
    kface = 4 * KN
    period = math.pi * math.sqrt(MASS / kface)
    dt = period / 1000
    cells = [dict(x=(0, 0, A + RM + 5 * v0 * dt), q=IDENTITY, v=(0.0, 0.0, -v0))]
    setup_cells(lmp, tmp_path, cells, pair=False, dt=dt,
                extra=wall_cmd(en2=0.25, mu=0.0) + "fix move all bcm/rigid\n")
    rigid_props(lmp, cells)
    lmp.command("run 1500")
    v = per_tag(lmp, "v")[0]
    assert wall_values(lmp)[0] == 0  # left the wall

    # expectation: the 1D spring-dashpot of SPEC Eq. 1 with the clamp f_n >= 0
    from scipy.integrate import solve_ivp  # noqa: PLC0415
    gam = 2 * alpha(0.25) * math.sqrt(kface * MASS)

    def rhs(_, y):
        s, sdot = y  # overlap and its rate
        return [sdot, -max(0.0, kface * s + gam * sdot) / MASS]

    def leave(_, y):
        return kface * y[0] + gam * y[1] if y[0] > 0 else y[0]
    leave.terminal, leave.direction = True, -1
    sol = solve_ivp(rhs, (0, 10 * period), [0.0, v0], events=leave, rtol=1e-11, atol=1e-16,
                    max_step=period / 1000)
    v_out = -sol.y_events[0][0][1]
    assert v[2] / v0 == pytest.approx(v_out / v0, rel=2e-3)
    assert abs(v[2] / v0 - 0.5) < 0.1  # close to e_n
    # energy: kinetic loss = dissipated at the wall, up to the O(h^2) error of velocity
    # Verlet on the elastic force (1e-6 at 1000 steps per contact period): the damping work
    # is the exact work of its half kicks
    n, fn, diss, stored = wall_values(lmp)
    assert diss == pytest.approx(0.5 * MASS * (v0**2 - v[2] ** 2), rel=1e-5)


def test_two_cell_collision_conserves_momenta(lmp, tmp_path):
    qb = quat_axis_angle([1, 1, 0], 0.6)
    # B's lowest vertex 2 r_m + 1e-7 above A's top face, off centre
    xb = np.array([0.4 * A, -0.3 * A, 0.0])
    xb[2] = A + 2 * RM + 1e-7 - space_vertices(xb, qb)[:, 2].min()
    cells = [dict(x=(0.0, 0.0, 0.0), q=IDENTITY, v=(0.0, 0.0, 0.5), omega=(0, 2000.0, 0)),
             dict(x=xb, q=qb, v=(0.1, 0.0, -0.5), omega=(-1000.0, 0, 3000.0))]
    period = math.pi * math.sqrt(MASS / 2 / KN)
    setup_cells(lmp, tmp_path, cells, dt=period / 100, extra="fix move all bcm/rigid")
    moment = rigid_props(lmp, cells)

    def momenta():
        x, v = per_tag(lmp, "x"), per_tag(lmp, "v")
        angmom = lmp.numpy.extract_atom("d2_bcm_angmom")
        tags = np.array(lmp.numpy.extract_atom("id"))
        lsum = np.array(angmom)[np.argsort(tags)].sum(axis=0)
        return MASS * v.sum(axis=0), MASS * np.cross(x, v).sum(axis=0) + lsum

    p0, l0 = momenta()
    lmp.command("run 3000")
    assert lmp.lmp.last_thermo()["c_cp[2]"] == 0  # they met and parted
    p1, l1 = momenta()
    pscale = MASS * 0.5
    assert_vec(p1, p0, pscale, rel=1e-10)
    assert_vec(l1, l0, pscale * A + moment * 3000.0, rel=1e-9)
    # they did touch: the velocities changed
    assert not np.allclose(per_tag(lmp, "v")[0], cells[0]["v"])


def test_two_cell_collision_energy_accounting(lmp, tmp_path):
    """A glancing, spinning collision of two cubes with damping and friction: after they part,
    the kinetic energy lost equals what the pair reports as dissipated (damping, Coulomb slip,
    changes of the number of points), and the work it reports its forces did equals the
    change of kinetic energy."""
    qb = quat_axis_angle([1, 1, 0], 0.6)
    xb = np.array([0.4 * A, -0.3 * A, 0.0])
    xb[2] = A + 2 * RM + 1e-7 - space_vertices(xb, qb)[:, 2].min()
    cells = [dict(x=(0.0, 0.0, 0.0), q=IDENTITY, v=(0.3, 0.0, 0.5), omega=(0, 2000.0, 0)),
             dict(x=xb, q=qb, v=(-0.2, 0.1, -0.5), omega=(-1000.0, 0, 3000.0))]
    period = math.pi * math.sqrt(MASS / 2 / KN)
    setup_cells(lmp, tmp_path, cells, dt=period / 100, extra="fix move all bcm/rigid\n"
                "thermo_style custom step pe c_cp[1] c_cp[2] c_cp[3] c_cp[4] c_cp[5] c_cp[6] c_cp[7]")
    moment = rigid_props(lmp, cells)

    def kinetic():
        v = per_tag(lmp, "v")
        angmom = np.array(lmp.numpy.extract_atom("d2_bcm_angmom"))
        return 0.5 * MASS * (v * v).sum() + 0.5 * (angmom * angmom).sum() / moment

    k0 = kinetic()
    lmp.command("run 3000")
    th = lmp.lmp.last_thermo()
    assert th["c_cp[2]"] == 0 and th["PotEng"] == 0  # they met and parted
    k1 = kinetic()
    damp, fric, npts, work = (th[f"c_cp[{k}]"] for k in (4, 5, 6, 7))
    assert damp > 0 and fric > 0
    assert k0 - k1 > 0.05 * k0
    # the work is settled exactly for translation, to second order in h with rotation
    assert work == pytest.approx(k1 - k0, rel=1e-4)
    # the elastic forces give back what they stored, up to velocity Verlet's O(h^2)
    assert damp + fric + npts == pytest.approx(k0 - k1, rel=1e-3)


# ---------------------------------------------------------------- MPI: history across ranks

MPI_INPUT = """
plugin load {plugin}
units si
atom_style hybrid bond sphere
atom_modify map array
boundary f f f
newton {newton}
comm_modify vel yes
processors {procs}
region box block -4e-4 4e-4 -4e-4 4e-4 -2e-4 2e-4
create_box 1 box bond/types 1 extra/bond/per/atom 2 extra/special/per/atom 4
fix props all property/atom d2_bcm_quat 4 d2_bcm_inertia 3 d2_bcm_angmom 3 ghost yes
special_bonds lj 0 1 1
create_atoms 1 single {xa} {y0} 0
create_atoms 1 single {xb} {y0} 0
set atom * diameter {diam}
set atom * mass {mass}
mass 1 1.0
set atom * d2_bcm_quat[1] 1.0
set atom * d2_bcm_inertia[1] {moment}
set atom * d2_bcm_inertia[2] {moment}
set atom * d2_bcm_inertia[3] {moment}
velocity all set 0.0 50.0 0.0
group top id 2
group bottom id 1
velocity top set 0.0 50.0 {vrel}
pair_style bcm/contact cells {cells} rm {rm}
pair_coeff * * {kn} {kt} 0.001 {mu}
fix left all bcm/wall cells {cells} rm {rm} plane xlo {xlo} {kn} {kt} 0.001 0.0
fix right all bcm/wall cells {cells} rm {rm} plane xhi {xhi} {kn} {kt} 0.001 0.0
fix load2 top addforce 0.0 0.0 {fz}
fix load1 bottom addforce 0.0 0.0 {mfz}
neighbor 1e-6 bin
neigh_modify every 1 delay 0 check no
fix move all bcm/rigid
timestep {dt}
variable dx equal x[2]-x[1]
variable dz equal z[2]-z[1]
variable y1 equal y[1]
thermo 1000
run {steps}
print "RESULT ${{dx}} ${{dz}} ${{y1}}"
"""


def run_lmp(tmp_path, nprocs, text):
    import subprocess  # noqa: PLC0415

    from driver.engine import venv_bin  # noqa: PLC0415

    inp = tmp_path / f"in.{nprocs}"
    inp.write_text(text)
    cmd = [venv_bin("mpiexec"), "-n", str(nprocs), venv_bin("lmp"), "-in", inp.name,
           "-log", f"log.{nprocs}", "-screen", "none", "-nocite"]
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    log = (tmp_path / f"log.{nprocs}").read_text()
    assert proc.returncode == 0, log[-2000:] + proc.stderr
    line = [ln for ln in log.splitlines() if ln.startswith("RESULT")][-1]
    return np.array([float(t) for t in line.split()[1:]])


@pytest.mark.mpi
@pytest.mark.parametrize("newton", ["on", "off"])
@pytest.mark.parametrize("layout,sign", [("split", 1.0), ("split", -1.0), ("migrate", 1.0)])
def test_history_follows_cells_across_ranks(plugin_path, tmp_path, newton, layout, sign):
    """Two cells side by side along x, held face to face between two frictionless walls
    (fix bcm/wall xlo and xhi), glide along y, reneighboring every step; cell 2 starts with
    a small velocity along z relative to cell 1, taken up by static friction. 'split': one
    rank per cell (processors 2 1 1) and the cells pulled apart along z with a quarter of
    the Coulomb limit of the face contact, 4 points of mu k_n d each (applied at once, the
    undamped springs overshoot to half of it); with
    newton on, the rank of the cell lower in z computes the pair, so the sign of the load
    picks whether the ghost is the cell of smaller tag. 'migrate': both cells cross from one
    rank to the other (processors 1 2 1). The springs must carry on (the cells stick) and
    the two-rank run must follow the one-rank run."""
    cells = tmp_path / "cells.txt"
    write_cells_file(cells, {1: cube(), 2: cube()})
    d, vrel = 1e-8, 0.01 * sign        # overlap of each contact, relative velocity
    xc = A + RM - d / 2                 # centres at -xc, +xc: cell-cell overlap d
    xwall = 2 * A + 2 * RM - 1.5 * d    # walls: overlap d with the outer faces
    fz = 0.25 * MU * 4 * KN * d * sign if layout == "split" else 0.0
    period = math.pi * math.sqrt(MASS / 2 / KN)
    moment = MASS * (2 * (A + RM)) ** 2 / 6
    steps = 8000
    y0 = -2.0 * A if layout == "migrate" else 0.0
    text = MPI_INPUT.format(
        plugin=plugin_path, newton=newton, procs="* 1 1" if layout == "split" else "1 * 1",
        xa=-xc, xb=xc, y0=y0, vrel=vrel, fz=fz, mfz=-fz,
        diam=2 * (math.sqrt(3) * A + RM) * 1.001, mass=MASS, moment=moment, cells=cells, rm=RM,
        kn=KN, kt=KT, mu=MU, xlo=-xwall, xhi=xwall, dt=period / 50, steps=steps)
    one, two = run_lmp(tmp_path, 1, text), run_lmp(tmp_path, 2, text)
    if layout == "migrate":
        assert one[2] > 0.2 * A  # crossed y = 0
    # stuck: far below free sliding
    slide = abs(vrel) * steps * period / 50
    assert abs(one[1]) < 0.1 * slide
    assert two[1] == pytest.approx(one[1], rel=1e-9)
    assert two[0] == pytest.approx(one[0], rel=1e-12)
