"""Writing tidy tables: parquet for tools, CSV for people, each written atomically."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from runfiles.atomic import atomic_save


def save_table(df: pd.DataFrame, path_without_suffix: Path) -> None:
    """Write `df` as `<path>.parquet` and `<path>.csv`."""
    atomic_save(path_without_suffix.with_suffix(".parquet"), lambda p: df.to_parquet(p, index=False))
    atomic_save(path_without_suffix.with_suffix(".csv"), lambda p: df.to_csv(p, index=False))
