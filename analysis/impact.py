"""Measures of one BCM impact (SPEC 1.5), in one place.

Energies in J, areas in m^2. The SPEC 1.5 definitions:
  W_k^- = M v^2 / 2 before impact, W_k^+ = kinetic energy of all cells after,
  W_f = 2 A G_c, W_s = 2 A_0 G_c, D_w = A / A_0, eta = W_f / W_k^-, e_k^2 = W_k^+ / W_k^-,
  omega = W_k^- / W_s, chi = W_k^+ / W_f, W_c = W_k^- - W_k^+ - W_f.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.dumps import read_atom_dump, read_local_dump
from analysis.grains import grain_labels
from analysis.pictures import render_cells
from analysis.plots import plot_energies
from analysis.shapes import fragment_table, shape_averages, vertices_in_space
from analysis.tables import save_table
from driver.bcm.lammps_files import read_cells


def impact_measures(wk_minus: float, wk_plus: float, wk_plus_cm: float, broken_area: float,
                    total_area: float, g_c: float, elastic_end: float,
                    dissipated_measured: float | None = None) -> dict[str, float]:
    """SPEC 1.5 measures of one impact. `wk_plus_cm` is the fragments' centre-of-mass part of
    W_k^+; `dissipated_measured` is W_c from the work of the dissipative forces (damping,
    friction, switch, changes of a contact's number of points: see read_impact_thermo),
    reported beside the balance value as a check."""
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


# ----------------------------------------------------------------------- run directory
THERMO_COLUMNS = ["step", "time", "ke_trans", "ke_rot", "intact", "broken", "broken_area", "W_f", "E_interfaces",
                  "W_damp", "W_friction", "W_switch", "wall_contacts", "wall_force", "W_wall", "E_wall",
                  "W_wall_damp", "W_wall_friction", "W_wall_npoints", "work_wall",
                  "E_contacts", "W_contact_damp", "W_contact_friction", "W_contact_npoints", "work_contacts"]
INTERFACE_COLUMNS = ["atom1", "atom2", "state", "area", "energy", "break_step", "break_time", "energy_at_break"]


def read_impact_thermo(path: Path) -> pd.DataFrame:
    """The `fix print` energy record of an impact run, one row per record (latest per step).

    Stores and sinks of the three force styles (plugins/doc): the interfaces
    (bond bcm/griffith: E_interfaces, W_f, W_damp, W_friction, W_switch), the plane (fix
    bcm/wall: E_wall, W_wall = W_wall_damp + W_wall_friction + W_wall_npoints) and the contacts
    of cells that share no interface (pair bcm/contact: E_contacts, W_contact_damp,
    W_contact_friction, W_contact_npoints). `*_npoints` is the energy lost when a contact's
    number of points changes (its stiffness is shared by them; < 0 when gained).
    Derived: kinetic, elastic (all stores), dissipated (all sinks but W_f), and the parts of
    dissipated: dissipated_damping, dissipated_friction, dissipated_npoints (W_switch apart).
    work_wall and work_contacts, the work of those styles' forces on the cells, are a check:
    work + change of stored + dissipated = 0 for each."""
    df = pd.read_csv(path, sep=r"\s+", comment="#", names=THERMO_COLUMNS, header=None)
    df = df.drop_duplicates("step", keep="last").reset_index(drop=True)
    df["kinetic"] = df.ke_trans + df.ke_rot
    df["elastic"] = df.E_interfaces + df.E_wall + df.E_contacts
    df["dissipated_damping"] = df.W_damp + df.W_wall_damp + df.W_contact_damp
    df["dissipated_friction"] = df.W_friction + df.W_wall_friction + df.W_contact_friction
    df["dissipated_npoints"] = df.W_wall_npoints + df.W_contact_npoints
    df["dissipated"] = df.dissipated_damping + df.dissipated_friction + df.dissipated_npoints + df.W_switch
    return df


def read_interfaces(path: Path) -> pd.DataFrame:
    frame = read_local_dump(path)[-1]
    cols = list(frame.columns.values())
    return pd.DataFrame({name: col for name, col in zip(INTERFACE_COLUMNS, cols)})


def fragments_of(n_cells: int, interfaces: pd.DataFrame) -> np.ndarray:
    """SPEC 1.5: fragments are connected components of the graph of intact interfaces."""
    pairs = interfaces[["atom1", "atom2"]].to_numpy(dtype=np.int64) - 1
    return grain_labels(n_cells, pairs, interfaces["state"].to_numpy() > 0.5)


def analyse_impact(run_dir: Path, cfg: dict, plots: bool = True) -> dict:
    """Measures, fragment table, energy series, plots and picture of a finished impact run."""
    run_dir = Path(run_dir)
    model, scen = cfg["model"], cfg["scenario"]
    system = json.loads((run_dir / "system.json").read_text())
    thermo = read_impact_thermo(run_dir / "thermo.dat")
    cells = read_atom_dump(run_dir / "dumps" / "cells.end.lammpstrj")[-1]
    ifaces = read_interfaces(run_dir / "dumps" / "interfaces.end.lammpstrj")
    n = len(cells.ids)
    labels = fragments_of(n, ifaces)
    masses = cells.extra["mass"]
    volumes = masses / model["density"]
    body, faces = read_cells(run_dir / "cells.txt")
    offsets = np.concatenate([[0], np.cumsum([len(v) for v in body])])
    space = vertices_in_space(np.concatenate(body), offsets, cells.positions, cells.quaternions())
    frags = fragment_table(labels, masses, volumes, (space, offsets))

    # fragments' centre-of-mass kinetic energy (SPEC 1.5: part of W_k^+)
    mom = np.zeros((len(frags), 3))
    np.add.at(mom, labels, masses[:, None] * cells.velocities)
    frag_mass = np.bincount(labels, weights=masses)
    frags["v_cm"] = np.linalg.norm(mom / frag_mass[:, None], axis=1)
    wk_cm = float(0.5 * np.sum(np.sum(mom ** 2, axis=1) / frag_mass))

    last = thermo.iloc[-1]
    wk_minus = 0.5 * system["mass"] * scen["velocity"] ** 2
    measures = impact_measures(
        wk_minus=wk_minus, wk_plus=float(last.kinetic), wk_plus_cm=wk_cm, broken_area=float(last.broken_area),
        total_area=system["A0"], g_c=model["interface"]["G_c"], elastic_end=float(last.elastic),
        dissipated_measured=float(last.dissipated))
    measures.update({
        "W_c_damping": float(last.dissipated_damping), "W_c_friction": float(last.dissipated_friction),
        "W_c_switch": float(last.W_switch), "W_c_npoints": float(last.dissipated_npoints),
        "n_fragments": int(len(frags)), "n_fragments_multi_cell": int((~frags.single_cell).sum()),
        "largest_fragment_mass_fraction": float(frags.mass.max() / system["mass"]),
        "broken_interfaces": int(last.broken), "end_time": float(last.time), "end_step": int(last.step),
        "timestep": system["timestep"], "settled": bool(last.step < system["max_steps"]),
        "cells_on_plane_end": int(last.wall_contacts),
        "stop_rule": (f"stopped after a window of {system['window_steps']} steps with no break, kinetic energy "
                      f"within {scen['ke_tolerance']:g} and the plane unloaded, or at max_time "
                      f"{scen['max_time']:g} s"),
        **{f"shape_{k}": v for k, v in shape_averages(frags).items()},
    })

    res = run_dir / "results"
    save_table(thermo, res / "energies")
    save_table(frags, res / "fragments")
    save_table(ifaces, res / "interfaces")
    if plots:
        title = (f"BCM impact, N_c = {system['n_cells']}, v0 = {scen['velocity']:g} m/s, "
                 f"G_c = {model['interface']['G_c']:g} J/m²")
        plot_energies(thermo, wk_minus, run_dir / "plots" / "energies.png", title)
        cell_vertices = [space[offsets[i]:offsets[i + 1]] for i in range(n)]
        render_cells(cell_vertices, faces, labels, run_dir / "plots" / "fragments.png",
                     f"{title}\n{len(frags)} fragments, D_w = {measures['D_w']:.3f}")
    return measures
