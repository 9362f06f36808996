"""The analysis of one crush run (SPEC 4.1): the platen force against the platen's travel, F_c by
analysis.strength.first_peak, the work and loading stiffness up to it, sigma_c = F_c / d², the
damage at F_c and at the end, the energy account and the fragments at the end (the impact's
fragment analysis, analysis/bcm_impact.py and bpm_impact.py) (`BcmCrushAnalysis`,
`BpmCrushAnalysis`, on what they share, `CrushAnalysis`); and a set of crush runs, the
F_c and sigma_c of its grains with a Weibull fit, the size effect and the half-speed check of
quasi-static loading (`analyse_crush_set`).

Displacement u: the upper platen's travel from first contact (its travel since the start less
the initial gap), closing positive, m. Force: the normal force on the upper platen, N.
Energies in J. The rule of F_c is analysis.strength.first_peak's (CRUSH_RULE below).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from analysis.bcm_impact import _fragment_picture, cell_shapes, fragments_of, last_state_dumps, read_interfaces
from analysis.bpm_impact import break_series, particle_fragments
from analysis.breaks import read_break_log
from analysis.dumps import read_atom_dump, read_local_dump
from analysis.fragment_shapes import fragment_table, shape_averages, vertices_in_space
from analysis.grains import grain_labels
from analysis.impact_measures import fragment_counts, settle_outcome
from analysis.report import Report, provenance_line, write_report
from analysis.run_analysis import RunAnalysis
from analysis.runset import RunSetError
from analysis.strength import (DROP, NOISE_FLOOR, characteristic_stress, first_peak,
                               loading_stiffness, size_effect, weibull_fit, work_to)
from analysis.strength_plots import plot_force_displacement, plot_size_effect, plot_weibull
from analysis.tables import save_table
from runfiles.atomic import atomic_save
from runfiles.records import BPM_CRUSH_RECORD, CRUSH_RECORD, read_record

#: The rule of F_c, quoted in every summary and report (analysis.strength.first_peak).
CRUSH_RULE = (f"F_c is the largest upper-platen force before the force first falls below {DROP:g} times its "
              f"running maximum, such a fall counting once the running maximum has reached {NOISE_FLOOR:g} of the "
              "record's largest force (analysis.strength.first_peak); when it never falls so, F_c is the largest "
              "force recorded and dropped is false")
#: Quasi-static: the rms difference of the two platens' forces on the loading branch is below
#: this fraction of F_c (1-4 % measured at 0.01-0.02 m/s, 80 cells).
QUASI_STATIC_TOLERANCE = 0.05
#: F_max above this multiple of F_c is flagged: the first peak was a local failure.
FIRST_PEAK_BELOW_MAX = 1.5
#: The two strengths of a grain that the set statistics (Weibull, size effect) are taken over:
#: column -> (force, what it is). SPEC 4.1's is sigma_c, the first peak's. sigma_max is beside
#: it because a grain's first peak can be a local failure under a platen contact (a cell or
#: a few crushed, the force falling by 20 %) far below the force that splits it: 18 of 20
#: BCM grains of 200 cells did so at 5-12 N and split at 38-58 N (examples/studies/
#: crush_weibull.yaml, docs/scenarios/crush.md). The run stops after the force has fallen below
#: stop_after_drop of its largest value, so F_max is the peak before the split it stopped on.
STRENGTHS = {"sigma_c": ("F_c", "first peak: F_c / d² (SPEC 4.1)"),
             "sigma_max": ("F_max", "largest force: F_max / d² (the peak before the split the run stopped on)")}
#: The energy account is flagged when it does not close to this fraction of W_p.
BALANCE_TOLERANCE = 1e-3


def read_crush_record(path: Path) -> pd.DataFrame:
    """The `fix print` record of a crush run (runfiles/records.py CRUSH_RECORD), one row per
    step, with derived columns as the impact's (analysis/bcm_impact.py read_impact_thermo):
    kinetic, elastic (interfaces + platens + contacts), dissipated (damping, friction,
    number-of-points changes and switch losses of the three force styles; W_f apart)."""
    return bcm_energy_columns(read_record(path, CRUSH_RECORD.names))


def bcm_energy_columns(df: pd.DataFrame) -> pd.DataFrame:
    """A BCM record's energy account columns (the crush's and the bed's records name their
    fields alike): kinetic, elastic (interfaces + walls + contacts), dissipated by channel
    (damping, friction, number-of-points changes of the three force styles) and in all with
    the switch losses (W_f apart)."""
    df["kinetic"] = df.ke_trans + df.ke_rot
    df["elastic"] = df.E_interfaces + df.E_wall + df.E_contacts
    df["dissipated_damping"] = df.W_damp + df.W_wall_damp + df.W_contact_damp
    df["dissipated_friction"] = df.W_friction + df.W_wall_friction + df.W_contact_friction
    df["dissipated_npoints"] = df.W_wall_npoints + df.W_contact_npoints
    df["dissipated"] = df.dissipated_damping + df.dissipated_friction + df.dissipated_npoints + df.W_switch
    return df


def energy_residual(record: pd.DataFrame) -> pd.Series:
    """W_p - (change of kinetic + elastic + W_f + dissipated) at each record: the energy account
    of the crush (plugins/doc/fix_bcm_wall.md), zero to velocity Verlet's O(h²) of the instant."""
    k0 = float(record.kinetic.iloc[0]) + float(record.elastic.iloc[0])
    return record.W_p - (record.kinetic + record.elastic - k0 + record.W_f + record.dissipated)


