"""Time step by measurement (issue 15, point 1): energy drift and impact outcome against
`scenario.steps_per_period` (dt = 2 pi sqrt((m_min / 2) / k_max) / steps_per_period).

(a) Drift, nothing damps, slides or breaks (e_n = 1 for interfaces, contacts and plane, mu = 0,
    G_c = 1e12 J/m^2), on the intact particle of `--cells` cells (SPEC 1.3 stiffnesses), the same
    simulated time (`--periods` shortest contact periods) at every steps_per_period:
    - `vibrating`: no plane; random cell velocities of rms `--v-rms` with no net momentum or
      angular momentum (a small impulse), so the particle vibrates about its rest state.
    - `pressed`: the same particle and impulse, resting on the plane (lowest rounded point at
      z = 0, at rest) and pressed on it by a uniform body force (`fix gravity`, `--press` m/s^2)
      that it never leaves on average: it oscillates in the plane's well with the interfaces
      above the contact loaded.
    E(t) = kinetic (translation + rotation) + interfaces + cell-cell contacts (+ plane contacts
    + the body force's potential). E_scale = max over the run of (kinetic + elastic): the
    energy that moves (E(0) for `vibrating`). Reported:
      drift       = |mean E over the second half - mean E over the first half| / E_scale
                    (the secular change; velocity Verlet has no other);
      fluctuation = max |E(t) - E(0)| / E_scale (the bounded O((omega dt)^2) offset of the
                    shadow energy, not a drift).
    Series in runs/timestep_study/drift/<case>_cells<N>_spp<S>.csv; a finished one is not rerun.
(b) Outcome: the impact of examples/bcm_impact.yaml (4.5 m/s, G_c = 1 J/m^2) against
    steps_per_period (100, 50, 30, 20, 15, 12), three tessellations each, through the sweep
    machinery (bench/timestep_study_sweep.yaml; finished runs are kept and a re-run resumes), at
    the scales `--scales` names: `full` (1728 cells to the settled outcome: 20+ min a run at 100
    steps per period on this machine), `small` (300 cells, to the settled outcome) and `t15us`
    (1728 cells, stopped at 15 us, after the breaking, before the slow settling). D_w, e_k^2,
    eta and the fragment count, mean +- std over seeds; a value passes when every measure's mean
    lies within the 100-steps reference's seed-to-seed std of the reference mean. The scales
    `fast100` and `fast300` check the run's own energy balance where the plane's account is
    hardest, a coarse particle (100 or 300 cells) at 10 m/s through its contact (to 1e-5 s), at
    50, 40 and 30 (no reference; the balance is the criterion). Runs listed in a scale's
    runs table stay in it when their folders are gone.
(c) Stability (`--stability 3 4 5 6 8 10 12 15`): the vibrating particle and a cube pressed
    face-on on the plane (`--stability-cells`, 300), 50 shortest periods at each value; unstable
    when the total energy changes by more than its starting scale.
(d) Which elements set the step (`--modes`): the fastest modes of the intact particle's
    interfaces (linearised, sparse eigenvalues) and of a cell touching the plane with one vertex
    or one face, against the rule's frequency sqrt(k_max / (m_min / 2)).

Prints the tables; writes bench/timestep_study.csv (drift), timestep_study_stability.csv,
timestep_study_modes.json, timestep_study_impact_<scale>.csv (and _runs_<scale>.csv) and
timestep_study.png. Baseline: drift < 1e-4; the outcome within the reference's spread.

    python bench/timestep_study.py --modes --stability 3 4 5 6 8 10 12 15 --scales small t15us fast100 fast300
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from driver.bcm.conservative import CONSERVATIVE_SETUP, impulse, intact_particle
from driver.bcm.section import BCMModel
from driver.engine import Lammps
from driver.plugin_build import plugin_library

ROOT = Path(__file__).resolve().parent.parent
SPP = [10, 15, 20, 30, 50, 100]
SWEEP_FILE = ROOT / "bench" / "timestep_study_sweep.yaml"
SWEEP_DIR = ROOT / "runs" / "timestep_study_sweep"
MEASURES = ["D_w", "e_k2", "eta", "n_fragments"]
DRIFT_LIMIT = 1e-4

INPUT = CONSERVATIVE_SETUP
PRESS = """
fix             plane all bcm/wall cells {dir}/cells.txt rm {rm!r} plane zlo 0.0 {kn_c!r} {kt_c!r} 1.0 0.0
fix             press all gravity {g!r} vector 0 0 -1
"""


def particle_files(n_cells: int, seed: int, work: Path, shape: str = "truncated_pentakis_dodecahedron",
                   orient: bool = True) -> dict:
    """The intact particle's files (SPEC 1.3 defaults; driver/bcm/conservative.py) with its
    lowest rounded point on the plane z = 0. shape cube, orient False: a cube face on the plane,
    every cell of it touching face-on."""
    return intact_particle(work, BCMModel(n_cells=n_cells, shape=shape), seed, np.random.default_rng([seed, 1]),
                           gap=0.0, orient=orient)


def energy_series(files: dict, work: Path, case: str, spp: float, periods: float, seed: int, v_rms: float,
                  press: float, plugin: str, every: int = 1, halt_kinetic: float | None = None) -> pd.DataFrame:
    """Run one drift case; columns step, time, kinetic, elastic, E (total, incl. the body force's
    potential for `pressed`), broken. halt_kinetic: stop once the kinetic energy passes this (J):
    a run that blows up then ends before its cells fly apart (the neighbour bins of a growing
    box exhaust the memory)."""
    dt = files["period"] / spp
    steps = int(math.ceil(periods * spp))
    tmp = tempfile.TemporaryDirectory(prefix="timestep-series-")  # the energy record, read back then dropped
    lmp = Lammps()
    try:
        lmp.command(f"plugin load {plugin}")
        setup = files["setup"]
        lmp.commands(INPUT.format(**setup, dt=dt))
        extra_e, extra_k = "", ""
        if case == "pressed":
            lmp.commands(PRESS.format(dir=work, rm=setup["rm"], kn_c=setup["kn_c"], kt_c=setup["kt_c"], g=press))
            extra_e, extra_k = "+f_press", "+f_plane[4]"
        elif case != "vibrating":
            raise ValueError(f"unknown case {case!r}")
        out = Path(tmp.name) / f"{case}_spp{spp:g}.dat"
        lmp.commands(f"""
