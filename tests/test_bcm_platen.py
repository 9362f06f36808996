"""fix bcm/wall with a moving plane (a platen, SPEC 4.1): one cube crushed between a fixed
and a moving plane, against the contact law of SPEC 1.2 with the plane's velocity in the
relative velocity, and the energy account of plugins/doc/fix_bcm_wall.md ("How the work is
counted"): [8] = -(change of [4]) - [3] + [11] for each plane, W_p = [11].

The cube (core half-side A, rounding RM, mass MASS: tests/test_bcm_contact.py) lies face down
on one plane, at zero overlap; the other plane comes at it at the speed VP, starting GAP
away. Each plane touches with the 4 vertices of a face, K = 4 k_n (k_n per vertex, SPEC 1.2
and plugins/src/bcm_contact_law.h), and the damping of the 4 points adds up to
C = 4 x 2 alpha sqrt(k_n m / 4) = 2 alpha sqrt(K m).

The rigid cell between the two platens (derivation of the line of test_platen_force_line).
Let s be the moving plane's travel past first contact (its displacement less GAP), z the
cell's displacement along the same direction. The cell is rigid, so the two contacts are the
only springs, in series: the fixed plane's overlap is z, the moving plane's s - z, and
    m z'' = F_moving - F_fixed = K (s - 2 z) + C (VP - 2 z'),
the damping of each contact acting on its own rate of overlap, relative to its plane (VP - z'
against the moving one: the SPEC 4.1 relative velocity). With s = VP t the particular
solution is z = VP t / 2 = s / 2 exactly (z' = VP / 2; no offset, since both contacts have
the same rate of overlap VP / 2), and the homogeneous part, of frequency sqrt(2 K / m) and
damping ratio sqrt(2) alpha, starts from z = 0, z' = 0 and dies out. Then both contacts have
the overlap s / 2 and the overlap rate VP / 2, and
    F_fixed = F_moving = K s / 2 + C VP / 2 = 2 k_n s + alpha sqrt(K m) VP,
two springs K in series (2 k_n) plus the damping of either contact at half the platen's
speed. A law that left the plane's velocity out of the moving contact's damping would see
that contact opening at VP / 2 instead of closing: -C VP / 2 there, +C VP / 2 at the fixed
one, and both forces at K s / 2: the offset C VP / 2 is the test of the relative velocity.
Velocity Verlet keeps this steady state exactly (constant velocities, forces balanced), so
after the transient the forces are on the line to round-off. Each contact stores
4 k_n (s / 2)^2 / 2.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_bcm_contact import (
    A,
    IDENTITY,
    KN,
    KT,
    MASS,
    RM,
    cube,
    per_tag,
    quat_axis_angle,
    rigid_props,
    setup_cells,
    space_vertices,
    write_cells_file,
)

from driver.bcm.section import BCMModel
from driver.bcm.styles import wall_setup
from driver.engine import Lammps, LammpsError

K = 4 * KN                                      # a face on a plane: 4 vertices of k_n
OMEGA = math.sqrt(2 * K / MASS)                 # the cell between the two contacts
PERIOD = 2 * math.pi / OMEGA
DT = PERIOD / 200
VP = 0.2                                        # the platen's speed (m/s)
GAP = 20 * VP * DT                              # the moving plane starts this far from the cube
ZC = A + RM                                     # the cube on z = 0 at zero overlap
ZHI = ZC + A + RM                               # a zhi plane touching its top face at zero overlap


def alpha(en2):
    """SPEC 1.2 Eq. 2."""
    if en2 == 0:
        return 1.0
    ln_e = 0.5 * math.log(en2)
    return -ln_e / math.sqrt(ln_e**2 + math.pi**2)


def planes(moving, en2, mu):
    """fix lower (zlo) and fix upper (zhi) around the cube at ZC: the `moving` one ("lower" or
    "upper") starts GAP away and comes at the cube at VP (its velocity along +z: VP for the
    lower plane, -VP for the upper one); the other touches the cube at zero overlap."""
    lines = []
    for fix, face, rest, sign in (("lower", "zlo", 0.0, -1.0), ("upper", "zhi", ZHI, 1.0)):
        coord = rest + sign * GAP if fix == moving else rest
        velocity = f" velocity {-sign * VP!r}" if fix == moving else ""
        lines.append(f"fix {fix} all bcm/wall cells {{cells}} rm {RM!r} plane {face} {coord!r} "
                     f"{KN!r} {KT!r} {en2!r} {mu!r}{velocity}")
    return "\n".join(lines) + "\n"


def vector(lmp, fix, k):
    """f_fix[k] (1-based), straight from the fix."""
    return lmp.extract_fix(fix, 0, 1, k - 1)


def read_series(path):
    rows = [ln.split() for ln in path.read_text().splitlines() if ln and not ln.startswith("#")]
    return np.array(rows, dtype=float)


# ---------------------------------------------------------------- (a) the force line

@pytest.mark.parametrize("moving", ["upper", "lower"])
def test_platen_force_line(lmp, tmp_path, moving):
    """Quasi-static crushing with damping (contact e_n^2 = 0.001): after the transient (20
    of its slowest decay times), the two planes carry the same force, on the line
    F = 2 k_n s + C VP / 2 of the module's derivation, each storing 4 k_n (s/2)^2 / 2; the
    moving plane's position and velocity are [9] and [10]. The upper plane moving down
    (velocity < 0 along +z) and the lower one moving up (> 0) give the same line."""
    en2, mu = 0.001, 0.3
    out = tmp_path / "force.txt"
    extra = planes(moving, en2, mu) + (
        "fix move all bcm/rigid\n"
        f"fix series all ave/time 10 1 10 f_lower[2] f_upper[2] f_{moving}[9] f_{moving}[10] "
        f"f_lower[4] f_upper[4] f_lower[1] f_upper[1] file {out} format \" %.17g\"\n")
    cells = [dict(x=(0.0, 0.0, ZC), q=IDENTITY)]
    setup_cells(lmp, tmp_path, cells, pair=False, dt=DT, extra=extra)
    rigid_props(lmp, cells)
    lmp.command("run 0")
    start = vector(lmp, moving, 9)
    assert start == (-GAP if moving == "lower" else ZHI + GAP)
    steps = 3000
    lmp.command(f"run {steps}")

    data = read_series(out)
    step, f_lo, f_up, pos, vel, e_lo, e_up, n_lo, n_up = data.T
    sign = 1.0 if moving == "lower" else -1.0
    assert np.all(vel == sign * VP)
    # coord += V h each step
    np.testing.assert_allclose(pos, start + sign * VP * DT * step, rtol=0, atol=1e-9 * VP * DT * steps)
    s = sign * (pos - start) - GAP                # the travel past first contact
    c = 2 * alpha(en2) * math.sqrt(K * MASS)
    zeta = math.sqrt(2) * alpha(en2)
    slowest = OMEGA * (zeta - math.sqrt(zeta * zeta - 1)) if zeta > 1 else OMEGA * zeta
    settled = s > VP * 20 / slowest
    assert settled.sum() > 100 and settled[-1]
    assert np.all(n_lo[settled] == 1) and np.all(n_up[settled] == 1)   # one cell each
    line = K * s / 2 + c * VP / 2
    assert line[-1] > 10 * c * VP / 2 > 0        # the offset is a few per cent of the force
    for f in (f_lo, f_up):
        np.testing.assert_allclose(f[settled], line[settled], rtol=0, atol=1e-4 * c * VP / 2)
    np.testing.assert_allclose(f_up[settled], f_lo[settled], rtol=1e-9)
    stored = 4 * 0.5 * KN * (s / 2) ** 2
    for e in (e_lo, e_up):
        np.testing.assert_allclose(e[settled], stored[settled], rtol=1e-6)
    # the cell moves at half the platen's speed
    assert per_tag(lmp, "v")[0][2] == pytest.approx(sign * VP / 2, rel=1e-9)
    # before the moving plane reached the cube, nothing touched
    # (the fixed plane touches at zero overlap to round-off: 1e-21 m, 1e-13 N)
    before = s < -VP * DT
    assert before.any() and np.all(f_lo[before] < 1e-9) and np.all(f_up[before] < 1e-9)


# ---------------------------------------------------------------- (b) the energy account

@pytest.mark.parametrize("en2,mu,drift,exact", [
    pytest.param(1.0, 10.0, 0.0, 1e-12, id="elastic"),
    pytest.param(1.0, 10.0, 0.1, 1e-11, id="elastic-drifting-no-slip"),
    pytest.param(0.25, 0.3, 5.0, 1e-9, id="damped-slipping"),
])
def test_platen_energy_balance(lmp, tmp_path, en2, mu, drift, exact):
    """The upper plane comes down at VP onto the cube, which may also drift sideways at
    `drift` VP (its tangential springs load and tilt it a little; damped, with mu = 0.3, it
    slides on both planes). The account of plugins/doc/fix_bcm_wall.md:

    - each plane, read during the run: [8] = -(change of [4]) - [3] + [11]. Every work is a
      trapezoid on the displacements (bcm_kick_work.h), which is what a linear spring
      stores, so this is exact to round-off for the translating cube (1e-12 of W_p), and
      to velocity Verlet's second order with the drifting cube's small rotation and the
      damping's clamp (1e-11, 1e-9);
    - the whole, after `run 0` (every half kick settled: [8] summed over the planes is the
      change of kinetic energy), W_p = [11] of the moving plane:
          W_p = change of (kinetic + stored) + dissipated            to 1e-6 of W_p,
      and to round-off as above with velocity Verlet's own term: its full-step kinetic
      energy differs from the trapezoid by (h^2 / 8 m) |F|^2 at the instant it is read, F
      the net force on the cell (0 at the start), which does not accumulate.

    Elastic, nothing is dissipated but the slip of a drifting vertex at the step its contact
    begins (f_n ~ 0: 1e-15 J); damped, damping ([5]) and slip ([6]) take 1 % each. W_p is
    also the trapezoid (h/2) sum (F_k + F_k+1) VP of the upper plane's force at every step."""
    out = tmp_path / "series.txt"
    extra = planes("upper", en2, mu) + (
        "fix move all bcm/rigid\n"
        "compute ke all ke\n"
        f"fix series all ave/time 1 1 1 f_upper[2] file {out} format \" %.17g\"\n")
    cells = [dict(x=(0.0, 0.0, ZC), q=IDENTITY, v=(drift * VP, 0.5 * drift * VP, 0.0))]
    setup_cells(lmp, tmp_path, cells, pair=False, dt=DT, extra=extra)
    rigid_props(lmp, cells)
    lmp.command("thermo_style custom step c_ke f_move")

    def kinetic():
        lmp.command("run 0")
        th = lmp.lmp.last_thermo()
        return th["c_ke"] + th["f_move"]

    k0 = kinetic()
    steps = 3000
    lmp.command(f"run {steps}")
    w_p = vector(lmp, "upper", 11)
    assert w_p > 0 and vector(lmp, "lower", 11) == 0
    for fix in ("upper", "lower"):
        w8, e4, d3, w11 = (vector(lmp, fix, k) for k in (8, 4, 3, 11))
        assert abs(w8 - (-e4 - d3 + w11)) < exact * w_p, fix

    k1 = kinetic()                                # run 0: the last half kick settled
    stored = vector(lmp, "upper", 4) + vector(lmp, "lower", 4)
    dissipated = vector(lmp, "upper", 3) + vector(lmp, "lower", 3)
    assert stored > 0.5 * w_p
    slip = vector(lmp, "upper", 6) + vector(lmp, "lower", 6)
    if en2 == 1.0:
        assert vector(lmp, "upper", 5) == vector(lmp, "lower", 5) == 0
        assert slip == 0 if drift == 0.0 else slip < 1e-7 * w_p
    else:
        assert min(vector(lmp, fix, k) for fix in ("upper", "lower") for k in (5, 6)) > 1e-3 * w_p
    residual = w_p - (k1 - k0 + stored + dissipated)
    assert abs(residual) < 1e-6 * w_p, residual / w_p
    f_net = per_tag(lmp, "f")[0]
    shadow = DT**2 / (8 * MASS) * (f_net @ f_net)
    assert abs(residual + shadow) < exact * w_p, (residual + shadow) / w_p

    # W_p: the force of each step over the platen's displacement VP h (a run's setup writes
    # its step again: the first row of each step is the run's); to 1e-9, since W_p takes the
    # displacement of the stored position, which rounds VP h by up to 4e-10 of it
    series = read_series(out)
    _, first = np.unique(series[:, 0], return_index=True)
    f = series[np.sort(first), 1]
    assert len(f) == steps + 1
    trapezoid = 0.5 * DT * VP * np.sum(f[1:] + f[:-1])
    assert w_p == pytest.approx(trapezoid, rel=1e-9)


