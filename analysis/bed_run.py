"""The analysis of a bed's confined compression (issue 25, point 4): one BCM run, and a set.

From the record (runfiles/records.py COMPRESS_RECORD): the compression curve of the loading
(void ratio against log10 of the platen's stress) with its yield stress and compression index
(analysis/bed.py yield_stress: the rule is stated there), the lateral stress ratio K_0, the
inertial number of the loading (quasi-static below INERTIAL_LIMIT) and the energy account
from the start of the loading (the cells are stopped there: driver/bcm/compress.py). From the
dumps at the start of the loading, at each grading stress and at the end: the fragments
(connected components of intact interfaces, SPEC 1.5) with their grain and box, the grading
curve (sieve size b), Hardin's B_r, Einav's B_r*, the grains broken and the fragments per
grain, against the stress of the dump.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from analysis import bed
from analysis.bcm_impact import _fragment_picture, cell_shapes, fragments_of, read_interfaces
from analysis.crush import bcm_energy_columns
from analysis.bpm_impact import break_series, particle_fragments
from analysis.breaks import read_break_log
from analysis.dumps import read_atom_dump, read_local_dump
from analysis.fragment_shapes import fragment_table, vertices_in_space
from analysis.grains import grain_labels
from analysis.report import Report, provenance_line
from analysis.run_analysis import RunAnalysis
from analysis.runset import RunSetError
from analysis.tables import save_table
from runfiles.records import BPM_COMPRESS_RECORD, COMPRESS_RECORD, read_record

#: the loading is quasi-static while the inertial number I = (v / H) d sqrt(rho / sigma_v) stays below this
INERTIAL_LIMIT = 1e-3
#: the energy account is flagged when its residual exceeds this fraction of the platen's work
BALANCE_TOLERANCE = 1e-3


def read_compress_record(path: Path) -> pd.DataFrame:
    """The record of a bed run with the energy account's columns (the crush's,
    analysis/crush.py bcm_energy_columns) and sigma_h (the mean of the x and y walls' stresses)."""
    df = bcm_energy_columns(read_record(path, COMPRESS_RECORD.names))
    df["sigma_h"] = 0.5 * (df.sigma_x + df.sigma_y)
    return df


#: the energy account's channels (analysis.bed.energy_balance): fracture and every loss
CHANNELS = ("W_f", "dissipated_damping", "dissipated_friction", "dissipated_npoints", "W_switch")


def inertial_number(record: pd.DataFrame, speed: float, diameter: float, density: float) -> np.ndarray:
    """I = gamma_dot d sqrt(rho / sigma_v) with gamma_dot = v / H (the bed's strain rate), at
    each record; NaN where sigma_v <= 0."""
    sv = record.sigma_v.to_numpy(float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(sv > 0, speed / record.height.to_numpy(float) * diameter * np.sqrt(density / sv), np.nan)


def grain_of_cells(grain_cells: list[int]) -> np.ndarray:
    """Each cell's grain id (1-based), cells numbered grain by grain (driver/bcm/bed.py)."""
    return np.repeat(np.arange(1, len(grain_cells) + 1), grain_cells)


class BedState:
    """One dumped state of the bed: its fragments with their grain and box, its grading."""

    def __init__(self, run_dir: Path, name: str, grain: np.ndarray, body, faces, density: float) -> None:
        dumps = run_dir / "dumps"
        self.name = name
        cells = read_atom_dump(dumps / f"cells.{name}.lammpstrj")[-1]
        ifaces = read_interfaces(dumps / f"interfaces.{name}.lammpstrj")
        self.step = int(cells.timestep)
        labels = fragments_of(len(cells.ids), ifaces)
        masses = cells.extra["mass"]
        offsets = np.concatenate([[0], np.cumsum([len(v) for v in body])])
        space = vertices_in_space(np.concatenate(body), offsets, cells.positions, cells.quaternions())
        frags = fragment_table(labels, masses, masses / density, (space, offsets))
        # a fragment is part of one grain: the grain of any of its cells (the first)
        first = np.full(int(labels.max()) + 1, -1)
        first[labels[::-1]] = np.arange(len(labels))[::-1]
        frags["grain"] = grain[first[frags.fragment.to_numpy()]]
        frags["intact"] = frags.n_cells.to_numpy() == np.bincount(grain)[frags.grain.to_numpy()]
        self.fragments = frags
        self.picture = (space, offsets, faces, grain)


def _balance_residual(residual: pd.Series, work: pd.Series) -> float:
    """The largest |residual| over the account against the largest platen work W_p (the energy
    put in, as the crush's account is measured against W_p)."""
    top = float(work.max())
    return float(residual.abs().max() / top) if top > 0 else float("nan")


class BcmBedAnalysis(RunAnalysis):
    """Compression curve, yield stress, C_c, K_0, the quasi-static check, gradings and breakage
    at the dumped stresses, the energy account, figures and report of a BCM bed run. Cut short:
    refused (the gradings need the dumps of the stresses reached)."""

    refuses_cut_short = ("a bed is measured on its loading and the dumps at its grading stresses, which a run cut "
                         "short may not have: resume it (driver run CONFIG -o DIR --resume)")
    #: the energy account's channels, the system's count of elements, the summary's broken count
    channels = CHANNELS
    elements = "n_cells"
    broken_key = "broken_interfaces"
    dump_prefix = "cells"
    picture_fn = staticmethod(_fragment_picture)

    def _prepare(self) -> None:
        self.model, self.scen = self.cfg["model"], self.cfg["scenario"]
        self.system = json.loads((self.run_dir / "system.json").read_text())
        self.record = read_compress_record(self.run_dir / "thermo.dat")
        self.density = float(self.model["density"])
        # the smallest piece a grain breaks into: a cell (B_r's second cut, Einav's d_m)
        self.element_size = float(self.system["mean_cell_size"])
        self.states: list[BedState] = []
        self.title = (f"BCM bed, {self.system['n_grains']} grains of {self.model['n_cells']} cells, "
                      f"v_p = {self.scen['platen_speed']:g} m/s, G_c = {self.model['interface']['G_c']:g} J/m²")

    def _frames(self):
        names = ["load", *self.system["grading_dumps"], "end"]
        return [n for n in names if (self.run_dir / "dumps" / f"{self.dump_prefix}.{n}.lammpstrj").exists()]

    def _single_frame(self, name: str) -> None:
        if not self.states:
            self.grain = grain_of_cells(self.system["grain_cells"])
            self.body, self.faces, warning = cell_shapes(self.run_dir)
            if warning:
                self.warnings.append(warning)
        self.states.append(BedState(self.run_dir, name, self.grain, self.body, self.faces, self.model["density"]))

    def _conclude(self) -> None:
        rec, sys_, sc = self.record, self.system, self.scen
        loading = rec[rec.phase == 2]
        if loading.empty:
            raise ValueError(f"{self.run_dir}: the record has no loading phase (phase 2): the bed never reached its "
                             "start (see thermo.dat's phase column)")
        start = loading.index[0]
        branch = bed.loading_branch(loading)
        branch = branch[branch.sigma_v >= sc["start_stress"]]
        fit = bed.yield_stress(branch.sigma_v, branch.void_ratio)
        self.fit, self.branch = fit, branch
        d_mean = float(np.mean(sys_["grain_diameter"]))
        # quasi-static where the curve is measured: from a tenth of the target stress up (at the
        # start stress the bed is loose and I is large at any practical speed)
        upper = branch[branch.sigma_v >= 0.1 * sc["target_stress"]]
        inertial = inertial_number(upper, sc["platen_speed"], d_mean, self.density)
        try:
            K0 = bed.mean_K0(branch.sigma_h, branch.sigma_v, 0.1 * sc["target_stress"], sc["target_stress"])
        except ValueError as err:  # a loading that jumps past its window between two records
            K0 = None
            self.warnings.append(f"K_0 not measured: {err}")
        account = rec.loc[start:].reset_index(drop=True)
        balance = bed.energy_balance(account, self.channels)
        end = account.iloc[-1]
        peak = loading.sigma_v.idxmax()
        self.account = account.assign(residual=balance.residual, relative=balance.relative)
        summary = {
            "n_grains": sys_["n_grains"], self.elements: sys_[self.elements], "start_fraction_spheres": sys_["start_fraction"],
            "e_start": float(loading.void_ratio.iloc[0]), "sigma_v_max": float(loading.sigma_v.max()),
            "e_at_max": float(rec.void_ratio[peak]), "e_end": float(rec.void_ratio.iloc[-1]),
            "sigma_y": fit.sigma_y, "C_c": fit.C_c, "C_s": fit.C_s, "knee_flag": fit.flag, "knee_rule": fit.rule,
            "K0": K0, "inertial_max": float(np.nanmax(inertial)) if np.isfinite(inertial).any() else None,
            "inertial_window": "sigma_v >= 0.1 x target_stress, loading",
            self.broken_key: int(end.broken), "W_p": float(end.W_p - account.W_p.iloc[0]),
            "W_f": float(end.W_f - account.W_f.iloc[0]),
            "balance_residual": _balance_residual(balance.residual, account.W_p - account.W_p.iloc[0]),
        }
        if summary["inertial_max"] is not None and summary["inertial_max"] > INERTIAL_LIMIT:
            self.warnings.append(f"not quasi-static: the inertial number reached {summary['inertial_max']:.2g} "
                                 f"(> {INERTIAL_LIMIT:g}) while loading; lower scenario.platen_speed")
        if fit.flag:
            self.warnings.append(f"no yield knee resolved on the compression curve: {fit.flag}")
        if summary["balance_residual"] > BALANCE_TOLERANCE:
            self.warnings.append(f"energy account: residual {summary['balance_residual']:.2g} of the platen's work "
                                 f"(> {BALANCE_TOLERANCE:g})")
        states, gradings = self._states()
        summary["states"] = states.to_dict("records")
        self.results.summary = summary
        self.results.tables.update(compress=rec, states=states, grading=gradings,
                                   fragments=pd.concat([s.fragments.assign(state=s.name) for s in self.states],
                                                       ignore_index=True) if self.states else pd.DataFrame())

    def _states(self) -> tuple[pd.DataFrame, pd.DataFrame]:
        """Per dumped state: its stress and void ratio, B_r (Hardin's cut and the cell size's),
        B_r*, grains broken, fragments per grain; and the grading curves."""
        rec = self.record.set_index("step")
        if not self.states:
            return pd.DataFrame(), pd.DataFrame()
        first = self.states[0].fragments.set_index("grain")
        for s in self.states[1:]:
            # an intact grain keeps its size of the first state: the box of a grain whose cells
            # move by their elastic strain changes by ~1e-4, which is no breakage
            intact = s.fragments.intact.to_numpy()
            for col in ("a", "b", "c"):
                s.fragments.loc[intact, col] = first.loc[s.fragments.grain[intact], col].to_numpy()
        original = bed.grading_curve(self.states[0].fragments)
        h = self.element_size
        grains = pd.DataFrame({"grain": np.arange(1, self.system["n_grains"] + 1),
                               "mass": self.system["grain_mass"], "diameter": self.system["grain_diameter"]})
        rows, curves = [], []
        for s in self.states:
            curve = bed.grading_curve(s.fragments)
            per_grain = bed.grain_breakage(s.fragments, grains)
            r = rec.loc[s.step] if s.step in rec.index else rec.iloc[(np.abs(rec.index - s.step)).argmin()]
            rows.append({
                "state": s.name, "step": s.step, "sigma_v": float(r.sigma_v), "void_ratio": float(r.void_ratio),
                "B_r": bed.hardin_breakage(original, curve).relative,
                "B_r_cell": bed.hardin_breakage(original, curve, d_cut=h).relative,
                "B_r_star": bed.einav_breakage(original, curve, d_m=h).relative,
                "fraction_broken": bed.fraction_broken(per_grain),
                "fragments_per_grain": float(per_grain.n_fragments.mean()), "fragments": len(s.fragments)})
            curves.append(curve.assign(state=s.name, sigma_v=float(r.sigma_v)))
        return pd.DataFrame(rows), pd.concat(curves, ignore_index=True)

    def _plot(self) -> None:
        self.draw("compression", plot_compression, self.branch, self.fit, self.png("compression"), self.title)
        if self.states:
            self.draw("grading", plot_grading, self.results.tables["grading"], self.png("grading"), self.title)
            self.draw("breakage", plot_breakage, self.results.tables["states"], self.png("breakage"), self.title)
            last = self.states[-1]
            self.draw("fragments", self.picture_fn, *last.picture, self.png("fragments"),
                      f"{self.title}\n{self.elements.removeprefix('n_')} coloured by grain, state '{last.name}'")
        self.draw("energy", plot_energy, self.account, self.png("energy"), self.title, self.channels)

    def _report(self) -> Report:
        s = self.results.summary
        rep = Report(self.title, provenance_line(self.run_dir))
        rep.values({k: s[k] for k in ("n_grains", self.elements, "e_start", "sigma_v_max", "e_at_max", "sigma_y",
                                      "C_c", "C_s", "K0", "inertial_max", self.broken_key, "W_p", "W_f",
                                      "balance_residual")}, "the loading")
        rep.text(f"Yield stress rule: {s['knee_rule']}")
        if self.states:
            rep.table(self.results.tables["states"], "the dumped states: stress, void ratio, breakage (B_r with "
                                                     "Hardin's 0.074 mm cut, B_r_cell with the mean cell size as cut, "
                                                     "B_r_star Einav's with d_m the mean cell size)")
        for name, caption in (("compression", "compression curve"), ("grading", "grading curves"),
                              ("breakage", "breakage against stress"), ("energy", "energy account"),
                              ("fragments", "the bed at its last state")):
            if self.png(name).exists():
                rep.figure(self.png(name), caption)
        for w in self.warnings:
            rep.lead(f"Warning: {w}")
        return rep


def read_bpm_compress_record(path: Path, units: dict) -> pd.DataFrame:
    """The record of a BPM bed (runfiles/records.py BPM_COMPRESS_RECORD) in SI (m, Pa, J, s)
    with the energy account's columns, as analysis/crush.py read_bpm_crush_record does for one
    particle: kinetic; elastic (repulsion, bonds, angles, the walls' and the platen's normal
    springs); dissipated by the fixed walls (the work of their forces on the particles, less
    their springs' energy: their damping and friction, tangential springs included), by the
    platen (W_p less its work on the particles and its springs' energy) and by the damping of
    Eq. 5 on pairs and bonds; sigma_h the mean of the x and y walls' stresses. W_f comes from
    the break log (BpmBedAnalysis)."""
    df = read_record(path, BPM_COMPRESS_RECORD.names)
    a, u = units["a"], units["u"]
    stress = u / a ** 3
    out = pd.DataFrame({"step": df.step, "time": df.time, "phase": df.phase.astype(int), "height": df.height * a})
    for col in ("sigma_v", "sigma_v_bottom", "sigma_x", "sigma_y"):
        out[col] = df[col] * stress
    out["void_ratio"] = df.void_ratio
    for col in ("W_p", "ke", "E_pair", "E_bonds", "E_angles", "E_walls", "E_top", "work_walls", "work_top",
                "W_damp_pair", "W_damp_bond"):
        out[col] = df[col] * u
    out["sigma_h"] = 0.5 * (out.sigma_x + out.sigma_y)
    out["kinetic"] = out.ke
    out["elastic"] = out.E_pair + out.E_bonds + out.E_angles + out.E_walls + out.E_top
    out["dissipated_walls"] = -out.work_walls - out.E_walls
    out["dissipated_platen"] = out.W_p - out.work_top - out.E_top
    for col in ("top_contacts", "bottom_contacts", "side_contacts", "bonds_broken", "angles_broken"):
        out[col] = df[col].astype(int)
    out["broken"] = out.bonds_broken
    return out


#: the BPM bed's energy channels: fracture (the energy the broken bonds and angles held) and every loss
BPM_CHANNELS = ("W_f", "dissipated_walls", "dissipated_platen", "W_damp_pair", "W_damp_bond")


class BpmBedState:
    """One dumped state of a BPM bed: its fragments (grains of intact bonds) with their grain and
    box (the spheres' centres plus one diameter, analysis/bpm_impact.py particle_fragments)."""

    def __init__(self, run_dir: Path, name: str, grain: np.ndarray, units: dict, volumes: np.ndarray) -> None:
        dumps = run_dir / "dumps"
        self.name = name
        atoms = read_atom_dump(dumps / f"atoms.{name}.lammpstrj")[-1]
        bonds = read_local_dump(dumps / f"bonds.{name}.lammpstrj")[-1].columns
        self.step = int(atoms.timestep)
        n = len(atoms.ids)
        intact = np.column_stack([bonds["batom1"], bonds["batom2"]]).astype(np.int64).reshape(-1, 2) - 1
        labels = grain_labels(n, intact)
        a, tau = units["a"], units["tau"]
        x = np.asarray(atoms.positions, float) * a
        frags = particle_fragments(labels, x, np.asarray(atoms.velocities, float) * a / tau, units["m"], volumes, a,
                                   intact)
        first = np.full(int(labels.max()) + 1, -1)
        first[labels[::-1]] = np.arange(n)[::-1]
        frags["grain"] = grain[first[frags.fragment.to_numpy()]]
        frags["intact"] = frags.n_cells.to_numpy() == np.bincount(grain)[frags.grain.to_numpy()]
        self.fragments = frags
        self.picture = (x, grain)


def particles_picture(x: np.ndarray, grain: np.ndarray, path: Path, title: str) -> None:
    """The bed's particles seen from the side (x, z), coloured by grain."""
    fig, ax = _axes()
    ax.scatter(x[:, 0] * 1e3, x[:, 2] * 1e3, c=grain % 20, cmap="tab20", s=4, linewidths=0)
    ax.set(xlabel="x (mm)", ylabel="z (mm)", title=title, aspect="equal")
    _save(fig, path)


class BpmBedAnalysis(BcmBedAnalysis):
    """The BCM bed's analysis (BcmBedAnalysis) of a BPM bed: the record in SI with W_f from the
    break log, the fragments of the intact bonds; B_r's second cut and Einav's d_m are the
    particle diameter a."""

    channels = BPM_CHANNELS
    elements = "n_particles"
    broken_key = "broken_bonds"
    dump_prefix = "atoms"
    picture_fn = staticmethod(particles_picture)

    def _prepare(self) -> None:
        run_dir = self.run_dir
        self.model, self.scen = self.cfg["model"], self.cfg["scenario"]
        self.system = sys_ = json.loads((run_dir / "system.json").read_text())
        self.units = un = sys_["units"]
        record = read_bpm_compress_record(run_dir / "thermo.dat", un)
        table = np.loadtxt(run_dir / "bond_areas.txt", ndmin=2)
        all_bonds, area = table[:, :2].astype(np.int64) - 1, table[:, 2]
        self.volumes = np.loadtxt(run_dir / "particle_volumes.txt", ndmin=1) * un["a"] ** 3
        breaks = read_break_log(run_dir / "breaks.dat") if (run_dir / "breaks.dat").exists() else None
        break_series(record, breaks, all_bonds, area, sys_["n_particles"], un)
        record["W_f"] = record.W_f_held
        self.record = record
        self.density = float(sys_["mass"]) / float(sys_["solid_volume"])
        self.element_size = float(un["a"])
        self.states = []
        self.grain = grain_of_cells(sys_["grain_particles"])
        self.title = (f"BPM bed, {sys_['n_grains']} grains, {sys_['n_particles']} particles, "
                      f"v_p = {self.scen['platen_speed']:g} m/s, k_A = {self.model['k_A']:g}, "
                      f"lambda_c = {self.model['lambda_c']:g}")
        if sys_.get("bonds_breaking_in_repulsion"):
            self.warnings.append(f"{sys_['bonds_breaking_in_repulsion']} bonds break inside the non-bonded "
                                 "repulsion (lambda_c r0 < a): each such break creates energy the account cannot hold")

    def _single_frame(self, name: str) -> None:
        self.states.append(BpmBedState(self.run_dir, name, self.grain, self.units, self.volumes))


def _axes() -> tuple[Figure, object]:
    fig = Figure(figsize=(6, 4.2))
    return fig, fig.subplots()


def _save(fig: Figure, path: Path) -> None:
    fig.savefig(path, dpi=120, bbox_inches="tight")


def plot_compression(branch: pd.DataFrame, fit, path: Path, title: str) -> None:
    fig, ax = _axes()
    ax.semilogx(branch.sigma_v, branch.void_ratio, ".", ms=3, label="loading")
    s = np.geomspace(branch.sigma_v.min(), branch.sigma_v.max(), 50)
    if not fit.flag:
        ax.semilogx(s, fit.e_pre(s), "--", lw=1, label=f"C_s = {fit.C_s:.3g}")
        ax.semilogx(s, fit.e_post(s), "--", lw=1, label=f"C_c = {fit.C_c:.3g}")
        ax.axvline(fit.sigma_y, color="k", lw=0.8, label=f"sigma_y = {fit.sigma_y / 1e6:.3g} MPa")
    ax.set(xlabel="vertical stress sigma_v (Pa)", ylabel="void ratio e", title=title)
    ax.legend(fontsize=8)
    _save(fig, path)


def plot_grading(curves: pd.DataFrame, path: Path, title: str) -> None:
    fig, ax = _axes()
    for name, c in curves.groupby("state", sort=False):
        ax.step(c["size"] * 1e3, c.passing * 100, where="post", label=f"{name}: {c.sigma_v.iloc[0] / 1e6:.3g} MPa")
    ax.set(xscale="log", xlabel="sieve size b (mm)", ylabel="mass passing (%)", title=title)
    ax.legend(fontsize=8)
    _save(fig, path)


def plot_breakage(states: pd.DataFrame, path: Path, title: str) -> None:
    fig, ax = _axes()
    s = states.sigma_v / 1e6
    for col in ("B_r", "B_r_cell", "B_r_star", "fraction_broken"):
        ax.plot(s, states[col], "o-", label=col)
    ax.set(xlabel="vertical stress sigma_v (MPa)", ylabel="breakage", title=title)
    ax.legend(fontsize=8)
    _save(fig, path)


def plot_energy(account: pd.DataFrame, path: Path, title: str, channels: tuple[str, ...] = CHANNELS) -> None:
    fig, ax = _axes()
    t = (account.time - account.time.iloc[0]) * 1e3
    base = account.iloc[0]
    ax.plot(t, account.W_p - base.W_p, "k", label="platen work W_p")
    for col in ("kinetic", "elastic", *channels):
        ax.plot(t, account[col] - base[col], label=col)
    ax.set(xlabel="time since the loading began (ms)", ylabel="energy (J)", title=title)
    ax.legend(fontsize=7)
    _save(fig, path)


def analyse_bed_set(runs: list[dict], out: Path, plots: bool = True, left_out: list[dict] | None = None) -> dict:
    """One row per bed run (yield stress, C_c, K_0, breakage at the last state) in runs.csv."""
    keys = ("sigma_y", "C_c", "C_s", "K0", "e_start", "sigma_v_max", "inertial_max", "broken_interfaces",
            "balance_residual")
    rows = []
    for r in runs:
        s = r["summary"]
        last = (s.get("states") or [{}])[-1]
        rows.append({"run": r["cfg"]["name"], "run_dir": str(r["dir"]), **{k: s.get(k) for k in keys},
                     **{f"{k}_end": last.get(k) for k in ("B_r", "B_r_star", "fraction_broken")}})
    if not rows:
        raise RunSetError("no bed runs to analyse")
    table = pd.DataFrame(rows)
    save_table(table, Path(out) / "runs")
    return {"beds": len(table), "left_out": [lo.get("run") for lo in (left_out or [])]}
