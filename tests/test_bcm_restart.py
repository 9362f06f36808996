"""Resuming from a restart file: pair_style bcm/contact carries its state through
write_restart / read_restart (plugins/doc/pair_bcm_contact.md, "Restart files").

Run A does `run N1` then `run N2` in one LAMMPS instance; run B does `run N1`, writes a restart
file, and a new instance loads the plugin, reads the file (the pair style comes back from it:
no pair_style or pair_coeff), re-specifies the fixes and computes, and does `run N2`. On one
rank B must follow A bit for bit: positions, velocities, orientations, the tangential history,
the pair's energy and every extra value of `compute pair` (the cumulative energies [4]-[7]
included) at every printed step, with N1 inside a sliding contact whose number of points
changes, so that every accumulator and the history are in use across the restart. ([6], the
energy of changes of the number of points, is identically zero under the per-point contact
law of plugins/src/bcm_contact_law.h: it must stay so.)
"""

from __future__ import annotations

import math
import subprocess

import numpy as np
import pytest

from driver.engine import Lammps, venv_bin

A = 5.0e-5            # core half-side of the cubes (m)
RM = 2.0e-6           # rounding radius r_m
KN, KT, EN2, MU = 1.0e8, 8.0e7, 0.25, 0.3
MASS = 6000.0 * (2 * (A + RM)) ** 3
MOMENT = MASS * (2 * (A + RM)) ** 2 / 6
PERIOD = math.pi * math.sqrt(MASS / 2 / KN)   # normal contact period of the pair
# the restart falls inside the contact (steps 550-625, 4 points at 572-596, slipping until
# 614), then they part
N1, N2 = 590, 410
# the cumulative values in use: [4] damping, [5] friction, [7] work ([6] is zero)
IN_USE = ["c_cp[4]", "c_cp[5]", "c_cp[7]"]
EXTRA = [f"c_cp[{k}]" for k in range(1, 8)]

# re-specified after read_restart exactly as in the first instance (same ids)
FIXES = """
fix props all property/atom d2_bcm_quat 4 d2_bcm_inertia 3 d2_bcm_angmom 3 ghost yes
comm_modify vel yes
fix move all bcm/rigid
compute cp all pair bcm/contact
thermo_style custom step pe c_cp[1] c_cp[2] c_cp[3] c_cp[4] c_cp[5] c_cp[6] c_cp[7]
thermo 10
thermo_modify norm no format float %.17g
"""


def quat_axis_angle(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    return np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * axis])


def rotate(q, b):
    """R(q) b for a unit quaternion q = (w, x, y, z)."""
    w, u = q[0], np.asarray(q[1:])
    return b + 2 * w * np.cross(u, b) + 2 * np.cross(u, np.cross(u, b))


CORNERS = np.array([[x, y, z] for x in (-A, A) for y in (-A, A) for z in (-A, A)])
# faces counter-clockwise seen from outside (corner k = 4 ix + 2 iy + iz)
FACES = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]


def write_cells(path):
    """Cells file (format: plugins/doc/pair_bcm_contact.md) with a cube core for tags 1, 2."""
    lines = ["bcm/cells 2"]
    for tag in (1, 2):
        lines.append(f"{tag} 8 6")
        lines += [" ".join(f"{c:.17g}" for c in v) for v in CORNERS]
        lines += ["4 " + " ".join(map(str, f)) for f in FACES]
    path.write_text("\n".join(lines) + "\n")


def cells():
    """B above A, faces parallel but for a slight tilt, offset and sliding: the contact grows
    from an edge to the overlap rectangle of the faces and shrinks again as B bounces off (its
    number of points changes), with Coulomb slip and damping. A at x < 0, B at x > 0 (one
    rank each with `processors 2 1 1`); gap 1e-7 m at B's lowest corner."""
    qb = quat_axis_angle([1.0, -0.6, 0.0], 4e-5)
    xb = np.array([0.3 * A, 0.3 * A, 0.0])
    xb[2] = A + 2 * RM + 1e-7 - min(rotate(qb, c)[2] for c in CORNERS)
    return [dict(x=(-0.3 * A, 0.0, 0.0), q=(1.0, 0.0, 0.0, 0.0), v=(0.2, 0.0, 0.5),
                 omega=(0.0, 0.0, 300.0)),
            dict(x=xb, q=qb, v=(-0.2, 0.1, -0.5), omega=(0.0, 0.0, -200.0))]