variable        kin equal c_ket+f_integrate
variable        ela equal f_BCM_GRIFFITH[5]+c_cpair{extra_k}
variable        etot equal v_kin+v_ela{extra_e}
variable        nb equal f_BCM_GRIFFITH[2]
thermo          0
""")
        impulse(lmp, np.random.default_rng([seed, 7]), v_rms)
        lmp.command(f'fix rec all print {every} "$(step) $(time:%.10e) $(v_kin:%.14e) $(v_ela:%.14e) '
                    f'$(v_etot:%.14e) $(v_nb)" file {out} screen no title "step time kinetic elastic E broken"')
        if halt_kinetic is not None:
            lmp.command(f"fix halt all halt 1 v_kin > {halt_kinetic!r} error soft")
        lmp.command(f"run {steps}")
    finally:
        lmp.close()
    with tmp:
        return pd.read_csv(out, sep=r"\s+")  # the title line names the columns


def drift_figures(t: pd.DataFrame) -> dict:
    scale = float((t.kinetic + t.elastic).max())
    e = t.E.to_numpy()
    half = len(e) // 2
    finite = bool(np.isfinite(e).all())
    return {"E_scale": scale,
            "drift": abs(e[half:].mean() - e[:half].mean()) / scale if finite else math.inf,
            "fluctuation": float(np.abs(e - e[0]).max()) / scale if finite else math.inf,
            "broken": int(t.broken.max()) if finite else -1}


def drift_study(cells: int, seed: int, spps: list[float], periods: float, v_rms: float, press: float,
                cases: list[str], base: Path, run: bool = True) -> pd.DataFrame:
    """The drift table; run=False tabulates the series already measured and runs nothing."""
    work = base / f"particle_{cells}_seed{seed}"
    files = particle_files(cells, seed, work) if run else None
    plugin = str(plugin_library())
    rows = []
    for case in cases:
        for spp in spps:
            path = base / f"{case}_cells{cells}_spp{spp:g}.csv"
            if not path.exists() and not run:
                continue
            if not path.exists():
                t0 = time.perf_counter()
                t = energy_series(files, work, case, spp, periods, seed, v_rms, press, plugin)
                t.to_csv(path, index=False)
                print(f"  {case} spp {spp:g}: {len(t) - 1} steps in {time.perf_counter() - t0:.0f} s", flush=True)
            t = pd.read_csv(path)
            rows.append({"case": case, "cells": cells, "steps_per_period": spp, "dt": float(t.time.iloc[1]),
                         "steps": int(t.step.iloc[-1]), **drift_figures(t)})
    return pd.DataFrame(rows)


def stability_study(cells: int, seed: int, spps: list[float], periods: float, v_rms: float, press: float,
                    base: Path) -> pd.DataFrame:
    """Blow-up check over `periods` shortest periods at each steps_per_period: the vibrating
    particle (interfaces only), and a cube of `cells` cells pressed face-on on the plane (every
    cell of its bottom face touches the plane with a whole face: the stiffest contact). Unstable
    when the total energy changes by more than its starting scale or is no longer finite, or LAMMPS stops."""
    plugin = str(plugin_library())
    rows = []
    for case, shape, orient in [("vibrating", "truncated_pentakis_dodecahedron", True), ("pressed", "cube", False)]:
        work = base / f"particle_{shape}_{cells}_seed{seed}_{'random' if orient else 'faceon'}"
        files = particle_files(cells, seed, work, shape, orient)
        for spp in spps:
            path = base / f"stability_{case}_{shape}_cells{cells}_spp{spp:g}.csv"
            if not path.exists():
                try:
                    t = energy_series(files, work, case, spp, periods, seed, v_rms, press, plugin,
                                      halt_kinetic=1e-4)
                except Exception as exc:  # a blown-up run may stop LAMMPS (lost atoms): that is the answer
                    t = pd.DataFrame({"step": [0], "time": [0.0], "kinetic": [math.inf], "elastic": [math.inf],
                                      "E": [math.inf], "broken": [-1], "error": [str(exc)[:200]]})
                t.to_csv(path, index=False)
            t = pd.read_csv(path)
            scale = float((t.kinetic + t.elastic).iloc[: max(2, len(t) // 20)].max())
            e = t.E.to_numpy()
            grown = float(np.abs(e - e[0]).max() / scale) if np.isfinite(e).all() and scale > 0 else math.inf
            rows.append({"case": case, "shape": shape, "cells": cells, "steps_per_period": spp,
                         "max_dE_over_E_start": grown, "stable": bool(np.isfinite(grown) and grown < 1.0)})
    return pd.DataFrame(rows)

def _cross_matrix(r: np.ndarray) -> np.ndarray:
    """[r]x with [r]x t = r x t, for r of shape (..., 3)."""
    z = np.zeros(r.shape[:-1])
    return np.stack([np.stack([z, -r[..., 2], r[..., 1]], -1), np.stack([r[..., 2], z, -r[..., 0]], -1),
                     np.stack([-r[..., 1], r[..., 0], z], -1)], -2)


def fastest_modes(cells: int, seed: int, n_modes: int = 6) -> dict:
    """Which elements set the step. The intact particle linearised about its rest state: each
    interface point a spring k_n/N_p along n and k_t/N_p across (the per_interface split), cells
    rigid with their mass and full inertia; the largest eigenfrequencies omega of K v = omega^2 M v
    (12 DOF per interface, sparse), against the rule's omega_rule = sqrt(k_max / (m_min / 2)).
    And for contacts (k_n per point, the rule's k_max): a single cell touching the plane with one
    vertex of its core, omega^2 = k_n (1/m + (r x n)^T J^-1 (r x n)), r from the centroid to the
    vertex, maximised over n; the rule counts only 1/m (twice, for two cells). Velocity Verlet is
    stable for omega dt < 2, i.e. steps_per_period > pi omega / omega_rule."""
    import scipy.sparse as sp  # noqa: PLC0415

    from driver.bcm.particle import particle_tessellation  # noqa: PLC0415
    from driver.cache import cache_base  # noqa: PLC0415
    from scipy.sparse.linalg import eigsh  # noqa: PLC0415

    model = BCMModel(n_cells=cells)
    tess = particle_tessellation(model, seed, cache_base() / "tessellations")
    rho = model.density
    mass = rho * tess.volume
    inertia = rho * tess.inertia
    n = tess.n_cells
    kn, kt = model.interface.kn, model.interface.kt
    rows, cols, vals = [], [], []
    for k in range(tess.n_interfaces):
        i, j = tess.iface_cells[k]
        pts = tess.interface_polygon(k)
        nrm = tess.iface_normal[k]
        npts = len(pts)
        kp = (kn / npts) * np.outer(nrm, nrm) + (kt / npts) * (np.eye(3) - np.outer(nrm, nrm))
        ki = np.zeros((12, 12))
        for p in pts:
            # relative displacement of the point: (u_j + th_j x r_j) - (u_i + th_i x r_i)
            b = np.hstack([-np.eye(3), _cross_matrix(p - tess.centroid[i]),
                           np.eye(3), -_cross_matrix(p - tess.centroid[j])])
            ki += b.T @ kp @ b
        dof = np.r_[6 * i:6 * i + 6, 6 * j:6 * j + 6]
        rows.append(np.repeat(dof, 12))
        cols.append(np.tile(dof, 12))
        vals.append(ki.ravel())
    stiff = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(6 * n, 6 * n))
    # M^-1/2 per cell: 1/sqrt(m) on translations, J^-1/2 on rotations
    blocks = []
    for i in range(n):
        w, v = np.linalg.eigh(inertia[i])
        blocks.append(sp.block_diag([np.eye(3) / math.sqrt(mass[i]), v @ np.diag(w ** -0.5) @ v.T]))
    minv = sp.block_diag(blocks, format="csr")
    a = minv @ stiff @ minv
    lam, vec = eigsh(a, k=n_modes, which="LA")
    order = np.argsort(lam)[::-1]
    lam, vec = lam[order], vec[:, order]
    k_max = max(model.contact.kn, model.interface.kn)
    omega_rule = math.sqrt(k_max / (0.5 * mass.min()))
    top = vec[:, 0].reshape(n, 6)
    share = (top ** 2).sum(1)
    c = int(np.argmax(share))
    rot_share = float((top[c, 3:] ** 2).sum() / share[c])
    ext = tess.cell(c).vertices - tess.centroid[c]
    sides = np.sort(np.ptp(ext @ tess.principal_axes[c], axis=0))
    faces = np.flatnonzero((tess.iface_cells == c).any(1))
    # contacts: one core vertex of a cell on the plane, worst direction
    factor = np.empty(n)
    for i in range(n):
        verts = tess.cell(i).vertices - tess.centroid[i]
        jinv = np.linalg.inv(inertia[i])
        rx = _cross_matrix(verts)  # (v, 3, 3); r x n = rx @ n
        q = np.einsum("vab,bc,vcd->vad", rx.transpose(0, 2, 1), jinv, rx)  # n^T q n = (r x n)^T J^-1 (r x n)
        factor[i] = 1.0 + mass[i] * np.linalg.eigvalsh(q)[:, -1].max()
    omega_vertex = np.sqrt(model.contact.kn * factor / mass)
    cv = int(np.argmax(omega_vertex))
    # two cells touching vertex to vertex: their inverse effective masses add (the rule: 2 / m_min)
    w = np.sort(factor / mass)
    omega_pair = math.sqrt(model.contact.kn * (w[-1] + w[-2]))
    # a whole face on the plane: k_n n n^T + k_t (1 - n n^T) at each of its N vertices
    kc, ktc = model.contact.kn, model.contact.kt
    omega_face, cf = 0.0, -1
    for i in range(n):
        cell = tess.cell(i)
        jw, jv = np.linalg.eigh(inertia[i])
        msq = sp.block_diag([np.eye(3) / math.sqrt(mass[i]), jv @ np.diag(jw ** -0.5) @ jv.T]).toarray()
        for f, nrm in zip(cell.faces, cell.normals):
            pts = cell.vertices[f] - tess.centroid[i]
            kp = kc * np.outer(nrm, nrm) + ktc * (np.eye(3) - np.outer(nrm, nrm))
            kf = np.zeros((6, 6))
            for r in pts:
                b = np.hstack([np.eye(3), -_cross_matrix(r)])
                kf += b.T @ kp @ b
            om = math.sqrt(np.linalg.eigvalsh(msq @ kf @ msq)[-1])
            if om > omega_face:
                omega_face, cf = om, i
    return {
        "omega_rule": omega_rule, "k_max": k_max, "m_min": float(mass.min()),
        "omega_interfaces": np.sqrt(lam).tolist(),
        "interfaces_over_rule": float(math.sqrt(lam[0]) / omega_rule),
        "interfaces_cell": c, "interfaces_cell_mass_over_min": float(mass[c] / mass.min()),
        "interfaces_cell_mass_over_mean": float(mass[c] / mass.mean()),
        "interfaces_cell_share": float(share[c]), "interfaces_cell_rotation_share": rot_share,
        "interfaces_cell_aspect": float(sides[-1] / sides[0]), "interfaces_cell_n_interfaces": int(len(faces)),
        "interfaces_cell_min_area_over_median": float(tess.iface_area[faces].min() / np.median(tess.iface_area)),
        "vertex_contact_over_rule": float(omega_vertex[cv] / omega_rule),
        "vertex_contact_cell": cv, "vertex_contact_cell_mass_over_min": float(mass[cv] / mass.min()),
        "vertex_contact_factor_max": float(factor.max()), "vertex_contact_factor_median": float(np.median(factor)),
        "pair_vertex_contact_over_rule": omega_pair / omega_rule,
        "face_on_plane_over_rule": omega_face / omega_rule, "face_on_plane_cell": cf,
        "face_on_plane_cell_mass_over_min": float(mass[cf] / mass.min()),
        "stability_spp_pair_vertex_contact": math.pi * omega_pair / omega_rule,
        "stability_spp_face_on_plane": math.pi * omega_face / omega_rule,
        "stability_spp_interfaces": float(math.pi * math.sqrt(lam[0]) / omega_rule),
        "stability_spp_vertex_contact": float(math.pi * omega_vertex[cv] / omega_rule),
    }


def impact_runs(run: bool, scale: str | None, previous: Path | None = None) -> pd.DataFrame:
    """Each finished impact run of the sweep (at `scale`: None, the 1728 cells; small, 300):
    steps_per_period, seed and the outcome measures. Runs listed in `previous` (this table as an
    earlier invocation wrote it) and no longer on disk are kept: the study's runs take hours and
    their folders need not outlive the table."""
    extra = ["--scale", scale] if scale else []
    if run:
        subprocess.run([sys.executable, "-m", "driver.cli", "sweep", str(SWEEP_FILE), "--workers", "1", "--np", "1",
                        *extra], cwd=ROOT, check=False)
    directory = SWEEP_DIR.with_name(SWEEP_DIR.name + (f"_{scale}" if scale else ""))
    rows = []
    for summary in sorted(directory.glob("*/results/summary.json")):
        cfg = json.loads((summary.parent.parent / "system.json").read_text())
        s = json.loads(summary.read_text())
        name = summary.parent.parent.name  # steps_per_period<N>_seed<S>
        spp, seed = name.removeprefix("steps_per_period").split("_seed")
        prov = summary.parent.parent / "provenance.json"
        wall = json.loads(prov.read_text()).get("wall_seconds") if prov.exists() else None
        rows.append({"steps_per_period": float(spp), "seed": int(seed), "dt": cfg["timestep"],
                     "wall_s": wall, "end_step": s.get("end_step"), "settled": s.get("settled"),
                     # the energy balance's closure, W_k^- - W_k^+ - W_f - W_c measured - E_el(end),
                     # over W_k^- (analysis/impact_measures.py): the integration error of the whole run
                     "residual": s.get("balance_residual", math.nan),
                     **{k: s.get(k) for k in MEASURES}})
    runs = pd.DataFrame(rows)
    if previous is not None and previous.exists():
        old = pd.read_csv(previous)
        if not runs.empty:
            here = set(zip(runs.steps_per_period, runs.seed))
            old = old[[(p, s) not in here for p, s in zip(old.steps_per_period, old.seed)]]
        runs = pd.concat([old, runs], ignore_index=True) if not old.empty else runs
    return runs.sort_values(["steps_per_period", "seed"], ascending=[False, True]).reset_index(drop=True) \
        if not runs.empty else runs


def outcome_table(runs: pd.DataFrame) -> pd.DataFrame:
    """mean, std and n per steps_per_period; `within` = every measure within the reference's
    (100 steps per period) seed-to-seed std of its mean."""
    if runs.empty:
        return pd.DataFrame()
    g = runs.groupby("steps_per_period")[MEASURES]
    table = g.mean().add_suffix("_mean").join(g.std().add_suffix("_std")).join(g.size().rename("n"))
    table["abs_residual_max"] = runs.assign(r=runs.residual.abs()).groupby("steps_per_period").r.max()
    table["wall_s_mean"] = runs.groupby("steps_per_period").wall_s.mean()
    table["energy_ok"] = table.abs_residual_max < DRIFT_LIMIT  # the whole run's balance within 1e-4
    if 100.0 in table.index:
        ref = table.loc[100.0]
        ok = np.ones(len(table), bool)
        for k in MEASURES:
            dev = (table[f"{k}_mean"] - ref[f"{k}_mean"]).abs()
            table[f"{k}_dev_over_refstd"] = dev / ref[f"{k}_std"]
            ok &= (dev <= ref[f"{k}_std"]).to_numpy()
        # a spread needs two reference seeds at least
        table["within_ref_spread"] = pd.Series(ok, index=table.index, dtype=object) if ref.n > 1 else None
        # paired by seed (same tessellation and orientation): the mean change from the reference,
        # over the reference's std, the largest over the measures
        ref_runs = runs[runs.steps_per_period == 100.0].set_index("seed")[MEASURES]
        paired = {}
        for spp, grp in runs.groupby("steps_per_period"):
            d = (grp.set_index("seed")[MEASURES] - ref_runs).dropna()
            paired[spp] = max(abs(d[k].mean()) / ref[f"{k}_std"] for k in MEASURES) if len(d) else math.nan
        table["paired_dev_over_refstd"] = pd.Series(paired)
        # the same as a fraction of the reference value (defined with one seed too)
        rel = {}
        for spp, grp in runs.groupby("steps_per_period"):
            d = ((grp.set_index("seed")[MEASURES] - ref_runs) / ref_runs).dropna()
            rel[spp] = max(abs(d[k].mean()) for k in MEASURES) if len(d) else math.nan
        table["paired_rel_change"] = pd.Series(rel)
    return table.sort_index(ascending=False)


def plot(drift: pd.DataFrame, stab: pd.DataFrame, outcomes: dict[str, pd.DataFrame], png: Path) -> None:
    """Row 1: drift and fluctuation against steps_per_period, and the stability check; then one
    row per impact sweep scale: the four measures, mean +- std, the reference's band shaded."""
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    outcomes = {k: v for k, v in outcomes.items() if not v.empty}
    n_rows = 1 + len(outcomes)
    fig, axes = plt.subplots(n_rows, len(MEASURES), figsize=(4 * len(MEASURES), 3.3 * n_rows), squeeze=False)
    ax = axes[0, 0]
    for case, d in drift.groupby("case"):
        ax.loglog(d.steps_per_period, d.drift, "o-", label=f"{case}: drift")
        ax.loglog(d.steps_per_period, d.fluctuation, "s--", alpha=0.6, label=f"{case}: fluctuation")
    ax.axhline(DRIFT_LIMIT, color="k", lw=0.8, ls=":")
    ax.set_xlabel("steps_per_period")
    ax.set_ylabel("relative energy change")
    ax.legend(fontsize=7)
    ax.set_title(f"energy, {int(drift.cells.iloc[0])} cells, no damping/friction/breaks", fontsize=9)
    ax = axes[0, 1]
    if not stab.empty:
        for (case, shape), d in stab.groupby(["case", "shape"]):
            ax.semilogy(d.steps_per_period, d.max_dE_over_E_start, "o-", label=f"{case} ({shape[:5]})")
        ax.axhline(1.0, color="k", lw=0.8, ls=":")
        ax.set_xlabel("steps_per_period")
        ax.set_ylabel("max |E - E0| / E_scale")
        ax.set_title("stability (300 cells, 50 periods)", fontsize=9)
        ax.legend(fontsize=7)
    ax = axes[0, 2]
    for name, outcome in outcomes.items():
        ax.loglog(outcome.index, outcome.abs_residual_max, "o-", label=name)
    ax.axhline(DRIFT_LIMIT, color="k", lw=0.8, ls=":")
    ax.set_xlabel("steps_per_period")
    ax.set_ylabel("max |balance residual| / W_k-")
    ticks = sorted({v for outcome in outcomes.values() for v in outcome.index})
    ax.set_xticks(ticks, [f"{v:g}" for v in ticks], fontsize=7)
    ax.minorticks_off()
    ax.set_title("impact energy balance (damping, friction, breaks on)", fontsize=9)
    if outcomes:
        ax.legend(fontsize=7)
    for ax in axes[0, 3:]:
        ax.axis("off")
    for row, (name, outcome) in enumerate(outcomes.items(), start=1):
        for ax, k in zip(axes[row], MEASURES):
            ax.errorbar(outcome.index, outcome[f"{k}_mean"], yerr=outcome[f"{k}_std"], fmt="o-", capsize=3)
            if 100.0 in outcome.index:
                r = outcome.loc[100.0]
                ax.axhspan(r[f"{k}_mean"] - r[f"{k}_std"], r[f"{k}_mean"] + r[f"{k}_std"], color="C1", alpha=0.2)
            ax.set_xscale("log")
            ax.set_xticks(list(outcome.index), [f"{v:g}" for v in outcome.index])
            ax.minorticks_off()
            ax.set_xlabel("steps_per_period")
            ax.set_title(f"{k} ({name})", fontsize=9)
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)


