"""What an incomplete run means to its analysis: one meaning for every per-run analysis.

A run is complete when its LAMMPS part reached its planned end (status.json: `finished`, or
`lammps_done` for a run whose analysis alone failed or was interrupted). A run that stopped
before (interrupted, failed, killed) is cut short, and each analysis does one of two things
with it, decided by the analysis and never by the caller:

- it analyses what the run left (its last snapshot, its records up to there) and flags the
  result: the summary gets ``"completeness": "cut_short"`` and, first in its ``warnings``, a
  note saying what was measured on what (the report says the same under its title, and
  `driver post` prints it). Such measures are those of the state the run reached, not its
  outcome; a set analysis never sees them (sets leave out runs that did not finish).
- or it refuses: `RunRefused` (a ValueError) with a message saying why and what to do. Nothing
  is written: the run's earlier results stay as they were.

A finished run's summary carries no mark (it is the summary earlier versions wrote).

This module is light (no numpy, no pandas) so that the driver can name the states without
importing an analysis.
"""

from __future__ import annotations

import enum


class RunCompleteness(enum.Enum):
    """How far a run got, and what its analysis makes of it (module docstring).

    FINISHED: the run reached its planned end; analysed in full, the summary unmarked.
    CUT_SHORT: the run stopped before its end; analysed on what it left and flagged
        (summary ``completeness: cut_short``, the note first in ``warnings``).
    REFUSED: the run stopped before its end and what it left holds none of this analysis's
        measures; never passed in: the state `RunRefused` carries.
    """

    FINISHED = "finished"
    CUT_SHORT = "cut_short"
    REFUSED = "refused"


class RunRefused(ValueError):
    """A run cut short that an analysis cannot measure; the message says why and what to do."""

    completeness = RunCompleteness.REFUSED


def completeness_of(status: dict | None) -> RunCompleteness:
    """The completeness of a run from its status.json: FINISHED when the run finished or its
    LAMMPS part ended (`lammps_done`: only its analysis failed or was interrupted), CUT_SHORT
    otherwise, and for a run without status.json (nothing says it finished)."""
    status = status or {}
    if status.get("state") == "finished" or status.get("lammps_done"):
        return RunCompleteness.FINISHED
    return RunCompleteness.CUT_SHORT
