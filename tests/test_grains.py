"""Grain graphs on hand-built bond lists, and N(M) binning."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.grains import grain_labels, grain_sizes, grains_from_bond_dump, relabel_largest_first
from analysis.statistics import log_bin_edges, mass_distribution, moments


def test_chain_ring_isolated():
    # atoms 0-1-2-3 chain, 4-5-6-4 ring, 7 isolated, 8-9 pair
    pairs = np.array([[0, 1], [1, 2], [2, 3], [4, 5], [5, 6], [6, 4], [8, 9]])
    lab = grain_labels(10, pairs)
    assert lab.tolist() == [0, 0, 0, 0, 1, 1, 1, 3, 2, 2]
    assert grain_sizes(lab).tolist() == [4, 3, 2, 1]


def test_broken_bonds_split():
    pairs = np.array([[0, 1], [1, 2], [2, 3]])
    lab = grain_labels(4, pairs, intact=[True, False, True])
    assert lab.tolist() == [0, 0, 1, 1]


def test_bond_dump_type_zero_is_broken():
    pairs = np.array([[1, 2], [2, 3], [3, 4], [4, 5]])  # 1-based ids
    types = np.array([1, 0, 1, 1])
    lab = grains_from_bond_dump(5, pairs, types)
    assert grain_sizes(lab).tolist() == [3, 2]
    assert lab.tolist() == [1, 1, 0, 0, 0]


def test_periodic_ring_is_one_grain():
    """A chain that wraps the periodic box is one grain: grains follow bonds, not positions."""
    n = 6
    pairs = np.array([[i, (i + 1) % n] for i in range(n)])
    assert grain_sizes(grain_labels(n, pairs)).tolist() == [6]


def test_relabel_ties_smallest_index_first():
    raw = np.array([5, 5, 2, 2, 9])
    assert relabel_largest_first(raw).tolist() == [0, 0, 1, 1, 2]


def test_bad_index_rejected():
    with pytest.raises(ValueError):
        grain_labels(3, np.array([[0, 3]]))


def test_nm_counts_per_unit_mass():
    masses = np.array([1, 2, 3, 3, 4, 10, 10, 11, 100])
    nm = mass_distribution(masses, m_min=3, bins_per_decade=5)
    assert nm["count"].sum() == 7  # grains below the cut are left out
    # integer widths: first bin [3, 4.75) holds integers 3 and 4
    assert nm.iloc[0]["width"] == 2 and nm.iloc[0]["count"] == 3
    assert np.allclose(nm["N"], nm["count"] / nm["width"])
    edges = log_bin_edges(3, 100, 5)
    assert edges[0] == 3 and edges[-1] > 100


def test_moments_not_normalised():
    m = moments(np.array([1.0, 2.0, 3.0]))
    assert m == {"M1": 6.0, "M2": 14.0, "M3": 36.0}


def test_nm_mean_mass_of_bin():
    nm = mass_distribution(np.array([3, 3, 4, 10]), m_min=3, bins_per_decade=5)
    assert nm.iloc[0]["m_mean"] == (3 + 3 + 4) / 3


def test_normalised_mass_distribution_density():
    """p(m/m_max) is a density on (0, 1]: the last bin ends at 1, a uniform sample is flat."""
    from analysis.statistics import normalised_mass_distribution

    x = np.random.default_rng(1).uniform(0.3, 1.0, 100_000)
    x[0] = 1.0
    t = normalised_mass_distribution(x)
    assert t.x_hi.iloc[-1] == 1.0 and t.x_lo.iloc[0] <= x.min()
    assert np.sum(t.p * (t.x_hi - t.x_lo)) == pytest.approx(1.0)
    full = t[t.x_lo >= 0.3]  # bins wholly inside the support
    assert np.allclose(full.p, 1 / 0.7, rtol=0.03)
    assert t["count"].sum() == len(x)


def test_frame_measures_counts_and_nonpercolating_moment():
    from analysis.statistics import frame_measures

    row = frame_measures(np.array([100.0, 5, 3, 1, 1]), np.array([True, False, False, False, False]), 3, (5, 50))
    assert row["n_grains"] == 5 and row["n_grains_M>=3"] == 3 and row["n_grains_M>=5"] == 2
    assert row["n_grains_M>=50"] == 1 and row["percolating_grains"] == 1
    assert row["M2"] == 10000 + 25 + 9 + 2 and row["M2_nonpercolating"] == 25 + 9 + 2


def test_mass_ratio_law_recovers_tau_of_truncated_samples():
    """Fragments drawn from p(m) ~ m^-1.6 on [1e-2, 1] kg x 1e-6: tau of p(m/m_max) comes back
    (largest of each run left out, law truncated at 1); an untruncated fit would not."""
    from analysis.powerlaw import fit_power_law
    from powerlaw_samples import sample_power_law
    from analysis.statistics import fit_mass_ratio_law

    rng = np.random.default_rng(5)
    runs = [1e-6 * sample_power_law(300, 1.6, 1e-2, xmax=1.0, rng=rng) for _ in range(10)]
    fit = fit_mass_ratio_law(runs, n_bootstrap=0)
    assert abs(fit.tau - 1.6) < 3 * fit.sigma and fit.xmax == 1.0
    pooled = np.concatenate([r / r.max() for r in runs])
    assert fit_power_law(pooled, xmin=fit.xmin).tau > 1.6 + 3 * fit.sigma  # the bias truncation removes
    assert fit_mass_ratio_law([np.ones(5)]) is None


@pytest.mark.parametrize("tau", [1.5, 2.5])
def test_grain_tau_recovers_discrete_law_beside_a_remnant(tau):
    """Grains drawn exactly from N(M) ~ M^-tau on 3..300 (probability table), plus the remnant
    of the solid (M = 5000) and a grain wrapping the box: both are left out of the fit, which
    recovers tau as if they were not there."""
    from analysis.powerlaw import fit_power_law
    from analysis.statistics import fit_grain_tau

    rng = np.random.default_rng(21)
    k = np.arange(3, 301)
    hits = []
    for _ in range(40):
        m = np.concatenate([rng.choice(k, 400, p=k ** -tau / np.sum(k ** -tau)), [5000, 20000]]).astype(float)
        perc = m == 20000
        fit = fit_grain_tau(m, 3, perc)
        hits.append(abs(fit.tau - tau) < 2 * fit.sigma)
    assert fit.n == 400 and fit.xmax == float(np.sort(m[~perc])[-2]) and fit.xmax <= 300
    assert "left out" in fit.method and "percolating" in fit.method
    assert np.mean(hits) > 0.85
    draws = m[m < 5000]
    alone = fit_power_law(draws, xmin=3, xmax=draws.max(), discrete=True)  # the remnant changes nothing
    assert (alone.tau, alone.sigma, alone.n) == (fit.tau, fit.sigma, fit.n)
    assert fit_grain_tau(np.array([3.0] * 20 + [5.0]), 3) is None  # no range above the cut
    assert fit_grain_tau(np.arange(3.0, 12.0), 3) is None  # 9 grains: too few
