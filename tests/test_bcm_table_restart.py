"""bond_style bcm/griffith's interface table through restart files (plugins/doc/bond_bcm_griffith.md,
"Storage"). The table keeps the geometry file's space frame, the reference
state of the cells (position, orientation) and the reference box, and computes an interface's
body frames from them whenever the working copy is laid out; restart files carry all of it.

- `test_resumed_run_is_identical`: a run continued from a restart file follows the uninterrupted
  run to the last bit, in a box periodic in x whose boundary cuts the block (the body frames by
  minimum image, in the box of the reference state), with the cells' tags 1..N or with gaps
  (the table's look-up of a cell by tag); the restart falls amid the breaks (some interfaces
  broken before it, more after it, most intact and loaded).
- `test_restart_file_of_the_layout_before`: a restart file of the layout before (its table held
  the body frames themselves), written by the code of commit 7bcf5c7 (tests/data/bcm_table_legacy,
  made by `--write` below), resumes as that code resumed it, to the last bit; and a restart
  file written from it in today's layout (which keeps those body frames) resumes as the run
  that wrote it went on.

Make the data of the layout before (only with the plugin library of a tree before the change):
    python tests/test_bcm_table_restart.py --write PLUGIN.so
"""

from __future__ import annotations

import gzip
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from driver.engine import Lammps  # noqa: E402
from test_bcm_interface import (  # noqa: E402
    A, KN, KNC, KT, KTC, MASS, MOMENTS, MU, PERIOD, X1, fnum, lattice_faces, wxyz)

LEGACY = Path(__file__).resolve().parent / "data" / "bcm_table_legacy"
SHAPE = (4, 2, 2)
LX = (SHAPE[0] + 4) * A          # the periodic length: a gap of 4 A between the block's images
N1, N2 = 90, 600                 # the restart at N1, amid the breaks (steps 50-125)
GC = 0.6                         # J/m^2: 2 S G_c = 1.2e-6 J per interface

INPUT = """
units si
atom_style hybrid bond sphere
atom_modify map array
boundary p m m
newton on off
comm_modify vel yes
special_bonds lj/coul 0 1 1
fix props all property/atom d2_bcm_quat 4 d2_bcm_inertia 3 d2_bcm_angmom 3 ghost yes
read_data {path}/block.data fix props NULL Cells
pair_style zero {cutoff}
pair_coeff * *
bond_style bcm/griffith geometry {path}/block.geo
bond_coeff 1 {kn} {kt} 0.25 {gc} {knc} {ktc} 0.25 {mu}
neighbor {skin} bin
neigh_modify every 1 delay 0 check yes
timestep {dt}
"""
RUN = """
fix rig all bcm/rigid
thermo_modify lost/bond ignore
"""
# after read_restart, as in the first instance (same ids)
FIXES = """
fix props all property/atom d2_bcm_quat 4 d2_bcm_inertia 3 d2_bcm_angmom 3 ghost yes
comm_modify vel yes
""" + RUN
STATE = ("x", "v", "omega", "d2_bcm_quat", "d2_bcm_angmom")


def write_block(path: Path, tag_step: int = 1, seed: int = 3):
    """Cube cells on a lattice with spacing A, every face bonded, tags 1, 1 + tag_step, ...;
    random body frames, spins and velocities (an outward burst of 1 m/s on top). The box is
    periodic in x with its boundary between the block's first and second layers: the first
    layer is written wrapped across the box, while the geometry file's points lie near cell 1,
    so each interface of that layer has a cell across the box from its points."""
    rng = np.random.default_rng(seed)
    index = {ijk: 1 + tag_step * k for k, ijk in enumerate(np.ndindex(*SHAPE))}
    centres = {t: X1 + A * np.array(ijk, dtype=float) for ijk, t in index.items()}
    lines, bonds = lattice_faces(index, centres)
    (path / "block.geo").write_text("\n".join(lines) + "\n")
    xlo = X1[0] + 0.5 * A
    lo, hi = X1 - 3 * A, X1 + A * (np.array(SHAPE) + 2)
    out = [f"BCM cube block\n\n{len(index)} atoms\n1 atom types\n{len(bonds)} bonds\n1 bond types\n",
           f"{fnum(xlo)} {fnum(xlo + LX)} xlo xhi"]
    out += [f"{fnum(lo[k])} {fnum(hi[k])} {c}lo {c}hi" for k, c in ((1, "y"), (2, "z"))]
    density = MASS / (np.pi / 6 * (2 * A) ** 3)
    out += ["\nAtoms # hybrid\n"]
    for t, x in centres.items():
        x = x.copy()
        if x[0] < xlo:
            x[0] += LX
        out.append(f"{t} 1 " + " ".join(fnum(c) for c in x) + f" 1 {fnum(2 * A)} {fnum(density)}")
    out += ["\nVelocities\n"]
    middle = np.mean(list(centres.values()), axis=0)
    for t, x in centres.items():
        v = (x - middle) / np.linalg.norm(x - middle) + rng.normal(scale=0.3, size=3)
        out.append(f"{t} " + " ".join(fnum(c) for c in v) + " 0 0 0")
    out += ["\nBonds\n"] + [f"{b} 1 {t1} {t2}" for b, (t1, t2) in enumerate(bonds, start=1)]
    out += ["\nCells\n"]
    for t in centres:
        values = [*wxyz(Rotation.random(random_state=100 + t)), *MOMENTS,
                  *rng.normal(scale=30 * MOMENTS[0], size=3)]
        out.append(f"{t} " + " ".join(fnum(v) for v in values))
    (path / "block.data").write_text("\n".join(out) + "\n")


