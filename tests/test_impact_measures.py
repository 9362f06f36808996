"""SPEC 1.5 measures on hand-computed numbers."""

import math

import pytest

from analysis.impact_measures import impact_measures


def test_measures_by_hand():
    m = impact_measures(wk_minus=10.0, wk_plus=2.0, wk_plus_cm=1.5, broken_area=0.5, total_area=4.0, g_c=3.0,
                        elastic_end=0.25, dissipated_measured=4.75)
    assert m["W_f"] == 3.0 and m["W_s"] == 24.0
    assert m["D_w"] == 0.125 and m["eta"] == 0.3 and m["e_k2"] == 0.2
    assert math.isclose(m["omega"], 10 / 24) and math.isclose(m["chi"], 2 / 3)
    assert m["W_c"] == 5.0 and math.isclose(m["W_c_over_W_s"], 5 / 24)
    assert math.isclose(m["balance_residual"], 0.0, abs_tol=1e-15)


def test_no_fracture_chi_infinite():
    m = impact_measures(1.0, 0.5, 0.5, 0.0, 1.0, 1.0, 0.0)
    assert m["chi"] == math.inf and m["D_w"] == 0.0 and "balance_residual" not in m


def test_rockable_like_fracture_energy_flagged():
    """The issue's 2 m/s rockable case: the Griffith sum counts N_p times what the springs
    store, so W_f = 2 A G_c = 0.77 W_k^- while the switch term books -0.56 W_k^- and W_c < 0.
    The breaks released W_f + W_switch = 0.21 W_k^-: both are reported, the difference is
    flagged, and no negative dissipation goes without its flag."""
    channels = {"interface_damping": 0.05, "switch": -0.56, "wall_damping": 0.3, "wall_friction": 0.02}
    measured = sum(channels.values())  # -0.19
    m = impact_measures(wk_minus=1.0, wk_plus=0.42, wk_plus_cm=0.4, broken_area=0.77 / 2, total_area=2.0, g_c=1.0,
                        elastic_end=0.0, dissipated_measured=measured, channels=channels, w_f_held=0.22,
                        convention="rockable")
    assert m["W_f"] == 0.77 and math.isclose(m["W_f_released"], 0.21) and m["W_f_held"] == 0.22
    assert math.isclose(m["W_f_released_over_W_f"], 0.21 / 0.77) and math.isclose(m["W_f_held_over_W_f"], 0.22 / 0.77)
    assert math.isclose(m["eta"], 0.77) and math.isclose(m["eta_released"], 0.21)
    assert math.isclose(m["W_c"], 1.0 - 0.42 - 0.77) and m["W_c"] < 0  # -0.19: bookkeeping, not a loss
    assert math.isclose(m["W_c_released"], 1.0 - 0.42 - 0.21) and m["W_c_released"] > 0
    assert m["W_c_switch"] == -0.56 and math.isclose(m["balance_residual"], 0.0, abs_tol=1e-15)
    assert "rockable" in m["W_f_flag"] and "-72.7%" in m["W_f_flag"] and "never held" in m["W_f_flag"]
    flags = m["energy_flags"]
    assert flags[0] == m["W_f_flag"]
    negative = {f.split(" = ")[0] for f in flags[1:]}
    assert negative == {"W_c", "W_c_measured", "W_c_switch"}  # every negative dissipation, none else
    assert all("W_f_flag" in f for f in flags[1:])


def test_fracture_energy_within_tolerance_not_flagged():
    """Within 1 % (a small switch term): no flag; beyond it, released above W_f (the switch
    loss of the stored convention at high speed) is flagged with that reading."""
    m = impact_measures(1.0, 0.2, 0.2, 0.1, 1.0, 1.0, 0.0, dissipated_measured=0.6,
                        channels={"wall_damping": 0.5984, "switch": 0.0016}, convention="stored")
    assert m["W_f_flag"] is None and m["energy_flags"] == [] and math.isclose(m["W_f_released_over_W_f"], 1.008)
    m = impact_measures(1.0, 0.2, 0.2, 0.1, 1.0, 1.0, 0.0, channels={"switch": 0.066})
    assert "+33.0%" in m["W_f_flag"] and "switch loss" in m["W_f_flag"] and m["energy_flags"] == [m["W_f_flag"]]
    assert "W_f_released" not in impact_measures(1.0, 0.2, 0.2, 0.1, 1.0, 1.0, 0.0)


