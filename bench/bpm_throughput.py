"""BPM throughput: the project's styles against native LAMMPS styles, same network, same run.

On one 3D Delaunay network of about 30,000 particles (SPEC 2.1) this prints:
  - atom-steps per second of the full model (breakable/cr bonds and angles, cr/repulsion pair)
    on 1 and 2 MPI ranks, and on 1 rank with the native pair styles it replaces
    (hybrid/overlay lj/cut + dpd/tstat at T = 0), with the time by section of both;
  - nanoseconds per bond per step of `bond_style breakable/cr` and of native `bpm/spring`,
    and per angle per step of `angle_style breakable/cr` and of native `harmonic`, each from
    LAMMPS's own timing breakdown (the "Bond" row, which holds bonds + angles; each of these
    runs has only one of them).
Targets (issue 2): bond <= 1.3x bpm/spring, angle <= 1.2x harmonic, full model >= 0.8e6
atom-steps/s on 1 core, 2 ranks >= 1.6x 1 rank.

    python bench/bpm_throughput.py [--L 29] [--steps 1000] [--seed 1]
"""

from __future__ import annotations

import argparse
import re
import subprocess
import tempfile
from dataclasses import replace
from pathlib import Path

from driver.bpm.datafile import write_data
from driver.bpm.network import MAX_BOND_LENGTH_3D, delaunay_network
from driver.bpm.packing import cached_packing
from driver.engine import Lammps, venv_bin
from driver.cache import cache_base
from driver.mpi_launch import launch_env, launcher
from driver.plugin_build import plugin_library

COMMON = """
units lj
dimension 3
boundary p p p
atom_style angle
newton on off
special_bonds lj 0 1 1 coul 1 1 1
read_data {data}
comm_modify vel yes cutoff 3.3
neighbor 0.3 bin
neigh_modify delay 0 every 1 check yes
timestep 0.005
velocity all create 0.002 {seed} loop geom
fix integrate all nve
fix shear all deform 1 x trate 5e-5 y trate 5e-5 z trate -1e-4 remap x
thermo 500
"""

PAIR_FULL = """
pair_style cr/repulsion
pair_coeff 1 1 1.0 1.0 50.0
"""

PAIR_NATIVE = """
pair_style hybrid/overlay lj/cut 1.0 dpd/tstat 0.0 0.0 1.0 {seed}
pair_coeff 1 1 lj/cut 1.0 {sigma} 1.0
pair_coeff 1 1 dpd/tstat 50.0 1.0
pair_modify pair lj/cut shift yes
"""

BONDED = ("bond_style breakable/cr\nbond_coeff 1 1.05 50\n"
          "angle_style breakable/cr\nangle_coeff 1 4.0 10.0 1.05\n")

VARIANTS = {
    "full": PAIR_FULL + BONDED,
    "full_native_pair": PAIR_NATIVE + BONDED,
    "bond_cr": "pair_style zero 1.0\npair_coeff * *\nbond_style breakable/cr\nbond_coeff 1 1.05 50\n",
    "bond_bpm_spring": "pair_style zero 1.0\npair_coeff * *\nbond_style bpm/spring\nbond_coeff 1 1.0 0.2 0.1\n",
    "angle_cr": "pair_style zero 1.0\npair_coeff * *\nbond_style zero\nbond_coeff *\n"
                "angle_style breakable/cr\nangle_coeff 1 4.0 10.0 1.05\n",
    "angle_harmonic": "pair_style zero 1.0\npair_coeff * *\nbond_style zero\nbond_coeff *\n"
                      "angle_style harmonic\nangle_coeff 1 0.001 60.0\n",
}


def script(data: Path, variant: str, plugin: Path, steps: int, seed: int) -> str:
    body = VARIANTS[variant].format(seed=seed, sigma=2 ** (-1 / 6))
    if "breakable/cr" in body:  # r0 and theta0 from the builder's file next to the data file
        body += f"fix references all breakable/references {data.with_suffix('.refs')}\n"
    common = COMMON.format(data=data, seed=seed)
    # read_data must precede pair/bond styles that need box; settings that LAMMPS wants
    # before read_data (none here) would go first.
    return f"plugin load {plugin}\n{common}\n{body}\nrun 100\nrun {steps}\n"


