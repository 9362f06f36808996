"""The scenario API: what a unit (driver/scenarios/<model>_<scenario>.py) provides.

A unit is one `Scenario` value, `UNIT`, in its module. It knows how to build its system, write
its LAMMPS input, name its progress fields, estimate its cost, analyse a run, draw an animation
frame and analyse a set of its runs. This module sits below every unit and below the registry
(driver/registry.py), so a unit imports it without importing the registry or the config.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Callable

if TYPE_CHECKING:  # the types of the callables, for readers and checkers only
    from analysis.completeness import RunCompleteness
    from driver.config import RunConfig
    from driver.size_model import SizeEstimate
    from driver.rundir import RunDir
    from driver.runner import ProgressSpec


@dataclass(frozen=True)
class Scenario:
    """What a (model, scenario) pair does; every callable takes the run's config.

    build(cfg, run_dir: RunDir, plugin) -> (system facts, ProgressSpec): the system, its
        inputs and schedule written into the run directory.
    progress(cfg, system) -> ProgressSpec: the progress fields of a run (again on resume).
    estimate(cfg, ranks) -> SizeEstimate: size, memory and time without building.
    analyse(run_dir, cfg: dict, plots, completeness: RunCompleteness) -> summary: the run's
        tables, figures and report, by its analysis (an analysis.run_analysis.RunAnalysis); a
        run cut short is analysed and flagged, or refused (analysis/completeness.py).
    set_params(cfg: dict) -> the parameters a set compares runs by (runs table columns).
    result_tables: result tables (results/<name>.parquet) a set analysis reads; or a function of
        the run's config (dict) giving them, for a unit whose runs differ (calibrate: by test).
    analyse_set(runs, out, plots, left_out, options) -> figures: a set of runs of this pair.
    frame: (dump prefix, draw(run_dir, cfg: dict, step, png)) of an animation frame.
    elements(cfg) -> particles or cells the system will hold (sizes the default chunk).
    check(cfg) -> None: consistency checks across sections (ValueError with the message).
    work(cfg) -> a number growing with a run's expected length among runs of equal estimate
        (sweeps start the longest first).
    """

    model: str
    scenario: str
    section: type
    description: str
    build: Callable[[RunConfig, RunDir, Path], tuple[dict, ProgressSpec]]
    progress: Callable[[RunConfig, dict], ProgressSpec]
    estimate: Callable[[RunConfig, int], SizeEstimate]
    analyse: Callable[[Path, dict, bool, RunCompleteness], dict]
    set_params: Callable[[dict], dict]
    analyse_set: Callable[..., dict]
    frame: tuple[str, Callable[[Path, dict, int, Path], None]]
    elements: Callable[[RunConfig], int]
    result_tables: tuple[str, ...] | Callable[[dict], tuple[str, ...]] = ()
    check: Callable[[RunConfig], None] = field(default=lambda cfg: None)
    work: Callable[[RunConfig], float] = field(default=lambda cfg: 0.0)

    @property
    def key(self) -> tuple[str, str]:
        """(model kind, scenario kind): the pair this unit serves."""
        return (self.model, self.scenario)