def markdown(drift: pd.DataFrame, outcomes: dict[str, pd.DataFrame]) -> str:
    """The tables of docs/models/bcm-timestep.md: drift per case, and per scale the measures as mean +- std."""
    lines = ["| steps_per_period | " + " | ".join(f"{c}: drift | {c}: fluctuation" for c in drift.case.unique()) + " |",
             "|---|" + "---|---|" * drift.case.nunique()]
    for spp, d in drift.groupby("steps_per_period"):
        cells = []
        for c in drift.case.unique():
            r = d[d.case == c]
            cells += [f"{r.drift.iloc[0]:.2g}", f"{r.fluctuation.iloc[0]:.2g}"] if len(r) else ["—", "—"]
        lines.append(f"| {spp:g} | " + " | ".join(cells) + " |")
    for name, t in outcomes.items():
        if t.empty:
            continue
        lines += ["", f"{name}:", "",
                  "| steps_per_period | runs | D_w | e_k² | η | fragments | max \\|residual\\| / W_k⁻ "
                  "| within the reference's spread | paired change / reference std | paired relative change |",
                  "|---|---|---|---|---|---|---|---|---|---|"]
        for spp, r in t.iterrows():
            ms = " | ".join(f"{r[f'{k}_mean']:.3g}" + (f" ± {r[f'{k}_std']:.2g}" if r.n > 1 else "") for k in MEASURES)
            ok = {True: "yes", False: "no"}.get(r.get("within_ref_spread"), "—")
            paired = r.get("paired_dev_over_refstd", math.nan)
            rel = r.get("paired_rel_change", math.nan)
            pc = "—" if pd.isna(paired) else f"{paired:.2f}"
            rc = "—" if pd.isna(rel) else f"{rel:.1%}"
            lines.append(f"| {spp:g} | {int(r.n)} | {ms} | {r.abs_residual_max:.1e} | {ok} | {pc} | {rc} |")
    return "\n".join(lines)