# ---------------------------------------------------------------- (c) a plane at rest

THERMO = ("thermo_style custom step " + " ".join(f"f_wall[{k}]" for k in range(1, 12)) + "\n"
          "thermo 10\nthermo_modify norm no format float %.17g\n")


@pytest.mark.parametrize("velocity", [" velocity 0.0", " velocity v_zero"])
def test_plane_at_velocity_zero_is_the_plane_at_rest(plugin_path, tmp_path, velocity):
    """A tilted, spinning, drifting cube dropped on the plane (it lands tilted, with
    damping and Coulomb slip) gives the very same records, to the last printed bit (%.17g),
    and the same final state, with `velocity 0.0` or a zero variable as without the keyword;
    [9], [10], [11] print 0."""
    q = quat_axis_angle([1.0, 0.3, 0.0], 0.05)
    cells = [dict(x=(0.0, 0.0, 0.0), q=q, v=(0.3, 0.1, -1.0), omega=(2000.0, -1000.0, 500.0))]
    lowest = space_vertices((0.0, 0.0, 0.0), q)[:, 2].min()
    cells[0]["x"] = (0.0, 0.0, RM - lowest + 5 * 1.0 * DT)

    def records(kw, name):
        log = tmp_path / f"{name}.log"
        with Lammps() as lmp:
            lmp.command(f"plugin load {plugin_path}")
            lmp.command("variable zero equal 0.0")
            extra = (f"fix wall all bcm/wall cells {{cells}} rm {RM!r} plane zlo 0.0 {KN!r} {KT!r} "
                     f"0.25 0.3{kw}\nfix move all bcm/rigid\n" + THERMO)
            setup_cells(lmp, tmp_path, cells, pair=False, dt=DT, extra=extra)
            rigid_props(lmp, cells)
            lmp.command(f"log {log}")
            lmp.command("run 1500")
            state = {n: per_tag(lmp, n) for n in ("x", "v", "omega", "d2_bcm_quat", "d2_bcm_angmom")}
        rows = [ln.split() for ln in log.read_text().splitlines()
                if ln.split() and ln.split()[0].isdigit() and len(ln.split()) == 12]
        return rows, state

    rows_rest, state_rest = records("", "rest")
    rows_zero, state_zero = records(velocity, "zero")
    assert len(rows_rest) == 151
    touched = [r for r in rows_rest if float(r[1]) > 0]
    assert touched and float(rows_rest[-1][5]) > 0 and float(rows_rest[-1][6]) > 0   # damping, slip
    assert all(r[9] == "0" and r[10] == "0" and r[11] == "0" for r in rows_rest)
    assert rows_zero == rows_rest
    for name, value in state_rest.items():
        assert np.array_equal(state_zero[name], value), name