def crush_measures(record: pd.DataFrame, height: float, gap0: float) -> tuple[dict, pd.DataFrame, object, object]:
    """(measures, record with u, Peak, Stiffness or None) of one crush record in SI, of either
    model: columns step, time, displacement, F_upper, F_lower, W_p, broken, D_w and the energy
    account's kinetic, elastic, W_f, dissipated; `height` is d (the particle between the
    platens at contact), `gap0` the upper platen's initial gap."""
    rec = record.copy()
    rec["u"] = rec.displacement - gap0
    peak = first_peak(rec.u, rec.F_upper)
    at = rec.iloc[peak.index]
    end = rec.iloc[-1]
    try:
        stiff = loading_stiffness(rec.u, rec.F_upper, peak.F_c)
    except ValueError:
        stiff = None
    # quasi-static check: the platens' forces on the loading branch between 0.1 F_c and F_c.
    # Their difference is the particle's m a_cm: its mean is ~0 whatever the speed (the
    # particle's momentum stays small), its rms is the ringing; single samples spike at breaks
    loading = rec.iloc[: peak.index + 1]
    loading = loading[loading.F_upper >= 0.1 * peak.F_c]
    diff = (loading.F_upper - loading.F_lower).to_numpy()
    mismatch = float(np.sqrt(np.mean(diff ** 2)) / peak.F_c) if len(diff) else float("nan")
    mismatch_max = float(np.abs(diff).max() / peak.F_c) if len(diff) else float("nan")
    # the largest force before the run's end: above F_c when a local failure (a contact
    # crushing) made the first drop and the particle carried more afterwards
    f_max = float(rec.F_upper.max())
    residual = energy_residual(rec)
    w_p_end = float(end.W_p)
    measures = {
        "F_c": peak.F_c, "sigma_c": characteristic_stress(peak.F_c, height), "height": height,
        "sigma_max": characteristic_stress(f_max, height),
        "u_c": peak.displacement, "W_p_at_F_c": work_to(rec.u, rec.F_upper, peak.index, work=rec.W_p),
        "loading_stiffness": stiff.slope if stiff else None,
        "loading_stiffness_stderr": stiff.sigma if stiff else None,
        "loading_stiffness_samples": stiff.n if stiff else 0,
        "dropped": peak.dropped, "drop_u": float(rec.u.iloc[peak.drop_index]) if peak.dropped else None,
        "broken_at_F_c": int(at.broken), "D_w_at_F_c": float(at.D_w),
        "broken_end": int(end.broken), "D_w_end": float(end.D_w),
        "u_end": float(end.u), "strain_end": float(end.u) / height, "time_end": float(end.time),
        "F_end": float(end.F_upper), "F_end_over_F_c": float(end.F_upper) / peak.F_c,
        "F_max": f_max, "F_max_over_F_c": f_max / peak.F_c,
        "force_mismatch_loading": mismatch, "force_mismatch_loading_max": mismatch_max,
        "W_p": w_p_end, "W_f": float(end.W_f), "kinetic_end": float(end.kinetic), "elastic_end": float(end.elastic),
        "dissipated": float(end.dissipated),
        "balance_residual": float(residual.iloc[-1]) / w_p_end if w_p_end > 0 else float("nan"),
        "balance_residual_max": float(residual.abs().max()) / w_p_end if w_p_end > 0 else float("nan"),
        "F_c_rule": CRUSH_RULE,
    }
    rec["energy_residual"] = residual
    return measures, rec, peak, stiff


