"""Each model's parameters at every G_c of a comparison's grid, from one calibration.

BCM (driver/calibration/bcm.py): k_t / k_n and k_n from the block's moduli curve; the interface
G_c from the block's fracture curve, which is measured around the material's own G_c. The
energy per unit crack area of the block is linear through zero in the interface G_c (Griffith
scaling; calibrate_bcm fits its slope s), so every G_c of the grid is reached with the same
curve: G_c(interface) = G_c / s. One fracture curve, whatever the grid.

BPM (driver/calibration/bpm.py calibrate_bpm, in 3D): k_A from nu and the LJ units from
E and the density on the 3D moduli curve, lambda_c from the 3D mode-I curve measured at that
k_A. Every G_c of the grid inverts the same mode-I curve at its own K_IC = sqrt(G_c E') (E' =
E / (1 - nu^2), the target's): one curve, whatever the grid. `bpm.lambda_c` of the compare file
overrides it at the material's G_c, and is then scaled to the grid's other G_c by the curve's
law, lambda_c - 1 ~ K_IC ~ sqrt(G_c).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from rich.console import Console

from driver.calibration import curves as cv
from driver.calibration import solve
from driver.calibration.material import MaterialFile


def bcm_interface_gc(result: dict[str, Any], G_c: float) -> float:
    """The interface G_c that gives the material's G_c (module docstring), rounded as the
    calibration rounds its parameters."""
    return cv.rounded(G_c / result["fracture_slope"]["slope"])


def bpm_lambda_c(lambda_ref: float, G_ref: float, G_c: float) -> float:
    """lambda_c at G_c from lambda_ref at G_ref: lambda_c - 1 ~ sqrt(G_c) (module docstring)."""
    return 1.0 + cv.rounded((lambda_ref - 1.0) * math.sqrt(G_c / G_ref))


def calibrate_bcm(mat: MaterialFile, cache: Path, workers: int, console: Console,
                  reuse: dict[str, Any] | None = None) -> dict[str, Any]:
    """The BCM calibration (driver/calibration/bcm.py), or `reuse` (a calibration.json's)."""
    if reuse is not None:
        return reuse
    from driver.calibration.bcm import calibrate_bcm as run  # noqa: PLC0415

    out = run(mat, cache, workers, console)
    out.pop("_curves", None)
    return out


def calibrate_bpm(mat: MaterialFile, cache: Path, workers: int, console: Console) -> dict[str, Any]:
    """The 3D BPM's calibration (driver/calibration/bpm.py): k_A, units, lambda_c."""
    from driver.calibration.bpm import calibrate_bpm as run  # noqa: PLC0415

    out = run(mat, cache, workers, console)
    out.pop("_curves", None)
    # 8 digits: the same units whether the curves were just measured or read from the cache
    out["units"] = {k: cv.rounded(v, 8) for k, v in out["units"].items()}
    return out


def lambda_c_on_curve(bpm: dict[str, Any], mat: MaterialFile, G_c: float) -> solve.Inverse:
    """lambda_c at the material's fracture energy G_c: the calibration's 3D mode-I curve
    (K_IC* against lambda_c at the chosen k_A) inverted at K_IC = sqrt(G_c E')."""
    tgt = mat.material
    table = bpm["curves"]["bpm_mode1"]["table"]
    lc = [row["lambda_c"] for row in table]
    K_red = [row["K_IC_mean"] for row in table]
    K = math.sqrt(G_c * tgt.plane_modulus(3))
    return solve.bpm_lambda_c(K, tgt.E, mat.bpm.a(), lc, K_red, bpm["reduced"]["E_reduced"])


def lambda_c_table(bpm: dict[str, Any], mat: MaterialFile, g_values: list[float], given: float | None,
                   G_ref: float) -> list[dict[str, Any]]:
    """lambda_c at each G_c of the grid: from the mode-I curve (lambda_c_on_curve), or from the
    compare file's `given` value at the material's G_c scaled by lambda_c - 1 ~ sqrt(G_c)."""
    rows = []
    for g in g_values:
        if given is not None:
            rows.append({"G_c": g, "lambda_c": bpm_lambda_c(given, G_ref, g), "reached": True,
                         "note": "given in the compare file at the material's G_c, scaled as sqrt(G_c)"})
            continue
        inv = lambda_c_on_curve(bpm, mat, g)
        rows.append({"G_c": g, "lambda_c": 1.0 + cv.rounded(inv.x - 1.0), "reached": inv.reached,
                     "note": inv.note or "the 3D mode-I curve at the chosen k_A"})
    return rows


def lambda_c_for(bpm: dict[str, Any], G_c: float) -> float:
    """The BPM's lambda_c at G_c, from bpm["lambda_c_by_G_c"] (lambda_c_table)."""
    for row in bpm["lambda_c_by_G_c"]:
        if math.isclose(row["G_c"], G_c, rel_tol=1e-9):
            return row["lambda_c"]
    raise KeyError(f"no lambda_c for G_c = {G_c:g}")


def grid_parameters(bcm: dict[str, Any], bpm: dict[str, Any], g_values: list[float]) -> list[dict[str, Any]]:
    """One row per (model, G_c): the model's fracture parameter at the material's G_c."""
    rows = []
    for g in g_values:
        rows.append({"model": "bcm", "G_c": g, "parameter": "model.interface.G_c",
                     "value": bcm_interface_gc(bcm, g)})
        rows.append({"model": "bpm", "G_c": g, "parameter": "model.lambda_c", "value": lambda_c_for(bpm, g)})
    return rows
