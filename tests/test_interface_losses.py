"""analysis/interface_losses.py on hand-made tables: the depth of an interface from its
reference centroid, the losses summed per slab of depth, and the channels in time."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from analysis.interface_losses import channels_in_time, interface_centroids, losses_by_depth, with_depth


def test_centroid_depth_and_slabs(tmp_path):
    geo = tmp_path / "interfaces.txt"
    # two interfaces: a triangle centred at z = 0.3 mm and a square centred at z = 1.5 mm
    geo.write_text("# tag1 tag2 area nx ny nz npts points\n"
                   "1 2 1e-8 0 0 1 3  0 0 0.2e-3  1e-4 0 0.3e-3  0 1e-4 0.4e-3\n"
                   "2 3 4e-8 1 0 0 4  0 0 1.4e-3  0 1e-4 1.4e-3  0 1e-4 1.6e-3  0 0 1.6e-3\n")
    c = interface_centroids(geo)
    assert c.z.to_numpy() == pytest.approx([0.3e-3, 1.5e-3])
    ifaces = pd.DataFrame({"atom1": [2, 1], "atom2": [3, 2], "state": [1.0, 0.0], "area": [4e-8, 1e-8],
                           "W_damp": [0.5, 3.0], "W_damp_broken": [0.0, 2.0], "W_friction": [0.0, 4.0],
                           "W_switch": [0.0, 1.0], "slip": [0.0, 1e-6]})
    t = with_depth(ifaces, c, lowest_z=0.1e-3, diameter=2e-3)  # depths 0.1 and 0.7
    assert t.set_index("atom1").depth.to_dict() == pytest.approx({1: 0.1, 2: 0.7})
    slabs = losses_by_depth(t, wk_minus=10.0, n_bins=5)
    assert list(slabs.interfaces) == [1, 0, 0, 1, 0] and list(slabs.broken) == [1, 0, 0, 0, 0]
    assert slabs.broken_area.tolist() == pytest.approx([1e-8, 0, 0, 0, 0])
    assert slabs.W_friction_share[0] == pytest.approx(0.4) and slabs.W_switch_share[0] == pytest.approx(0.1)
    assert slabs.W_damp_broken[0] == 2.0 and slabs.W_damp_intact.tolist() == pytest.approx([1.0, 0, 0, 0.5, 0])
    with pytest.raises(ValueError, match="not in the geometry file"):
        with_depth(ifaces.assign(atom2=[9, 2]), c, 0.0, 1.0)


def test_channels_in_time_are_shares_of_the_impact_energy():
    thermo = pd.DataFrame({"time": [0.0, 1e-6], "W_friction": [0.0, 2.0], "W_switch": [0.0, 1.0],
                           "W_damp": [0.0, 3.0], "W_damp_broken": [0.0, 2.5], "W_wall_damp": [0.0, 0.5],
                           "W_wall_friction": [0.0, 0.0], "W_f": [0.0, 1.5], "broken": [0, 7],
                           "broken_closed": [0, 3], "closed_force": [0.0, 9.0], "wall_force": [0.0, 4.0]})
    ts = channels_in_time(thermo, wk_minus=10.0)
    assert ts["damping, intact interfaces"].tolist() == pytest.approx([0.0, 0.05])
    assert ts["friction on broken interfaces"].iloc[-1] == pytest.approx(0.2)
    assert ts.closed_force.iloc[-1] == 9.0 and np.isfinite(ts.to_numpy(dtype=float)).all()
    # a record of a run before the diagnostics: the channels it has, nothing invented
    old = channels_in_time(thermo.drop(columns=["W_damp_broken", "broken_closed", "closed_force"]), 10.0)
    assert "damping, intact interfaces" not in old and "broken_closed" not in old