def first_instance(plugin: Path, path: Path) -> Lammps:
    """The block's input (files of write_block() in `path`) up to its first run."""
    lmp = Lammps()
    lmp.command(f"plugin load {plugin}")
    lmp.commands(INPUT.format(path=path, cutoff=fnum(2 * A), skin=fnum(0.2 * A), kn=KN, kt=KT, gc=GC,
                              knc=KNC, ktc=KTC, mu=MU, dt=fnum(PERIOD / 400)))
    lmp.commands(RUN)
    return lmp


def resumed(plugin: Path, restart: Path) -> Lammps:
    lmp = Lammps()
    lmp.command(f"plugin load {plugin}")
    lmp.command(f"read_restart {restart}")
    lmp.commands(FIXES)
    return lmp


def state(lmp) -> dict[str, np.ndarray]:
    """Per-atom state of the owned cells by atom ID, and the bond style's global vector."""
    n = lmp.extract_global("nlocal")    # the arrays hold the ghost cells after them
    ids = np.array(lmp.numpy.extract_atom("id")[:n])
    order = np.argsort(ids)
    out = {name: np.array(lmp.numpy.extract_atom(name)[:n])[order] for name in STATE}
    out["id"] = ids[order]
    out["griffith"] = np.array([lmp.extract_fix("BCM_GRIFFITH", 0, 1, k) for k in range(13)])
    return out


def counts(lmp) -> tuple[int, int]:
    """(intact, broken) interfaces."""
    return int(lmp.extract_fix("BCM_GRIFFITH", 0, 1, 0)), int(lmp.extract_fix("BCM_GRIFFITH", 0, 1, 1))


def assert_same(a: dict, b: dict):
    for name, value in a.items():
        assert np.array_equal(b[name], value), name


@pytest.mark.parametrize("tag_step", [pytest.param(1, id="tags-1..N"), pytest.param(3, id="tags-with-gaps")])
def test_resumed_run_is_identical(plugin_path, tmp_path, tag_step):
    write_block(tmp_path, tag_step)
    # A: both runs in one instance
    with first_instance(plugin_path, tmp_path) as a:
        a.command(f"run {N1}")
        at_restart = counts(a)
        a.command(f"run {N2}")
        end = counts(a)
        sa = state(a)
    # B: the first run, a restart file, the second run in a new instance
    with first_instance(plugin_path, tmp_path) as b:
        b.command(f"run {N1}")
        b.command(f"write_restart {tmp_path / 'half.restart'}")
    with resumed(plugin_path, tmp_path / "half.restart") as c:
        c.command(f"run {N2}")
        sc = state(c)

    # some interfaces broken before the restart, some after it, some intact to the end; the
    # block spans the periodic boundary
    assert 0 < at_restart[1] < end[1] < sum(end) and end[0] > 0
    assert np.ptp(sa["x"][:, 0]) > 0.5 * LX
    assert list(sa["id"]) == [1 + tag_step * k for k in range(int(np.prod(SHAPE)))]
    assert_same(sa, sc)


def legacy_runs(plugin: Path, path: Path):
    """With a plugin of the layout before: the restart file at N1 and the state after N2 more
    steps resumed from it."""
    write_block(path)
    with first_instance(plugin, path) as a:
        a.command(f"run {N1}")
        a.command(f"write_restart {path / 'legacy.restart'}")
    with resumed(plugin, path / "legacy.restart") as b:
        b.command(f"run {N2}")
        return state(b)


def test_restart_file_of_the_layout_before(plugin_path, tmp_path):
    legacy = tmp_path / "legacy.restart"
    legacy.write_bytes(gzip.decompress((LEGACY / "legacy.restart.gz").read_bytes()))
    expected = dict(np.load(LEGACY / "resumed.npz"))
    with resumed(plugin_path, legacy) as b:
        b.command(f"run {N2}")
        assert_same(expected, state(b))
    # its two runs in one instance, and the second from a restart file written in today's
    # layout (the body frames as read) between them (a run's setup makes two runs differ
    # from one in the last bits: compared with the same split)
    with resumed(plugin_path, legacy) as c:
        c.command(f"run {N2 // 3}")
        c.command(f"write_restart {tmp_path / 'today.restart'}")
        c.command(f"run {N2 - N2 // 3}")
        split = state(c)
    with resumed(plugin_path, tmp_path / "today.restart") as d:
        d.command(f"run {N2 - N2 // 3}")
        assert_same(split, state(d))


if __name__ == "__main__":
    import argparse
    import tempfile

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--write", type=Path, required=True, metavar="PLUGIN",
                    help="the plugin library of a tree before the change (its restart layout)")
    args = ap.parse_args()
    LEGACY.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        final = legacy_runs(args.write.resolve(), Path(tmp))
        data = gzip.compress((Path(tmp) / "legacy.restart").read_bytes(), mtime=0)
        (LEGACY / "legacy.restart.gz").write_bytes(data)
    np.savez_compressed(LEGACY / "resumed.npz", **final)
    print(f"wrote {LEGACY}")
