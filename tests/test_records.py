"""runfiles/records.py: the records LAMMPS prints are declared once and read by their title."""

from __future__ import annotations

import pytest

from runfiles.records import IMPACT_RECORD, SHEAR_RECORD, RecordError, read_record


def test_fix_print_text_and_title_come_from_one_declaration():
    assert SHEAR_RECORD.print_text().startswith('"$(step) $(v_strain:%.8g) $(c_thermo_press[1]:%.10g)')
    assert SHEAR_RECORD.title() == ('title "# step strain pxx pyy pzz pxy pxz pyz pe ke vol bonds_broken '
                                    'angles_broken"')
    assert IMPACT_RECORD.print_text().count("$(") == len(IMPACT_RECORD.names) == 30
    assert IMPACT_RECORD.column("broken") == 5 and SHEAR_RECORD.column("bonds_broken") == 11
    assert len(set(IMPACT_RECORD.names)) == len(IMPACT_RECORD.names)


def test_columns_are_read_by_title_in_any_order(tmp_path):
    """A file whose columns come in another order, with an extra column and a repeated step
    (each `run` prints its first step again): fields by name, the latest record of a step."""
    path = tmp_path / "thermo.dat"
    path.write_text("# strain extra step\n0.0 7 0\n0.1 7 100\n# strain extra step\n0.1 8 100\n0.2 9 200\n")
    df = read_record(path, ["step", "strain"])
    assert list(df.step) == [0, 100, 200] and list(df.strain) == [0.0, 0.1, 0.2] and list(df.extra) == [7, 8, 9]


@pytest.mark.parametrize("text,message", [
    ("0 0.1\n", "no title line"),
    ("# step strain\n0 0.1\n# step time\n1 0.2\n", "title lines differ"),
    ("# step time\n0 0.1\n", "no column strain in its title"),
])
def test_a_record_that_cannot_be_read_by_its_title_is_refused(tmp_path, text, message):
    path = tmp_path / "thermo.dat"
    path.write_text(text)
    with pytest.raises(RecordError, match=message):
        read_record(path, ["step", "strain"])