# ---------------------------------------------------------------- (d) restart

N1, N2 = 1600, 800
RESPECIFIED = """
fix props all property/atom d2_bcm_quat 4 d2_bcm_inertia 3 d2_bcm_angmom 3 ghost yes
comm_modify vel yes
{planes}
fix move all bcm/rigid
thermo_style custom step {columns}
thermo 10
thermo_modify norm no format float %.17g
"""
COLUMNS = " ".join(f"f_{p}[{k}]" for p in ("upper", "lower") for k in range(1, 12))


def restart_system(cells_file):
    """The cube between the planes, drifting and spinning, the upper plane coming down (the
    restart falls while both touch, slipping, with damping): the first instance's commands."""
    moment = MASS * (2 * (A + RM)) ** 2 / 6
    v, omega = (0.1 * VP, 0.05 * VP, 0.0), (0.0, 0.0, 3000.0)
    fixes = RESPECIFIED.format(planes=planes("upper", 0.25, 0.3).format(cells=cells_file),
                               columns=COLUMNS)
    after_atoms = fixes.split("\n", 2)[2]     # fix props comes before the atoms
    return f"""
units si
atom_style hybrid bond sphere
atom_modify map array
boundary f f f
newton on
region box block -1e-3 1e-3 -1e-3 1e-3 -1e-3 1e-3
create_box 1 box bond/types 1 extra/bond/per/atom 2 extra/special/per/atom 4
special_bonds lj 0 1 1
timestep {DT!r}
fix props all property/atom d2_bcm_quat 4 d2_bcm_inertia 3 d2_bcm_angmom 3 ghost yes
create_atoms 1 single 0.0 0.0 {ZC!r}
set group all diameter {2 * (math.sqrt(3) * A + RM) * 1.001!r} mass {MASS!r} \
d2_bcm_inertia[1] {moment!r} d2_bcm_inertia[2] {moment!r} d2_bcm_inertia[3] {moment!r}
mass 1 1.0
set atom 1 d2_bcm_quat[1] 1.0 vx {v[0]!r} vy {v[1]!r} vz 0.0 omega {omega[0]!r} {omega[1]!r} \
{omega[2]!r} d2_bcm_angmom[3] {moment * omega[2]!r}
pair_style zero 1e-4 nocoeff
pair_coeff * *
""" + after_atoms, fixes


