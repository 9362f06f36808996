"""The loose start of a bed (driver/assembly.py, issue 25 point 1): sizes by their law, spheres
placed inside the box without overlap, reproducible by seed, and a box too small refused with
the volume fraction it would need."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.distance import pdist, squareform

from driver.assembly import RSA_JAMMING, AssemblySection, GrainSizes, grain_sizes, loose_start


def test_list_sizes_repeat_in_turn():
    d = grain_sizes(GrainSizes(kind="list", values=[1e-3, 2e-3]), 5, np.random.default_rng(0))
    np.testing.assert_array_equal(d, [1e-3, 2e-3, 1e-3, 2e-3, 1e-3])


def test_uniform_sizes_fill_their_bounds():
    d = grain_sizes(GrainSizes(kind="uniform", min=1e-3, max=3e-3), 20_000, np.random.default_rng(1))
    assert d.min() >= 1e-3 and d.max() <= 3e-3
    assert d.mean() == pytest.approx(2e-3, rel=0.01)


def test_lognormal_sizes_are_truncated_not_clipped():
    spec = GrainSizes(kind="lognormal", min=1e-3, max=4e-3, median=2e-3, sigma=0.5)
    d = grain_sizes(spec, 20_000, np.random.default_rng(2))
    assert d.min() >= 1e-3 and d.max() <= 4e-3
    # redrawn, not clipped: no pile-up at the bounds
    assert np.mean(d == 1e-3) == 0.0 and np.mean(d == 4e-3) == 0.0
    # the median of a lognormal truncated symmetrically in ln d stays where it was
    assert np.median(d) == pytest.approx(2e-3, rel=0.02)


@pytest.mark.parametrize("bad,field", [({"kind": "uniform", "min": 2e-3, "max": 1e-3}, "sizes.min"),
                                       ({"kind": "lognormal", "min": 1e-3, "max": 2e-3}, "sizes.median"),
                                       ({"kind": "lognormal", "min": 1e-3, "max": 2e-3, "median": 3e-3,
                                         "sigma": 0.3}, "sizes.median"),
                                       ({"kind": "list", "values": []}, "sizes.values")])
def test_incomplete_size_laws_are_refused_by_name(bad, field):
    with pytest.raises(ValueError, match=field):
        GrainSizes(**bad)


def test_spheres_inside_the_box_without_overlap_and_reproducible():
    rng = np.random.default_rng(3)
    radii = grain_sizes(GrainSizes(kind="uniform", min=0.5e-3, max=1.5e-3), 200, rng) / 2
    box = [1.2e-2, 1.2e-2, 2.4e-2]
    start = loose_start(radii, box, np.random.default_rng(4))
    c, r = start.centres, start.radii
    assert np.all(c - r[:, None] >= 0.0) and np.all(c + r[:, None] <= np.asarray(box))
    gap = squareform(pdist(c)) - (r[:, None] + r[None, :])
    np.fill_diagonal(gap, np.inf)
    assert gap.min() >= 0.0
    again = loose_start(radii, box, np.random.default_rng(4))
    np.testing.assert_array_equal(again.centres, c)
    np.testing.assert_array_equal(again.rotations.as_quat(), start.rotations.as_quat())
    assert start.order[0] == np.argmax(radii)  # largest first
    assert 0.0 < start.solid_fraction < RSA_JAMMING


def test_orientations_cover_the_rotation_group():
    start = loose_start(np.full(2000, 1e-4), [3e-2, 3e-2, 3e-2], np.random.default_rng(5))
    # uniform rotations: each body axis points uniformly on the sphere, mean z component 0, mean z^2 1/3
    z = start.rotations.apply([0.0, 0.0, 1.0])[:, 2]
    assert abs(z.mean()) < 0.05 and z.var() == pytest.approx(1 / 3, abs=0.03)


def test_a_box_too_small_is_refused_with_the_fraction_it_needs():
    radii = np.full(100, 1e-3)
    with pytest.raises(ValueError, match=r"would fill \d+% of it.*times larger"):
        loose_start(radii, [8e-3, 8e-3, 8e-3], np.random.default_rng(6))
    with pytest.raises(ValueError, match="narrower than the largest grain"):
        loose_start(radii, [1.5e-3, 1e-2, 1e-2], np.random.default_rng(6))


def test_a_box_near_jamming_reports_the_grain_that_found_no_place():
    radii = np.full(300, 1e-3)
    side = (4 / 3 * np.pi * 300 * 1e-9 / 0.37) ** (1 / 3)  # 37 %: allowed, but beyond what RSA reaches in 50 tries
    with pytest.raises(ValueError, match="found no place in 50 tries"):
        loose_start(radii, [side] * 3, np.random.default_rng(7), max_attempts=50)


def test_section_defaults_and_box_check():
    a = AssemblySection()
    assert a.n_grains == 10 and a.sizes.kind == "list"
    with pytest.raises(ValueError, match="box: every side > 0"):
        AssemblySection(box=[1e-2, 0.0, 1e-2])