def plot_broken(rec: pd.DataFrame, u_c: float, path: Path, title: str = "", label: str = "broken interfaces") -> None:
    """Broken elements (interfaces, bonds) and D_w against the platen's travel, F_c's travel marked."""
    fig = Figure(figsize=(5.0, 3.6), dpi=150)
    ax = fig.subplots()
    ax.plot(rec.u * 1e6, rec.broken, "k-", lw=1.0)
    ax.axvline(u_c * 1e6, color="0.5", ls="--", lw=1.0, label="$F_c$")
    ax.set_xlabel("platen displacement from first contact [µm]")
    ax.set_ylabel(label)
    ax2 = ax.twinx()
    ax2.plot(rec.u * 1e6, rec.D_w, alpha=0)  # the D_w scale of the same curve
    ax2.set_ylabel("$D_w$")
    ax.legend(fontsize=7, frameon=False)
    if title:
        ax.set_title(title, fontsize=8)
    fig.tight_layout()
    atomic_save(Path(path), lambda p: fig.savefig(p, format="png"))


class CrushAnalysis(RunAnalysis):
    """What the crush analyses of both models share: the measures of crush_measures and their
    flags, the stop, the figures and the report. A model's subclass reads its run in
    `_prepare` (self.record in SI, crush_measures' columns; self.gap0, the upper platen's
    initial gap, m; self.timestep_s; self.title) and gives `_fragments()`, the
    fragment table at the end with what its picture needs, and `model_measures`."""

    #: what an element and a broken one are called in the figures and report
    broken_name = "broken interfaces"
    model_name = "BCM"

    def _fragments(self) -> pd.DataFrame:
        raise NotImplementedError

    def model_measures(self, end: pd.Series) -> dict:
        """The model's own entries of the summary (its energy channels at the end)."""
        return {}

    def _conclude(self) -> None:
        system = self.system
        measures, rec, peak, stiff = crush_measures(self.record, system["height"], self.gap0)
        if not peak.dropped:
            self.warnings.append(f"no drop: the platen force never fell below {DROP:g} of its running maximum; F_c "
                                 "is only the largest force recorded (raise scenario.max_strain or max_time)")
        if stiff is None:
            self.warnings.append("too few records on the loading branch for a loading stiffness (lower "
                                 "scenario.thermo_every)")
        if measures["force_mismatch_loading"] > QUASI_STATIC_TOLERANCE:
            self.warnings.append(f"the platens' forces differ by {measures['force_mismatch_loading']:.3g} of F_c (rms) "
                                 "while loading: not quasi-static (lower scenario.platen_speed)")
        if measures["F_max_over_F_c"] > FIRST_PEAK_BELOW_MAX:
            self.warnings.append(f"the largest force, {measures['F_max']:.4g} N, is {measures['F_max_over_F_c']:.3g} "
                                 "times F_c: the first drop was a local failure (a contact crushing) and the particle "
                                 "carried more afterwards")
        if abs(measures["balance_residual_max"]) > self.balance_tolerance:
            self.warnings.append(f"the energy account closes only to {measures['balance_residual_max']:.2g} of W_p")
        frags = self._fragments()
        outcome = settle_outcome(self.run_dir, system, int(rec.step.iloc[-1]))
        measures.update({
            **self.model_measures(self.record.iloc[-1]),
            **fragment_counts(frags, system["mass"]),
            **{f"shape_{k}": v for k, v in shape_averages(frags).items()},
            "stopped_by_drop": outcome["settled"], "end_step": outcome["end_step"],
            "stop_rule": (f"stopped at a check (every {system['window_steps']} steps) once an element had broken "
                          f"and the upper platen's force was below {self.scen['stop_after_drop']:g} of the largest "
                          f"force at the checks; else at the strain limit {self.scen['max_strain']:g} or max_time "
                          f"{self.scen['max_time']:g} s"),
            "platen_speed": self.scen["platen_speed"], "timestep": self.timestep_s,
        })
        self.results.summary = measures
        self.results.tables.update(crush=rec, fragments=frags)
        self.rec, self.peak, self.stiff, self.frags = rec, peak, stiff, frags

    #: the energy account is flagged above this fraction of W_p
    balance_tolerance = BALANCE_TOLERANCE

    def _plot(self) -> None:
        self.draw("force_displacement", plot_force_displacement, self.rec.u, self.rec.F_upper, self.peak, self.stiff,
                  self.png("force_displacement"), self.title)
        self.draw("broken", plot_broken, self.rec, self.peak.displacement, self.png("broken"), self.title,
                  self.broken_name)

    def _plots_failed(self) -> list[dict[str, str]]:
        return self.system.get("plots_failed", []) + self.guard.failed

    def _report(self) -> Report:
        s = self.results.summary
        rep = Report(f"{self.cfg['name']}: {self.title}", provenance_line(self.run_dir))
        shown = ("F_c", "sigma_c", "height", "u_c", "W_p_at_F_c", "loading_stiffness", "dropped", "broken_at_F_c",
                 "D_w_at_F_c", "F_max", "broken_end", "D_w_end", "n_fragments", "largest_fragment_mass_fraction",
                 "force_mismatch_loading", "balance_residual_max", "stopped_by_drop", "strain_end")
        rep.values({k: s[k] for k in shown if k in s}, "SPEC 4.1 measures (SI units; all in summary.json)")
        rep.text(f"Rule: {CRUSH_RULE}; sigma_c = F_c / d², d the particle's height between the platens at contact.")
        rep.text(s["stop_rule"] + f"; time step {self.timestep_s:.4g} s.")
        for msg in self.warnings:
            rep.text(f"Warning: {msg}")
        for name, caption in (("force_displacement", "upper platen force against its travel, F_c marked"),
                              ("broken", f"{self.broken_name} against the platen's travel"),
                              ("fragments", "cells coloured by fragment at the end"),
                              ("cells", "cell statistics of the tessellation")):
            if self.png(name).exists():
                rep.figure(self.png(name), caption)
        rep.table(self.frags[["fragment", "n_cells", "mass", "a", "b", "c"]],
                  "largest fragments (results/fragments.csv has all)", max_rows=10)
        return rep