def breakdown(log: str) -> dict[str, float]:
    """Loop time, atoms, steps and the 'Bond' avg time of the last run in a LAMMPS log."""
    loops = re.findall(r"Loop time of ([\d.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms", log)
    sections = dict(re.findall(r"^(\w+)\s*\|\s*[\d.eE+-]+\s*\|\s*([\d.eE+-]+)", log.split("Loop time")[-1],
                               re.MULTILINE))
    t, procs, steps, atoms = loops[-1]
    return {"loop": float(t), "procs": int(procs), "steps": int(steps), "atoms": int(atoms),
            "bond_time": float(sections.get("Bond", "nan")),
            "sections": {k: float(v) for k, v in sections.items()}}


def run_variant(workdir: Path, data: Path, variant: str, plugin: Path, steps: int, seed: int,
                ranks: int = 1) -> dict[str, float]:
    inp = workdir / f"in.{variant}"
    inp.write_text(script(data, variant, plugin, steps, seed))
    log = workdir / f"log.{variant}.{ranks}"
    if ranks == 1:
        with Lammps(log=log) as lmp:
            lmp.file(inp)
    else:
        subprocess.run([*launcher(ranks), venv_bin("lmp"), "-in", str(inp), "-log", str(log),
                        "-screen", "none", "-nocite"], check=True, cwd=workdir, env=launch_env())
    return breakdown(log.read_text())


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--L", type=float, default=29.0)
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    plugin = plugin_library()
    packing = cached_packing(cache_base() / "packings", 3, args.L, args.seed)
    net = delaunay_network(packing, MAX_BOND_LENGTH_3D)
    n = len(packing.radii)
    nb, na = len(net.bonds), len(net.angles)
    print(f"network: {n:,} particles, {nb:,} bonds ({2 * nb / n:.2f} per particle, coordination), "
          f"{na:,} angles ({na / n:.2f} per particle); {args.steps} timed steps per run")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        full_data, bond_data = work / "full.data", work / "bonds.data"
        write_data(full_data, packing, net)
        write_data(bond_data, packing, replace(net, angles=net.angles[:0], theta0=net.theta0[:0]))
        res = {}
        for variant, data in [("full", full_data), ("full_native_pair", full_data), ("bond_cr", bond_data),
                              ("bond_bpm_spring", bond_data), ("angle_cr", full_data),
                              ("angle_harmonic", full_data)]:
            res[variant] = run_variant(work, data, variant, plugin, args.steps, args.seed)
        res["full_2"] = run_variant(work, full_data, "full", plugin, args.steps, args.seed, ranks=2)

    def rate(r):
        return r["atoms"] * r["steps"] / r["loop"]

    def per_item(r, count):
        return 1e9 * r["bond_time"] / (r["steps"] * count)

    def sections(r):
        return ", ".join(f"{k} {v / r['loop']:.0%}" for k, v in r["sections"].items())

    r1, r2, r_nat = rate(res["full"]), rate(res["full_2"]), rate(res["full_native_pair"])
    b_cr, b_nat = per_item(res["bond_cr"], nb), per_item(res["bond_bpm_spring"], nb)
    a_cr, a_nat = per_item(res["angle_cr"], na), per_item(res["angle_harmonic"], na)
    print(f"full model, 1 rank : {r1 / 1e6:6.3f} Matom-steps/s   (target >= 0.8)")
    print(f"full model, 2 ranks: {r2 / 1e6:6.3f} Matom-steps/s   speed-up {r2 / r1:.2f}x (target >= 1.6x)")
    print(f"full model, 1 rank, time by section: {sections(res['full'])}")
    print(f"full model with native pair (hybrid/overlay lj/cut + dpd/tstat), 1 rank: {r_nat / 1e6:6.3f} "
          f"Matom-steps/s; time by section: {sections(res['full_native_pair'])}")
    print(f"bond  breakable/cr : {b_cr:6.1f} ns/bond/step   native bpm/spring {b_nat:6.1f}   "
          f"ratio {b_cr / b_nat:.2f} (target <= 1.3)")
    print(f"angle breakable/cr : {a_cr:6.1f} ns/angle/step  native harmonic   {a_nat:6.1f}   "
          f"ratio {a_cr / a_nat:.2f} (target <= 1.2)")


if __name__ == "__main__":
    main()
