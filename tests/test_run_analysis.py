"""The analysis skeleton (analysis/run_analysis.py) and the one meaning of a run cut short
(analysis/completeness.py), on a toy analysis whose every number is known by hand: a record of
three values summed frame by frame. No LAMMPS."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from analysis.completeness import RunCompleteness, RunRefused, completeness_of
from analysis.report import Report
from analysis.run_analysis import RunAnalysis


class Sum(RunAnalysis):
    """Sums values.json's values, one frame each; table `values`, figure `line`."""

    def _prepare(self) -> None:
        self.values = json.loads((self.run_dir / "values.json").read_text())
        self.total = 0
        if self.cut_short:
            self.cut_short_note = f"measured on its {len(self.values)} values"

    def _frames(self):
        return iter(self.values)

    def _single_frame(self, frame: int) -> None:
        self.total += frame

    def _conclude(self) -> None:
        self.results.summary = {"total": self.total}
        self.results.tables["values"] = pd.DataFrame({"value": self.values})
        if self.total > 5:
            self.warnings.append("large")

    def _plot(self) -> None:
        self.draw("line", self._line, self.png("line"))

    def _line(self, path) -> None:
        path.parent.mkdir(exist_ok=True)
        path.write_bytes(b"png")

    def _report(self) -> Report:
        rep = Report("sum")
        rep.values(self.results.summary)
        return rep


class BrokenFigure(Sum):
    def _line(self, path) -> None:
        path.parent.mkdir(exist_ok=True)
        path.write_bytes(b"half a png")
        raise RuntimeError("no ink")


class Refusing(Sum):
    refuses_cut_short = "cannot: run it again"


class TailFirst(Sum):
    summary_tail = ("plots_failed", "warnings")


@pytest.fixture
def run(tmp_path):
    (tmp_path / "values.json").write_text("[1, 2, 3]")
    return tmp_path


def test_finished_run_summary_tables_figures_report(run):
    summary = Sum(run, {}).run()
    assert summary == {"total": 6, "warnings": ["large"], "plots_failed": []}
    assert list(summary) == ["total", "warnings", "plots_failed"]  # the default tail order
    assert list(pd.read_csv(run / "results" / "values.csv").value) == [1, 2, 3]
    assert (run / "results" / "values.parquet").exists() and (run / "plots" / "line.png").exists()
    assert "Cut short" not in (run / "report.md").read_text()


def test_cut_short_run_is_analysed_and_flagged(run):
    summary = Sum(run, {}, completeness=RunCompleteness.CUT_SHORT).run()
    assert summary["total"] == 6
    assert summary["completeness"] == "cut_short"
    assert summary["warnings"] == ["measured on its 3 values", "large"]  # the note first
    lines = [ln for ln in (run / "report.md").read_text().splitlines() if ln]
    assert lines[:2] == ["# sum", "Cut short: measured on its 3 values."]  # right under the title


def test_cut_short_run_is_refused_before_anything_is_read(run):
    (run / "report.md").write_text("earlier")
    (run / "values.json").unlink()  # nothing to read: the refusal comes first
    with pytest.raises(RunRefused, match="cannot: run it again") as exc:
        Refusing(run, {}, completeness=RunCompleteness.CUT_SHORT).run()
    assert isinstance(exc.value, ValueError) and exc.value.completeness is RunCompleteness.REFUSED
    assert (run / "report.md").read_text() == "earlier" and not (run / "results").exists()


def test_refusing_analysis_analyses_a_finished_run(run):
    assert Refusing(run, {}).run()["total"] == 6


def test_refused_is_not_an_input(run):
    with pytest.raises(ValueError, match="finished or cut short"):
        Sum(run, {}, completeness=RunCompleteness.REFUSED).run()


def test_failed_figure_is_listed_removed_and_not_fatal(run):
    summary = BrokenFigure(run, {}).run()
    assert summary["plots_failed"] == [{"plot": "line", "error": "RuntimeError: no ink"}]
    assert not (run / "plots" / "line.png").exists() and (run / "report.md").exists()


def test_no_figures_when_plots_are_off(run):
    assert Sum(run, {}, plots=False).run()["plots_failed"] == []
    assert not (run / "plots").exists()


def test_summary_tail_order_and_no_empty_warnings(run):
    assert list(TailFirst(run, {}).run()) == ["total", "plots_failed", "warnings"]
    (run / "values.json").write_text("[1]")
    assert list(Sum(run, {}).run()) == ["total", "plots_failed"]  # no caveat: no warnings key


@pytest.mark.parametrize("status, expected", [
    ({"state": "finished"}, RunCompleteness.FINISHED),
    ({"state": "failed", "phase": "analysis", "lammps_done": True}, RunCompleteness.FINISHED),
    ({"state": "interrupted", "phase": "lammps", "checkpoint_step": 100}, RunCompleteness.CUT_SHORT),
    ({"state": "failed", "error": "killed"}, RunCompleteness.CUT_SHORT),
    ({"state": "running"}, RunCompleteness.CUT_SHORT),
    (None, RunCompleteness.CUT_SHORT),
])
def test_completeness_of_status(status, expected):
    assert completeness_of(status) is expected


def test_every_per_run_analysis_follows_the_skeleton():
    """The analyses the units run, and which of them refuse a run cut short."""
    from analysis.bcm_calibrate import BlockFractureAnalysis, BlockModuliAnalysis
    from analysis.bcm_impact import BcmImpactAnalysis
    from analysis.bpm_impact import BpmImpactAnalysis
    from analysis.mode1 import Mode1Analysis
    from analysis.mode2 import Mode2Analysis
    from analysis.moduli import ModuliAnalysis
    from analysis.shear import ShearAnalysis

    refusing = {BpmImpactAnalysis, ModuliAnalysis, BlockModuliAnalysis}
    for cls in (BcmImpactAnalysis, BpmImpactAnalysis, ShearAnalysis, ModuliAnalysis, Mode1Analysis, Mode2Analysis,
                BlockModuliAnalysis, BlockFractureAnalysis):
        assert issubclass(cls, RunAnalysis)
        assert bool(cls.refuses_cut_short) == (cls in refusing), cls.__name__


def test_refusal_reaches_the_caller_of_a_unit(tmp_path):
    """A unit passes the completeness through: a moduli run cut short is refused by name, with
    nothing read (the directory is empty)."""
    from driver.registry import unit_of

    unit = unit_of({"model": {"kind": "bpm"}, "scenario": {"kind": "calibrate"}})
    cfg = {"name": "m", "model": {"kind": "bpm", "dimension": 2}, "scenario": {"kind": "calibrate", "test": "moduli"}}
    with pytest.raises(RunRefused, match="has no moduli"):
        unit.analyse(tmp_path, cfg, False, RunCompleteness.CUT_SHORT)
