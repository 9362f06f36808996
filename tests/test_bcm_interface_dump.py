"""The interface dump of fix bcm/interfaces/dump and write_bcm_interfaces
(plugins/doc/fix_bcm_interfaces_dump.md) against LAMMPS's own: byte for byte.

One input writes every frame twice: LAMMPS's way, as the driver's inputs did before the plugin
wrote them (`compute property/local batom1 batom2`, `compute bond/local b1 ... b13`, `dump
local` every N steps, `write_dump ... local` at named moments, columns renamed with
dump_modify colname), and the plugin's, at the same moments. The system is the 6x2x2 block of
bonded cube cells of tests/test_bcm_interface.py drifting across the boundary between two
ranks while it vibrates, breaks part of its interfaces and slides on them (frames with intact,
broken and closed interfaces); the run is cut into `run` commands whose ends are and are not
multiples of N (a dump at a run's setup, never the same step twice), and goes on from a
restart file in a second LAMMPS process (the driver's resume). At the end four cells are moved
far away: on two ranks their partners are then known to no rank that owns them and those rows
are left out (on one rank every partner is owned); then an empty group (a frame of no rows)
and a triclinic box. On two ranks the rows come rank by rank (their order differs from one
rank's, checked), in chunks of a few rows (keyword chunk), so chunk boundaries inside an
atom's bonds are crossed.
"""

from __future__ import annotations

import subprocess

import numpy as np
import pytest

from driver.engine import LammpsError, venv_bin
from runfiles.records import INTERFACES_DUMP
from tests.test_bcm_interface import A, KN, KNC, KT, KTC, MU, PERIOD, fnum, make_pair, write_lattice

# LAMMPS's interface dump (the driver's until the plugin wrote it)
OLD_COMPUTES = ("compute ifc all property/local batom1 batom2\n"
                "compute ifs all bond/local " + " ".join(f"b{k}" for k in range(1, 14)))
OLD_ARGS = " ".join(["c_ifc[1]", "c_ifc[2]", *(f"c_ifs[{k}]" for k in range(1, 14))])
OLD_NAMES = " ".join(f"colname {k} {name}" for k, name in enumerate(INTERFACES_DUMP.names, start=1))
NEW_ARGS = f"{INTERFACES_DUMP.args()} {INTERFACES_DUMP.names_keyword()}"
EVERY, EVERY_ONE_FILE = 200, 300

SYSTEM = """
plugin load {plugin}
units si
atom_style hybrid bond sphere
atom_modify map array
boundary m m m
processors * 1 1
newton on off
comm_modify vel yes
special_bonds lj/coul 0 1 1
fix props all property/atom d2_bcm_quat 4 d2_bcm_inertia 3 d2_bcm_angmom 3 ghost yes
read_data lattice.data fix props NULL Cells
pair_style zero {cutoff}
pair_coeff * *
bond_style bcm/griffith geometry lattice.geo
bond_coeff 1 {kn} {kt} 0.25 0.1 {knc} {ktc} 0.25 {mu}
timestep {dt}
"""
RESUME = """
plugin load {plugin}
read_restart state.restart
fix props all property/atom d2_bcm_quat 4 d2_bcm_inertia 3 d2_bcm_angmom 3 ghost yes
comm_modify vel yes
"""
COMMON = """
neighbor {skin} bin
neigh_modify every 1 delay 0 check yes
fix rig all bcm/rigid
thermo_modify lost/bond ignore
"""


def both_periodic(process: str) -> str:
    """Every EVERY steps one file per frame, every EVERY_ONE_FILE steps one file of frames (one
    per process): LAMMPS's and the plugin's (the plugin's in chunks of 3 and 5 rows)."""
    return f"""{OLD_COMPUTES}
dump old all local {EVERY} old/periodic.*.lammpstrj {OLD_ARGS}
dump_modify old {OLD_NAMES}
fix new all bcm/interfaces/dump {EVERY} new/periodic.*.lammpstrj {NEW_ARGS} chunk 3
dump old1 all local {EVERY_ONE_FILE} old/frames.{process}.lammpstrj {OLD_ARGS}
dump_modify old1 {OLD_NAMES}
fix new1 all bcm/interfaces/dump {EVERY_ONE_FILE} new/frames.{process}.lammpstrj {NEW_ARGS} chunk 5
"""


