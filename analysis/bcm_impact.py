"""The analysis of one BCM impact run (SPEC 1.5): its record, dumps and cells into the SPEC 1.5
measures (analysis/impact_measures.py, shared with the BPM's analysis/bpm_impact.py), the
energy channels of the three force styles, fragment table, mass and shape distributions,
fragment history, interface losses, figures and report (`BcmImpactAnalysis`).

Energies in J, areas in m^2. W_f = 2 A G_c is what the Griffith convention books; the elastic
energy the breaks released (W_f_released = W_f + W_c_switch) and the energy the broken
interfaces held just before (W_f_held) are reported beside it (analysis/impact_measures.py).
A run cut short is measured on its last periodic snapshot and flagged; without one it is
refused (analysis/completeness.py).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.completeness import RunRefused
from analysis.dumps import DumpError, read_atom_dump, read_local_dump
from analysis.fragment_shapes import fragment_table, shape_averages, vertices_in_space
from analysis.grain_table import grain_table
from analysis.grains import grain_labels
from analysis.impact_measures import fragment_counts, fragment_mass_fit, impact_measures, settle_outcome
from analysis.interface_losses import (LOSS_COLUMNS, channels_in_time, interface_centroids, losses_by_depth,
                                       with_depth)
from analysis.pictures import render_cells
from analysis.plots import plot_energies, plot_losses, plot_mass_pdf, plot_shapes
from analysis.report import Report, provenance_line
from analysis.run_analysis import RunAnalysis
from analysis.statistics import normalised_mass_distribution
from analysis.tracking import lineage_table
from runfiles.cells import read_cells
from runfiles.layout import display_dir
from runfiles.records import IMPACT_DIAGNOSTICS, IMPACT_RECORD, INTERFACES_DUMP, INTERFACES_REQUIRED, read_record


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
    points; with the per-point law (plugins/doc) the plane's is identically zero, and the
    contacts' holds the energy of tangential springs dropped with their history (a point that
    changes its pair of features while loaded: plugins/doc/pair_bcm_contact.md, [6]).
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
    ("contact_npoints", "W_contact_npoints", "cell-cell contacts: tangential springs dropped (features changed)"),
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


def last_state_dumps(run_dir: Path, cut_short: bool) -> tuple[Path, Path, str | None]:
    """The (cells, interfaces) dumps of the end state; for a run cut short, the latest
    periodic pair instead, with a note saying so (None when the end state is there). A run cut
    short without a periodic snapshot is refused (RunRefused)."""
    dumps = Path(run_dir) / "dumps"
    end = (dumps / "cells.end.lammpstrj", dumps / "interfaces.end.lammpstrj")
    if end[0].exists() and end[1].exists():
        return (*end, None)
    if not cut_short:
        raise FileNotFoundError(f"{end[0]}: the end state of the run is missing")
    steps = sorted(int(p.name.split(".")[1]) for p in dumps.glob("cells.*.lammpstrj")
                   if p.name.split(".")[1].isdigit() and (dumps / f"interfaces.{p.name.split('.')[1]}.lammpstrj").exists())
    if not steps:
        raise RunRefused(f"{display_dir(run_dir)}: the run did not finish and left no snapshot after the start "
                         "(set scenario.dump_every to keep periodic ones); nothing to analyse")
    step = steps[-1]
    return (dumps / f"cells.{step}.lammpstrj", dumps / f"interfaces.{step}.lammpstrj",
            f"the run did not finish: measured on its last snapshot (step {step}), not on a settled outcome; "
            f"the end state (dumps/cells.end.lammpstrj) is missing")


class BcmImpactAnalysis(RunAnalysis):
    """Measures, fragment table, mass and shape distributions, energy series, fragment history
    (when periodic dumps exist), plots, picture and report of a BCM impact run (cut short: on
    its last periodic snapshot, flagged; refused without one)."""

    def _prepare(self) -> None:
        self.model, self.scen = self.cfg["model"], self.cfg["scenario"]
        self.system = json.loads((self.run_dir / "system.json").read_text())
        cells_dump, ifaces_dump, note = last_state_dumps(self.run_dir, self.cut_short)
        self.cells = read_atom_dump(cells_dump)[-1]
        self.ifaces = read_interfaces(ifaces_dump)
        self.thermo = read_impact_thermo(self.run_dir / "thermo.dat")
        self.on_snapshot = note is not None  # measured on a periodic snapshot, not the end state
        if self.on_snapshot:
            self.cut_short_note = note
            self.thermo = self.thermo[self.thermo.step <= self.cells.timestep].reset_index(drop=True)

    def _conclude(self) -> None:
        model, scen, system, cells, ifaces, thermo = (self.model, self.scen, self.system, self.cells, self.ifaces,
                                                      self.thermo)
        n = len(cells.ids)
        labels = fragments_of(n, ifaces)
        masses = cells.extra["mass"]
        volumes = masses / model["density"]
        body, faces, warning = cell_shapes(self.run_dir)
        if warning:
            self.warnings.append(warning)
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
            self.warnings.append("the interfaces dump has no energy_at_break: W_f_held is not measured")
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
            "timestep": system["timestep"], **settle_outcome(self.run_dir, system, int(last.step)),
            "cells_on_plane_end": int(last.wall_contacts),
            "stop_rule": (f"stopped after a window of {system['window_steps']} steps with no break, kinetic energy "
                          f"within {scen['ke_tolerance']:g} and the plane unloaded, or at max_time "
                          f"{scen['max_time']:g} s"),
            **({"settled": False} if self.on_snapshot else {}),
            **{f"shape_{k}": v for k, v in shape_averages(frags).items()},
            **{f"mass_{k}": v for k, v in tau.items()},
        })
        history, tracking = fragment_history(self.run_dir, n)
        losses = interface_losses(self.run_dir, self.cfg, ifaces, thermo, wk_minus)

        self.results.summary = measures
        tables = self.results.tables
        tables.update(energies=thermo, energy_channels=channels, fragments=frags, interfaces=ifaces,
                      fragment_masses=mass_pdf)
        if history is not None:
            tables.update(frames=history, tracking=tracking)
        if losses is not None:
            tables["losses_by_depth"] = losses[1]
        self.title = (f"BCM impact, N_c = {system['n_cells']}, v0 = {scen['velocity']:g} m/s, "
                      f"G_c = {model['interface']['G_c']:g} J/m²")
        self.wk_minus, self.mass_pdf, self.tau, self.frags, self.channels = wk_minus, mass_pdf, tau, frags, channels
        self.picture, self.losses = (space, offsets, faces, labels), losses

    def _plot(self) -> None:
        title, measures = self.title, self.results.summary
        self.draw("energies", plot_energies, self.thermo, self.wk_minus, self.png("energies"), title)
        label = f"v0 = {self.scen['velocity']:g} m/s"
        self.draw("fragment_masses", plot_mass_pdf, {label: self.mass_pdf}, self.png("fragment_masses"), title,
                  fits={label: self.tau})
        self.draw("shapes", plot_shapes, self.frags, self.png("shapes"), title)
        self.draw("fragments", _fragment_picture, *self.picture, self.png("fragments"),
                  f"{title}\n{len(self.frags)} fragments, D_w = {measures['D_w']:.3f}")
        if self.losses is not None:
            self.draw("losses", plot_losses, {f"omega = {measures['omega']:.3g}": self.losses}, self.png("losses"),
                      title)

    def _plots_failed(self) -> list[dict[str, str]]:
        # a figure that failed when the system was built (plots/cells.png), then those here
        return self.system.get("plots_failed", []) + self.guard.failed

    def _report(self) -> Report:
        return impact_report(self.run_dir, self.cfg, self.system, self.results.summary, self.frags, self.channels,
                             self.title, self.warnings)


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
                  channels: pd.DataFrame, title: str, warnings: list[str]) -> Report:
    """The one-page report of an impact run (`warnings`: its caveats; a cut-short note is
    added under the title by RunAnalysis)."""
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
    for msg in warnings:
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
