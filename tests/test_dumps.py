"""Dump readers on hand-written LAMMPS dumps: values, failures that name their line, gzip."""

from __future__ import annotations

import gzip
import warnings

import numpy as np
import pytest

from analysis.dumps import (AtomFrame, DumpError, DumpWarning, bond_pairs, iter_local_dump, read_atom_dump,
                            read_local_dump)

BOX = "0.0000000000000000e+00 4.0000000000000000e+00\n" * 3


def local_frame(step: int, rows: list[tuple], names=("c_bl[1]", "c_bl[2]", "c_bl[3]"), n=None) -> str:
    """A `dump local` frame as LAMMPS writes it (each value followed by a space)."""
    body = "".join(" ".join(str(v) for v in r) + " \n" for r in rows)
    return (f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ENTRIES\n{len(rows) if n is None else n}\n"
            f"ITEM: BOX BOUNDS pp pp pp\n{BOX}ITEM: ENTRIES {' '.join(names)}\n{body}")


def atom_frame(step: int, names: str, rows: list[tuple], box: str = "ITEM: BOX BOUNDS pp pp pp\n" + BOX) -> str:
    """A `dump custom` frame (values separated by single spaces, no trailing space)."""
    body = "".join(" ".join(str(v) for v in r) + "\n" for r in rows)
    return f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n{len(rows)}\n{box}ITEM: ATOMS {names}\n{body}"


THREE = [local_frame(0, [(1, 2, 1), (2, 3, 1), (3, 4, 1)]),
         local_frame(100, [(1, 2, 1), (2, 3, 0)]),
         local_frame(200, [(1, 2, 0)])]


def write(tmp_path, text: str, name="d.txt") -> str:
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def test_local_frames_values(tmp_path):
    frames = read_local_dump(write(tmp_path, "".join(THREE)))
    assert [f.timestep for f in frames] == [0, 100, 200]
    assert [len(f) for f in frames] == [3, 2, 1]
    assert list(frames[1].columns) == ["c_bl[1]", "c_bl[2]", "c_bl[3]"]
    assert frames[1].columns["c_bl[3]"].tolist() == [1.0, 0.0]
    assert np.array_equal(frames[0].box, [[0, 4]] * 3) and frames[0].boundary == ("pp",) * 3
    pairs, types = bond_pairs(frames[0])
    assert pairs.tolist() == [[1, 2], [2, 3], [3, 4]] and types.tolist() == [1, 1, 1]
    assert [f.timestep for f in iter_local_dump(write(tmp_path, "".join(THREE)))] == [0, 100, 200]


def test_local_empty_frame_and_empty_file(tmp_path):
    frames = read_local_dump(write(tmp_path, local_frame(0, []) + local_frame(5, [(1, 2, 1)])))
    assert [len(f) for f in frames] == [0, 1] and frames[0].columns["c_bl[1]"].shape == (0,)
    assert read_local_dump(write(tmp_path, "", "empty.txt")) == []


def test_truncated_last_frame_keeps_good_frames(tmp_path):
    text = "".join(THREE[:2]) + local_frame(200, [(1, 2, 0), (4, 5, 1)], n=3)
    path = write(tmp_path, text)
    with pytest.raises(DumpError) as err:
        read_local_dump(path)
    e = err.value
    # Frame 2 starts at line 1 + 12 + 11 = 24; its body at line 33, the missing line is 35.
    assert (e.frame, e.timestep, e.line) == (2, 200, 35)
    assert "truncated" in str(e) and path in str(e) and "timestep 200" in str(e) and "line 35" in str(e)
    assert [f.timestep for f in e.frames] == [0, 100]
    with pytest.warns(DumpWarning, match="keeping the 2 complete frame"):
        kept = read_local_dump(path, on_error="keep")
    assert [len(f) for f in kept] == [3, 2]


