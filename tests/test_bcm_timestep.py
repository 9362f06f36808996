"""The BCM time step (issue 15, point 1; README "Time step"): steps_per_period below the
stability limit is refused with a message naming the field, the value and the limit; at the
default, an undamped, frictionless, unbreakable vibrating particle keeps its energy without a
drift, measured as bench/timestep_study.py measures it (the default is chosen on the run energy
balance, which that study measures beside it).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from driver.bcm.conservative import CONSERVATIVE_SETUP, impulse, intact_particle
from driver.bcm.section import MIN_STEPS_PER_PERIOD, BCMModel
from driver.config import ConfigError, parse_config
from driver.scenarios.sections import ImpactScenario


def _impact(spp: float) -> dict:
    return {"name": "t", "model": {"kind": "bcm", "n_cells": 100},
            "scenario": {"kind": "impact", "steps_per_period": spp}}


def _block(spp: float) -> dict:
    return {"name": "t", "model": {"kind": "bcm"},
            "scenario": {"kind": "calibrate", "test": "moduli", "block": {"steps_per_period": spp}}}


@pytest.mark.parametrize("make,field", [(_impact, "scenario.steps_per_period"),
                                        (_block, "scenario.block.steps_per_period")])
@pytest.mark.parametrize("spp", [3.0, 8.0, MIN_STEPS_PER_PERIOD - 0.5])
def test_steps_per_period_below_the_stability_limit_is_refused(make, field, spp):
    with pytest.raises(ConfigError) as info:
        parse_config(make(spp))
    text = str(info.value)
    assert field in text and f"steps_per_period = {spp:g}" in text
    assert f"stability limit {MIN_STEPS_PER_PERIOD:g}" in text


@pytest.mark.parametrize("make", [_impact, _block])
def test_steps_per_period_at_the_limit_and_the_default_are_accepted(make):
    parse_config(make(MIN_STEPS_PER_PERIOD))
    assert ImpactScenario().steps_per_period >= MIN_STEPS_PER_PERIOD


INPUT = CONSERVATIVE_SETUP + """variable        kin equal c_ket+f_integrate
variable        etot equal c_ket+f_integrate+f_BCM_GRIFFITH[5]+c_cpair
variable        nb equal f_BCM_GRIFFITH[2]
thermo          0
"""


@pytest.mark.slow
def test_vibrating_particle_has_no_drift_at_the_default_step(lmp, tmp_path):
    """300 cells, SPEC 1.3 stiffnesses, e_n = 1, mu = 0, G_c = 1e12 J/m^2, no plane; random cell
    velocities (rms 0.05 m/s, no net momentum or angular momentum) over 100 shortest periods at
    the default steps_per_period. drift = |mean E, second half - mean E, first half| / E_scale
    (E_scale the largest kinetic + elastic energy) < 1e-4: the figure bench/timestep_study.py
    reports (2e-5 at 10 steps per period on 1728 cells)."""
    spp = ImpactScenario().steps_per_period
    seed = 1
    particle = intact_particle(tmp_path, BCMModel(n_cells=300), seed, np.random.default_rng([seed, 1]),
                               gap=BCMModel().diameter)
    lmp.commands(INPUT.format(**particle["setup"], dt=particle["period"] / spp))
    impulse(lmp, np.random.default_rng([seed, 7]), 0.05)
    out = tmp_path / "energy.txt"
    lmp.command(f'fix rec all print 1 "$(v_kin:%.14e) $(v_etot:%.14e) $(v_nb)" file {out} screen no')
    lmp.command(f"run {math.ceil(100 * spp)}")
    kin, etot, broken = np.loadtxt(out, comments="#", unpack=True)
    assert broken.max() == 0
    assert kin.min() < 0.8 * etot[0]  # it vibrates: energy moves into the interfaces
    scale = etot.max()  # the largest kinetic + elastic energy
    half = len(etot) // 2
    drift = abs(etot[half:].mean() - etot[:half].mean()) / scale
    assert drift < 1e-4, drift
