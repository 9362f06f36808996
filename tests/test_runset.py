"""`driver scaling` on sets of runs: the exponents of synthetic sets built with known scaling
forms come back, crossovers are bracketed, bad sets are refused.

The run directories here hold only what the set analysis reads (config, status, summary and
result tables), written from known laws; the runs' own analysis is tested on real runs."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from analysis.runset import RunSetError, survey_runs
from analysis.statistics import mass_distribution
from driver.sets import analyse_set
from powerlaw_samples import sample_power_law

TAU, ALPHA, GAMMA, PHI, NU_ALPHA = 1.8, 1.0, 1.5, 0.7, 0.5
STRAINS = [0.1, 0.2, 0.4, 0.8]


def _write_run(root: Path, cfg: dict, summary: dict, tables: dict[str, pd.DataFrame]) -> Path:
    (root / "results").mkdir(parents=True)
    (root / "config.resolved.yaml").write_text(yaml.safe_dump(cfg))
    (root / "status.json").write_text(json.dumps({"state": "finished"}))
    (root / "results" / "summary.json").write_text(json.dumps(summary))
    for name, df in tables.items():
        df.to_parquet(root / "results" / f"{name}.parquet", index=False)
    return root


def fake_shear_run(root: Path, L: float, edot: float, m_star: float, amplitude: float, seed: int,
                   k_A: float = 4) -> Path:
    """Grain masses at the last strain from N(M) = amplitude M^-TAU exp(-M / m_star) (discrete,
    drawn by rejection from the pure law); the number of grains above the cut grows as eps^PHI."""
    k = np.arange(1, int(30 * m_star) + 1)
    n = int(amplitude * np.sum(k ** -TAU))
    rng = np.random.default_rng(seed)
    draws = sample_power_law(n, TAU, 1, xmax=30 * m_star, discrete=True, rng=rng).astype(float)
    masses = draws[rng.random(n) < np.exp(-draws / m_star)]
    nm = mass_distribution(masses, m_min=3)
    nm.insert(0, "strain", STRAINS[-1])
    frames = pd.DataFrame({"strain": STRAINS, "n_grains_M>=3": [100 * e ** PHI for e in STRAINS],
                           "M2": [float(np.sum(masses ** 2))] * len(STRAINS)})
    grains = pd.DataFrame({"strain": STRAINS[-1], "mass": masses})
    cfg = {"name": f"L{L:g}_e{edot:g}", "seed": seed, "model": {"kind": "bpm", "dimension": 2, "L": L, "k_A": k_A,
                                                                 "lambda_c": 1.05},
           "scenario": {"kind": "shear", "strain_rate": edot}}
    return _write_run(root, cfg, {"n_particles": int(masses.sum())}, {"nm": nm, "frames": frames, "grains": grains})


@pytest.fixture(scope="module")
def size_set(tmp_path_factory) -> Path:
    """Finite size: N(M, L) = L^(GAMMA - ALPHA TAU) f(M / L^ALPHA), f(x) = 20 x^-TAU exp(-x / 10)."""
    root = tmp_path_factory.mktemp("sizes")
    for i, L in enumerate([16, 32, 64]):
        fake_shear_run(root / f"L{L}", L, 1e-3, 10 * L ** ALPHA, 20 * L ** GAMMA, seed=i)
    return root


@pytest.fixture(scope="module")
def rate_set(tmp_path_factory) -> Path:
    """Finite rate at L = 16: N = L^2 edot^(2 NU_ALPHA) h(M edot^NU_ALPHA), h(x) = 40 x^-TAU exp(-x / 4)."""
    root = tmp_path_factory.mktemp("rates")
    for i, edot in enumerate([1e-3, 4e-3, 1.6e-2]):
        amp = 40 * 16 ** 2 * edot ** (2 * NU_ALPHA) * edot ** (-NU_ALPHA * TAU)
        fake_shear_run(root / f"e{edot:g}", 16, edot, 4 * edot ** -NU_ALPHA, amp, seed=10 + i)
    return root


def _fits(out: Path) -> pd.DataFrame:
    return pd.read_csv(out / "fits.csv")


def _value(fits: pd.DataFrame, fit_prefix: str, parameter: str) -> tuple[float, float]:
    row = fits[fits.fit.str.startswith(fit_prefix) & (fits.parameter == parameter)].iloc[0]
    return float(row.value), float(row.sigma)


def test_finite_size_set_recovers_exponents(size_set, tmp_path):
    out = tmp_path / "out"
    analyse_set([size_set], out, n_bootstrap=40)
    fits = _fits(out)
    tau, s_tau = _value(fits, "N(M)", "tau")
    # the sample is truncated at 4 L^alpha while the MLE assumes an unbounded law: a small bias
    assert abs(tau - TAU) < max(3 * s_tau, 0.05)
    alpha, s_alpha = _value(fits, "finite size", "alpha")
    gamma, s_gamma = _value(fits, "finite size", "gamma")
    assert abs(alpha - ALPHA) < min(3 * s_alpha, 0.15), (alpha, s_alpha)  # 3 sizes, one seed each
    assert abs(gamma - GAMMA) < max(3 * s_gamma, 0.1), (gamma, s_gamma)
    assert s_alpha > 0 and s_gamma > 0
    phi = fits[fits.parameter == "phi"]
    assert len(phi) == 3 and np.allclose(phi.value, PHI)
    assert "finite rate" not in " ".join(fits.fit)  # one rate: no finite-rate collapse
    for name in ["report.md", "report.html", "runs.csv", "nm.csv", "plots/collapse_finite_size_at_edot_0.001.png",
                 "plots/growth.png"]:
        assert (out / name).exists(), name


def test_materials_are_scaled_apart(size_set, tmp_path):
    """A set of two materials (k_A = 4 with alpha = 1, k_A = 12 with alpha = 0.6): one tau and
    one finite-size collapse per material, named by it, each recovering its own alpha."""
    other = tmp_path / "kA12"
    for i, L in enumerate([16, 32, 64]):
        fake_shear_run(other / f"L{L}", L, 1e-3, 10 * L ** 0.6, 20 * L ** GAMMA, seed=20 + i, k_A=12)
    out = tmp_path / "out"
    analyse_set([size_set, other], out, n_bootstrap=20)
    fits = _fits(out)
    assert not fits.fit.str.startswith("finite size").any()  # no collapse mixes the two materials
    a4, s4 = _value(fits, "k_A=4: finite size", "alpha")
    a12, s12 = _value(fits, "k_A=12: finite size", "alpha")
    assert abs(a4 - ALPHA) < max(3 * s4, 0.15) and abs(a12 - 0.6) < max(3 * s12, 0.15), (a4, s4, a12, s12)
    assert abs(a4 - a12) > 2 * np.hypot(s4, s12)  # told apart: a mixed collapse would blur them into one
    assert len(fits[fits.parameter == "tau"]) == 2
    assert set(pd.read_csv(out / "nm.csv").material) == {"k_A=4", "k_A=12"}
    assert (out / "plots" / "collapse_k_A12_finite_size_at_edot_0.001.png").exists()


def test_finite_rate_set_recovers_nu_alpha(rate_set, tmp_path):
    out = tmp_path / "out"
    analyse_set([rate_set], out, n_bootstrap=40)
    nu_alpha, sigma = _value(_fits(out), "finite rate", "nu_alpha")
    assert abs(nu_alpha - NU_ALPHA) < max(3 * sigma, 0.05), (nu_alpha, sigma)


def test_no_bootstrap_and_repeated_run_names(size_set, tmp_path):
    """--bootstrap 0 gives curvature errors; two sweeps made from one base config (same run
    names in different directories) stay separate runs."""
    import shutil

    shutil.copytree(size_set, tmp_path / "again")
    out = tmp_path / "out"
    analyse_set([size_set, tmp_path / "again"], out, n_bootstrap=0)
    assert pd.read_csv(out / "nm.csv").run_dir.nunique() == 6
    fits = _fits(out)
    alpha, s_alpha = _value(fits, "finite size", "alpha")
    assert np.isfinite(s_alpha) and s_alpha > 0 and "curvature" in " ".join(fits.method)


def fake_impact_run(root: Path, velocity: float, seed: int, model: dict | None = None, breakup: float = 5.0) -> Path:
    """omega = velocity^2 / 4; D_w = 0.2 (omega - 0.5)^0.8 above 0.5; two or more multi-cell
    fragments from omega 2 (chips: the largest fragment keeps 95 % of the mass), the largest
    below 0.9 of the parent from omega `breakup` (5); eta = 0.05 omega^0.3; fragment masses
    p(m) ~ m^-1.6. model: further keys of the model section."""
    omega = velocity ** 2 / 4
    d_w = 0.2 * (omega - 0.5) ** 0.8 if omega > 0.5 else 0.0
    multi = 1 if omega < 2 else int(3 * omega)
    largest = 1.0 if omega < 2 else 0.95 if omega < breakup else 0.5
    rng = np.random.default_rng(seed)
    masses = sample_power_law(150, 1.6, 1e-3, xmax=1.0, rng=rng)
    frags = pd.DataFrame({"mass": masses, "single_cell": False, "shape_factor": rng.uniform(3.0, 3.5, len(masses))})
    summary = {"omega": omega, "D_w": d_w, "eta": 0.05 * omega ** 0.3, "e_k2": 0.7 * omega ** -0.2,
               "n_fragments": multi + 5, "n_fragments_multi_cell": multi, "largest_fragment_mass_fraction": largest,
               "second_fragment_mass_fraction": min(0.3, 1 - largest)}
    cfg = {"name": f"v{velocity:g}_s{seed}", "seed": seed,
           "model": {"kind": "bcm", "n_cells": 100, "interface": {"G_c": 1.0}, **(model or {})},
           "scenario": {"kind": "impact", "velocity": velocity}}
    return _write_run(root, cfg, summary, {"fragments": frags})


@pytest.mark.slow
def test_impact_set_crossovers_and_fits(tmp_path):
    runs = tmp_path / "runs"
    for v in [0.6, 1.0, 1.6, 2.4, 3.6, 5.0, 7.0]:
        for seed in (1, 2):
            fake_impact_run(runs / f"v{v:g}_s{seed}", v, seed)
    out = tmp_path / "out"
    result = analyse_set([runs], out)
    th = result["thresholds"]["1"]
    # omega sampled at 0.09, 0.25, 0.64, 1.44, 3.24, 6.25, 12.25
    assert th["omega_0"]["cracks_D_w>0"]["value"] == pytest.approx((0.25 + 0.64) / 2)
    assert (th["omega_0"]["cracks_D_w>0"]["lo"], th["omega_0"]["cracks_D_w>0"]["hi"]) == pytest.approx((0.25, 0.64))
    assert th["omega_1"]["two_multicell_fragments"]["value"] == pytest.approx((1.44 + 3.24) / 2)
    assert th["omega_1"]["largest_below_0.9"]["value"] == pytest.approx((3.24 + 6.25) / 2)
    assert result["omega_1_definition"] == "largest_below_0.9"
    thresholds = pd.read_csv(out / "thresholds.csv")
    assert set(zip(thresholds.threshold, thresholds.definition)) == {
        ("omega_0", "cracks_D_w>0"), ("omega_1", "largest_below_0.9"), ("omega_1", "two_multicell_fragments")}
    fits = _fits(out)
    assert _value(fits, "D_w", "omega0")[0] == pytest.approx(0.5, abs=1e-4)
    assert _value(fits, "D_w", "beta")[0] == pytest.approx(0.8, abs=1e-4)
    assert _value(fits, "eta", "b")[0] == pytest.approx(0.3, abs=1e-9)
    tau, sigma = _value(fits, "p(m", "tau")
    assert abs(tau - 1.6) < 3 * sigma
    points = pd.read_csv(out / "points.csv")
    assert (points.n_runs == 2).all() and len(points) == 7
    assert (out / "plots/measures_vs_omega.png").exists() and (out / "report.html").exists()


@pytest.mark.slow
def test_impact_set_varying_a_model_option_is_analysed_per_option(tmp_path):
    """Runs of two model options (as a sweep of model.interface_stiffness zipped with
    model.min_interface_area makes them) with their break-up at different omega: the points,
    crossovers and fits are per option, never pooled over both (issue 23)."""
    runs = tmp_path / "runs"
    options = {"per_interface": ({"interface_stiffness": "per_interface", "min_interface_area": 0.0}, 5.0),
               "per_area": ({"interface_stiffness": "per_area", "min_interface_area": 0.01}, 3.0)}
    for name, (model, breakup) in options.items():
        for v in [1.0, 1.6, 2.4, 3.6, 5.0, 7.0]:
            for seed in (1, 2):
                fake_impact_run(runs / f"{name}_v{v:g}_s{seed}", v, seed, model=model, breakup=breakup)
    out = tmp_path / "out"
    result = analyse_set([runs], out, n_bootstrap=0)
    assert set(result["thresholds"]) == {
        "1, model.interface_stiffness=per_area, model.min_interface_area=0.01",
        "1, model.interface_stiffness=per_interface, model.min_interface_area=0"}
    thresholds = pd.read_csv(out / "thresholds.csv")
    primary = thresholds[thresholds.definition == "largest_below_0.9"].set_index("variant")
    assert (primary.n_runs == 12).all()  # each option's own 12 runs, not 24
    # omega sampled at 0.25, 0.64, 1.44, 3.24, 6.25, 12.25
    assert primary.value["model.interface_stiffness=per_interface, model.min_interface_area=0"] == pytest.approx(
        (3.24 + 6.25) / 2)
    assert primary.value["model.interface_stiffness=per_area, model.min_interface_area=0.01"] == pytest.approx(
        (1.44 + 3.24) / 2)
    points = pd.read_csv(out / "points.csv")
    assert (points.n_runs == 2).all() and len(points) == 12 and points.variant.nunique() == 2
    assert "variant" in pd.read_csv(out / "fits.csv")
    assert (out / "plots/measures_vs_omega.png").exists()


def test_sets_of_several_kinds_are_analysed_per_kind(tmp_path, size_set):
    """A shear sweep and an impact run named together: each (model, scenario) group gets its
    own analysis in its folder, and the top report lists the groups."""
    impact = fake_impact_run(tmp_path / "imp", 3.0, 1)
    n_shear = len(survey_runs([size_set])[0])  # its finished runs
    out = tmp_path / "o"
    result = analyse_set([size_set, impact], out, n_bootstrap=0)
    assert set(result["groups"]) == {"bpm_shear", "bcm_impact"}
    assert len(pd.read_csv(out / "bpm_shear" / "runs.csv")) == n_shear
    assert (out / "bcm_impact" / "report.md").exists() or "error" in result["groups"]["bcm_impact"]
    top = (out / "report.md").read_text()
    assert "bpm + shear: %d runs" % n_shear in top and "bcm + impact: 1 runs" in top
    proc = subprocess.run([sys.executable, "-m", "driver.cli", "scaling", str(size_set), str(impact), "--out",
                           str(tmp_path / "o2"), "--bootstrap", "0", "--no-plots"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "o2" / "bpm_shear" / "runs.csv").exists()


def test_sets_refused_with_reasons(tmp_path):
    unfinished = tmp_path / "unfinished"
    fake_impact_run(unfinished / "a", 3.0, 1)
    (unfinished / "a" / "status.json").write_text(json.dumps({"state": "running"}))
    with pytest.raises(RunSetError, match="no finished runs.*not finished: running"):
        analyse_set([unfinished], tmp_path / "o1")
    proc = subprocess.run([sys.executable, "-m", "driver.cli", "scaling", str(unfinished), "--out",
                           str(tmp_path / "o2")], capture_output=True, text=True)
    assert proc.returncode == 2 and "no finished runs" in proc.stderr
    assert not (tmp_path / "o2").exists()


def test_stress_window_means_with_block_errors():
    """mu (and P, sqrt(J2)) averaged over the last 20 % of the strain, with the standard error
    of 10 block means: a hand-built series whose pairs of records are correlated (each block
    is c_k +- 0.01). The loading transient before the window does not enter, and the last
    record (0.14 here, like the issue's 0.083) is not the measure."""
    from analysis.stress import block_mean, stress_windows

    c = np.array([0.17, 0.13, 0.16, 0.14, 0.18, 0.12, 0.15, 0.15, 0.16, 0.14])
    window = np.ravel(np.column_stack([c + 0.01, c - 0.01]))  # 20 records, 2 per block
    strain = np.arange(1, 101) / 100
    mu = np.concatenate([np.full(80, 5.0), window])
    stress = pd.DataFrame({"strain": strain, "mu": mu, "P": 2 * mu, "sqrtJ2": 2 * mu ** 2})
    windows = stress_windows(stress)
    assert list(windows.strain_hi) == pytest.approx([0.2, 0.4, 0.6, 0.8, 1.0]) and list(windows.n) == [20] * 5
    last = windows.iloc[-1]
    assert last.mu_mean == pytest.approx(0.15) and last.mu_blocks == 10
    assert last.mu_se == pytest.approx(c.std(ddof=1) / np.sqrt(10))
    assert last.P_mean == pytest.approx(0.30) and last.P_se == pytest.approx(2 * c.std(ddof=1) / np.sqrt(10))
    assert windows.iloc[0].mu_mean == 5.0 and windows.iloc[0].mu_se == 0.0
    # NaNs (mu where P <= 0) are left out; too few samples for 4 blocks: no error stated
    assert block_mean([1.0, np.nan, 3.0, 5.0, 7.0, 9.0, 11.0, 13.0, 15.0])["n"] == 8
    assert block_mean([1.0, 2.0, 3.0])["se"] is None and block_mean([])["mean"] is None