def both_now(name: str, group: str = "all", old_args: str = OLD_ARGS, chunk: int = 4) -> str:
    """The state now, both ways (old_args: other computes over `group`)."""
    return (f"write_dump all local old/{name}.lammpstrj {old_args} modify {OLD_NAMES}\n"
            f"write_bcm_interfaces {group} new/{name}.lammpstrj {NEW_ARGS} chunk {chunk}\n")


def first_input(plugin: str) -> str:
    values = dict(plugin=plugin, cutoff=fnum(2 * A), skin=fnum(0.2 * A), kn=KN, kt=KT, knc=KNC, ktc=KTC,
                  mu=MU, dt=fnum(PERIOD / 400))
    # runs ending on and off the multiples of 200 and 300; run 0 at a step already written
    runs = "run 0\n" + both_now("start") + "run 250\nrun 350\nrun 0\nrun 1130\n" + both_now("mid") + "run 270\n"
    return (SYSTEM.format(**values) + COMMON.format(**values) + both_periodic("first") + runs
            + "write_restart state.restart\n")


def resumed_input(plugin: str) -> str:
    # four cells moved 30 mm away: two ranks' partners out of reach (four interfaces); then
    # an empty group; then a triclinic box (no dump may be defined while it changes)
    far = (f"group far id 1:4\ndisplace_atoms far move {fnum(-30 * A)} 0 0\nrun 0\n" + both_now("far")
           + "group nobody empty\ncompute none1 nobody property/local batom1 batom2\n"
           + "compute none2 nobody bond/local " + " ".join(f"b{k}" for k in range(1, 14)) + "\nrun 0\n"
           + both_now("empty", "nobody", OLD_ARGS.replace("c_ifc", "c_none1").replace("c_ifs", "c_none2"))
           + "undump old\nundump old1\nchange_box all triclinic\nrun 0\n" + both_now("triclinic", chunk=1))
    values = dict(plugin=plugin, skin=fnum(0.2 * A))
    return (RESUME.format(**values) + COMMON.format(**values) + both_periodic("resumed") + "run 1400\n"
            + both_now("end") + far)


def run_lmp(tmp_path, nprocs: int, name: str, text: str) -> None:
    (tmp_path / name).write_text(text)
    cmd = [venv_bin("mpiexec"), "-n", str(nprocs), venv_bin("lmp"), "-in", name, "-log", f"log.{name}",
           "-screen", "none", "-nocite"]
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    log = (tmp_path / f"log.{name}").read_text()
    assert proc.returncode == 0, log[-2000:] + proc.stderr
    assert f"on {nprocs} procs" in log


def frames(path) -> list[list[str]]:
    """The row lines of each frame of a dump file (9 header lines, then as many rows as it says)."""
    lines, out, k = path.read_text().splitlines(), [], 0
    while k < len(lines):
        n = int(lines[k + 3])
        out.append(lines[k + 9:k + 9 + n])
        k += 9 + n
    return out


def write_both(tmp_path, plugin_path, nprocs: int) -> list[str]:
    """Runs the two inputs on `nprocs` ranks; the names of the files LAMMPS wrote, each checked
    byte for byte against the plugin's."""
    write_lattice(tmp_path, (6, 2, 2), drift=np.array([120.0, 0.0, 0.0]))
    for d in ("old", "new"):
        (tmp_path / d).mkdir()
    run_lmp(tmp_path, nprocs, "in.first", first_input(plugin_path))
    run_lmp(tmp_path, nprocs, "in.resumed", resumed_input(plugin_path))
    old = sorted(p.name for p in (tmp_path / "old").iterdir())
    assert old == sorted(p.name for p in (tmp_path / "new").iterdir())
    for name in old:
        assert (tmp_path / "new" / name).read_bytes() == (tmp_path / "old" / name).read_bytes(), name
    return old