class BcmCrushAnalysis(CrushAnalysis):
    """F_c and the crush measures, the energy account, the fragments at the end, figures and
    report of a BCM crush run (cut short: on the record so far and its last periodic snapshot,
    flagged; refused without one)."""

    def _prepare(self) -> None:
        self.model, self.scen = self.cfg["model"], self.cfg["scenario"]
        self.system = json.loads((self.run_dir / "system.json").read_text())
        self.gap0 = self.system["platen_start"] - self.system["highest_z"]  # the upper platen's initial gap, m
        self.timestep_s = self.system["timestep"]
        cells_dump, ifaces_dump, note = last_state_dumps(self.run_dir, self.cut_short)
        self.cells = read_atom_dump(cells_dump)[-1]
        self.ifaces = read_interfaces(ifaces_dump)
        self.record = read_crush_record(self.run_dir / "thermo.dat")
        if note is not None:
            self.cut_short_note = note
            self.record = self.record[self.record.step <= self.cells.timestep].reset_index(drop=True)
        self.title = (f"BCM crush, N_c = {self.system['n_cells']}, v_p = {self.scen['platen_speed']:g} m/s, "
                      f"G_c = {self.model['interface']['G_c']:g} J/m²")

    def model_measures(self, end: pd.Series) -> dict:
        return {"W_damping": float(end.dissipated_damping), "W_friction": float(end.dissipated_friction),
                "W_switch": float(end.W_switch)}

    def _fragments(self) -> pd.DataFrame:
        """The impact's fragment analysis (analysis/bcm_impact.py) on the end state."""
        cells = self.cells
        labels = fragments_of(len(cells.ids), self.ifaces)
        masses = cells.extra["mass"]
        body, faces, warning = cell_shapes(self.run_dir)
        if warning:
            self.warnings.append(warning)
        offsets = np.concatenate([[0], np.cumsum([len(v) for v in body])])
        space = vertices_in_space(np.concatenate(body), offsets, cells.positions, cells.quaternions())
        self.picture = (space, offsets, faces, labels)
        self.results.tables["interfaces"] = self.ifaces
        return fragment_table(labels, masses, masses / self.model["density"], (space, offsets))

    def _plot(self) -> None:
        super()._plot()
        self.draw("fragments", _fragment_picture, *self.picture, self.png("fragments"),
                  f"{self.title}\n{len(self.frags)} fragments, D_w = {self.results.summary['D_w_end']:.3f}")


