"""`driver calibrate material.yaml`: the target material into each model's parameters (BPM:
driver/calibration/bpm.py, BCM: driver/calibration/bcm.py), from the calibration curves
(driver/calibration/curves.py, measured on first use and cached) by the formulas of
driver/calibration/solve.py; with `verify`, the calibration tests run again at
the chosen parameters and their measured E, nu and fracture energy are compared with the
target (the round trip).

Order per model: the elastic curve first (it fixes k_A, or k_t / k_n), then the fracture
curve measured at that stiffness (the toughness of a network depends on its k_A too, so it is
not measured on a grid of both)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from rich.console import Console

from driver.calibration.bcm import calibrate_bcm, verify_bcm
from driver.calibration.bpm import calibrate_bpm, verify_bpm
from driver.calibration.material import MaterialFile


def calibrate(mat: MaterialFile, cache: Path, workers: int = 1, console: Console | None = None,
              verify: bool = False, verify_dir: Path | None = None) -> dict[str, Any]:
    """Both models' parameters (those named in the file): {"bpm": ..., "bcm": ...}; with
    `verify`, each with its round trip under "verify" (runs in verify_dir/<model>)."""
    console = console or Console(stderr=True)
    out: dict[str, Any] = {}
    if mat.bcm is not None:
        out["bcm"] = calibrate_bcm(mat, cache, workers, console)
        if verify:
            out["bcm"]["verify"] = verify_bcm(mat, out["bcm"], Path(verify_dir) / "bcm", workers, console)
    if mat.bpm is not None:
        out["bpm"] = calibrate_bpm(mat, cache, workers, console)
        if verify:
            out["bpm"]["verify"] = verify_bpm(mat, out["bpm"], Path(verify_dir) / "bpm", workers, console)
    return out
