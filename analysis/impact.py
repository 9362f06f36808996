"""Measures of one BCM impact (SPEC 1.5), in one place.

Energies in J, areas in m^2. The SPEC 1.5 definitions:
  W_k^- = M v^2 / 2 before impact, W_k^+ = kinetic energy of all cells after,
  W_f = 2 A G_c, W_s = 2 A_0 G_c, D_w = A / A_0, eta = W_f / W_k^-, e_k^2 = W_k^+ / W_k^-,
  omega = W_k^- / W_s, chi = W_k^+ / W_f, W_c = W_k^- - W_k^+ - W_f.
"""

from __future__ import annotations

import math


def impact_measures(wk_minus: float, wk_plus: float, wk_plus_cm: float, broken_area: float,
                    total_area: float, g_c: float, elastic_end: float,
                    dissipated_measured: float | None = None) -> dict[str, float]:
    """SPEC 1.5 measures of one impact. `wk_plus_cm` is the fragments' centre-of-mass part of
    W_k^+; `dissipated_measured` is W_c from the work of the dissipative forces (damping,
    friction, switch), reported beside the balance value as a check."""
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
    return out