def test_file_cut_inside_a_line(tmp_path):
    text = "".join(THREE)[:-4]  # "1 2 0 \n" loses its last characters
    with pytest.raises(DumpError, match="ends inside line 1") as err:
        read_local_dump(write(tmp_path, text))
    assert (err.value.frame, err.value.line) == (2, 33)
    with pytest.raises(DumpError, match="truncated in its header"):
        read_local_dump(write(tmp_path, "".join(THREE[:2]) + "ITEM: TIMESTEP\n200\nITEM: NUMB", "h.txt"))


def test_inconsistent_middle_frame_names_its_line(tmp_path):
    bad = THREE[1].replace("2 3 0 \n", "2 3 \n")  # one value missing on body line 2 of frame 1
    with pytest.raises(DumpError, match="line has 2 values, the header names 3") as err:
        read_local_dump(write(tmp_path, THREE[0] + bad + THREE[2]))
    assert (err.value.frame, err.value.timestep, err.value.line) == (1, 100, 12 + 9 + 2)
    # Fewer lines than announced while another frame follows: inconsistent, not truncated.
    short = local_frame(100, [(1, 2, 1)], n=2)
    with pytest.raises(DumpError, match="inconsistent: 2 lines announced, 1 present"):
        read_local_dump(write(tmp_path, THREE[0] + short + THREE[2], "s.txt"))
    extra_token = THREE[1].replace("2 3 0 \n", "2 3 0 7\n")  # would hide behind usecols
    with pytest.raises(DumpError, match="line has 4 values"):
        read_local_dump(write(tmp_path, THREE[0] + extra_token, "x.txt"))
    with pytest.raises(DumpError, match="non-numeric"):
        read_local_dump(write(tmp_path, THREE[1].replace("2 3 0", "2 x 0"), "n.txt"))


def test_odd_spacing_and_nan_parse(tmp_path):
    text = ("ITEM: TIMESTEP\n7\nITEM: NUMBER OF ENTRIES\n2\nITEM: BOX BOUNDS pp pp pp\n" + BOX +
            "ITEM: ENTRIES a b\n    1   2.5\n  -3 nan\n")
    f = read_local_dump(write(tmp_path, text))[0]
    assert f.columns["a"].tolist() == [1.0, -3.0]
    assert f.columns["b"][0] == 2.5 and np.isnan(f.columns["b"][1])


def test_gzip_and_truncated_gzip(tmp_path):
    raw = "".join(THREE).encode()
    gz = tmp_path / "d.gz"
    gz.write_bytes(gzip.compress(raw))
    assert [len(f) for f in read_local_dump(gz)] == [3, 2, 1]
    cut = tmp_path / "cut.gz"
    cut.write_bytes(gzip.compress(raw)[:-12])  # the stream's end (and maybe some data) lost
    with pytest.raises(DumpError, match="gzip stream ends early|truncated") as err:
        read_local_dump(cut)
    assert len(err.value.frames) >= 2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DumpWarning)
        assert len(read_local_dump(cut, on_error="keep")) == len(err.value.frames)


def test_bad_arguments_rejected_before_reading(tmp_path):
    with pytest.raises(ValueError, match="on_error"):
        read_local_dump(tmp_path / "does-not-exist", on_error="ignore")
    with pytest.raises(ValueError, match="engine"):
        read_atom_dump(tmp_path / "does-not-exist", engine="ovito")


def test_wrong_reader_is_named(tmp_path):
    path = write(tmp_path, atom_frame(0, "id type x y z", [(1, 1, 0.0, 0.0, 0.0)]))
    with pytest.raises(DumpError, match="use read_atom_dump"):
        read_local_dump(path)


# -- atom dumps --------------------------------------------------------------------------

NAMES = "id type x y z vx vy vz c_q[1] c_q[2] c_q[3] c_q[4] mass radius"
ROWS = [  # written out of id order on purpose
    (3, 2, 1.5, 0.5, 0.25, 0.1, 0.0, 0.0, 1, 0, 0, 0, 2.0, 0.3),
    (1, 1, 0.5, 1.0, 1.25, 0.0, 0.2, 0.0, 0.5, 0.5, 0.5, 0.5, 1.0, 0.1),
    (2, 1, 2.5, 3.0, 3.75, 0.0, 0.0, -0.3, 0, 1, 0, 0, 1.5, 0.2),
]


