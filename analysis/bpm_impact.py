"""Measures of one BPM particle impact (SPEC 1.5, 3), with the meanings of the BCM's
(analysis/bcm_impact.py beside it; the model-neutral measures of analysis/impact_measures.py are
shared wherever the meaning is the same): `BpmImpactAnalysis`.

The run is in LJ units; everything here is converted to SI with system.json's a, m, u, tau.

- A bond's area: its Voronoi face (bond_areas.txt, driver/bpm/clipped.py). A_0 = sum over the
  bonds, A = sum over the broken bonds (the bonds missing from the end's bond dump), so
  D_w = A / A_0 is the broken-area fraction, as for the BCM's interfaces.
- W_f twice: 2 A G_c (the published definition, G_c = model.particle.G_c) and W_f_held, the
  elastic energy the broken bonds and angles held when they broke (the break log's energy).
- Energy channels, all measured: the plane's dissipation W_c_wall = -(work of the plane's
  forces) - (energy of its normal springs), the damping of Eq. 5 on non-bonded pairs
  (W_c_pair_damping) and on bonds (W_c_bond_damping), each the time integral, every step, of
  the power the style's single() reports (plugins/doc/pair_cr_repulsion.md,
  bond_breakable_cr.md); and the energy the breaks took out of the springs (W_f_held). Their
  sum is W_c_measured (W_f_held apart), and the balance W_k^- = W_k^+ + E_el + W_c_measured +
  W_f_held leaves balance_residual (as a fraction of W_k^-).
- Fragments: grains, connected components of the intact bonds; mass N m, volume = sum of the
  particles' Voronoi volumes, box a >= b >= c of the particles' centres plus their diameter
  (the extent of a set of spheres of diameter a along any direction is that of their centres
  plus a), b/a, c/b, S_f; p(m / m_max) and its fit.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.breaks import read_break_log
from analysis.dumps import read_atom_dump, read_local_dump
from analysis.fragment_shapes import shape_averages, shape_factor, fragment_table
from analysis.grain_table import grain_table
from analysis.grains import grain_labels
from analysis.impact_measures import fragment_counts, fragment_mass_fit, impact_measures, settle_outcome
from analysis.plots import plot_energies, plot_mass_pdf, plot_shapes
from analysis.report import Report, provenance_line
from analysis.run_analysis import RunAnalysis
from analysis.statistics import normalised_mass_distribution
from runfiles.records import BPM_IMPACT_RECORD, read_record


def read_bpm_impact_thermo(path: Path, units: dict) -> pd.DataFrame:
    """The energy record in SI (J, s; m/s) with derived columns: kinetic, elastic (bonds, angles,
    repulsion, plane springs), W_c_wall (the plane's dissipation)."""
    df = read_record(path, BPM_IMPACT_RECORD.names)
    u, tau = units["u"], units["tau"]
    out = pd.DataFrame({"step": df.step, "time": df.time})  # printed in s
    for col in ("ke", "E_pair", "E_bonds", "E_angles", "E_wall", "work_wall", "W_damp_pair", "W_damp_bond"):
        out[col] = df[col] * u
    out["kinetic"] = out.ke
    out["elastic"] = out.E_pair + out.E_bonds + out.E_angles + out.E_wall
    out["W_c_wall"] = -out.work_wall - out.E_wall
    out["W_c_pair_damping"] = out.W_damp_pair
    out["W_c_bond_damping"] = out.W_damp_bond
    for col in ("wall_contacts", "bonds_broken", "angles_broken"):
        out[col] = df[col].astype(int)
    out["vcm_z"] = df.vcm_z * units["a"] / tau
    return out


def broken_bonds(all_bonds: np.ndarray, intact_pairs: np.ndarray, n: int) -> np.ndarray:
    """Mask over all_bonds (0-based, (m, 2)) of those absent from intact_pairs (0-based)."""
    key = lambda p: np.minimum(p[:, 0], p[:, 1]) * n + np.maximum(p[:, 0], p[:, 1])  # noqa: E731
    return ~np.isin(key(all_bonds), key(intact_pairs))


def area_of_pairs(bonds: np.ndarray, area: np.ndarray, pairs: np.ndarray, n: int) -> np.ndarray:
    """The area (bond_areas.txt) of each pair (0-based ids, either order) among `bonds`."""
    key = lambda p: np.minimum(p[:, 0], p[:, 1]) * n + np.maximum(p[:, 0], p[:, 1])  # noqa: E731
    kb = key(bonds)
    order = np.argsort(kb)
    pos = np.searchsorted(kb[order], key(pairs))
    found = order[np.clip(pos, 0, len(kb) - 1)]
    if len(pairs) and not np.all(kb[found] == key(pairs)):
        raise ValueError("the break log names a bond that is not in bond_areas.txt")
    return area[found]


def particle_fragments(labels, positions, velocities, mass, volumes, diameter, intact) -> pd.DataFrame:
    """Fragment table (analysis.fragment_shapes columns; n_cells = particles) with the box of
    the spheres: a, b, c of the centres plus one diameter each; motion columns of grain_table."""
    n = len(labels)
    frags = fragment_table(labels, np.full(n, mass), volumes, (positions, np.arange(n + 1)))
    for col in ("a", "b", "c"):
        frags[col] = frags[col].fillna(0.0) + diameter
    frags["elongation"] = frags.b / frags.a
    frags["flatness"] = frags.c / frags.b
    frags["shape_factor"] = shape_factor(frags.a.to_numpy(), frags.b.to_numpy(), frags.c.to_numpy())
    frags["n_particles"] = frags.n_cells
    box = np.array([positions.min(0) - 1.0, positions.max(0) + 1.0]).T
    motion = grain_table(labels, positions, velocities, np.full(n, mass), intact, box, periodic=(False, False, False))
    frags = frags.join(motion.drop(columns=["grain", "size", "mass", "percolating"]).rename(columns={"ke": "ke_trans"}))
    frags["v_cm"] = np.sqrt(sum(frags[c] ** 2 for c in ("vx", "vy", "vz")))
    return frags


def break_series(thermo: pd.DataFrame, breaks: pd.DataFrame | None, all_bonds: np.ndarray, area: np.ndarray, n: int,
                 units: dict) -> tuple[dict[str, float], float]:
    """From the break log: the columns W_f_held (J, the energy the broken bonds and angles held)
    and broken_area (m², the Voronoi areas of the broken bonds) of `thermo` at each record
    (added in place); returns (held energy by kind, "bond" and "angle", J; logged area, m²)."""
    held = {k: 0.0 for k in ("bond", "angle")}
    thermo["W_f_held"] = 0.0
    thermo["broken_area"] = 0.0
    logged_area = 0.0
    if breaks is not None and len(breaks):
        a, u = units["a"], units["u"]
        for kind in held:
            held[kind] = float(breaks.loc[breaks.kind == kind, "energy"].sum()) * u
        # each broken bond's Voronoi area, from the log's pair of ids
        bond_rows = breaks[breaks.kind == "bond"]
        pairs = np.column_stack([bond_rows.id1, bond_rows.id2]).astype(np.int64) - 1
        areas = pd.Series(area_of_pairs(all_bonds, area, pairs, n) * a ** 2, index=bond_rows.index)
        logged_area = float(areas.sum())
        for col, per_event in (("W_f_held", breaks.energy * u),
                               ("broken_area", areas.reindex(breaks.index).fillna(0.0))):
            cum = per_event.groupby(breaks.step).sum().cumsum()
            # records at a step hold that step's breaks (the break happens in its force evaluation)
            idx = np.searchsorted(cum.index.to_numpy(), thermo.step.to_numpy(), side="right") - 1
            thermo[col] = np.where(idx >= 0, cum.to_numpy()[np.clip(idx, 0, None)], 0.0)
    return held, logged_area


class BpmImpactAnalysis(RunAnalysis):
    """Measures, tables, figures and report of a BPM impact run, on its end state. Cut short:
    refused (the end state is missing and the periodic snapshots are not analysed)."""

    refuses_cut_short = ("a BPM impact is measured on its end state, which a run cut short does not have (its "
                         "periodic snapshots are not analysed): resume it (driver run CONFIG -o DIR --resume)")

    def _prepare(self) -> None:
        run_dir = self.run_dir
        self.system = json.loads((run_dir / "system.json").read_text())
        self.units = self.system["units"]
        dumps = run_dir / "dumps"
        atoms_path, bonds_path = dumps / "atoms.end.lammpstrj", dumps / "bonds.end.lammpstrj"
        if not atoms_path.exists():
            raise FileNotFoundError(f"{atoms_path}: the end state of the run is missing")
        self.atoms = read_atom_dump(atoms_path)[-1]
        bonds = read_local_dump(bonds_path)[-1].columns
        self.intact = np.column_stack([bonds["batom1"], bonds["batom2"]]).astype(np.int64) - 1
        table = np.loadtxt(run_dir / "bond_areas.txt", ndmin=2)
        self.all_bonds, self.area = table[:, :2].astype(np.int64) - 1, table[:, 2]
        self.volumes = np.loadtxt(run_dir / "particle_volumes.txt", ndmin=1) * self.units["a"] ** 3
        self.thermo = read_bpm_impact_thermo(run_dir / "thermo.dat", self.units)
        self.breaks = read_break_log(run_dir / "breaks.dat") if (run_dir / "breaks.dat").exists() else None

    def _conclude(self) -> None:
        model, scen, system, un = self.cfg["model"], self.cfg["scenario"], self.system, self.units
        part = model["particle"]
        a, u = un["a"], un["u"]
        atoms, intact, all_bonds, area, thermo, breaks = (self.atoms, self.intact, self.all_bonds, self.area,
                                                          self.thermo, self.breaks)
        n = len(atoms.ids)
        broken = broken_bonds(all_bonds, intact, n)
        held, logged_area = break_series(thermo, breaks, all_bonds, area, n, un)

        m_p = un["m"]
        wk_minus = 0.5 * system["mass"] * scen["velocity"] ** 2
        n_in = system.get("bonds_breaking_in_repulsion", 0)
        if n_in:
            # driver/bpm/network.py repulsion_at_break: such a break creates U_NB(lambda_c r0)
            self.warnings.append(
                f"{n_in} of {system['n_bonds']} bonds break inside the non-bonded repulsion (lambda_c r0 < a: bonded "
                f"neighbours that overlap in the packing); each such break switches Eq. 1 on and creates up to "
                f"{system['repulsion_energy_per_break_max']:.3g} u, {system['repulsion_energy_if_all_break_J']:.3g} J "
                f"if all break ({system['repulsion_energy_if_all_break_J'] / wk_minus:.3g} W_k^-): the energy balance "
                "cannot close. Use model.packing: lj_minimum (neighbours beyond a) or a larger lambda_c")
        last = thermo.iloc[-1]
        w_f_held = held["bond"] + held["angle"]
        elastic_end = float(last.elastic)
        chans = {"wall": float(last.W_c_wall), "pair_damping": float(last.W_c_pair_damping),
                 "bond_damping": float(last.W_c_bond_damping)}
        # plot_energies' columns: fracture as held, dissipation as the measured channels
        thermo["W_f"] = thermo.W_f_held
        thermo["dissipated"] = thermo.W_c_wall + thermo.W_c_pair_damping + thermo.W_c_bond_damping
        thermo["balance_residual"] = (wk_minus - thermo.kinetic - thermo.elastic - thermo.dissipated
                                      - thermo.W_f_held) / wk_minus

        positions = np.asarray(atoms.positions, float) * a
        velocities = np.asarray(atoms.velocities, float) * a / un["tau"]
        labels = grain_labels(n, intact)
        frags = particle_fragments(labels, positions, velocities, m_p, self.volumes, a, intact)
        A = float(area[broken].sum()) * a ** 2
        A0 = float(area.sum()) * a ** 2
        measures = impact_measures(
            wk_minus=wk_minus, wk_plus=float(last.kinetic), wk_plus_cm=float(frags.ke_cm.sum()), broken_area=A,
            total_area=A0, g_c=part["G_c"], elastic_end=elastic_end, w_f_held=w_f_held,
            dissipated_measured=sum(chans.values()), channels=chans)
        # impact_measures' balance books W_f = 2 A G_c; here the breaks took W_f_held out of the springs
        measures["balance_residual"] = float(thermo.balance_residual.iloc[-1])
        mass_pdf = normalised_mass_distribution(frags.mass.to_numpy())
        tau_fit = fragment_mass_fit(frags.mass.to_numpy())
        settled = settle_outcome(self.run_dir, system, int(last.step))
        measures.update({
            "W_f_held_bonds": held["bond"], "W_f_held_angles": held["angle"],
            "broken_bonds": int(broken.sum()), "bonds_broken_logged": int(last.bonds_broken),
            "A_logged": logged_area,
            "angles_broken": int(last.angles_broken), "n_particles": n, "end_time": float(last.time),
            "timestep_s": system["timestep_s"], "particles_on_plane_end": int(last.wall_contacts),
            **fragment_counts(frags, system["mass"]), **settled,
            "stop_rule": (f"stopped after a window of {system['window_steps']} steps with no break, kinetic energy "
                          f"within {scen['ke_tolerance']:g} and the plane's springs unloaded, or at max_time "
                          f"{scen['max_time']:g} s"),
            **{f"shape_{k}": v for k, v in shape_averages(frags).items()},
            **{f"mass_{k}": v for k, v in tau_fit.items()},
        })
        channels = pd.DataFrame([
            ("wall", "plane: damping and friction (-work - spring energy)", chans["wall"], True),
            ("pair_damping", "damping of Eq. 5, non-bonded pairs", chans["pair_damping"], True),
            ("bond_damping", "damping of Eq. 5, bonds", chans["bond_damping"], True),
            ("fracture_held", "energy the broken bonds and angles held (break log)", w_f_held, False),
            ("fracture_2AGc", "2 A G_c (published definition)", measures["W_f"], False),
            ("kinetic", "kinetic energy W_k^+", float(last.kinetic), False),
            ("elastic", "elastic energy still stored", elastic_end, False)],
            columns=["channel", "what", "energy", "part_of_W_c"])
        channels.insert(3, "over_W_k_minus", channels.energy / wk_minus)

        self.results.summary = measures
        self.results.tables.update(energies=thermo, energy_channels=channels, fragments=frags,
                                   fragment_masses=mass_pdf)
        self.title = (f"BPM impact, N = {n}, v0 = {scen['velocity']:g} m/s, k_A = {model['k_A']:g}, "
                      f"lambda_c = {model['lambda_c']:g}")
        self.wk_minus, self.mass_pdf, self.tau_fit, self.frags, self.channels = (wk_minus, mass_pdf, tau_fit, frags,
                                                                                 channels)

    def _plot(self) -> None:
        title = self.title
        self.draw("energies", plot_energies, self.thermo, self.wk_minus, self.png("energies"), title,
                  labels={"elastic": "elastic (bonds, angles, repulsion, plane)",
                          "W_f": "held by broken bonds and angles $W_{f,held}$",
                          "dissipated": "dissipated (plane, damping)"})
        label = f"v0 = {self.cfg['scenario']['velocity']:g} m/s"
        self.draw("fragment_masses", plot_mass_pdf, {label: self.mass_pdf}, self.png("fragment_masses"), title,
                  fits={label: self.tau_fit})
        self.draw("shapes", plot_shapes, self.frags, self.png("shapes"), title)

    def _report(self) -> Report:
        measures, system = self.results.summary, self.system
        rep = Report(f"{self.cfg['name']}: {self.title}", provenance_line(self.run_dir))
        shown = ("omega", "D_w", "eta", "e_k2", "chi", "W_f", "W_f_held", "W_c_over_W_s", "W_c_wall",
                 "W_c_pair_damping", "W_c_bond_damping", "balance_residual", "n_fragments",
                 "largest_fragment_mass_fraction", "mass_tau", "shape_shape_factor_mean", "end_time", "settled")
        rep.values({k: measures[k] for k in shown if k in measures}, "SPEC 1.5 measures of the BPM particle (SI)")
        rep.text(measures["stop_rule"] + f"; time step {system['timestep_s']:.4g} s ({system['timestep_rule']}).")
        for msg in self.warnings:
            rep.text(f"Warning: {msg}")
        rep.table(self.channels, "where W_k^- went (results/energy_channels)")
        rep.figure(self.png("energies"), "energy budget against time, fractions of W_k^-")
        rep.table(self.frags[["fragment", "n_cells", "mass", "volume", "a", "b", "c", "elongation", "flatness",
                              "shape_factor", "v_cm"]], "largest fragments (n_cells = particles)", max_rows=15)
        return rep
