"""The BCM side of `driver calibrate` (solve.py, BCM): k_t / k_n from nu and k_n from E on the
block's moduli curve, then the interface G_c from the block's fracture curve measured at that
stiffness.

Fracture energy. The material's G_c is an energy release rate, energy per unit crack area
(G_c = K_IC^2 / E', SPEC 3). The block's fracture test (analysis/bcm_calibrate.py) reports
G_released = W / (2 A): W the elastic energy the broken interfaces held when they broke, A the
ligament's projected area; an interface breaks when its energy reaches 2 S G_c (SPEC 1.2,
Eq. 4-6: G = Delta W_p / (2 S)), so a flat crack through the ligament gives G_released = G_c
of the interfaces, and the material's energy per unit crack area is W / A = 2 G_released
(crack roughness and secondary breaks add to it). The curve W / A against the interface G_c
is linear through zero by the Griffith scaling; its slope s turns the target into
G_c(interface) = G_c(material) / s.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from rich.console import Console

from driver.calibration import curves as cv
from driver.calibration import solve
from driver.calibration.common import curve_record, means, panel, round_trip_errors, with_changes
from driver.calibration.material import MaterialFile

#: Reference interface normal stiffness of the moduli curve, N/m (SPEC 1.3 default).
KN_REFERENCE = 1e7
#: k_t / k_n of the moduli curve (SPEC 1.3 default 0.8 in the range; nu falls from about 0.2
#: at 0.2 to 0.01 at 1, so the points reach down to 0.05 for the nu of glass and rock).
KT_OVER_KN = (0.05, 0.1, 0.2, 0.4, 0.6, 0.8, 1.0)
#: Interface G_c of the fracture curve, as multiples of the first estimate (target / 2).
GC_FACTORS = (0.5, 1.0, 2.0)
#: Cells of the block.
BLOCK_CELLS = 300


def bcm_moduli() -> cv.CurveSpec:
    """B, G, E, nu of the block against k_t / k_n at k_n = KN_REFERENCE and the default
    particle's cell size (the block's default h)."""
    base = {"name": "cal_bcm_moduli", "seed": 1,
            "model": {"kind": "bcm", "interface": {"kn": KN_REFERENCE}},
            "scenario": {"kind": "calibrate", "test": "moduli", "block": {"n_cells": BLOCK_CELLS}}}
    return cv.CurveSpec("bcm_moduli", {"base": base, "axes": {"model.interface.kt": [
        cv.rounded(r * KN_REFERENCE) for r in KT_OVER_KN]}, "seeds": 2}, "moduli", "kt_over_kn")


def bcm_fracture(kn: float, kt: float, h: float, G_estimate: float) -> cv.CurveSpec:
    """Released energy against the interface G_c at the chosen stiffness and cell size."""
    base = {"name": "cal_bcm_fracture", "seed": 1,
            "model": {"kind": "bcm", "interface": {"kn": cv.rounded(kn), "kt": cv.rounded(kt)}},
            "scenario": {"kind": "calibrate", "test": "fracture",
                         "block": {"n_cells": BLOCK_CELLS, "cell_size": cv.rounded(h)}}}
    return cv.CurveSpec("bcm_fracture", {"base": base, "axes": {"model.interface.G_c": [
        cv.rounded(f * G_estimate) for f in GC_FACTORS]}, "seeds": 2}, "fracture", "G_c")


def calibrate_bcm(mat: MaterialFile, cache: Path, workers: int, console: Console) -> dict[str, Any]:
    """The BCM's parameters for the target."""
    res, tgt = mat.bcm, mat.material
    h = res.h()
    moduli = cv.measure(cv.changed(bcm_moduli(), mat.curves.get("bcm_moduli")), cache, workers, console)
    t = moduli.table
    e = means(t, "E") * t.cell_size.to_numpy(float) / t.kn.to_numpy(float)  # E h / k_n, dimensionless
    inv_r, elastic = solve.bcm_elastic(tgt.nu, tgt.E, h, t.kt_over_kn.to_numpy(float), means(t, "nu"), e)
    G_target, K_target = tgt.toughness(3)
    frac = cv.measure(cv.changed(bcm_fracture(elastic["kn"], elastic["kt"], h, G_target / 2.0),
                                 mat.curves.get("bcm_fracture")), cache, workers, console)
    f = frac.table
    per_area = 2.0 * means(f, "G_released")  # W / A, energy per unit crack area (module docstring)
    slope, slope_se = solve.through_zero_slope(f.G_c.to_numpy(float), per_area)
    G_iface = G_target / slope
    inv_g = solve.Inverse(G_iface, G_target, G_target, True, "")
    nu_model = inv_r.y
    E_model = tgt.E
    return {
        "model": "bcm",
        "parameters": {"kn": cv.rounded(elastic["kn"]), "kt": cv.rounded(elastic["kt"]),
                       "kt_over_kn": cv.rounded(inv_r.x), "G_c": cv.rounded(G_iface), "cell_size_m": h,
                       "density": tgt.density},
        "fracture_slope": {"slope": slope, "slope_se": slope_se, "meaning": "W/A per unit interface G_c"},
        "achieved": {"density": tgt.density, "E": E_model, "nu": nu_model, "G_c": G_target,
                     "K_IC": math.sqrt(G_target * E_model / (1.0 - nu_model ** 2))},
        "target": {"density": tgt.density, "E": tgt.E, "nu": tgt.nu, "K_IC": K_target, "G_c": G_target},
        "reach": {"nu": inv_r.as_dict()},
        "curves": {c.spec.name: curve_record(c) for c in (moduli, frac)},
        "_curves": {"nu": panel(t.kt_over_kn, means(t, "nu"), inv_r, "$k_t/k_n$", r"$\nu$"),
                    "fracture": panel(f.G_c, per_area, inv_g, r"interface $G_c$ (J/m$^2$)",
                                      r"$W/A$ (J/m$^2$)")},
    }


def verify_bcm(mat: MaterialFile, result: dict[str, Any], directory: Path, workers: int,
               console: Console) -> dict[str, dict[str, float]]:
    """The round trip of the BCM: the block's moduli and fracture tests (the curves' sizes, first
    seed) at the chosen k_n, k_t, G_c and cell size; E, nu and W / A against the target."""
    p, h = result["parameters"], result["parameters"]["cell_size_m"]
    moduli = cv.changed(bcm_moduli(), mat.curves.get("bcm_moduli")).sweep["base"]
    frac = cv.changed(bcm_fracture(p["kn"], p["kt"], h, p["G_c"]), mat.curves.get("bcm_fracture")).sweep["base"]
    moduli = with_changes(moduli, {"model.interface.kn": p["kn"], "model.interface.kt": p["kt"],
                            "scenario.block.cell_size": cv.rounded(h)})
    frac = with_changes(frac, {"model.interface.G_c": p["G_c"]})
    s = cv.run_configs({"bcm_moduli": moduli, "bcm_fracture": frac}, directory, workers, console)
    return round_trip_errors(result["target"], {"E": s["bcm_moduli"]["E"], "nu": s["bcm_moduli"]["nu"],
                                      "G_c": 2.0 * s["bcm_fracture"]["G_released"]})