def test_atom_frame_sorted_with_extras(tmp_path):
    fr = read_atom_dump(write(tmp_path, atom_frame(10, NAMES, ROWS)))[0]
    assert isinstance(fr, AtomFrame) and fr.timestep == 10 and len(fr) == 3
    assert fr.ids.tolist() == [1, 2, 3] and fr.types.tolist() == [1, 1, 2]
    assert fr.positions.tolist() == [[0.5, 1.0, 1.25], [2.5, 3.0, 3.75], [1.5, 0.5, 0.25]]
    assert fr.velocities[:, 2].tolist() == [0.0, -0.3, 0.0]
    assert fr.extra["mass"].tolist() == [1.0, 1.5, 2.0] and fr.extra["radius"].tolist() == [0.1, 0.2, 0.3]
    q = fr.quaternions()
    assert q.shape == (3, 4) and q[0].tolist() == [0.5] * 4 and q[2].tolist() == [1, 0, 0, 0]
    assert np.array_equal(fr.vector("c_q"), q)
    assert fr.coordinate_convention == "unscaled"


def test_atom_fix_property_quaternion_names(tmp_path):
    names = "id type x y z d2_bcm_quat[1] d2_bcm_quat[2] d2_bcm_quat[3] d2_bcm_quat[4]"
    fr = read_atom_dump(write(tmp_path, atom_frame(0, names, [(1, 1, 0, 0, 0, 1, 0, 0, 0)])))[0]
    assert fr.quaternions().tolist() == [[1, 0, 0, 0]]
    with pytest.raises(KeyError):
        fr.vector("c_missing")


def test_scaled_triclinic_positions(tmp_path):
    # Box 0..4 with xy = 0.5: LAMMPS writes the bounding box xhi = 4.5 (see Howto_triclinic).
    box = ("ITEM: BOX BOUNDS xy xz yz pp pp pp\n0 4.5 0.5\n0 4 0\n0 4 0\n")
    rows = [(1, 1, 0.21875, 0.25, 0.25), (2, 2, 0.46875, 0.25, 0.25), (3, 1, 0.703125, 0.375, 0.25)]
    fr = read_atom_dump(write(tmp_path, atom_frame(0, "id type xs ys zs", rows, box)))[0]
    assert np.allclose(fr.box, [[0, 4]] * 3) and fr.tilt.tolist() == [0.5, 0, 0]
    # x = xlo + xs lx + ys xy: atom 1 at (0.875 + 0.125, 1, 1)
    assert np.allclose(fr.positions, [[1, 1, 1], [2, 1, 1], [3, 1.5, 1]])


def test_mdanalysis_engine_agrees(tmp_path):
    """MDAnalysis' DumpReader as an independent check of positions, velocities and id order."""
    rng = np.random.default_rng(3)
    box = "ITEM: BOX BOUNDS xy xz yz pp pp pp\n-1.2 10.3 0.7\n-2 6 -0.4\n0.5 7 0.3\n"
    frames = []
    for step in (0, 50):
        ids = rng.permutation(40) + 1
        x = rng.random((40, 3)) * 5
        v = rng.normal(size=(40, 3))
        rows = [(int(i), 1, *np.round(xi, 6), *np.round(vi, 6), 1.0) for i, xi, vi in zip(ids, x, v)]
        frames.append(atom_frame(step, "id type x y z vx vy vz mass", rows, box))
    path = write(tmp_path, "".join(frames))
    ours = read_atom_dump(path)
    mda = read_atom_dump(path, engine="mdanalysis")
    for a, b in zip(ours, mda):
        assert np.allclose(a.positions, b.positions, atol=2e-6)  # MDAnalysis keeps float32
        assert np.allclose(a.velocities, b.velocities, atol=1e-6)
        assert np.array_equal(a.ids, b.ids)
    # Scaled coordinates with the origin at 0 agree too (tilted box).
    box0 = "ITEM: BOX BOUNDS xy xz yz pp pp pp\n0 4.5 0.5\n0 4 0\n0 4 0\n"
    rows = [(2, 1, 0.46875, 0.25, 0.25), (1, 1, 0.21875, 0.25, 0.25), (3, 1, 0.703125, 0.375, 0.25)]
    path = write(tmp_path, atom_frame(0, "id type xs ys zs", rows, box0), "s.txt")
    assert np.allclose(read_atom_dump(path, engine="mdanalysis")[0].positions, [[1, 1, 1], [2, 1, 1], [3, 1.5, 1]])
    # ... but not with another origin (MDAnalysis issue #4788): refused, not silently wrong.
    box1 = "ITEM: BOX BOUNDS pp pp pp\n-5 5\n-5 5\n-5 5\n"
    path = write(tmp_path, atom_frame(0, "id type xs ys zs", [(1, 1, 0.5, 0.5, 0.5)], box1), "o.txt")
    assert np.allclose(read_atom_dump(path)[0].positions, 0.0)
    with pytest.raises(ValueError, match="4788"):
        read_atom_dump(path, engine="mdanalysis")