def read_bpm_crush_record(path: Path, units: dict) -> pd.DataFrame:
    """The record of a BPM crush (runfiles/records.py BPM_CRUSH_RECORD) in SI (m, N, J, s) with
    crush_measures' columns: kinetic; elastic (repulsion, bonds, angles, both planes' normal
    springs); dissipated = the planes' (each: the work its motion put in, less the work of its
    forces on the particles and its springs' energy; tangential springs included, as for the
    impact) + the damping of Eq. 5 on pairs and bonds. W_f, broken, D_w come from the break log
    (BpmCrushAnalysis)."""
    df = read_record(path, BPM_CRUSH_RECORD.names)
    a, u = units["a"], units["u"]
    out = pd.DataFrame({"step": df.step, "time": df.time, "displacement": df.displacement * a, "gap": df.gap * a,
                        "F_upper": df.F_upper * u / a, "F_lower": df.F_lower * u / a})
    for col in ("W_p", "ke", "E_pair", "E_bonds", "E_angles", "E_wall_lower", "E_wall_upper", "work_lower",
                "work_upper", "W_damp_pair", "W_damp_bond"):
        out[col] = df[col] * u
    out["kinetic"] = out.ke
    out["elastic"] = out.E_pair + out.E_bonds + out.E_angles + out.E_wall_lower + out.E_wall_upper
    out["W_c_lower"] = -out.work_lower - out.E_wall_lower
    out["W_c_upper"] = out.W_p - out.work_upper - out.E_wall_upper
    out["dissipated"] = out.W_c_lower + out.W_c_upper + out.W_damp_pair + out.W_damp_bond
    for col in ("lower_contacts", "upper_contacts", "bonds_broken", "angles_broken"):
        out[col] = df[col].astype(int)
    out["broken"] = out.bonds_broken
    return out


class BpmCrushAnalysis(CrushAnalysis):
    """The crush measures of a BPM run (SI), its energy account with the energy the breaks took
    (W_f = W_f_held, the break log's) and the fragments (grains of intact bonds) at the end. Cut
    short: refused (measured on the end state, as the BPM impact)."""

    broken_name = "broken bonds"
    refuses_cut_short = ("a BPM crush is measured on its end state, which a run cut short does not have: resume it "
                         "(driver run CONFIG -o DIR --resume)")
    # the breaks of bonds whose particles overlap switch the repulsion on (driver/bpm/network.py):
    # energy the account cannot hold, flagged with the system's count
    balance_tolerance = 1e-2

    def _prepare(self) -> None:
        run_dir = self.run_dir
        self.model, self.scen = self.cfg["model"], self.cfg["scenario"]
        self.system = json.loads((run_dir / "system.json").read_text())
        self.units = un = self.system["units"]
        self.gap0 = (self.system["platen_start"] - self.system["height_a"]) * un["a"]  # the platen's initial gap, m
        self.timestep_s = self.system["timestep_s"]
        atoms_path, bonds_path = run_dir / "dumps" / "atoms.end.lammpstrj", run_dir / "dumps" / "bonds.end.lammpstrj"
        if not atoms_path.exists():
            raise FileNotFoundError(f"{atoms_path}: the end state of the run is missing")
        self.atoms = read_atom_dump(atoms_path)[-1]
        bonds = read_local_dump(bonds_path)[-1].columns
        self.intact = np.column_stack([bonds["batom1"], bonds["batom2"]]).astype(np.int64) - 1
        table = np.loadtxt(run_dir / "bond_areas.txt", ndmin=2)
        all_bonds, area = table[:, :2].astype(np.int64) - 1, table[:, 2]
        self.volumes = np.loadtxt(run_dir / "particle_volumes.txt", ndmin=1) * un["a"] ** 3
        record = read_bpm_crush_record(run_dir / "thermo.dat", un)
        breaks = read_break_log(run_dir / "breaks.dat") if (run_dir / "breaks.dat").exists() else None
        break_series(record, breaks, all_bonds, area, len(self.atoms.ids), un)
        record["W_f"] = record.W_f_held
        record["D_w"] = record.broken_area / self.system["A0"]
        self.record = record
        self.title = (f"BPM crush, N = {len(self.atoms.ids)}, v_p = {self.scen['platen_speed']:g} m/s, "
                      f"k_A = {self.model['k_A']:g}, lambda_c = {self.model['lambda_c']:g}")
        if self.system.get("bonds_breaking_in_repulsion"):
            self.warnings.append(f"{self.system['bonds_breaking_in_repulsion']} bonds break inside the non-bonded "
                                 "repulsion (lambda_c r0 < a): each such break creates energy the account cannot hold")

    def model_measures(self, end: pd.Series) -> dict:
        return {"W_c_lower": float(end.W_c_lower), "W_c_upper": float(end.W_c_upper),
                "W_c_pair_damping": float(end.W_damp_pair), "W_c_bond_damping": float(end.W_damp_bond),
                "angles_broken_end": int(end.angles_broken)}

    def _fragments(self) -> pd.DataFrame:
        """Grains of the intact bonds at the end (analysis/bpm_impact.py particle_fragments)."""
        un, atoms = self.units, self.atoms
        labels = grain_labels(len(atoms.ids), self.intact)
        return particle_fragments(labels, np.asarray(atoms.positions, float) * un["a"],
                                  np.asarray(atoms.velocities, float) * un["a"] / un["tau"], un["m"], self.volumes,
                                  un["a"], self.intact)