def thermo_rows(log):
    rows = []
    for line in log.read_text().splitlines():
        words = line.split()
        if words[:1] == ["Step"]:
            rows = []
        elif words and words[0].isdigit() and len(words) == 1 + 22:
            rows.append(words)
    return rows


def test_restart_continues_the_plane(plugin_path, tmp_path):
    """Run A: `run N1` and `run N2` in one instance, writing a restart file between them.
    Run B: `run N1`, write_restart, and a new instance that reads it, re-issues the commands
    (the moving plane's at its starting VALUE) and does `run N2`. The plane carries on from
    where it was ([9] at N1, not VALUE), and B follows A to the last printed bit: every
    value of both planes, W_p [11] included, and the cell's state."""
    cells_file = tmp_path / "cells.txt"
    text, fixes = restart_system(cells_file)

    def state(lmp):
        return {n: per_tag(lmp, n) for n in ("x", "v", "omega", "d2_bcm_quat", "d2_bcm_angmom")}

    with Lammps() as a:
        a.command(f"plugin load {plugin_path}")
        write_cells_file(cells_file, {1: cube()})
        a.commands(text)
        a.command(f"run {N1}")
        at_restart = a.lmp.last_thermo()
        a.command(f"write_restart {tmp_path / 'a.restart'}")
        a.command(f"log {tmp_path / 'a.log'}")
        a.command(f"run {N2}")
        end_a = state(a)
    with Lammps() as b:
        b.command(f"plugin load {plugin_path}")
        b.commands(text)
        b.command(f"run {N1}")
        b.command(f"write_restart {tmp_path / 'b.restart'}")
    with Lammps() as c:
        c.command(f"plugin load {plugin_path}")
        c.command(f"read_restart {tmp_path / 'b.restart'}")
        c.commands(fixes)
        c.command(f"log {tmp_path / 'c.log'}")
        c.command(f"run {N2}")
        end_c = state(c)

    # the restart fell in the crushing: both planes touch, the upper one has moved
    assert at_restart["f_upper[1]"] == 1 and at_restart["f_lower[1]"] == 1
    assert at_restart["f_upper[9]"] == pytest.approx(ZHI + GAP - VP * DT * N1, rel=1e-12)
    assert at_restart["f_upper[11]"] > 0 and at_restart["f_upper[6]"] > 0
    rows_a, rows_c = thermo_rows(tmp_path / "a.log"), thermo_rows(tmp_path / "c.log")
    assert len(rows_a) == N2 // 10 + 1
    assert float(rows_c[0][9]) == at_restart["f_upper[9]"]       # where it was, not VALUE
    assert float(rows_a[-1][9]) < float(rows_a[0][9])             # and it goes on down
    assert rows_c == rows_a
    for name, value in end_a.items():
        assert np.array_equal(end_c[name], value), name


