"""Each model's parameters at every G_c of a comparison's grid, from one calibration.

BCM (driver/calibration/bcm.py): k_t / k_n and k_n from the block's moduli curve; the interface
G_c from the block's fracture curve, which is measured around the material's own G_c. The
energy per unit crack area of the block is linear through zero in the interface G_c (Griffith
scaling; calibrate_bcm fits its slope s), so every G_c of the grid is reached with the same
curve: G_c(interface) = G_c / s. One fracture curve, whatever the grid.

BPM: k_A from nu and the LJ units from E and the density on the 3D moduli curve (as
driver/calibration/calibrate.py calibrate_bpm, in 3D). lambda_c is not calibrated (the mode-I
test is 2D only): at the material's G_c it is given, or estimated from the 2D mode-I law
K_IC = c E sqrt(a) (lambda_c - 1) (solve.bpm_lambda_c's law; c = MODE1_SLOPE_2D), and scaled to
another G_c by the same law with G_c = K_IC^2 / E': lambda_c - 1 ~ sqrt(G_c).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from rich.console import Console

from driver.calibration import curves as cv
from driver.calibration import solve
from driver.calibration.material import MaterialFile


#: c of K_IC / (E sqrt(a)) = c (lambda_c - 1), measured in 2D (README, the BPM mode-I
#: toughness: K_IC / E = 0.0309 at lambda_c = 1.05 and 0.0188 at 1.03, k_A = 4, L = 40; their
#: ratio 0.61 against 0.6 for proportionality). An estimate for the 3D particle, stated so.
MODE1_SLOPE_2D = 0.62


def estimated_lambda_c(mat: MaterialFile) -> float:
    """lambda_c at the material's K_IC (plane strain) by the 2D mode-I law (MODE1_SLOPE_2D)."""
    _, K = mat.material.toughness(3)
    return 1.0 + cv.rounded(K / (mat.material.E * math.sqrt(mat.bpm.a())) / MODE1_SLOPE_2D)


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


def calibrate_bpm_3d(mat: MaterialFile, cache: Path, workers: int, console: Console) -> dict[str, Any]:
    """k_A and the units of the 3D BPM (the moduli curve in 3D; `curves.bpm_moduli` of the
    material file changes it)."""
    res, tgt = mat.bpm, mat.material
    moduli = cv.measure(cv.changed(cv.bpm_moduli(3), mat.curves.get("bpm_moduli")), cache, workers, console)
    t = moduli.table
    col = lambda name: t[f"{name}_mean"].to_numpy(float)  # noqa: E731
    inv_k, units, reduced = solve.bpm_elastic(tgt.nu, tgt.E, tgt.density, res.a(), t.k_A, col("nu"), col("E"),
                                              col("number_density"))
    return {"model": "bpm", "dimension": 3,
            "parameters": {"k_A": cv.rounded(inv_k.x), "theta_c_deg": res.theta_c_deg,
                           "particles_across": res.diameter / res.a()},
            # 8 digits: the same units whether the curve was just measured or read from the cache
            "units": {k: cv.rounded(v, 8) for k, v in units.as_dict().items()}, "reduced": reduced,
            "achieved": {"density": tgt.density, "E": tgt.E, "nu": inv_k.y},
            "target": {"density": tgt.density, "E": tgt.E, "nu": tgt.nu},
            "reach": {"nu": inv_k.as_dict()},
            "curves": {"bpm_moduli": {"directory": str(moduli.directory), "from_cache": moduli.cached}}}


def grid_parameters(bcm: dict[str, Any], bpm: dict[str, Any], g_values: list[float], G_ref: float,
                    lambda_ref: float) -> list[dict[str, Any]]:
    """One row per (model, G_c): the model's fracture parameter at the material's G_c."""
    rows = []
    for g in g_values:
        rows.append({"model": "bcm", "G_c": g, "parameter": "model.interface.G_c",
                     "value": bcm_interface_gc(bcm, g)})
        rows.append({"model": "bpm", "G_c": g, "parameter": "model.lambda_c", "value": bpm_lambda_c(lambda_ref,
                                                                                                  G_ref, g)})
    return rows