def analyse_crush_set(runs: list[dict], out: Path, plots: bool = True, left_out: list[dict] | None = None, *,
                      params: Callable[[dict], dict]) -> dict:
    """F_c and sigma_c of each grain (runs table) and, per group of grains that differ only by
    their seed (one size, one material, one speed: SPEC 4.1's set of grains of one size), the
    Weibull fit of sigma_c over the grains that dropped (analysis.strength.weibull_fit; flagged
    under analysis.strength.MIN_WEIBULL_GRAINS grains), the size effects (_size_effects) and
    SPEC 4.1's quasi-static check between groups at a platen speed and half of it
    (_half_speed_checks). The groups' keys are those of `params` but the seed: platen_speed
    among them when `params` gives it (both crush units do), so grains at two speeds are two
    groups. Returns {grains, grains_dropped, groups: [{group, n, n_dropped, weibull_m,
    weibull_sigma_0, their intervals, weibull_flag}], size_effects: [...],
    half_speed_checks: [...]}."""
    rows = [{"run": r["cfg"]["name"], "run_dir": str(r["dir"]), **params(r["cfg"]),
             **{k: r["summary"].get(k) for k in ("F_c", "sigma_c", "height", "u_c", "dropped", "F_max", "D_w_end")}}
            for r in runs]
    if not rows:
        raise RunSetError("no crush runs to analyse")
    table = pd.DataFrame(rows)
    table["sigma_max"] = table.F_max / table.height ** 2  # STRENGTHS (the summary's sigma_max, for older runs too)
    keys = [k for k in params(runs[0]["cfg"]) if k != "seed"]
    table["group"] = [", ".join(f"{k} = {row[k]:g}" if isinstance(row[k], float) else f"{k} = {row[k]}"
                                for k in keys) for _, row in table.iterrows()]
    out = Path(out)
    save_table(table, out / "runs")
    figures: dict = {"grains": len(table), "grains_dropped": int(table.dropped.astype(bool).sum()), "groups": []}
    rep = Report(f"Crush set of {len(table)} grains", "F_c, sigma_c per grain (runs.csv); Weibull fits of sigma_c "
                                                      "and sigma_max per group of grains that differ by their seed "
                                                      "only")
    rep.table(table.drop(columns=["run_dir"]), "grains")
    rep.text("Two strengths per grain (analysis/crush.py STRENGTHS): " + "; ".join(
        f"{name}, the {what}" for name, (_, what) in STRENGTHS.items()) + ". They differ where the first peak "
        f"was a local failure (F_max above {FIRST_PEAK_BELOW_MAX:g} F_c): "
        f"{int((table.F_max > FIRST_PEAK_BELOW_MAX * table.F_c).sum())} of {len(table)} grains here.")
    for k, (group, members) in enumerate(table.groupby("group", sort=True)):
        broke = members[members.dropped.astype(bool)]
        entry = {"group": group, "n": len(members), "n_dropped": len(broke)}
        if len(broke) < 2:
            rep.text(f"{group}: {len(broke)} grain(s) dropped, no Weibull fit (2 or more needed).")
        for strength, prefix in (("sigma_c", "weibull_"), ("sigma_max", "weibull_max_")):
            values = broke[strength].to_numpy(float)
            values = values[np.isfinite(values)]
            if np.unique(values).size < 2:
                continue
            fit = weibull_fit(values)
            entry.update({f"{prefix}m": fit.m, f"{prefix}sigma_0": fit.sigma_0,
                          f"{prefix}m_interval": list(fit.m_interval),
                          f"{prefix}sigma_0_interval": list(fit.sigma_0_interval), f"{prefix}flag": fit.flag})
            rep.values({"m": fit.m, "sigma_0": fit.sigma_0, "m interval": fit.m_interval,
                        "sigma_0 interval": fit.sigma_0_interval},
                       f"{group}: Weibull fit of {strength} over the {len(broke)} grains that dropped "
                       f"({fit.confidence:.0%} intervals)")
            if fit.flag:
                rep.text(f"Flag: {fit.flag}.")
            if plots:
                png = out / f"{prefix.rstrip('_')}_{k}.png"
                plot_weibull(values, fit, png, f"{group}\n{strength}: the {STRENGTHS[strength][1]}")
                rep.figure(png, f"Weibull plot of {strength}, {group}")
        figures["groups"].append(entry)
    figures["size_effects"] = _size_effects(table, keys, out, plots, rep)
    figures["half_speed_checks"] = _half_speed_checks(table, keys, out, rep)
    write_report(rep, out)
    return figures