# ---------------------------------------------------------------- two ranks

MPI_INPUT = """
plugin load {plugin}
units si
atom_style hybrid bond sphere
atom_modify map array
boundary f f f
newton on
comm_modify vel yes
processors * 1 1
region box block -4e-4 4e-4 -4e-4 4e-4 -2e-4 2e-4
create_box 1 box bond/types 1 extra/bond/per/atom 2 extra/special/per/atom 4
fix props all property/atom d2_bcm_quat 4 d2_bcm_inertia 3 d2_bcm_angmom 3 ghost yes
special_bonds lj 0 1 1
create_atoms 1 single {x0!r} 0.0 {zc!r}
set atom 1 diameter {diam!r} mass {mass!r} d2_bcm_quat[1] 1.0 d2_bcm_inertia[1] {moment!r} &
    d2_bcm_inertia[2] {moment!r} d2_bcm_inertia[3] {moment!r} vx {vx!r} vy {vy!r}
mass 1 1.0
pair_style zero 1e-4 nocoeff
pair_coeff * *
{planes}
neighbor 1e-6 bin
neigh_modify every 1 delay 0 check no
fix move all bcm/rigid
timestep {dt!r}
run {steps}
print "RESULT $(x[1]:%.17g) $(vz[1]:%.17g) {values}"
"""


