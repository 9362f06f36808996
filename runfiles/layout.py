"""Names in a run directory that the driver writes and the analysis reads."""

from __future__ import annotations

import os
from pathlib import Path

#: Where an analysis works before its results replace the run's (driver/pipeline.py).
STAGING = ".post-staging"


def display_dir(path: str | os.PathLike) -> Path:
    """The run directory a path stands for (an analysis works in its staging folder)."""
    path = Path(path)
    return path.parent if path.name == STAGING else path