#: the parameters that make a grain's size: grains that differ in these (and their seed) only
#: are one family of sizes (the BCM's cell count grows with d³ at a fixed element size)
SIZE_KEYS = ("diameter", "n_cells")


def _size_effects(table: pd.DataFrame, keys: list[str], out: Path, plots: bool, rep: Report) -> list[dict]:
    """Per family of grains that differ only by their size (SIZE_KEYS) and seed, with two sizes
    or more among the grains that dropped, and per strength (STRENGTHS): median strength ~
    d^(-b) and 3/m (analysis.strength.size_effect; d per grain, the sizes grouped by `diameter`)."""
    family_keys = [k for k in keys if k not in SIZE_KEYS]
    broke = table[table.dropped.astype(bool)].copy()
    broke["family"] = [", ".join(f"{k} = {row[k]}" for k in family_keys) for _, row in broke.iterrows()]
    found = []
    for k, (family, members) in enumerate(broke.groupby("family", sort=True)):
        if members.diameter.nunique() < 2:
            continue
        for strength in STRENGTHS:
            have = members[np.isfinite(members[strength].to_numpy(float))]
            if have.diameter.nunique() < 2:
                continue
            effect = size_effect(have.height.to_numpy(), have[strength].to_numpy(), groups=have.diameter.to_numpy())
            found.append({"family": family, "strength": strength, "b": effect.b, "b_interval": list(effect.b_interval),
                          "b_weibull": effect.b_weibull, "b_weibull_interval": list(effect.b_weibull_interval),
                          "sizes": effect.groups.d.tolist(), "grains": effect.groups.n.tolist()})
            rep.values({"b": effect.b, "b interval": effect.b_interval, "3/m": effect.b_weibull,
                        "3/m interval": effect.b_weibull_interval},
                       f"{family}: size effect of {strength}, median ~ d^-b over {len(effect.groups)} sizes")
            if plots:
                png = out / f"size_effect{'' if strength == 'sigma_c' else '_max'}_{k}.png"
                plot_size_effect(effect, png, f"{family}\n{strength}: the {STRENGTHS[strength][1]}")
                rep.figure(png, f"size effect of {strength}, {family}")
    return found