@pytest.mark.mpi
def test_platen_on_two_ranks(plugin_path, tmp_path):
    """The damped, slipping crush of test_platen_energy_balance, the cube starting 5e-10 m
    from the boundary of two ranks (processors 2 1 1, x = 0) and crossing it, sliding, as
    the planes close on it (step 27; the upper one touches at step 20): on two ranks the planes' position and velocity ([9], [10], the same on every rank, not summed)
    and every sum, W_p [11] included, are those of one rank."""
    from test_bcm_contact import run_lmp  # noqa: PLC0415

    cells_file = tmp_path / "cells.txt"
    write_cells_file(cells_file, {1: cube()})
    columns = [f"f_{p}[{k}]" for p in ("upper", "lower") for k in range(1, 12)]
    text = MPI_INPUT.format(
        plugin=plugin_path, x0=-5e-10, zc=ZC, diam=2 * (math.sqrt(3) * A + RM) * 1.001,
        mass=MASS, moment=MASS * (2 * (A + RM)) ** 2 / 6, vx=VP, vy=0.5 * VP,
        planes=planes("upper", 0.25, 0.3).format(cells=cells_file), dt=DT, steps=3000,
        values=" ".join(f"$({c}:%.17g)" for c in columns))
    one, two = run_lmp(tmp_path, 1, text), run_lmp(tmp_path, 2, text)
    assert one[0] > 0                                  # crossed x = 0
    upper = dict(zip(range(1, 12), one[2:13]))
    assert upper[1] == 1 and upper[9] == pytest.approx(ZHI + GAP - VP * DT * 3000, rel=1e-12)
    assert upper[10] == -VP and upper[11] > 0
    np.testing.assert_allclose(two, one, rtol=1e-9, atol=0)


