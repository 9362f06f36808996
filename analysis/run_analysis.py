"""The one skeleton of a run's analysis, in the spirit of MDAnalysis's ``AnalysisBase``.

Every per-run analysis (BCM and BPM impact, shear, moduli, modes I and II with the crack speed,
the BCM block's moduli and fracture) is a `RunAnalysis`: it checks its arguments before reading
anything, prepares, goes through its frames or records, concludes, then writes its tables,
draws its figures through one `PlotGuard` and writes its report, all the same way, with one
meaning of a run cut short (analysis/completeness.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, ClassVar, Iterable

import pandas as pd

from analysis.completeness import RunCompleteness, RunRefused
from analysis.plots import PlotGuard
from analysis.report import Report, clear_report, write_report
from analysis.tables import save_table


@dataclass
class RunResults:
    """What an analysis produced, in one container.

    summary: the run's measures (results/summary.json; the pipeline adds the run's name first
        and the break counts last), keys in the order they are written.
    tables: name -> table, written as results/<name>.parquet and .csv in this order.
    """

    summary: dict[str, Any] = field(default_factory=dict)
    tables: dict[str, pd.DataFrame] = field(default_factory=dict)


class RunAnalysis:
    """The analysis of one run directory; `run()` returns its summary.

    The contract, in the order `run()` follows it:

    1. ``_check()``: the arguments, before anything is read. A run cut short is refused here,
       with `RunRefused`, when the analysis sets `refuses_cut_short` (its message: why and
       what to do); a subclass that needs a file to exist may check that too.
    2. The report is removed: it is written last, so a directory without one holds an
       analysis that did not finish.
    3. ``_prepare()``: read what every frame needs (system.json, the record). A subclass that
       analyses a run cut short sets `cut_short_note` here, or in `_conclude` when it depends on
       the frames read: what it measures on (the last snapshot, the record up to a step).
    4. ``_single_frame(frame)`` for each of ``_frames()`` (snapshots, phases, records); an
       analysis of one state only has none and works in `_conclude`.
    5. ``_conclude()``: the measures into ``results.summary``, the tables into
       ``results.tables``; caveats go to ``warnings`` (a list), never into the summary directly.
    6. The tables are written (results/<name>.parquet and .csv).
    7. ``_plot()`` when plots are on: figures through `draw` (plots/<name>.png; a figure that
       fails is listed, never fatal).
    8. The summary is closed: ``completeness`` and the cut-short note (first in ``warnings``)
       for a run cut short, then `summary_tail`: ``warnings`` (when there are any) and
       ``plots_failed`` (`_plots_failed()`), in the order the analysis's summaries have
       always had them.
    9. ``_report()`` builds the report (it may read the closed summary); the note of a run cut
       short goes right under its title; it is written as report.md and report.html.

    A run cut short (``completeness=CUT_SHORT``) is either analysed on what it left and
    flagged, or refused: analysis/completeness.py.
    """

    #: None: a run cut short is analysed on what it left and flagged; a message: it is refused.
    refuses_cut_short: ClassVar[str | None] = None
    #: The last keys of the summary, in the order earlier versions wrote them (summaries of
    #: finished runs stay byte for byte what they were).
    summary_tail: ClassVar[tuple[str, ...]] = ("warnings", "plots_failed")

    def __init__(self, run_dir: Path, cfg: dict, plots: bool = True,
                 completeness: RunCompleteness = RunCompleteness.FINISHED) -> None:
        """run_dir: the run directory (or the pipeline's staging copy of it); cfg: the resolved
        config as a plain mapping (config.resolved.yaml); plots: draw the figures;
        completeness: FINISHED or CUT_SHORT (analysis/completeness.py)."""
        self.run_dir = Path(run_dir)
        self.cfg = cfg
        self.plots = plots
        self.completeness = completeness
        self.results = RunResults()
        self.guard = PlotGuard()
        self.warnings: list[str] = []
        self.cut_short_note = "the run did not finish: measured on what it left, not on its planned end"

    @property
    def cut_short(self) -> bool:
        """True when the run stopped before its planned end."""
        return self.completeness is RunCompleteness.CUT_SHORT

    # ------------------------------------------------------------------ the skeleton
    def run(self) -> dict:
        """Check, prepare, frames, conclude, tables, figures, summary, report; the summary."""
        self._check()
        clear_report(self.run_dir)
        self._prepare()
        for frame in self._frames():
            self._single_frame(frame)
        self._conclude()
        for name, table in self.results.tables.items():
            save_table(table, self.run_dir / "results" / name)
        if self.plots:
            self._plot()
        self._close_summary()
        rep = self._report()
        if self.cut_short:
            rep.lead(f"Cut short: {self.cut_short_note}.")
        write_report(rep, self.run_dir)
        return self.results.summary

    def _check(self) -> None:
        """Refuse what cannot be analysed, before reading anything (extend with super())."""
        if self.completeness not in (RunCompleteness.FINISHED, RunCompleteness.CUT_SHORT):
            raise ValueError(f"completeness {self.completeness!r}: an analysis takes a run finished or cut short")
        if self.cut_short and self.refuses_cut_short:
            raise RunRefused(self.refuses_cut_short)

    def _prepare(self) -> None:
        """Read what the frames need."""

    def _frames(self) -> Iterable[Any]:
        """The frames (snapshots, phases, records) `_single_frame` takes, in order; none here."""
        return ()

    def _single_frame(self, frame: Any) -> None:
        """Measure one frame."""

    def _conclude(self) -> None:
        """Fill results.summary and results.tables."""
        raise NotImplementedError

    def _plot(self) -> None:
        """Draw the figures with `draw`; called only when plots are on."""

    def _plots_failed(self) -> list[dict[str, str]]:
        """The summary's plots_failed: the figures that failed here."""
        return self.guard.failed

    def _report(self) -> Report:
        """The one-page report."""
        raise NotImplementedError

    # ------------------------------------------------------------------ helpers
    def png(self, name: str) -> Path:
        """plots/<name>.png of the run."""
        return self.run_dir / "plots" / f"{name}.png"

    def draw(self, name: str, fn: Callable, *args: Any, **kwargs: Any) -> bool:
        """fn(*args, **kwargs) through the guard, as figure `name` (plots/<name>.png, removed when
        it fails); True when it was drawn."""
        return self.guard.draw(name, self.png(name), fn, *args, **kwargs)

    def _close_summary(self) -> None:
        summary = self.results.summary
        warnings = list(self.warnings)
        if self.cut_short:
            summary["completeness"] = RunCompleteness.CUT_SHORT.value
            warnings.insert(0, self.cut_short_note)
        tail = {"warnings": warnings, "plots_failed": self._plots_failed()}
        for key in self.summary_tail:
            summary.pop(key, None)
            if key != "warnings" or warnings:
                summary[key] = tail[key]