#: The tolerance of the half-speed check when fewer than 2 grains dropped at the faster speed (no
#: seed scatter to compare with): the 5 % of the single-seed checks (tests/test_bcm_crush.py).
HALF_SPEED_TOLERANCE = 0.05
#: Two speeds are v and v/2 when v_slow / v_fast is 1/2 to this relative tolerance.
HALF_SPEED_RTOL = 1e-9


def _half_speed_checks(table: pd.DataFrame, keys: list[str], out: Path, rep: Report) -> list[dict]:
    """SPEC 4.1's quasi-static check: per pair of groups that differ only by platen_speed, one
    speed v, the other v/2 (to HALF_SPEED_RTOL), the grains paired by seed among those that
    dropped at both speeds: the check passes when the mean paired |F_c(v/2) - F_c(v)| / F_c(v) is
    at most the seed-to-seed scatter of F_c at v (std, ddof = 1, over mean, over the grains of
    that group that dropped); with fewer than 2 such grains, at most HALF_SPEED_TOLERANCE. Returns
    [{group_fast, group_slow, pairs, mean_relative_difference, seed_scatter, tolerance, passed}]
    (no pair: mean_relative_difference and passed None), written to half_speed.csv (when there
    is a check) and the report, a failed check flagged."""
    if "platen_speed" not in keys or "seed" not in table:
        return []
    rest = [k for k in keys if k != "platen_speed"]
    # the group without its speed: the same formatting as the groups' names
    other = [", ".join(f"{k} = {row[k]:g}" if isinstance(row[k], float) else f"{k} = {row[k]}" for k in rest)
             for _, row in table.iterrows()]
    table = table.assign(_rest=other)
    groups = [(name, members) for name, members in table.groupby("group", sort=True)]
    checks = []
    for fast_name, fast in groups:
        v = float(fast.platen_speed.iloc[0])
        for slow_name, slow in groups:
            if (slow._rest.iloc[0] != fast._rest.iloc[0]
                    or abs(float(slow.platen_speed.iloc[0]) / v - 0.5) > 0.5 * HALF_SPEED_RTOL):
                continue
            fast_broke = fast[fast.dropped.astype(bool)]
            f_fast = fast_broke.groupby("seed").F_c.mean()
            f_slow = slow[slow.dropped.astype(bool)].groupby("seed").F_c.mean()
            seeds = f_fast.index.intersection(f_slow.index)
            diff = (f_slow[seeds] - f_fast[seeds]).abs() / f_fast[seeds]
            if len(fast_broke) >= 2:
                fc = fast_broke.F_c.to_numpy(float)
                scatter = float(np.std(fc, ddof=1) / np.mean(fc))
                tolerance = scatter
                basis = (f"the seed-to-seed scatter of F_c at {v:g} m/s, {scatter:.3g} (std / mean over its "
                         f"{len(fc)} grains that dropped)")
            else:
                scatter, tolerance = None, HALF_SPEED_TOLERANCE
                basis = (f"a fixed {HALF_SPEED_TOLERANCE:g} (fewer than 2 grains dropped at {v:g} m/s: no seed "
                         "scatter to compare with)")
            mean = float(diff.mean()) if len(seeds) else None
            passed = None if mean is None else bool(mean <= tolerance)
            checks.append({"group_fast": fast_name, "group_slow": slow_name, "pairs": int(len(seeds)),
                           "mean_relative_difference": mean, "seed_scatter": scatter, "tolerance": tolerance,
                           "passed": passed})
            head = (f"half-speed check, {v:g} against {v / 2:g} m/s"
                    + (f" ({fast._rest.iloc[0]})" if rest else ""))
            if mean is None:
                rep.text(f"H{head[1:]}: no seed dropped at both speeds, no check.")
                continue
            measured = (f"over {len(seeds)} seed{'s' if len(seeds) > 1 else ''} dropped at both speeds, the mean "
                        f"|F_c(v/2) - F_c(v)| / F_c(v) is {mean:.3g}")
            if passed:
                rep.text(f"H{head[1:]}: {measured}, within {basis}: quasi-static (SPEC 4.1).")
            else:
                rep.text(f"Flag: not quasi-static: {head}: {measured}, above {basis} (lower scenario.platen_speed).")
    if checks:
        save_table(pd.DataFrame(checks), out / "half_speed")
    return checks