# ---------------------------------------------------------------- the velocity's settings

def test_velocity_variable_and_fix_modify(lmp, tmp_path):
    """`velocity v_name` is evaluated at every step (at its end time): a platen stopped after
    100 steps holds its position; `fix_modify ID velocity V` sets a constant velocity for
    the next run (here: unloading). coord += V h, step by step, in double precision."""
    extra = (f"variable vp equal \"-{VP!r} * (step <= 100)\"\n"
             f"fix upper all bcm/wall cells {{cells}} rm {RM!r} plane zhi {ZHI + 1e-5!r} {KN!r} {KT!r} "
             "0.25 0.3 velocity v_vp\n")
    setup_cells(lmp, tmp_path, [dict(x=(0.0, 0.0, 0.0), q=IDENTITY)], pair=False, dt=DT, extra=extra)
    expected = ZHI + 1e-5
    lmp.command("run 200")
    for step in range(1, 201):
        expected += (-VP if step <= 100 else 0.0) * DT
    assert vector(lmp, "upper", 9) == expected
    assert vector(lmp, "upper", 10) == 0.0
    lmp.command("fix_modify upper velocity 0.5")
    lmp.command("run 50")
    for _ in range(50):
        expected += 0.5 * DT
    assert vector(lmp, "upper", 9) == expected
    assert vector(lmp, "upper", 10) == 0.5


@pytest.mark.parametrize("kw,message", [
    ("velocity v_missing", "velocity variable missing does not exist"),
    ("velocity v_atomic", "is not equal-style"),
    ("velocity fast", "Expected floating point"),
    ("velocity", "keyword velocity needs a value"),
])
def test_velocity_errors(lmp, tmp_path, kw, message):
    setup_cells(lmp, tmp_path, [dict(x=(0.0, 0.0, 0.0), q=IDENTITY)], pair=False, dt=DT,
                extra="variable atomic atom x\n")
    with pytest.raises(LammpsError, match=message):
        lmp.command(f"fix upper all bcm/wall cells {tmp_path / 'cells.txt'} rm {RM!r} plane zhi 1e-4 "
                    f"{KN!r} {KT!r} 0.25 0.3 {kw}")
        lmp.command("run 0")


# ---------------------------------------------------------------- the driver's line

def test_wall_setup_renders_the_platen():
    """driver.bcm.styles.wall_setup: the impact's plane unchanged, a platen with its face,
    position and velocity (a number, or an equal-style variable's name)."""
    m = BCMModel()
    c = m.contact
    assert wall_setup(m, 1e-6) == (f"fix             plane all bcm/wall cells cells.txt rm 1e-06 plane zlo 0.0 "
                                   f"{c.kn} {c.kt} {c.en2} {c.mu} stiffness per_point")
    up = wall_setup(m, 1e-6, fix_id="upper", face="zhi", coord=2.5e-3, velocity=-0.01).split()
    assert up[1] == "upper" and up[8:11] == ["plane", "zhi", "0.0025"] and up[-2:] == ["velocity", "-0.01"]
    assert wall_setup(m, 1e-6, face="zhi", coord=1e-3, velocity="vp").split()[-2:] == ["velocity", "v_vp"]
    for bad in (dict(face="top"), dict(velocity=float("nan")), dict(velocity="v p"), dict(velocity=True)):
        with pytest.raises(ValueError):
            wall_setup(m, 1e-6, **bad)
