"""The two 3D preparations of the BPM solid (model.packing; driver/bpm/packing.py, section.py)
and the 3D slab boxes.

Expectations from geometry: `lj_minimum` is the contact packing scaled by s = 2^(1/6), so its
Delaunay graph is the contact packing's, its edge lengths are s times longer (the cut
5/4 * 2^(1/6) a keeps exactly the edges 5/4 a keeps there), its number density is s^-3 =
2^(-1/2) times, and its nearest neighbours lie s times further (about 2^(1/6) a instead of a).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from driver.bpm.network import delaunay_network
from driver.bpm.packing import Packing, cached_packing, particle_count
from driver.bpm.section import MAX_BOND_LENGTH_3D, PACKING_SCALE, BPMModel
from driver.config import parse_config
from driver.schema import ConfigError

S = 2.0 ** (1.0 / 6.0)
L = 7.0


def nearest_neighbour_mean(p: Packing) -> float:
    lengths = p.lengths
    x = np.mod(p.positions[:, :3] - p.box[0], lengths)
    x[x >= lengths] = 0.0
    d, _ = cKDTree(x, boxsize=lengths).query(x, k=2)
    return float(d[:, 1].mean())


@pytest.fixture(scope="module")
def preparations(tmp_path_factory, plugin_path) -> dict[str, Packing]:
    cache = tmp_path_factory.mktemp("packings")
    return {prep: cached_packing(cache, 3, L, 5, preparation=prep) for prep in ("contact", "lj_minimum")}


def test_the_default_cut_follows_the_packing():
    assert BPMModel(dimension=3).packing == "contact"
    assert BPMModel(dimension=3).bond_max_length == MAX_BOND_LENGTH_3D == 1.25
    assert BPMModel(dimension=3, packing="lj_minimum").bond_max_length == pytest.approx(1.25 * S)
    assert BPMModel(dimension=3, packing="lj_minimum", bond_max_length=1.3).bond_max_length == 1.3
    assert PACKING_SCALE["lj_minimum"] == pytest.approx(S)


def test_the_option_is_refused_in_2d(tmp_path):
    """2D has one preparation (bidisperse disks in contact): setting one is an error, not ignored."""
    for prep in ("contact", "lj_minimum"):
        with pytest.raises(ConfigError, match="model: packing = .*a 3D option"):
            parse_config({"model": {"kind": "bpm", "dimension": 2, "packing": prep},
                          "output": {"dir": str(tmp_path)}})
    assert parse_config({"model": {"kind": "bpm", "dimension": 2}, "output": {"dir": str(tmp_path)}}).model.packing \
        is None


def test_both_preparations_have_the_same_topology_and_densities_in_ratio_root_2(preparations, tmp_path):
    contact, lj = preparations["contact"], preparations["lj_minimum"]
    assert np.allclose(lj.lengths, L) and np.allclose(contact.lengths, L)
    # the repulsion's diameter stays a in both
    assert np.all(contact.radii == 0.5) and np.all(lj.radii == 0.5)
    density = {k: p.n / np.prod(p.lengths) for k, p in preparations.items()}
    assert density["contact"] / density["lj_minimum"] == pytest.approx(2 ** 0.5, rel=0.02)
    assert nearest_neighbour_mean(contact) == pytest.approx(1.0, abs=0.03)
    assert nearest_neighbour_mean(lj) == pytest.approx(S, abs=0.03)
    nets = {k: delaunay_network(p, BPMModel(dimension=3, packing=k).bond_max_length) for k, p in preparations.items()}
    for net in nets.values():  # SPEC 2.1: about 11 bonds and 24 angles per particle
        assert 10.5 < net.bonds_per_particle < 12.0
        assert 23.0 < net.angles_per_particle < 27.0
    # lj_minimum of side L is the contact packing of side L / s, scaled: the same network
    base = cached_packing(tmp_path, 3, L / S, 5)
    net_base = delaunay_network(base, MAX_BOND_LENGTH_3D)
    assert np.array_equal(net_base.bonds, nets["lj_minimum"].bonds)
    assert np.array_equal(net_base.angles, nets["lj_minimum"].angles)
    assert np.allclose(nets["lj_minimum"].r0, S * net_base.r0)
    assert np.allclose(nets["lj_minimum"].theta0, net_base.theta0)
    assert lj.n == particle_count(3, L, 0.66, preparation="lj_minimum")


@pytest.mark.lammps
def test_a_slab_box(tmp_path):
    """An L x L x T periodic slab at the nominal fraction: T along z, the count from its volume."""
    p = cached_packing(tmp_path, 3, 10.0, 2, thickness=5.0)
    assert np.allclose(p.lengths, [10.0, 10.0, 5.0])
    assert p.n == particle_count(3, 10.0, 0.66, 5.0) == round(0.66 * 500 / (np.pi / 6))
    assert p.packing_fraction == pytest.approx(0.66, rel=1e-3)
    assert np.all((p.positions >= p.box[0]) & (p.positions < p.box[1]))
    assert p.relaxation["converged"]
