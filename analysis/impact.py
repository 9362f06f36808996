"""Measures of one BCM impact (SPEC 1.5), in one place.

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

from analysis.dumps import DumpError, read_atom_dump, read_local_dump
from analysis.grain_table import grain_table
from analysis.grains import grain_labels
from analysis.pictures import render_cells
from analysis.plots import PlotGuard, plot_energies, plot_losses, plot_mass_pdf, plot_shapes
from analysis.report import Report, clear_report, provenance_line, write_report
from analysis.fragment_shapes import fragment_table, shape_averages, vertices_in_space
from analysis.statistics import fit_mass_ratio_law, normalised_mass_distribution
from analysis.tables import save_table
from analysis.tracking import lineage_table
from runfiles.cells import read_cells
from runfiles.layout import display_dir
from analysis.interface_losses import (LOSS_COLUMNS, channels_in_time, interface_centroids, losses_by_depth,
                                       with_depth)
from runfiles.records import IMPACT_DIAGNOSTICS, IMPACT_RECORD, INTERFACES_DUMP, INTERFACES_REQUIRED, read_record


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


# ----------------------------------------------------------------------- run directory
#: the interface dump's columns as runs before named columns (0.x) wrote them, by position
_UNNAMED_INTERFACE_COLUMNS = dict(zip(("c_ifc[1]", "c_ifc[2]", *(f"c_ifs[{k}]" for k in range(1, 7))),
                                      INTERFACES_DUMP.names))


def read_impact_thermo(path: Path) -> pd.DataFrame:
    """The `fix print` energy record of an impact run, one row per record (latest per step).

    Stores and sinks of the three force styles (plugins/doc): the interfaces
    (bond bcm/griffith: E_interfaces, W_f, W_damp, W_friction, W_switch), the plane (fix
    bcm/wall: E_wall, W_wall = W_wall_damp + W_wall_friction + W_wall_npoints) and the contacts
    of cells that share no interface (pair bcm/contact: E_contacts, W_contact_damp,
    W_contact_friction, W_contact_npoints). `*_npoints` was the energy lost when a contact's
    number of points changed under the former law that shared a contact's stiffness among its
    points; with the per-point law (plugins/doc) it is identically zero, kept so that records of
    older runs read the same.
    Derived: kinetic, elastic (all stores), dissipated (all sinks but W_f), and the parts of
    dissipated: dissipated_damping, dissipated_friction, dissipated_npoints (W_switch apart).
    work_wall and work_contacts, the work of those styles' forces on the cells, are a check:
    work + change of stored + dissipated = 0 for each."""
    # columns by the file's title (runfiles/records.py); the diagnostics when the run has them
    df = read_record(path, [n for n in IMPACT_RECORD.names if n not in IMPACT_DIAGNOSTICS])
    df["kinetic"] = df.ke_trans + df.ke_rot
    df["elastic"] = df.E_interfaces + df.E_wall + df.E_contacts
    df["dissipated_damping"] = df.W_damp + df.W_wall_damp + df.W_contact_damp
    df["dissipated_friction"] = df.W_friction + df.W_wall_friction + df.W_contact_friction
    df["dissipated_npoints"] = df.W_wall_npoints + df.W_contact_npoints
    df["dissipated"] = df.dissipated_damping + df.dissipated_friction + df.dissipated_npoints + df.W_switch
    return df


# Where the measured dissipation W_c went (read_impact_thermo's sinks), one channel per force
# style and mechanism: (channel, record column, what). Their sum is the `dissipated` column.
ENERGY_CHANNELS = [
    ("interface_damping", "W_damp", "damping of intact interfaces (bond bcm/griffith)"),
    ("interface_friction", "W_friction", "friction on broken interfaces"),
    ("switch", "W_switch", "switch loss at breaks: stored before - stored after - 2 S G_c"),
    ("contact_damping", "W_contact_damp", "damping of cell-cell contacts (pair bcm/contact)"),
    ("contact_friction", "W_contact_friction", "friction of cell-cell contacts"),
    ("contact_npoints", "W_contact_npoints", "cell-cell contacts changing their number of points"),
    ("wall_damping", "W_wall_damp", "damping of cell-plane contacts (fix bcm/wall)"),
    ("wall_friction", "W_wall_friction", "friction on the plane"),
    ("wall_npoints", "W_wall_npoints", "cell-plane contacts changing their number of points"),
]


def energy_channels(record: pd.Series, wk_minus: float) -> pd.DataFrame:
    """The energy split of one record of read_impact_thermo (the last: the outcome): one row
    per dissipation channel (ENERGY_CHANNELS; they sum to the measured W_c, `dissipated`), then
    fracture (W_f), the kinetic energy W_k^+ and the elastic energy left. Columns: channel,
    record_column, what, energy [J], over_W_k_minus, part_of_W_c."""
    rows = [(name, col, what, float(record[col]), True) for name, col, what in ENERGY_CHANNELS]
    rows += [("fracture", "W_f", "fracture energy 2 A G_c (Griffith convention)", float(record.W_f), False),
             ("kinetic", "kinetic", "kinetic energy W_k^+ (rebound and fragments)", float(record.kinetic), False),
             ("elastic", "elastic", "elastic energy still stored", float(record.elastic), False)]
    df = pd.DataFrame(rows, columns=["channel", "record_column", "what", "energy", "part_of_W_c"])
    df.insert(4, "over_W_k_minus", df.energy / wk_minus)
    return df


def held_fracture_energy(interfaces: pd.DataFrame) -> float | None:
    """The elastic energy the broken interfaces held just before they broke (SPEC 3), the sum
    of their energy_at_break; None for a dump without it."""
    if "energy_at_break" not in interfaces:
        return None
    return float(interfaces.loc[interfaces["state"] <= 0.5, "energy_at_break"].sum())


def read_interfaces(path: Path) -> pd.DataFrame:
    """The last frame of an interface dump, columns by their header names (INTERFACES_DUMP,
    or the compute names of older runs), as atom1 atom2 state area energy break_step
    break_time energy_at_break; DumpError naming the columns found when one is missing."""
    frame = read_local_dump(path)[-1]
    cols = {_UNNAMED_INTERFACE_COLUMNS.get(k, k): v for k, v in frame.columns.items()}
    missing = [n for n in INTERFACES_DUMP.names[:INTERFACES_REQUIRED] if n not in cols]
    if missing:
        raise DumpError(f"interface dump: no column {', '.join(missing)} (found: {' '.join(frame.columns)})",
                        path=path)
    # the loss columns (W_damp ... closed_force) when the dump has them
    return pd.DataFrame({name: cols[name] for name in INTERFACES_DUMP.names if name in cols}).rename(
        columns={"batom1": "atom1", "batom2": "atom2"})


def fragments_of(n_cells: int, interfaces: pd.DataFrame) -> np.ndarray:
    """SPEC 1.5: fragments are connected components of the graph of intact interfaces."""
    pairs = interfaces[["atom1", "atom2"]].to_numpy(dtype=np.int64) - 1
    return grain_labels(n_cells, pairs, interfaces["state"].to_numpy() > 0.5)


def cell_shapes(run_dir: Path) -> tuple[list[np.ndarray], list[list[np.ndarray]], str | None]:
    """Body-frame vertices and faces of the Voronoi cells of an impact run (they carry the mass,
    and SPEC 1.5 measures fragment boxes on their vertices), and a warning when the run, made
    by an older version without voronoi_cells.txt, only has the cores eroded by r_m."""
    run_dir = Path(run_dir)
    if (run_dir / "voronoi_cells.txt").exists():
        return (*read_cells(run_dir / "voronoi_cells.txt"), None)
    return (*read_cells(run_dir / "cells.txt"),
            f"{display_dir(run_dir)} has no voronoi_cells.txt (made by an older version): fragment shapes are measured on "
            "the cell cores eroded by r_m, each of a, b, c about 2 r_m short")


def last_state_dumps(run_dir: Path, partial: bool) -> tuple[Path, Path, str | None]:
    """The (cells, interfaces) dumps of the end state; for a run cut short (partial), the
    latest periodic pair instead, with a warning saying so."""
    dumps = Path(run_dir) / "dumps"
    end = (dumps / "cells.end.lammpstrj", dumps / "interfaces.end.lammpstrj")
    if end[0].exists() and end[1].exists():
        return (*end, None)
    if not partial:
        raise FileNotFoundError(f"{end[0]}: the end state of the run is missing")
    steps = sorted(int(p.name.split(".")[1]) for p in dumps.glob("cells.*.lammpstrj")
                   if p.name.split(".")[1].isdigit() and (dumps / f"interfaces.{p.name.split('.')[1]}.lammpstrj").exists())
    if not steps:
        raise FileNotFoundError(f"{display_dir(run_dir)}: the run did not finish and left no snapshot after the start "
                                "(set scenario.dump_every to keep periodic ones); nothing to analyse")
    step = steps[-1]
    return (dumps / f"cells.{step}.lammpstrj", dumps / f"interfaces.{step}.lammpstrj",
            f"the run did not finish: measured on its last snapshot (step {step}), not on a settled outcome; "
            f"the end state (dumps/cells.end.lammpstrj) is missing")


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


def analyse_impact(run_dir: Path, cfg: dict, plots: bool = True, partial: bool = False) -> dict:
    """Measures, fragment table, mass and shape distributions, energy series, fragment history
    (when periodic dumps exist), plots, picture and report of a finished impact run (partial:
    of a run cut short, on its last snapshot)."""
    run_dir = Path(run_dir)
    clear_report(run_dir)  # written last: no report = the analysis did not finish
    model, scen = cfg["model"], cfg["scenario"]
    system = json.loads((run_dir / "system.json").read_text())
    cells_dump, ifaces_dump, cut_short = last_state_dumps(run_dir, partial)
    cells = read_atom_dump(cells_dump)[-1]
    ifaces = read_interfaces(ifaces_dump)
    thermo = read_impact_thermo(run_dir / "thermo.dat")
    if cut_short:
        thermo = thermo[thermo.step <= cells.timestep].reset_index(drop=True)
    n = len(cells.ids)
    labels = fragments_of(n, ifaces)
    masses = cells.extra["mass"]
    volumes = masses / model["density"]
    body, faces, warning = cell_shapes(run_dir)
    warnings_ = [w for w in (cut_short, warning) if w]
    offsets = np.concatenate([[0], np.cumsum([len(v) for v in body])])
    space = vertices_in_space(np.concatenate(body), offsets, cells.positions, cells.quaternions())
    frags = fragment_table(labels, masses, volumes, (space, offsets))
    # centre of mass, velocity, kinetic energy and gyration of each fragment (cell centres; open box)
    intact = ifaces[ifaces["state"] > 0.5][["atom1", "atom2"]].to_numpy(dtype=np.int64) - 1
    motion = grain_table(labels, cells.positions, cells.velocities, masses, intact, cells.box,
                         periodic=(False, False, False))
    frags = frags.join(motion.drop(columns=["grain", "size", "mass", "percolating"]).rename(
        columns={"ke": "ke_trans"}))
    frags["v_cm"] = np.sqrt(sum(frags[c] ** 2 for c in ("vx", "vy", "vz")))
    wk_cm = float(frags.ke_cm.sum())

    last = thermo.iloc[-1]
    wk_minus = 0.5 * system["mass"] * scen["velocity"] ** 2
    channels = energy_channels(last, wk_minus)
    held = held_fracture_energy(ifaces)
    if held is None:
        warnings_.append("the interfaces dump has no energy_at_break: W_f_held is not measured")
    measures = impact_measures(
        wk_minus=wk_minus, wk_plus=float(last.kinetic), wk_plus_cm=wk_cm, broken_area=float(last.broken_area),
        total_area=system["A0"], g_c=model["interface"]["G_c"], elastic_end=float(last.elastic),
        dissipated_measured=float(last.dissipated), w_f_held=held,
        channels=dict(zip(channels.channel[channels.part_of_W_c], channels.energy[channels.part_of_W_c])),
        convention=model.get("griffith_energy"))
    mass_pdf = normalised_mass_distribution(frags.mass.to_numpy())
    tau = fragment_mass_fit(frags.mass.to_numpy())
    measures.update({
        "W_c_damping": float(last.dissipated_damping), "W_c_friction": float(last.dissipated_friction),
        "W_c_switch": float(last.W_switch), "W_c_npoints": float(last.dissipated_npoints),
        **fragment_counts(frags, system["mass"]),
        "broken_interfaces": int(last.broken), "end_time": float(last.time),
        "timestep": system["timestep"], **settle_outcome(run_dir, system, int(last.step)),
        "cells_on_plane_end": int(last.wall_contacts),
        "stop_rule": (f"stopped after a window of {system['window_steps']} steps with no break, kinetic energy "
                      f"within {scen['ke_tolerance']:g} and the plane unloaded, or at max_time "
                      f"{scen['max_time']:g} s"),
        **({"settled": False} if cut_short else {}),
        **{f"shape_{k}": v for k, v in shape_averages(frags).items()},
        **{f"mass_{k}": v for k, v in tau.items()},
        **({"warnings": warnings_} if warnings_ else {}),
    })
    history, tracking = fragment_history(run_dir, n)
    losses = interface_losses(run_dir, cfg, ifaces, thermo, wk_minus)

    res = run_dir / "results"
    save_table(thermo, res / "energies")
    save_table(channels, res / "energy_channels")
    save_table(frags, res / "fragments")
    save_table(ifaces, res / "interfaces")
    save_table(mass_pdf, res / "fragment_masses")
    if history is not None:
        save_table(history, res / "frames")
        save_table(tracking, res / "tracking")
    if losses is not None:
        save_table(losses[1], res / "losses_by_depth")
    title = (f"BCM impact, N_c = {system['n_cells']}, v0 = {scen['velocity']:g} m/s, "
             f"G_c = {model['interface']['G_c']:g} J/m²")
    guard = PlotGuard()  # a figure that fails is listed in plots_failed; the analysis goes on
    if plots:
        plot_dir = run_dir / "plots"
        guard.draw("energies", plot_dir / "energies.png", plot_energies, thermo, wk_minus, plot_dir / "energies.png",
                   title)
        label = f"v0 = {scen['velocity']:g} m/s"
        guard.draw("fragment_masses", plot_dir / "fragment_masses.png", plot_mass_pdf, {label: mass_pdf},
                   plot_dir / "fragment_masses.png", title, fits={label: tau})
        guard.draw("shapes", plot_dir / "shapes.png", plot_shapes, frags, plot_dir / "shapes.png", title)
        guard.draw("fragments", plot_dir / "fragments.png", _fragment_picture, space, offsets, faces, labels,
                   plot_dir / "fragments.png", f"{title}\n{len(frags)} fragments, D_w = {measures['D_w']:.3f}")
        if losses is not None:
            guard.draw("losses", plot_dir / "losses.png", plot_losses, {f"omega = {measures['omega']:.3g}": losses},
                       plot_dir / "losses.png", title)
    measures["plots_failed"] = system.get("plots_failed", []) + guard.failed  # built with the system, then here
    write_report(impact_report(run_dir, cfg, system, measures, frags, channels, title), run_dir)
    return measures


def interface_losses(run_dir: Path, cfg: dict, ifaces: pd.DataFrame, thermo: pd.DataFrame,
                     wk_minus: float) -> tuple[pd.DataFrame, pd.DataFrame] | None:
    """(loss channels in time, losses by depth below the contact) of a run whose interface dump
    has the per-interface losses (analysis/interface_losses.py); None for runs made before them."""
    if not all(c in ifaces for c in LOSS_COLUMNS) or not (run_dir / "interfaces.txt").exists():
        return None
    model, scen = cfg["model"], cfg["scenario"]
    # the particle's lowest rounded point was placed `gap` above the plane z = 0 (driver/bcm/particle.py)
    lowest = scen.get("gap", 1e-3) * model["diameter"]
    table = with_depth(ifaces, interface_centroids(run_dir / "interfaces.txt"), lowest, model["diameter"])
    return channels_in_time(thermo, wk_minus), losses_by_depth(table, wk_minus)


def _fragment_picture(space: np.ndarray, offsets: np.ndarray, faces: list, labels: np.ndarray, path: Path,
                      title: str) -> None:
    """Cells coloured by fragment at the end (analysis.pictures.render_cells)."""
    cell_vertices = [space[offsets[i]:offsets[i + 1]] for i in range(len(offsets) - 1)]
    render_cells(cell_vertices, faces, labels, path, title)


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


def fragment_history(run_dir: Path, n_cells: int) -> tuple[pd.DataFrame | None, pd.DataFrame | None]:
    """With periodic dumps (scenario.dump_every > 0): one row per dumped frame (time, broken
    interfaces, fragments, largest fragment) and the parent-child table between consecutive
    frames (analysis.tracking), frames in time order, the start and end snapshots included (a
    run cut short: up to its last periodic snapshot).
    (None, None) without periodic dumps."""
    dumps = Path(run_dir) / "dumps"
    steps = sorted(int(p.name.split(".")[1]) for p in dumps.glob("interfaces.*.lammpstrj")
                   if p.name.split(".")[1].isdigit())
    if not steps:
        return None, None
    # a run cut short has no end snapshot: its history stops at its last periodic one
    names = ["start", *map(str, steps), *(["end"] if (dumps / "cells.end.lammpstrj").exists() else [])]
    rows, labels, masses = [], [], None
    for name in names:
        cells = read_atom_dump(dumps / f"cells.{name}.lammpstrj")[-1]
        ifc = read_interfaces(dumps / f"interfaces.{name}.lammpstrj")
        lab = fragments_of(n_cells, ifc)
        masses = cells.extra["mass"]
        frag_mass = np.bincount(lab, weights=masses)
        rows.append({"frame": len(rows), "step": cells.timestep, "broken_interfaces": int((ifc.state <= 0.5).sum()),
                     "n_fragments": int(lab.max() + 1), "n_fragments_multi_cell": int(np.sum(np.bincount(lab) > 1)),
                     "largest_fragment_mass_fraction": float(frag_mass.max() / masses.sum())})
        labels.append(lab)
    frames = pd.DataFrame(rows).drop_duplicates("step", keep="last")
    labels = [labels[i] for i in frames.index]
    frames = frames.reset_index(drop=True)
    frames["frame"] = np.arange(len(frames))
    return frames, lineage_table(labels, masses)


def impact_report(run_dir: Path, cfg: dict, system: dict, measures: dict, frags: pd.DataFrame,
                  channels: pd.DataFrame, title: str) -> Report:
    """The one-page report of an impact run."""
    prov = provenance_line(run_dir)
    rep = Report(f"{cfg['name']}: {title}", prov)
    shown = ("omega", "D_w", "eta", "eta_released", "e_k2", "chi", "W_f", "W_f_released", "W_f_held",
             "W_c_over_W_s",
             "W_c_released", "balance_residual", "n_fragments", "n_fragments_multi_cell",
             "largest_fragment_mass_fraction", "second_fragment_mass_fraction", "mass_tau", "mass_sigma", "mass_xmin",
             "shape_shape_factor_mean", "shape_elongation_mean", "shape_flatness_mean", "end_time", "settled")
    rep.values({k: measures[k] for k in shown if k in measures},
               "SPEC 1.5 measures (energies in J: see summary.json and the tables for all)")
    for msg in measures.get("energy_flags", []):
        rep.text(f"Flag: {msg}.")
    rep.text(measures["stop_rule"] + f"; time step {system['timestep']:.4g} s.")
    for msg in measures.get("warnings", []):
        rep.text(f"Warning: {msg}")
    for fail in measures.get("plots_failed", []):
        rep.text(f"Figure {fail['plot']} failed ({fail['error']}); the analysis is complete without it.")
    rep.table(channels[["channel", "what", "energy", "over_W_k_minus", "part_of_W_c"]],
              "where W_k^- went: dissipation channels (part_of_W_c; they sum to W_c_measured), fracture, "
              "kinetic and elastic energy at the end (results/energy_channels; time series in results/energies)")
    rep.figure(run_dir / "plots" / "energies.png", "energy budget against time, fractions of W_k^-")
    rep.figure(run_dir / "plots" / "fragments.png", "cells coloured by fragment at the end")
    rep.figure(run_dir / "plots" / "fragment_masses.png", "fragment mass distribution p(m/m_max)")
    rep.figure(run_dir / "plots" / "shapes.png", "shapes of multi-cell fragments")
    rep.figure(run_dir / "plots" / "cells.png", "cell statistics of the tessellation")
    rep.table(frags[["fragment", "n_cells", "mass", "a", "b", "c", "elongation", "flatness", "shape_factor",
                     "v_cm", "ke_trans", "rg"]], "largest fragments (results/fragments.csv has all)", max_rows=15)
    return rep
