"""Where the project's cache lives: plugin builds, packings, tessellations, blocks and
calibration curves, each in a folder of its own under one base directory."""

from __future__ import annotations

import os
from pathlib import Path


def cache_base() -> Path:
    """The project's cache directory: $BRITTLE_CACHE or ~/.cache/brittle."""
    env = os.environ.get("BRITTLE_CACHE")
    return Path(env) if env else Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "brittle"