def test_channel_split_sums_to_measured_dissipation(tmp_path):
    """A hand-written energy record: the channels (wall damping and friction, contact damping,
    friction and number-of-points changes, interface damping, friction on broken interfaces,
    switch) sum to the measured dissipation, and the summary's W_c_<channel> entries to
    W_c_measured; fracture, kinetic and elastic energy complete W_k^-."""
    from analysis.bcm_impact import ENERGY_CHANNELS, energy_channels, read_impact_thermo
    from runfiles.records import IMPACT_RECORD

    columns = IMPACT_RECORD.names[::-1]  # read by the title, not by position

    values = {"step": 100, "time": 1e-6, "ke_trans": 0.30, "ke_rot": 0.05, "intact": 10, "broken": 3,
              "broken_area": 0.05, "W_f": 0.1, "E_interfaces": 0.01, "W_damp": 0.02, "W_friction": 0.03,
              "W_switch": -0.0005, "wall_contacts": 0, "wall_force": 0.0, "W_wall": 0.3985, "E_wall": 0.0,
              "W_wall_damp": 0.2965, "W_wall_friction": 0.1, "W_wall_npoints": 0.002, "work_wall": -0.3985,
              "E_contacts": 0.004, "W_contact_damp": 0.04, "W_contact_friction": 0.05, "W_contact_npoints": -0.002,
              "work_contacts": 0.0, "broken_closed": 1, "closed_points": 3, "closed_force": 0.5, "slip": 1e-6,
              "W_damp_broken": 0.01}
    first = {k: 0.0 for k in columns} | {"ke_trans": 1.0, "intact": 13}
    path = tmp_path / "thermo.dat"
    path.write_text(f"# {' '.join(columns)}\n" + "\n".join(" ".join(str(row[c]) for c in columns)
                                                          for row in (first, values)))
    thermo = read_impact_thermo(path)
    last = thermo.iloc[-1]
    split = energy_channels(last, wk_minus=1.0)
    assert list(split.channel[split.part_of_W_c]) == [name for name, _, _ in ENERGY_CHANNELS]
    assert split.energy[split.part_of_W_c].sum() == pytest.approx(last.dissipated, rel=1e-12)
    assert last.dissipated == pytest.approx(0.536, rel=1e-12)  # by hand
    assert split.set_index("channel").energy["wall_friction"] == 0.1
    assert split.energy.sum() == pytest.approx(1.0, rel=1e-12)  # W_k^- = everything
    m = impact_measures(1.0, float(last.kinetic), 0.3, 0.05, 1.0, 1.0, float(last.elastic),
                        dissipated_measured=float(last.dissipated),
                        channels=dict(zip(split.channel[split.part_of_W_c], split.energy[split.part_of_W_c])))
    parts = [m[f"W_c_{name}"] for name, _, _ in ENERGY_CHANNELS]
    assert math.isclose(sum(parts), m["W_c_measured"], rel_tol=1e-12)
    assert math.isclose(m["balance_residual"], 0.0, abs_tol=1e-12)
    # the two negative parts (switch overshoot, contact points gained) are flagged with their causes
    assert [f.split(" = ")[0] for f in m["energy_flags"]] == ["W_c_switch", "W_c_contact_npoints"]


def test_a_record_without_the_broken_law_diagnostics_still_reads(tmp_path):
    """Runs made before the diagnostics columns (broken_closed ... W_damp_broken) are analysed
    as before: those columns are read when present, not required."""
    from analysis.bcm_impact import read_impact_thermo
    from runfiles.records import IMPACT_DIAGNOSTICS, IMPACT_RECORD

    columns = [c for c in IMPACT_RECORD.names if c not in IMPACT_DIAGNOSTICS]
    path = tmp_path / "thermo.dat"
    path.write_text(f"# {' '.join(columns)}\n" + " ".join("0" for _ in columns) + "\n")
    thermo = read_impact_thermo(path)
    assert len(thermo) == 1 and "closed_force" not in thermo
    path.write_text(f"# {' '.join(columns[:-1])}\n" + " ".join("0" for _ in columns[:-1]) + "\n")
    with pytest.raises(ValueError, match=columns[-1]):
        read_impact_thermo(path)
