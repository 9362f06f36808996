"""The runs of a comparison: one base config per model from its calibrated parameters, expanded
over the grid by the sweep machinery (driver/sweep.py expand_groups) into
`<out>/runs/<model>/G_c<G_c>/velocity<v>_seed<s>` (`omega<w>_seed<s>` on an omega grid;
`diameter<d>[_n_cells<n>]_seed<s>` for the crush, `seed<s>` for a bed), and
run together (finished runs kept, a re-run resumes, a failed run recorded and the others
carried on: driver/calibration/curves.py run_pending, in-process or on a local Dask cluster)."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

from driver.calibration.material import MaterialFile
from driver.compare.params import bcm_interface_gc, lambda_c_for
from driver.compare.schema import CompareFile
from driver.config import ConfigError, RunConfig, parse_config
from driver.sweep import Group, _assign, _seed_group, expand_groups, format_value, value_list

MODELS = ("bcm", "bpm")


def n_cells_of(mat: MaterialFile) -> int:
    """The BCM particle's cell count (n_cells, or the parent's volume over cell_size^3)."""
    res = mat.bcm
    if res.n_cells is not None:
        return res.n_cells
    from driver.bcm.particle import parent_shape  # noqa: PLC0415

    return max(2, int(round(parent_shape(res.shape, res.diameter, res.diameter_kind).volume / res.cell_size ** 3)))


def n_cells_at(mat: MaterialFile, diameter: float) -> int:
    """The BCM cell count of a particle of size `diameter` at the material's element size: the
    material's count scaled by (d / d_material)^3 (the crush's size grid keeps h, SPEC 4.1)."""
    return max(2, int(round(n_cells_of(mat) * (diameter / mat.bcm.diameter) ** 3)))


def size_group(model: str, mat: MaterialFile, diameters: list[float]) -> Group:
    """The crush's particle sizes as a sweep group of `model`'s keys: the BCM's diameter with
    its cell count (n_cells_at), the BPM's diameter at its fixed particle size a (the units)."""
    if model == "bcm":
        return ("model.diameter", "model.n_cells"), [(float(d), n_cells_at(mat, d)) for d in diameters]
    return ("model.particle.diameter",), [(float(d),) for d in diameters]


def base_configs(cmp: CompareFile, mat: MaterialFile, bcm: dict[str, Any], bpm: dict[str, Any],
                 G_c: float, G_ref: float) -> dict[str, dict[str, Any]]:
    """The run config of each model at the material's G_c (the velocity and seed set by the grid)."""
    shape = {"shape": mat.bcm.shape, "diameter": mat.bcm.diameter, "diameter_kind": mat.bcm.diameter_kind}
    pb, pp = bcm["parameters"], bpm["parameters"]
    scenario = {"kind": cmp.test, **copy.deepcopy(cmp.scenario)}
    configs = {
        "bcm": {"name": f"{cmp.name}_bcm", "seed": 1,
                "model": {"kind": "bcm", **shape, "n_cells": n_cells_of(mat), "density": mat.material.density,
                          "interface": {"kn": pb["kn"], "kt": pb["kt"], "G_c": bcm_interface_gc(bcm, G_c)}},
                "scenario": copy.deepcopy(scenario)},
        "bpm": {"name": f"{cmp.name}_bpm", "seed": 1,
                "model": {"kind": "bpm", "dimension": 3, "packing": mat.bpm.packing, "k_A": pp["k_A"],
                          "theta_c_deg": pp["theta_c_deg"],
                          "lambda_c": lambda_c_for(bpm, G_c),
                          "particle": {**shape, "G_c": G_c,
                                       "units": {k: bpm["units"][k] for k in ("length_a_m", "mass_m_kg",
                                                                               "energy_u_J")}}},
                "scenario": copy.deepcopy(scenario)},
    }
    for model, extra in (("bcm", cmp.base.bcm), ("bpm", cmp.base.bpm)):
        for key, value in extra.items():
            _assign(configs[model], key, value)
    return configs


def g_values(cmp: CompareFile, mat: MaterialFile) -> list[float]:
    return list(cmp.grid.G_c) if cmp.grid.G_c else [mat.material.toughness(3)[0]]