def system(procs="* * *"):
    """Commands of the first instance: the two cells, the pair style (its cells file named
    relative to the working directory), the fixes and computes."""
    text = [f"""
units si
atom_style hybrid bond sphere
atom_modify map array
boundary f f f
newton on
processors {procs}
region box block -1e-3 1e-3 -1e-3 1e-3 -1e-3 1e-3
create_box 1 box bond/types 1 extra/bond/per/atom 2 extra/special/per/atom 4
special_bonds lj 0 1 1
timestep {PERIOD / 100!r}
"""]
    text.append(FIXES.split("\n")[1])    # fix props, before the atoms get their values
    for c in cells():
        text.append("create_atoms 1 single {!r} {!r} {!r}".format(*map(float, c["x"])))
    rad = math.sqrt(3) * A + RM
    text.append(f"set group all diameter {2 * rad * 1.001!r} mass {MASS!r} "
                + " ".join(f"d2_bcm_inertia[{k}] {MOMENT!r}" for k in (1, 2, 3)))
    text.append("mass 1 1.0")
    for tag, c in enumerate(cells(), start=1):
        text.append(
            f"set atom {tag} " + " ".join(f"d2_bcm_quat[{k + 1}] {float(c['q'][k])!r}" for k in range(4))
            + " vx {!r} vy {!r} vz {!r}".format(*c["v"])
            + " omega {!r} {!r} {!r} ".format(*c["omega"])
            + " ".join(f"d2_bcm_angmom[{k + 1}] {MOMENT * c['omega'][k]!r}" for k in range(3)))
    text.append(f"pair_style bcm/contact cells cells.txt rm {RM!r}")
    text.append(f"pair_coeff * * {KN!r} {KT!r} {EN2!r} {MU!r}")
    text.append("\n".join(FIXES.split("\n")[2:]))
    return "\n".join(text) + "\n"


def state(lmp):
    """Per-atom state compared between A and B, by atom ID."""
    order = np.argsort(np.array(lmp.numpy.extract_atom("id")))
    return {name: np.array(lmp.numpy.extract_atom(name))[order]
            for name in ("x", "v", "omega", "d2_bcm_quat", "d2_bcm_angmom",
                         "d2_bcm_contact_history")}


def thermo_rows(log):
    """The thermo rows of the last run in a log file: Step, PotEng (the pair's energy) and
    c_cp[1..7] per printed step, as written (%.17g: every double exactly)."""
    rows = []
    for line in log.read_text().splitlines():
        words = line.split()
        if words[:2] == ["Step", "PotEng"]:
            rows = []
        elif words and words[0].isdigit() and len(words) == 2 + len(EXTRA):
            rows.append(words)
    return rows


def as_dict(row):
    return dict(zip(["step", "pe"] + EXTRA, map(float, row)))


@pytest.fixture
def in_tmp(tmp_path, monkeypatch):
    """Run in tmp_path, where the cells file is, named relative to the working directory."""
    monkeypatch.chdir(tmp_path)
    write_cells(tmp_path / "cells.txt")
    return tmp_path


def resumed(plugin_path, restart, log=None):
    """A new instance continuing from a restart file as a resumed run does."""
    inst = Lammps()
    inst.command(f"plugin load {plugin_path}")
    inst.command(f"read_restart {restart}")
    inst.commands(FIXES)
    if log:
        inst.command(f"log {log}")
    return inst


@pytest.mark.parametrize("a_writes", [
    pytest.param(True, id="A-writes-restart-too"),
    # fix bcm/rigid's init() leaves unit quaternions as they are, so write_restart's extra
    # init() changes nothing: a run that never checkpoints is matched too
    pytest.param(False, id="A-plain"),
])
def test_resumed_run_is_identical(lmp, plugin_path, in_tmp, a_writes):
    """A_writes: run A also writes a restart file at N1 (as a run that checkpoints does) and
    goes on in the same instance."""
    # A: both runs in one instance
    lmp.commands(system())
    lmp.command(f"run {N1}")
    at_restart = lmp.lmp.last_thermo()
    if a_writes:
        lmp.command("write_restart a.restart")
    lmp.command("log a.log")
    lmp.command(f"run {N2}")
    a = state(lmp)

    # B: the first run and a restart file, then the second run in a new instance
    with Lammps() as first:
        first.command(f"plugin load {plugin_path}")
        first.commands(system())
        first.command(f"run {N1}")
        first.command("write_restart half.restart")
    with resumed(plugin_path, "half.restart", log="b.log") as second:
        second.command(f"run {N2}")
        b = state(second)

    # the restart fell inside a sliding contact with every cumulative value in use; each
    # changes after it; the cells part before the end
    assert at_restart["c_cp[2]"] == 1
    rows_a, rows_b = thermo_rows(in_tmp / "a.log"), thermo_rows(in_tmp / "b.log")
    assert len(rows_a) == N2 // 10 + 1
    first_row, last_row = as_dict(rows_a[0]), as_dict(rows_a[-1])
    assert first_row["step"] == N1 and first_row["pe"] > 0
    assert last_row["c_cp[2]"] == 0 and last_row["pe"] == 0
    for name in IN_USE:
        assert first_row[name] != 0 and last_row[name] != 0, name
        assert last_row[name] != first_row[name], name
    assert first_row["c_cp[6]"] == last_row["c_cp[6]"] == 0

    # B follows A exactly: every printed step, and the final state of every cell
    assert rows_b == rows_a
    for name, value in a.items():
        assert np.array_equal(b[name], value), name


