"""`driver post FILE...` reads dumps by their header names and flags what is not a result.

Hand-made dumps: atoms on a line along x, each grain a chain of bonded neighbours, the bonds
between grains written broken (type 0); so the grains are known by construction.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from analysis.dump_files import analyse_dump_files
from analysis.dumps import DumpError, LocalFrame, bond_pairs
from analysis.powerlaw import MIN_FIT_GRAINS, TAU_RANGE, exponent_flag
from analysis.shear import _fit_tau
from driver.cli import app

RUNNER = CliRunner()
TWO_GRAINS = [3, 3]


def chain(sizes: list[int], dim: int = 2, broken: bool = True) -> tuple[list[dict], list[dict]]:
    """(atom rows, bond rows) by column name: atom i at x = i + 0.5; z = 0 in 2D, varied in 3D;
    broken=False leaves out the broken bonds between grains (as a dump of intact bonds only)."""
    atoms = [{"id": i + 1, "type": 1, "x": i + 0.5, "y": 1.0, "z": 0.0 if dim == 2 else 1.0 + 0.5 * (i % 3)}
             for i in range(sum(sizes))]
    grain = np.repeat(np.arange(len(sizes)), sizes)
    bonds = [{"atom1": i + 1, "atom2": i + 2, "state": int(grain[i] == grain[i + 1])} for i in range(len(atoms) - 1)
             if broken or grain[i] == grain[i + 1]]
    return atoms, bonds


def atoms_text(rows: list[dict], names: str, step: int = 0, dim: int = 2) -> str:
    """A `dump custom` frame with the columns `names` (x y z id type ...) in that order."""
    lx = len(rows) + 1
    z = "-0.5 0.5" if dim == 2 else "0 4"
    body = "".join(" ".join(str(r[nm]) for nm in names.split()) + "\n" for r in rows)
    return (f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n{len(rows)}\nITEM: BOX BOUNDS pp pp pp\n"
            f"0 {lx}\n0 4\n{z}\nITEM: ATOMS {names}\n{body}")


def bonds_text(rows: list[dict], header: str, order: str, step: int = 0, n_atoms: int = 10) -> str:
    """A `dump local` frame whose header reads `header`; `order` names the chain() key of each
    column ('index' for a running count). Lines end in a space, as LAMMPS writes them."""
    keys = order.split()
    body = "".join(" ".join(str(k + 1 if key == "index" else r[key]) for key in keys) + " \n"
                   for k, r in enumerate(rows))
    return (f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ENTRIES\n{len(rows)}\nITEM: BOX BOUNDS pp pp pp\n"
            f"0 {n_atoms + 1}\n0 4\n-0.5 0.5\nITEM: ENTRIES {header}\n{body}")


def write_pair(tmp_path, sizes=TWO_GRAINS, atom_names="id type x y z", bond_header="c_bl[1] c_bl[2] c_bl[3]",
               bond_order="atom1 atom2 state", dim: int = 2, edit=None, broken: bool = True):
    atoms, bonds = chain(sizes, dim, broken)
    if edit:
        edit(atoms)
    a, b = tmp_path / "atoms.txt", tmp_path / "bonds.txt"
    a.write_text(atoms_text(atoms, atom_names, dim=dim))
    b.write_text(bonds_text(bonds, bond_header, bond_order, n_atoms=len(atoms)))
    return a, b


def subdir(tmp_path, name: str):
    (tmp_path / name).mkdir()
    return tmp_path / name


def post(tmp_path, *files, extra=()):
    out = tmp_path / "post"
    res = RUNNER.invoke(app, ["post", *map(str, files), "--out", str(out), "--no-plots", *extra])
    return res, out


def grain_sizes(out) -> list[int]:
    return sorted(pd.read_csv(out / "grains.csv")["size"].tolist())


# -- columns by name -----------------------------------------------------------------------

@pytest.mark.parametrize("atom_names, bond_header, bond_order", [
    # intact bonds only, of type 1: read by position, a type became an atom id (wrong grains, no error)
    ("x z id y type", "batom1 btype batom2", "atom1 state atom2"),
    ("type id y x z", "c_bl[2] c_bl[3] c_bl[1]", "atom2 state atom1"),
    ("id x y z", "type atom2 atom1", "state atom2 atom1"),
])
def test_post_columns_in_any_order(tmp_path, atom_names, bond_header, bond_order):
    a, b = write_pair(tmp_path, atom_names=atom_names, bond_header=bond_header, bond_order=bond_order, broken=False)
    res, out = post(tmp_path, a, b)
    assert res.exit_code == 0, res.output
    assert grain_sizes(out) == [3, 3]


def test_post_skips_an_index_column(tmp_path):
    # `dump local ... index c_bl[1] c_bl[2] c_bl[3]`: by position, index would be atom1
    a, b = write_pair(tmp_path, bond_header="index c_bl[1] c_bl[2] c_bl[3]", bond_order="index atom1 atom2 state")
    res, out = post(tmp_path, a, b)
    assert res.exit_code == 0, res.output
    assert grain_sizes(out) == [3, 3]


def test_post_impact_interface_names(tmp_path):
    # the impact scenario's interfaces dump: ids from c_ifc, state from c_ifs[1] (bond bcm/griffith b1)
    header = "c_ifc[1] c_ifc[2] c_ifs[1] c_ifs[2] c_ifs[3] c_ifs[4] c_ifs[5] c_ifs[6]"
    a, b = write_pair(tmp_path, atom_names="id x y z", bond_header=header,
                      bond_order="atom1 atom2 state state state state state state")
    res, out = post(tmp_path, a, b)
    assert res.exit_code == 0, res.output
    assert grain_sizes(out) == [3, 3]


@pytest.mark.parametrize("bond_header, bond_order, found", [
    ("batom1 batom2", "atom1 atom2", "batom1 batom2"),  # no type/state
    ("a b c", "atom1 atom2 state", "a b c"),  # unknown names: not guessed by position
    ("c_bl[1] c_bl[2] c_bl[3] c_b2[1] c_b2[2] c_b2[3]", "atom1 atom2 state atom1 atom2 state",
     "c_bl[1] c_bl[2] c_bl[3] c_b2[1] c_b2[2] c_b2[3]"),  # two candidate vectors: ambiguous
])
def test_post_refuses_bond_dump_lacking_a_column(tmp_path, bond_header, bond_order, found):
    a, b = write_pair(tmp_path, bond_header=bond_header, bond_order=bond_order)
    res, out = post(tmp_path, a, b)
    assert res.exit_code == 2, res.output
    msg = " ".join(res.output.split())
    assert "bonds.txt" in msg and f"found: {found}" in msg and "batom1" in msg and "btype" in msg
    assert not (out / "grains.csv").exists()


def test_post_refuses_atom_dump_lacking_a_column(tmp_path):
    a, b = write_pair(tmp_path, atom_names="id type x z")  # no y
    res, _ = post(tmp_path, a, b)
    assert res.exit_code == 2, res.output
    msg = " ".join(res.output.split())
    assert "atoms.txt" in msg and "found: id type x z" in msg and "x y" in msg


def test_bond_pairs_by_name_and_refusal():
    cols = {"index": np.array([1.0, 2.0]), "btype": np.array([1.0, 0.0]),
            "batom2": np.array([2.0, 3.0]), "batom1": np.array([1.0, 2.0])}
    pairs, types = bond_pairs(LocalFrame(0, np.zeros((3, 2)), cols))
    assert pairs.tolist() == [[1, 2], [2, 3]] and types.tolist() == [1, 0]
    cols["batom1"] = np.array([1.5, 2.0])  # not an atom id
    with pytest.raises(DumpError, match="batom1.*not integer"):
        bond_pairs(LocalFrame(0, np.zeros((3, 2)), cols))


# -- dimension -----------------------------------------------------------------------------

def test_post_dimension_checked_against_dump(tmp_path):
    a, b = write_pair(tmp_path)  # 2D: z = 0 everywhere
    res, _ = post(tmp_path, a, b, extra=["--dimension", "3"])
    assert res.exit_code == 2, res.output
    assert "--dimension 3" in res.output and "z" in res.output
    res, _ = post(tmp_path, a, b)
    assert res.exit_code == 0 and json.loads(res.stdout)["dimension"] == 2

    a3, b3 = write_pair(subdir(tmp_path, "3d"), dim=3)
    res, _ = post(tmp_path, a3, b3, extra=["--dimension", "2"])
    assert res.exit_code == 2, res.output
    assert "--dimension 2" in res.output
    res, _ = post(tmp_path, a3, b3)
    assert res.exit_code == 0 and json.loads(res.stdout)["dimension"] == 3

    an, bn = write_pair(subdir(tmp_path, "noz"), atom_names="id type x y")
    res, _ = post(tmp_path, an, bn, extra=["--dimension", "3"])
    assert res.exit_code == 2 and "--dimension 3" in res.output, res.output


def test_post_dimension_2_needs_a_periodic_z_box(tmp_path):
    a, b = write_pair(tmp_path)
    a.write_text(a.read_text().replace("BOX BOUNDS pp pp pp", "BOX BOUNDS pp pp ff"))
    res, _ = post(tmp_path, a, b)
    assert res.exit_code == 2 and "periodic" in res.output, res.output


# -- flags ---------------------------------------------------------------------------------

def test_post_flags_nonfinite_coordinates(tmp_path):
    def nan_x(atoms):
        atoms[4]["x"] = "nan"
    a, b = write_pair(tmp_path, edit=nan_x)
    res, out = post(tmp_path, a, b)
    assert res.exit_code == 0, res.output
    summary = json.loads(res.stdout)
    assert summary["flags"]["nonfinite_coordinates"] == [0]
    assert any("non-finite" in w and "atom id 5" in w for w in summary["warnings"])
    assert pd.read_csv(out / "frames.csv")["nonfinite_atoms"].tolist() == [1]
    assert "non-finite" in (out / "report.md").read_text()


def test_post_flags_unphysical_tau(tmp_path):
    # 10 grains fitted (the largest, M = 9, left out), nearly all at the top: tau < 0
    a, b = write_pair(tmp_path, sizes=[3] + [8] * 9 + [9])
    res, out = post(tmp_path, a, b)
    assert res.exit_code == 0, res.output
    summary = json.loads(res.stdout)
    assert summary["tau_last"] < TAU_RANGE[0] and "outside" in summary["tau_last_flag"]
    assert summary["flags"]["tau"] == [0]
    frames = pd.read_csv(out / "frames.csv")
    assert frames["tau"].iloc[0] < 0 and "outside" in frames["tau_flag"].iloc[0]
    assert "not a result" in (out / "report.md").read_text()


def test_post_flags_too_few_grains(tmp_path):
    a, b = write_pair(tmp_path)
    summary = analyse_dump_files([a, b], tmp_path / "post", plots=False)
    assert summary["tau_last"] is None and "too few grains" in summary["tau_last_flag"]
    assert summary["flags"]["tau"] == [0]


def test_exponent_flag_range_and_minimum():
    assert exponent_flag(1.8, 50) is None and exponent_flag(TAU_RANGE[1], 50) is None
    assert "outside" in exponent_flag(-9.6, 50) and "outside" in exponent_flag(TAU_RANGE[0], 50)
    assert "outside" in exponent_flag(3.2, 50) and "outside" in exponent_flag(float("nan"), 50)
    assert "too few grains" in exponent_flag(1.8, MIN_FIT_GRAINS - 1)
    assert "too few grains" in exponent_flag(None, 0)


def test_shear_fit_rows_carry_the_flag():
    masses = np.array([3] + [8] * 9 + [9], dtype=float)
    row = _fit_tau(masses, np.zeros(len(masses), bool), 3, {"strain": 0.1, "step": 10})
    assert row["tau"] < 0 and "outside" in row["tau_flag"]
    rng = np.random.default_rng(0)
    good = np.floor(3 * (1 - rng.random(3000)) ** (-1 / 0.8))  # N(M) ~ M^-1.8 above 3
    row = _fit_tau(good, np.zeros(len(good), bool), 3, {"strain": 0.1, "step": 10})
    assert 1.6 < row["tau"] < 2.0 and row["tau_flag"] is None
