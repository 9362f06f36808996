"""The measures of one particle impact (SPEC 1.5) that do not depend on the model: both the
BCM's (analysis/bcm_impact.py) and the BPM's (analysis/bpm_impact.py) analyses use them.

Energies in J, areas in m^2. The SPEC 1.5 definitions:
  W_k^- = M v^2 / 2 before impact, W_k^+ = kinetic energy of all cells after,
  W_f = 2 A G_c, W_s = 2 A_0 G_c, D_w = A / A_0, eta = W_f / W_k^-, e_k^2 = W_k^+ / W_k^-,
  omega = W_k^- / W_s, chi = W_k^+ / W_f, W_c = W_k^- - W_k^+ - W_f.
SPEC 3 (and the rockable convention): W_f is also reported as the elastic energy the breaks
released (W_f_released = W_f + W_c_switch), with eta_released and W_c_released built on it and
a flag when the two differ by more than W_F_TOLERANCE, and as the energy the broken
interfaces held just before (W_f_held).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.statistics import fit_mass_ratio_law

W_F_TOLERANCE = 0.01  # |W_f_released - W_f| above this fraction of W_f is flagged


def impact_measures(wk_minus: float, wk_plus: float, wk_plus_cm: float, broken_area: float,
                    total_area: float, g_c: float, elastic_end: float,
                    dissipated_measured: float | None = None, channels: dict[str, float] | None = None,
                    w_f_held: float | None = None, convention: str | None = None) -> dict:
    """SPEC 1.5 measures of one impact. `wk_plus_cm` is the fragments' centre-of-mass part of
    W_k^+; `dissipated_measured` is W_c from the work of the dissipative forces (damping,
    friction, switch, changes of a contact's number of points: see read_impact_thermo),
    reported beside the balance value as a check; channels: its parts (energy_channels), as
    W_c_<channel>.

    W_f = 2 A G_c is what the Griffith convention books (`convention`: model.griffith_energy).
    What the breaks took out of the interfaces' springs, the energy held just before minus what
    the contact law kept, is W_f_released = W_f + W_c_switch (the switch term is exactly that
    difference, up to the half kick of the break step; plugins/doc/bond_bcm_griffith.md). Under
    `rockable` the springs held about 1/N_p of W_f and the switch term is negative. Both are
    reported, with eta_released = W_f_released / W_k^- and W_c_released = W_k^- - W_k^+ -
    W_f_released, and W_f_flag says why when they differ by more than W_F_TOLERANCE of W_f.
    w_f_held: the energy the broken interfaces held when they broke (sum of their
    energy_at_break; SPEC 3), as W_f_held. energy_flags lists every flag, and every negative
    dissipation (W_c, W_c_measured, W_c_released, a channel) with its cause: none is a result
    without its flag."""
    w_f = 2.0 * broken_area * g_c
    w_s = 2.0 * total_area * g_c
    w_c = wk_minus - wk_plus - w_f
    out = {
        "W_k_minus": wk_minus, "W_k_plus": wk_plus, "W_k_plus_cm": wk_plus_cm,
        "A": broken_area, "A0": total_area, "W_f": w_f, "W_s": w_s,
        "D_w": broken_area / total_area, "eta": w_f / wk_minus, "e_k2": wk_plus / wk_minus,
        "omega": wk_minus / w_s, "chi": wk_plus / w_f if w_f > 0 else math.inf,
        "W_c": w_c, "W_c_over_W_s": w_c / w_s, "elastic_end": elastic_end,
        "elastic_end_over_W_k_minus": elastic_end / wk_minus,
    }
    if dissipated_measured is not None:
        out["W_c_measured"] = dissipated_measured
        # the balance W_k^- = W_k^+ + W_f + W_c + E_el(end), with W_c measured directly
        out["balance_residual"] = (wk_minus - wk_plus - w_f - dissipated_measured - elastic_end) / wk_minus
    for name, value in (channels or {}).items():
        out[f"W_c_{name}"] = value
    flags: list[str] = []
    if channels is not None and "switch" in channels:
        released = w_f + channels["switch"]
        out.update({"W_f_released": released, "W_f_released_over_W_f": released / w_f if w_f > 0 else None,
                    "eta_released": released / wk_minus, "W_c_released": wk_minus - wk_plus - released})
        out["W_f_flag"] = fracture_energy_flag(w_f, released, convention)
        if out["W_f_flag"]:
            flags.append(out["W_f_flag"])
    if w_f_held is not None:
        out.update({"W_f_held": w_f_held, "W_f_held_over_W_f": w_f_held / w_f if w_f > 0 else None})
    flags += negative_dissipation_flags(out, wk_minus, list(channels or ()))
    out["energy_flags"] = flags
    return out


def fracture_energy_flag(w_f: float, w_f_released: float, convention: str | None = None,
                         tolerance: float = W_F_TOLERANCE) -> str | None:
    """Why W_f = 2 A G_c is not the elastic energy the breaks released, when the two differ by
    more than `tolerance` of W_f (None otherwise)."""
    if w_f == 0 and w_f_released == 0 or abs(w_f_released - w_f) <= tolerance * abs(w_f):
        return None
    conv = f" (model.griffith_energy = {convention})" if convention else ""
    head = (f"W_f = 2 A G_c = {w_f:.4g} J but the breaks released {w_f_released:.4g} J of elastic energy "
            f"(W_f + W_c_switch, {(w_f_released - w_f) / w_f:+.1%} of W_f){conv}: ")
    if w_f_released < w_f:
        return head + ("the convention books fracture energy the springs never held, so W_f, eta, chi and W_c are "
                       "bookkeeping; W_f_released, eta_released and W_c_released are what the springs gave up")
    return head + ("more than 2 A G_c left the springs at the breaks (the switch loss: broken points passing to the "
                   "contact law lose energy), so eta understates what breaking took; eta_released is that")


_NEGATIVE_CAUSES = {
    "npoints": "energy put in when a contact gained points (runs made with the former law that shared a "
               "contact's stiffness among its points; zero since)",
    "switch": "the one-step overshoot of the threshold and the half kick replaced at breaks",
}


def negative_dissipation_flags(measures: dict, wk_minus: float, channels: list[str]) -> list[str]:
    """One line per negative dissipation among W_c, W_c_measured, W_c_released and the
    channels W_c_<channel>, with its likely cause."""
    out = []
    for key in ("W_c", "W_c_measured", "W_c_released", *(f"W_c_{c}" for c in channels)):
        value = measures.get(key)
        if value is None or value >= 0:
            continue
        booked_beyond = measures.get("W_f_flag") and measures["W_f_released"] < measures["W_f"]
        if booked_beyond and key in ("W_c", "W_c_measured", "W_c_switch"):
            cause = "the Griffith convention books more fracture energy than the springs held (W_f_flag)"
        else:
            cause = next((c for k, c in _NEGATIVE_CAUSES.items() if key.endswith(k)),
                         "the energy balance does not close (see balance_residual)")
        out.append(f"{key} = {value:.4g} J ({value / wk_minus:+.3g} W_k^-) is negative: not a dissipation, "
                   f"not a result; cause: {cause}")
    return out


def settle_outcome(run_dir: Path, system: dict, last_record: int) -> dict:
    """How the run ended: `settled` (the stop rule fired) and `end_step`, from the session's
    outcome.json; runs made before it existed: settled when the last record is before the
    hard stop."""
    try:
        outcome = json.loads((Path(run_dir) / "outcome.json").read_text())
        return {"settled": bool(outcome["settled"]), "end_step": int(outcome["end_step"]),
                "settle_windows": int(outcome["windows"])}
    except (OSError, ValueError, KeyError):
        return {"settled": bool(last_record < system["max_steps"]), "end_step": last_record}


def fragment_counts(fragments: pd.DataFrame, parent_mass: float) -> dict:
    """Break-up measures of one impact (SPEC 1.5) from its fragment table (mass, n_cells):
    n_fragments, n_fragments_multi_cell (of two or more cells), and the mass fractions of the
    parent held by the largest and the second largest fragment (0 when there is one), which
    the set analysis compares with its break-up fraction."""
    masses = np.sort(fragments["mass"].to_numpy(dtype=float))[::-1] / parent_mass
    return {"n_fragments": int(len(masses)), "n_fragments_multi_cell": int((fragments["n_cells"] >= 2).sum()),
            "largest_fragment_mass_fraction": float(masses[0]) if len(masses) else 0.0,
            "second_fragment_mass_fraction": float(masses[1]) if len(masses) > 1 else 0.0}


def fragment_mass_fit(masses: np.ndarray, n_bootstrap: int = 200) -> dict:
    """tau of p(m/m_max) of one impact (statistics.fit_mass_ratio_law) as summary entries;
    None values with fewer than 20 fragments besides the largest."""
    fit = fit_mass_ratio_law([masses], n_bootstrap=n_bootstrap)
    if fit is None:
        return {"tau": None, "sigma": None, "sigma_bootstrap": None, "xmin": None, "xmax": None, "n_fit": None}
    return {"tau": float(fit.tau), "sigma": float(fit.sigma), "sigma_bootstrap": float(fit.sigma_bootstrap),
            "xmin": float(fit.xmin), "xmax": 1.0, "n_fit": int(fit.n)}
