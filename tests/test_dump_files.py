"""Pairing of loose atom and bond dumps by timestep (`driver post FILE...`), on hand-built files."""

from __future__ import annotations

import subprocess
import sys

import pytest

from analysis.dump_files import paired_frames
from analysis.dumps import DumpError
from test_dumps import atom_frame, local_frame

ROWS = [(1, 1, 0.5, 0.5, 0.5), (2, 1, 1.5, 0.5, 0.5), (3, 1, 2.5, 0.5, 0.5)]


def atoms(*steps: int) -> str:
    return "".join(atom_frame(s, "id type x y z", ROWS) for s in steps)


def bonds(*steps: int) -> str:
    return "".join(local_frame(s, [(1, 2, 1), (2, 3, 1)]) for s in steps)


def test_only_common_timesteps_are_paired(tmp_path):
    # atoms dumped more often than bonds, and the other way round, across several files
    (tmp_path / "a1.txt").write_text(atoms(0, 50, 100))
    (tmp_path / "a2.txt").write_text(atoms(150, 200))
    (tmp_path / "b.txt").write_text(bonds(0, 100, 125, 200, 300))
    pairs = list(paired_frames(sorted(tmp_path.glob("*.txt"))))
    assert [(fa.timestep, fb.timestep) for fa, _, fb, _ in pairs] == [(0, 0), (100, 100), (200, 200)]
    assert [fa_file.name for _, fa_file, _, _ in pairs] == ["a1.txt", "a1.txt", "a2.txt"]


def test_timesteps_out_of_order_refused(tmp_path):
    (tmp_path / "a.txt").write_text(atoms(0, 100, 50))
    (tmp_path / "b.txt").write_text(bonds(0, 50, 100))
    with pytest.raises(DumpError, match="timestep 50 comes after timestep 100"):
        list(paired_frames([tmp_path / "a.txt", tmp_path / "b.txt"]))


@pytest.mark.parametrize("reader", ["numpy", "mdanalysis"])
def test_truncated_atom_dump_keeps_earlier_frames(tmp_path, reader):
    (tmp_path / "a.txt").write_text(atoms(0, 100, 200)[:-10])
    (tmp_path / "b.txt").write_text(bonds(0, 100, 200))
    problems: list[str] = []
    pairs = list(paired_frames([tmp_path / "a.txt", tmp_path / "b.txt"], reader, problems))
    assert [fa.timestep for fa, *_ in pairs] == [0, 100]
    assert len(problems) == 1 and "a.txt, frame 2 (timestep 200)" in problems[0] and "truncated" in problems[0]


def test_dump_file_options_refused_for_a_run_directory(tmp_path):
    (tmp_path / "config.resolved.yaml").write_text("name: x\n")
    proc = subprocess.run([sys.executable, "-m", "driver.cli", "post", str(tmp_path), "--m-min", "5"],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and "--m-min: options for dump files" in proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["config.resolved.yaml"]  # nothing written
