"""The BPM side of `driver calibrate` (solve.py, BPM): k_A from nu on the moduli curve, the LJ
units from E and the density, then lambda_c from the mode-I curve measured at that k_A; and
its round trip (the tests run again at the chosen parameters)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from rich.console import Console

from driver.calibration import curves as cv
from driver.calibration import solve
from driver.calibration.common import curve_record, means, panel, round_trip_errors, with_changes
from driver.calibration.material import MaterialFile


def calibrate_bpm(mat: MaterialFile, cache: Path, workers: int, console: Console) -> dict[str, Any]:
    """The BPM's parameters for the target (solve.py, BPM)."""
    res, tgt = mat.bpm, mat.material
    dim = res.dimension
    a = res.a()
    moduli = cv.measure(cv.changed(cv.bpm_moduli(dim, res.packing), mat.curves.get("bpm_moduli")), cache, workers,
                        console)
    t = moduli.table
    if "number_density_mean" not in t:
        raise cv.CalibrationError(f"curve {moduli.directory}: no number density (measured by an older version); "
                                  "remove that folder to measure it again")
    inv_k, units, reduced = solve.bpm_elastic(tgt.nu, tgt.E, tgt.density, a, t.k_A, means(t, "nu"), means(t, "E"),
                                              means(t, "number_density"))
    G_target, K_target = tgt.toughness(dim)
    mode1_spec = cv.changed(cv.bpm_mode1(dim, inv_k.x, res.theta_c_deg, res.packing), mat.curves.get("bpm_mode1"))
    mode1 = cv.measure(mode1_spec, cache, workers, console)
    m1 = mode1.table
    inv_l = solve.bpm_lambda_c(K_target, tgt.E, a, m1.lambda_c.to_numpy(float), means(m1, "K_IC"),
                               reduced["E_reduced"])
    notes = repulsion_notes(moduli.spec.sweep["base"], inv_l.x)
    nu_model = inv_k.y
    E_model = tgt.E  # the energy unit makes the network's E the target's
    K_model = inv_l.y * tgt.E * math.sqrt(a)
    ep = E_model if dim == 2 else E_model / (1.0 - nu_model ** 2)
    return {
        "model": "bpm", "dimension": dim,
        "parameters": {"k_A": cv.rounded(inv_k.x), "lambda_c": 1.0 + cv.rounded(inv_l.x - 1.0),
                       "theta_c_deg": res.theta_c_deg, "grain_diameter_in_a": res.diameter / a},
        "units": units.as_dict(), "reduced": reduced,
        "achieved": {"density": tgt.density, "E": E_model, "nu": nu_model, "K_IC": K_model,
                     "G_c": K_model ** 2 / ep},
        "target": {"density": tgt.density, "E": tgt.E, "nu": tgt.nu, "K_IC": K_target, "G_c": G_target},
        "reach": {"nu": inv_k.as_dict(), "K_IC_over_E": inv_l.as_dict()},
        "notes": notes,
        "curves": {c.spec.name: curve_record(c) for c in (moduli, mode1)},
        "_curves": {"nu": panel(t.k_A, means(t, "nu"), inv_k, "$k_A$", r"$\nu$"),
                    "toughness": panel(m1.lambda_c.to_numpy(float) - 1.0, means(m1, "K_IC") / reduced["E_reduced"],
                                       inv_l, r"$\lambda_c - 1$", r"$K_{IC}^*/E^*$", log=True, shift=1.0)},
    }


def repulsion_notes(base: dict[str, Any], lambda_c: float) -> list[str]:
    """Whether bonds of the packing the curves were measured on break inside the non-bonded
    repulsion at this lambda_c (driver/bpm/network.py repulsion_at_break): each such break
    creates energy, so a dynamic run (an impact) gains energy at its breaks, and the mode-I
    curve itself bends away from K_IC ~ lambda_c - 1 there (measured on the 3D contact packing:
    K_IC at 1.001 is 1/125 of that at 1.01)."""
    # the BPM builders and the config are imported when used: a calibration read from the cache needs neither
    from driver.bpm.network import repulsion_at_break  # noqa: PLC0415
    from driver.bpm.solid import packing_and_network  # noqa: PLC0415
    from driver.config import parse_config  # noqa: PLC0415

    cfg = parse_config({**base, "scenario": {"kind": "calibrate", "test": "moduli"}}, "calibration curve base")
    packing, net = packing_and_network(cfg)  # cached: read back, not relaxed again
    abar = packing.radii[net.bonds[:, 0]] + packing.radii[net.bonds[:, 1]]
    n_in, u_max, _ = repulsion_at_break(net.r0, abar, lambda_c)
    if not n_in:
        return []
    where = "model.packing: lj_minimum" if cfg.model.dimension == 3 else "a larger lambda_c (a finer resolution)"
    return [f"at lambda_c = {lambda_c:.6g}, {n_in / net.n_bonds:.0%} of the bonds of this packing "
            f"({cfg.model.packing or '2D'}) break inside the non-bonded repulsion (lambda_c r0 below the sum of "
            f"radii: bonded neighbours that overlap), and each such break creates up to {u_max:.3g} u: a dynamic "
            f"run (an impact) gains energy at its breaks; use {where}"]


def verify_bpm(mat: MaterialFile, result: dict[str, Any], directory: Path, workers: int,
               console: Console) -> dict[str, dict[str, float]]:
    """The round trip of the BPM: the moduli and mode1 tests (the curves' sizes, first seed) at
    the chosen k_A and lambda_c; their E, nu and G_c in SI against the target."""
    dim, p, u = result["dimension"], result["parameters"], result["units"]
    a, unit_u = u["length_a_m"], u["energy_u_J"]
    packing = mat.bpm.packing
    moduli = cv.changed(cv.bpm_moduli(dim, packing), mat.curves.get("bpm_moduli")).sweep["base"]
    mode1 = cv.changed(cv.bpm_mode1(dim, p["k_A"], p["theta_c_deg"], packing),
                       mat.curves.get("bpm_mode1")).sweep["base"]
    moduli = with_changes(moduli, {"model.k_A": p["k_A"]})
    mode1 = with_changes(mode1, {"model.lambda_c": p["lambda_c"],
                          **{k: v[0] for k, v in cv.pull_keys([p["lambda_c"]], dim).items()}})
    s = cv.run_configs({"bpm_moduli": moduli, "bpm_mode1": mode1}, directory, workers, console)
    E = s["bpm_moduli"]["E"] * unit_u / a ** 3
    nu = s["bpm_moduli"]["nu"]
    K = s["bpm_mode1"]["K_IC"] * unit_u / a ** 2.5
    G = K ** 2 / (E if dim == 2 else E / (1.0 - nu ** 2))
    return round_trip_errors(result["target"], {"E": E, "nu": nu, "G_c": G})