def test_history_survives_read_restart(lmp, plugin_path, in_tmp):
    """The tangential-history slots (a fix property/atom that the pair style creates) come
    back from the restart file when the pair style re-creates its store; `run 0` reads the
    history without advancing it."""
    lmp.commands(system())
    lmp.command(f"run {N1}")
    before = state(lmp)["d2_bcm_contact_history"]
    assert np.count_nonzero(before) > 0
    lmp.command("write_restart half.restart")
    with resumed(plugin_path, "half.restart") as other:
        other.command("run 0")
        np.testing.assert_array_equal(state(other)["d2_bcm_contact_history"], before)
        th = other.lmp.last_thermo()
        assert (th["c_cp[1]"], th["c_cp[2]"]) == (4, 1) and th["PotEng"] > 0


def test_pair_style_reissued_after_read_restart_keeps_counters(lmp, plugin_path, in_tmp):
    """Re-issuing `pair_style bcm/contact` (the same style) after read_restart gives the
    restored style new settings (LAMMPS does not re-create it): the cumulative values carry on.
    Friction [5] is not advanced by a run's setup, so it reads back exactly."""
    lmp.commands(system())
    lmp.command(f"run {N1}")
    fric = lmp.lmp.last_thermo()["c_cp[5]"]
    assert fric > 0
    lmp.command("write_restart half.restart")
    with Lammps() as other:
        other.command(f"plugin load {plugin_path}")
        other.command("read_restart half.restart")
        other.command(f"pair_style bcm/contact cells cells.txt rm {RM!r}")
        other.command(f"pair_coeff * * {KN!r} {KT!r} {EN2!r} {MU!r}")
        other.commands(FIXES)
        other.command("run 0")
        assert other.lmp.last_thermo()["c_cp[5]"] == fric


@pytest.mark.mpi
def test_resume_on_two_ranks(plugin_path, in_tmp):
    """One cell per rank (the pair across ranks): the cumulative values of both ranks go
    through the restart file, with write_restart between runs and with the restart command
    inside a run. The last step's half kick is settled there with the velocities that the
    ghost cells had (second order): [4] and [7] within 2e-4, the rest as on one rank."""
    def lmp_run(name, text):
        (in_tmp / f"in.{name}").write_text(f"plugin load {plugin_path}\n" + text)
        cmd = [venv_bin("mpiexec"), "-n", "2", venv_bin("lmp"), "-in", f"in.{name}", "-log",
               f"{name}.log", "-screen", "none", "-nocite"]
        proc = subprocess.run(cmd, cwd=in_tmp, capture_output=True, text=True, timeout=300)
        log = (in_tmp / f"{name}.log").read_text()
        assert proc.returncode == 0, log[-2000:] + proc.stderr
        assert "WARNING: pair_style bcm/contact" not in log, log
        return as_dict(thermo_rows(in_tmp / f"{name}.log")[-1])

    setup = system(procs="2 1 1")
    a = lmp_run("a", setup + f"run {N1}\nrun {N2}\n")
    lmp_run("b1", setup + f"run {N1}\nwrite_restart b.restart\n")
    b = lmp_run("b2", f"read_restart b.restart\n{FIXES}run {N2}\n")
    lmp_run("c1", setup + f"restart {N1} c.*.restart\nrun {N1 + 10}\n")
    c = lmp_run("c2", f"read_restart c.{N1}.restart\n{FIXES}run {N2}\n")
    for other in (b, c):
        assert other["step"] == a["step"] == N1 + N2
        assert a["c_cp[6]"] == other["c_cp[6]"] == 0
        for name in IN_USE:
            assert a[name] != 0
            assert other[name] == pytest.approx(a[name], rel=2e-4 if name in ("c_cp[4]", "c_cp[7]")
                                                else 1e-9), name