def expected_files() -> list[str]:
    # the setups at 0 and 2000 (the restart's step: written again by the second process), every
    # 200 steps in the runs to 2000 and 3400, never a step twice
    steps = range(0, 3401, EVERY)
    return sorted([f"periodic.{s}.lammpstrj" for s in steps] + ["frames.first.lammpstrj", "frames.resumed.lammpstrj"]
                  + [f"{m}.lammpstrj" for m in ("start", "mid", "end", "far", "empty", "triclinic")])


def test_one_rank(plugin_path, tmp_path):
    assert write_both(tmp_path, plugin_path, 1) == expected_files()
    # what the frames hold: intact, broken and closed interfaces in the run; the one-file dumps
    # one frame per multiple of 300, none twice (the first process's run 0 at 600)
    rows = [r.split() for r in frames(tmp_path / "new" / "periodic.1000.lammpstrj")[0]]
    assert len(rows) == 44
    state = {int(r[2]) for r in rows}
    assert state == {0, 1} and any(float(r[13]) > 0 for r in rows)
    for process, steps in [("first", range(0, 2001, 300)), ("resumed", range(2100, 3401, 300))]:
        text = (tmp_path / "new" / f"frames.{process}.lammpstrj").read_text().splitlines()
        assert [int(text[k + 1]) for k, ln in enumerate(text) if ln == "ITEM: TIMESTEP"] == list(steps)
    assert len(frames(tmp_path / "new" / "far.lammpstrj")[0]) == 44    # one rank owns every partner
    assert frames(tmp_path / "new" / "empty.lammpstrj") == [[]]


@pytest.mark.mpi
def test_two_ranks(plugin_path, tmp_path):
    assert write_both(tmp_path, plugin_path, 2) == expected_files()
    # the rows of cells moved out of their partners' reach are left out, as LAMMPS leaves them
    assert len(frames(tmp_path / "new" / "far.lammpstrj")[0]) == 40
    # the rows come rank by rank: not in one rank's order
    one = tmp_path / "one"
    one.mkdir()
    write_both(one, plugin_path, 1)
    two_rows = frames(tmp_path / "new" / "periodic.1000.lammpstrj")[0]
    one_rows = frames(one / "new" / "periodic.1000.lammpstrj")[0]
    assert sorted(two_rows) == sorted(one_rows) and two_rows != one_rows


def test_turned_off_bonds_listed_with_single_values(lmp, tmp_path):
    """A bond turned off (delete_bonds: type < 0) is listed, as the computes list it, with the
    values single() gives it (zeros for bcm/griffith); compute bond/local leaves its row's
    previous values, so only the pairs are LAMMPS's."""
    make_pair(lmp, tmp_path)
    lmp.commands(f"""
        compute ifc all property/local batom1 batom2
        run 0
        delete_bonds all bond 1
        write_dump all local {tmp_path / 'old.txt'} c_ifc[1] c_ifc[2]
        write_bcm_interfaces all {tmp_path / 'new.txt'} {NEW_ARGS}
    """)
    old, new = frames(tmp_path / "old.txt")[0], frames(tmp_path / "new.txt")[0]
    assert [r.split()[:2] for r in new] == [r.split()[:2] for r in old] == [["1", "2"]]
    assert new[0].split()[2:] == ["0"] * 13


@pytest.mark.parametrize("args,message", [
    ("batom1 b14", "gives 13 extra values, b14 asked for"),
    ("batom1 btype", "unknown value btype"),
    ("batom1 b1 names x", "names needs one name per value"),
    ("batom1 b1 chunk 0", "chunk must be >= 1"),
])
def test_bad_arguments_refused(lmp, tmp_path, args, message):
    make_pair(lmp, tmp_path)
    lmp.command("run 0")
    with pytest.raises(LammpsError, match=message):
        lmp.command(f"write_bcm_interfaces all {tmp_path / 'x.txt'} {args}")
