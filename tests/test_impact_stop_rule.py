"""The impact stop rule latches 'the plane loaded the particle, then let go' (SPEC 1.4).

Observed before: a run whose first contact fell at the end of a settle window stopped there
(the plane barely touched, nothing broken, the kinetic energy unchanged) and reported
e_k^2 = 1 and D_w = 0. And a run that never reached the plane ended as if it had a result.
"""

from __future__ import annotations

import json
import math

import pytest

from analysis.bcm_impact import read_impact_thermo
from driver.bcm.particle import contact_timestep, particle_tessellation
from driver.bcm.section import BCMModel
from driver.config import parse_config
from driver.pipeline import execute
from driver.cache import cache_base
from driver.schedule import chunk_steps, settle_windows
from driver.session import SessionError

N_CELLS, SEED = 100, 2


def config(out, velocity: float, max_time: float = 2e-4) -> dict:
    # ke_tolerance 1 %: the heavily damped contact (e_n^2 = 0.001) takes 0.1 % of the kinetic
    # energy in its first step, so a looser tolerance is what exposed the unlatched rule
    return {"name": "stop", "seed": SEED, "model": {"kind": "bcm", "n_cells": N_CELLS},
            "scenario": {"kind": "impact", "velocity": velocity, "max_time": max_time, "thermo_every": 1,
                         "ke_tolerance": 0.01},
            "output": {"dir": str(out), "plots": False}}


def window_and_dt() -> tuple[int, float, float]:
    """The settle window (steps), time step and initial gap of the test particle, computed as
    the impact scenario computes them."""
    model = BCMModel(n_cells=N_CELLS)
    scen = parse_config(config("x", 1.0)).scenario
    tess = particle_tessellation(model, SEED, cache_base() / "tessellations")
    masses = tess.volume * model.density
    dt, _ = contact_timestep(masses, max(model.contact.kn, model.interface.kn), scen.steps_per_period)
    window, _ = settle_windows(math.ceil(scen.settle_window / dt), chunk_steps("bcm", N_CELLS, None))
    return window, dt, scen.gap * model.diameter


def first_contact_step(out) -> int:
    thermo = read_impact_thermo(out / "thermo.dat")
    return int(thermo.step[thermo.E_wall + thermo.W_wall > 0].iloc[0])


def test_first_contact_at_a_window_end_does_not_stop_the_run(tmp_path, plugin_path):
    window, dt, gap = window_and_dt()
    # a probe finds the flight distance the plane's contact law sees (the first step with a load)
    probe = tmp_path / "probe"
    execute(parse_config(config(probe, 2.0, max_time=1.2 * gap / 2.0)), show_progress=False)
    flight = 2.0 * (first_contact_step(probe) - 0.5) * dt
    # then the lowest point reaches the plane during the last step of the first window
    velocity = flight / ((window - 1.5) * dt)
    out = tmp_path / "run"
    execute(parse_config(config(out, velocity)), show_progress=False)
    system = json.loads((out / "system.json").read_text())
    assert system["window_steps"] == window and system["timestep"] == pytest.approx(dt, rel=1e-12)
    thermo = read_impact_thermo(out / "thermo.dat")
    assert window - 3 <= first_contact_step(out) <= window  # it did touch at the end of the first window
    outcome = json.loads((out / "outcome.json").read_text())
    summary = json.loads((out / "results/summary.json").read_text())
    assert outcome["settled"] and outcome["windows"] >= 3
    assert summary["end_step"] > 2 * window  # ran through the contact and the rebound
    assert thermo.E_wall.max() > 1e-3 * summary["W_k_minus"]  # the plane was loaded ...
    assert thermo.E_wall.iloc[-1] < 1e-2 * thermo.kinetic.iloc[-1]  # ... then let go
    assert summary["e_k2"] < 0.9  # contact damping (e_n^2 = 0.001) took energy


def test_a_particle_that_never_reaches_the_plane_is_an_error(tmp_path, plugin_path):
    _, _, gap = window_and_dt()
    out = tmp_path / "run"
    with pytest.raises(SessionError, match="did not reach the plane within max_time"):
        execute(parse_config(config(out, 0.1, max_time=0.5 * gap / 0.1)), show_progress=False)
    status = json.loads((out / "status.json").read_text())
    assert status["state"] == "failed" and "did not reach the plane" in status["error"]
    assert not (out / "results" / "summary.json").exists()