def grid_runs(cmp: CompareFile, mat: MaterialFile, bcm: dict[str, Any], bpm: dict[str, Any], out: Path,
              source: str) -> list[tuple[dict[str, Any], RunConfig]]:
    """Every run of both models: (its grid values {model, G_c, velocity, seed} and, on an omega
    grid, omega_target; {model, G_c, diameter, seed} for the crush; its config), each validated
    before anything runs (ConfigError naming the run). A velocity grid gives both models the
    same v_0; an omega grid gives each particle the v_0 of the target omega with the material's
    G_c (driver/compare/omega.py); a crush grid gives both the same sizes (size_group)."""
    G_ref = mat.material.toughness(3)[0]
    seeds = _seed_group(cmp.grid.seeds, source)
    particles: dict[tuple[str, int], tuple[float, float]] = {}  # (model, seed) -> (A_0, M), whatever the G_c
    runs = []
    for g in g_values(cmp, mat):
        for model, data in base_configs(cmp, mat, bcm, bpm, g, G_ref).items():
            where = Path(out) / "runs" / model / f"G_c{format_value(g)}"
            label = f"{source} ({model}, G_c = {g:g})"
            if cmp.test == "compress":  # the same bed in both models: grains, sizes, box; seeds
                data["model"]["assembly"] = copy.deepcopy(cmp.assembly)
                for values, cfg in expand_groups(data, [seeds], where, label):
                    runs.append(({"model": model, "G_c": g, "n_grains": cfg.model.assembly.n_grains,
                                  "seed": values["seed"]}, cfg))
            elif cmp.test == "crush":
                sizes = size_group(model, mat, list(cmp.grid.diameter or [mat.bcm.diameter]))
                for values, cfg in expand_groups(data, [sizes, seeds], where, label):
                    runs.append(({"model": model, "G_c": g, "diameter": values[sizes[0][0]], "seed": values["seed"]},
                                 cfg))
            elif cmp.grid.omega is None:
                velocities = value_list(cmp.grid.velocity, f"{source}: grid.velocity")
                groups: list[Group] = [(("scenario.velocity",), [(float(v),) for v in velocities]), seeds]
                for values, cfg in expand_groups(data, groups, where, label):
                    runs.append(({"model": model, "G_c": g, "velocity": values["scenario.velocity"],
                                  "seed": values["seed"]}, cfg))
            else:
                runs += _omega_runs(data, value_list(cmp.grid.omega, f"{source}: grid.omega"),
                                    [s for (s,) in seeds[1]], g, model, where, label, particles)
    return runs


def _omega_runs(data: dict[str, Any], omegas: list[Any], seeds: list[int], G_c: float, model: str, where: Path,
                source: str, particles: dict[tuple[str, int], tuple[float, float]]
                ) -> list[tuple[dict[str, Any], RunConfig]]:
    """The runs of one model at one G_c on an omega grid, in `where`/omega<w>_seed<s>: v_0 from
    the target omega and the A_0 and mass of the seed's particle, built once per (model, seed)
    into `particles` (its geometry does not depend on G_c)."""
    from driver.compare.omega import particle_area_mass, velocity_for_omega  # noqa: PLC0415

    if any(not isinstance(w, (int, float)) or isinstance(w, bool) or not w > 0 for w in omegas):
        raise ConfigError(f"{source}: grid.omega: positive damage potentials (got {omegas!r})")
    names = [format_value(float(w)) for w in omegas]
    if len(set(names)) != len(names):
        raise ConfigError(f"{source}: grid.omega: repeated values {omegas!r}")
    runs = []
    for seed in seeds:
        for w, name in zip(omegas, names):
            run = copy.deepcopy(data)
            run["seed"] = seed
            run["name"] = f"{data['name']}_omega{name}_seed{seed}"
            run.setdefault("output", {})["dir"] = str(where / f"omega{name}_seed{seed}")
            what = f"{source}, omega = {w:g}, seed {seed}"
            if (model, seed) not in particles:  # the velocity does not change the particle either
                particles[model, seed] = particle_area_mass(
                    parse_config({**run, "scenario": {**run["scenario"], "velocity": 1.0}}, what))
            A0, mass = particles[model, seed]
            v = velocity_for_omega(float(w), A0, mass, G_c)
            run["scenario"]["velocity"] = float(f"{v:.12g}")
            runs.append(({"model": model, "G_c": G_c, "omega_target": float(w), "velocity": run["scenario"]["velocity"],
                          "seed": seed}, parse_config(run, what)))
    return runs


def same(a: Any, b: Any, rel: float = 1e-6) -> bool:
    """Equal config values, floats to `rel` (a calibration read back from the cache's JSON
    differs from the freshly measured one in the last digits)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k], rel) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(same(x, y, rel) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, (int, float)) or isinstance(b, float) and isinstance(a, (int, float)):
        return abs(a - b) <= rel * max(abs(a), abs(b))
    return a == b


def check_kept(runs: list[tuple[dict[str, Any], RunConfig]]) -> None:
    """A run directory already there (finished or interrupted) must hold the run planned now:
    the same model and scenario sections (a changed calibration or compare file would otherwise
    mix two comparisons in one table); ConfigError naming the run and the way out."""
    from driver.config import load_config  # noqa: PLC0415

    for _, cfg in runs:
        resolved = cfg.run_dir() / "config.resolved.yaml"
        if not resolved.exists():
            continue
        old = load_config(resolved)
        if not (same(old.model.model_dump(), cfg.model.model_dump())
                and same(old.scenario.model_dump(), cfg.scenario.model_dump())):
            raise ConfigError(f"{cfg.run_dir()}: made with other model or scenario parameters than this comparison "
                              "plans (a changed calibration, resolution or compare file); give a new --out")


def run_grid(runs: list[tuple[dict[str, Any], RunConfig]], workers: int, console) -> list[str]:
    """Run the unfinished runs (both models, the longest first on Dask); the failed run directories."""
    from driver.calibration.curves import run_pending  # noqa: PLC0415
    from driver.rundir import SWEEP_MARKER, claim_dir  # noqa: PLC0415
    from driver.sweep import pending  # noqa: PLC0415

    for folder in sorted({cfg.run_dir().parent for _, cfg in runs}):
        claim_dir(folder, SWEEP_MARKER, "sweep directory")
    check_kept(runs)
    todo = pending(runs)
    if not todo:
        return []
    return run_pending(todo, workers, console)