SCALES = {"full": (None, "1728 cells, to the settled outcome"), "small": ("small", "300 cells, to the settled outcome"),
          "t15us": ("t15us", "1728 cells, stopped at 15 us"),
          "fast100": ("fast100", "100 cells at 10 m/s, to 1e-5 s (the balance; no reference)"),
          "fast300": ("fast300", "300 cells at 10 m/s, to 1e-5 s (the balance; no reference)")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cells", type=int, default=1728)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--spp", type=float, nargs="+", default=SPP)
    ap.add_argument("--periods", type=float, default=100.0, help="run length in shortest contact periods")
    ap.add_argument("--v-rms", type=float, default=0.05, help="impulse: rms cell velocity, m/s")
    ap.add_argument("--press", type=float, default=1e5, help="body force pressing on the plane, m/s^2")
    ap.add_argument("--cases", nargs="+", default=["vibrating", "pressed"])
    ap.add_argument("--stability", type=float, nargs="*", default=[],
                    help="steps_per_period values for the blow-up check")
    ap.add_argument("--stability-cells", type=int, default=300)
    ap.add_argument("--modes", action="store_true", help="print which elements set the step (linear analysis)")
    ap.add_argument("--no-impact", action="store_true", help="skip the impact sweep (no table of outcomes)")
    ap.add_argument("--scales", nargs="*", default=["small", "t15us"], choices=list(SCALES),
                    help="impact sweeps: full (1728 cells to the settled outcome), small (300 cells), t15us "
                         "(1728 cells, stopped at 15 us)")
    ap.add_argument("--tabulate-only", action="store_true",
                    help="run nothing: tabulate the drift series and impact runs already finished")
    ap.add_argument("--out", type=Path, default=ROOT / "bench", help="folder of the tables and the figure")
    a = ap.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    base = ROOT / "runs" / "timestep_study" / "drift"
    base.mkdir(parents=True, exist_ok=True)
    pd.set_option("display.width", 200)
    pd.set_option("display.max_columns", 30)

    if a.stability and not a.tabulate_only:
        stab = stability_study(a.stability_cells, a.seed, a.stability, 50.0, a.v_rms, a.press, base)
        print("\nstability (50 shortest periods; unstable: energy change > the starting energy scale):")
        print(stab.to_string(index=False))
        stab.to_csv(a.out / "timestep_study_stability.csv", index=False)

    if a.modes and not a.tabulate_only:
        modes = fastest_modes(a.cells, a.seed)
        print("\nfastest modes (frequencies over the rule's sqrt(k_max / (m_min / 2))):")
        for k, v in modes.items():
            print(f"  {k}: {v}")
        (a.out / "timestep_study_modes.json").write_text(json.dumps(modes, indent=1))

    drift = drift_study(a.cells, a.seed, a.spp, a.periods, a.v_rms, a.press, a.cases, base, run=not a.tabulate_only)
    if drift.empty and (a.out / "timestep_study.csv").exists():  # series no longer on disk: the table stays
        drift = pd.read_csv(a.out / "timestep_study.csv")
    print(f"\nenergy drift ({a.cells} cells, seed {a.seed}, {a.periods:g} shortest periods, v_rms {a.v_rms:g} m/s, "
          f"press {a.press:g} m/s^2; baseline: drift < {DRIFT_LIMIT:g}):")
    print(drift.to_string(index=False, float_format=lambda x: f"{x:.3g}"))
    drift.to_csv(a.out / "timestep_study.csv", index=False)

    stab = pd.read_csv(a.out / "timestep_study_stability.csv") if (a.out / "timestep_study_stability.csv").exists() \
        else pd.DataFrame()
    outcomes = {}
    for name in [] if a.no_impact else a.scales:
        scale, what = SCALES[name]
        table = a.out / f"timestep_study_impact_runs_{name}.csv"
        runs = impact_runs(run=not a.tabulate_only, scale=scale, previous=table)
        runs.to_csv(table, index=False)
        outcomes[name] = outcome = outcome_table(runs)
        print(f"\nimpact outcome, {what} (bench/timestep_study_sweep.yaml{' --scale ' + scale if scale else ''}; "
              f"mean and std over seeds; reference 100):")
        print(outcome.to_string(float_format=lambda x: f"{x:.4g}"))
        outcome.to_csv(a.out / f"timestep_study_impact_{name}.csv")
    plot(drift, stab, outcomes, a.out / "timestep_study.png")
    print("\n" + markdown(drift, outcomes))
    print(f"\nwrote {a.out / 'timestep_study.csv'}, {a.out / 'timestep_study.png'}")


if __name__ == "__main__":
    main()