def test_atom_count_may_change_between_frames(tmp_path):
    text = atom_frame(0, "id type x y z", [(1, 1, 0, 0, 0), (2, 1, 1, 1, 1)]) + \
        atom_frame(10, "id type x y z", [(2, 1, 1, 1, 1)])
    path = write(tmp_path, text)
    assert [len(f) for f in read_atom_dump(path)] == [2, 1]
    with pytest.raises(ValueError, match="same atoms"):
        read_atom_dump(path, engine="mdanalysis")


def test_atom_dump_truncated_and_duplicate_ids(tmp_path):
    text = atom_frame(0, NAMES, ROWS) + atom_frame(10, NAMES, ROWS)
    with pytest.raises(DumpError, match="truncated") as err:
        read_atom_dump(write(tmp_path, text[:-40]))
    assert (err.value.frame, err.value.timestep) == (1, 10) and len(err.value.frames) == 1
    gz = tmp_path / "a.lammpstrj.gz"
    gz.write_bytes(gzip.compress(text.encode()))
    assert len(read_atom_dump(gz)) == 2
    dup = atom_frame(0, "id type x y z", [(1, 1, 0, 0, 0), (1, 1, 1, 1, 1)])
    with pytest.raises(DumpError, match="appears twice"):
        read_atom_dump(write(tmp_path, dup, "dup.txt"))


def test_atom_ids_with_gaps_or_repeats_and_exact_values(tmp_path):
    # ids with gaps (a dump of a group, or after atoms were lost): sorted by a general sort
    rows = [(7, 1, 0.1, 0, 0), (3, 2, 0.2, 0, 0), (10, 1, 0.3, 0, 0)]
    fr = read_atom_dump(write(tmp_path, atom_frame(0, "id type x y z", rows)))[0]
    assert fr.ids.tolist() == [3, 7, 10] and fr.types.tolist() == [2, 1, 1]
    assert fr.positions[:, 0].tolist() == [0.2, 0.1, 0.3]
    # a contiguous range with one id repeated and one missing is not mistaken for a permutation
    rep = [(3, 1, 0, 0, 0), (1, 1, 0, 0, 0), (3, 1, 1, 1, 1)]
    with pytest.raises(DumpError, match="atom id 3 appears twice"):
        read_atom_dump(write(tmp_path, atom_frame(0, "id type x y z", rep), "rep.txt"))
    # 17 significant digits come back bit for bit (correctly rounded parsing)
    vals = np.random.default_rng(5).normal(size=(50, 3)) * 1e-3
    text = atom_frame(0, "id type x y z", [(i + 1, 1, *(f"{v:.17g}" for v in row)) for i, row in enumerate(vals)])
    fr = read_atom_dump(write(tmp_path, text, "exact.txt"))[0]
    assert np.array_equal(fr.positions, vals)
