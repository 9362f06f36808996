"""`driver compare` with `test: compress` (issue 25, point 6): both models, calibrated to one
material, fill the same bed (the compare file's `assembly`: grain count, sizes and box; the same
seeds, so the same grain sizes, drawn from the seed's stream in both) and compress it in the
rigid box to the same target stress, side by side.

The grains' places are the models' own: each model's dense start places its grains' bounding
spheres (the BPM's is wider by a particle's radius, a / 2), so the two beds are two samples of
one grading and box, not one packing.

Per grid point (G_c) the bed measures of each model over its seeds (BED_MEASURES: the start's
void ratio, the yield stress, C_c, C_s, K_0, the breakage at the last dumped state), with the
impact comparison's verdict on the difference of the means (driver/compare/stats.py
side_by_side: |z| <= z_agree agrees). Figures: both models' compression curves, their grading
curves at the last state and their breakage against stress, on the same axes.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

#: The bed measures compared point by point: column -> (label for plots, meaning and unit).
BED_MEASURES: dict[str, tuple[str, str]] = {
    "e_start": (r"$e_0$", "void ratio at the start of the loading"),
    "e_at_max": (r"$e(\sigma_{max})$", "void ratio at the largest stress"),
    "sigma_y": (r"$\sigma_y$ [Pa]", "yield stress (the knee of e against log sigma_v), Pa"),
    "C_c": (r"$C_c$", "compression index after the knee"),
    "C_s": (r"$C_s$", "slope before the knee"),
    "K0": (r"$K_0$", "lateral stress ratio sigma_h / sigma_v while loading"),
    "B_r_last": (r"$B_r$", "Hardin's relative breakage at the last dumped state"),
    "B_r_star_last": (r"$B_r^*$", "Einav's relative breakage at the last dumped state"),
    "fraction_broken_last": (r"broken", "fraction of grains broken at the last dumped state"),
    "fragments_per_grain_last": (r"$N/N_g$", "fragments per grain at the last dumped state"),
    "inertial_max": (r"$I_{max}$", "largest inertial number while loading (quasi-static below 1e-3)"),
    "balance_residual": (r"energy residual", "the energy account's residual / W_p"),
}
#: the states' columns carried into the runs table (their value at the last dumped state)
STATE_COLUMNS = ("B_r", "B_r_star", "fraction_broken", "fragments_per_grain")


def with_last_state(table: pd.DataFrame) -> pd.DataFrame:
    """The runs table with <column>_last of each finished run's last dumped state (its summary's
    `states`, analysis/bed_run.py); NaN where a run has none."""
    out = table.copy()
    for col in STATE_COLUMNS:
        out[f"{col}_last"] = np.nan
    for i, r in out.iterrows():
        summ = Path(str(r.get("run_dir", ""))) / "results" / "summary.json"
        if r.get("state") != "finished" or not summ.exists():
            continue
        states = json.loads(summ.read_text()).get("states") or []
        if states:
            for col in STATE_COLUMNS:
                out.at[i, f"{col}_last"] = states[-1].get(col, np.nan)
    return out


def bed_flags(table: pd.DataFrame) -> list[str]:
    """Sentences for the runs whose measures are not a quasi-static result or whose energy
    account does not close (the runs' own warnings, collected per model)."""
    out = []
    done = table[table.state == "finished"] if "state" in table else table
    for model, grp in done.groupby("model", sort=True):
        if "inertial_max" in grp:
            fast = grp[pd.to_numeric(grp.inertial_max, errors="coerce") > 1e-3]
            if len(fast):
                out.append(f"{model.upper()}: {len(fast)} of {len(grp)} beds loaded faster than quasi-static "
                           f"(inertial number up to {float(fast.inertial_max.max()):.2g} > 1e-3): their "
                           "compression curves carry the rate")
        if "balance_residual" in grp:
            bad = grp[pd.to_numeric(grp.balance_residual, errors="coerce") > 1e-3]
            if len(bad):
                out.append(f"{model.upper()}: the energy account of {len(bad)} beds closes only to "
                           f"{float(bad.balance_residual.max()):.2g} of W_p")
    return out


def bed_curves(table: pd.DataFrame) -> dict[str, list[dict[str, Any]]]:
    """Per model, each finished bed's loading branch (void ratio and sigma_v of its compress
    table, phase 2), its grading at the last state and its breakage against stress."""
    out: dict[str, list[dict[str, Any]]] = {}
    done = table[table.state == "finished"] if "state" in table else table
    for r in done.itertuples():
        res = Path(r.run_dir) / "results"
        rec_path = res / "compress.parquet"
        if not rec_path.exists():
            continue
        rec = pd.read_parquet(rec_path)
        load = rec[(rec.phase == 2) & (rec.sigma_v > 0)]
        entry: dict[str, Any] = {"seed": r.seed, "G_c": r.G_c, "sigma_v": load.sigma_v.to_numpy(),
                                 "void_ratio": load.void_ratio.to_numpy()}
        for name in ("grading", "states"):
            p = res / f"{name}.parquet"
            entry[name] = pd.read_parquet(p) if p.exists() else pd.DataFrame()
        out.setdefault(r.model, []).append(entry)
    return out
