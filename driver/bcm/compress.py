"""A BCM bed in confined compression (issue 25): the grains of model.assembly (driver/bcm/bed.py)
in a rigid box of six walls (fix bcm/wall: bottom, four sides, the top platen), run as a chain
of phases that the driver's checks advance (every scenario.check_every steps):

0 fill: breaking switched off (the interfaces' G_c set to BREAKING_OFF), the cell contacts'
  friction fill_friction (frictionless by default: a dense start), the top platen
  servo-controlled by the bottom wall's stress (velocity -fill_speed (1 - sigma_bottom /
  start_stress), never up: at full speed until the stress goes through the bed, then slowing;
  half as fast at each return to the fill, bed_phases.FILL_HALVINGS times at most),
  every cell damped by a drag -m v / t_d (fill_damping_time, FILL_DAMPING_PERIODS shortest
  contact periods: the grains' inner modes die out with it), until the bottom and the platen
  have carried 1 - FILL_TOLERANCE of start_stress on the mean over a check window at
  FILL_CHECKS checks in a row (driver/bed_phases.py);
1 rest: a stronger drag (rest_damping_time, REST_DAMPING_PERIODS shortest contact periods); the
  platen still, or backing up while its stress is above REST_ABOVE x start_stress, which the
  rest's end waits for (at rest_speed, fill_speed unless set, times the excess in
  units of start_stress, at most SERVO_BACK of it: a rest that pushes the bed down agitates it,
  one that backs up from start_stress on overshoots); once the kinetic energy is below rest_ke of
  the elastic energy the bed holds (interfaces, contacts, walls: the bed is in equilibrium) or
  after rest_time, and the platen carries at most REST_ABOVE x start_stress (window means): if
  the platen carries at least REST_HOLDS of start_stress the cells are stopped, the drag switched
  off, breaking switched on (the configured G_c), the contacts' friction set to the model's and
  the start state dumped; else the bed was not jammed and is filled again (phase 0);
2 load: the platen down at platen_speed until target_stress; the cells and interfaces are
  dumped as the stress first passes each of grading_at x target_stress;
3 hold (hold_time > 0), 4 unload (up at platen_speed, to start_stress), 5 done: the run ends.

The phase, the times and the dumps made are checkpoint variables, so a resumed run carries on
in its phase with the G_c of that phase (the bond coefficients are in the checkpoint).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import driver
from driver import bed_phases
from driver.bcm import styles
from driver.bcm.bed import place_bed
from driver.bcm.impact import SYSTEM_FRESH, SYSTEM_RESUME, _dump_commands, periodic_dumps
from driver.runner import ProgressSpec
from driver.schedule import settle, settle_windows, write_session
from driver.templates import render
from runfiles.atomic import atomic_write_json
from runfiles.records import BED_WALLS, COMPRESS_RECORD

if TYPE_CHECKING:  # for readers and checkers only
    from driver.config import RunConfig
    from driver.rundir import RunDir

#: G_c of the interfaces while the bed is filled: breaking off (no interface stores this much)
BREAKING_OFF = 1.0e30
#: while the bed is filled and rests every cell feels a drag -m v / t_d, t_d = FILL_DAMPING_PERIODS
#: shortest contact periods: the grains' inner modes die out within some ten of their periods,
#: and a grain set moving stops within a few contacts' time (the BPM bed's drag is 20 tau, some
#: 30 of its contact periods: driver/bpm/compress.py)
FILL_DAMPING_PERIODS = 100.0
#: the commands (quoted, for an `if`) that stop every cell: velocities and angular momenta zeroed
STOP_CELL_COMMANDS = ["velocity all set 0.0 0.0 0.0", "set group all d2_bcm_angmom[1] 0.0",
                      "set group all d2_bcm_angmom[2] 0.0", "set group all d2_bcm_angmom[3] 0.0"]
#: the six walls (their fix ids: the record's BED_WALLS): face, and the axis whose far side of
#: the box the wall is on (None: at 0)
WALLS = tuple(zip(BED_WALLS, ("zlo", "zhi", "xlo", "xhi", "ylo", "yhi"), (None, 2, None, 0, None, 1)))
#: fix bcm/wall's vector entries summed over the walls into variables (the phase checks read W_p)
WALL_SUMS = {"Wp": 11, "E": 4}


def grading_dump_name(k: int) -> str:
    """Dump name of the k-th grading stress (0-based): dumps/cells.grade<k+1>.lammpstrj."""
    return f"grade{k + 1}"


def wall_lines(model, r_m: float, box: list[float]) -> str:
    """The six fix bcm/wall lines: five fixed walls on the box's faces, the top platen at the
    box's height with its velocity the variable vp (the phase's)."""
    out = []
    for fix_id, face, far in WALLS:
        coord = 0.0 if far is None else float(box[far])
        out.append(styles.wall_setup(model, r_m, fix_id=fix_id, face=face, coord=coord,
                                     velocity="vp" if fix_id == "top" else None))
    return "\n".join(out)


def wall_sum_lines() -> str:
    """Equal-style variables summing the walls' work, stored energy and contacts (the record's
    W_p and side_contacts, the phase checks' elastic energy)."""
    lines = [f"variable        wall_{name} equal " + "+".join(f"f_{w[0]}[{k}]" for w in WALLS)
             for name, k in WALL_SUMS.items()]
    lines.append("variable        wall_side equal f_xlo[1]+f_xhi[1]+f_ylo[1]+f_yhi[1]")
    return "\n".join(lines)


def phase_checks(cfg: RunConfig) -> tuple[list[str], list[str]]:
    """(check lines, checkpoint variables) of the phase chain (driver/bed_phases.py, with the
    BCM's fill and rest ends and its switch to the loading)."""
    m, sc = cfg.model, cfg.scenario
    lines = [
        *bed_phases.SNAPSHOT,
        *bed_phases.filled(sc.start_stress),
        bed_phases.rested(sc.rest_ke, sc.rest_time, sc.start_stress),
        *bed_phases.transitions(sc.start_stress, sc.target_stress, sc.hold_time),
        # the fill and the rest are damped by the drag (lammps_inputs/bcm_compress.in), not quenched:
        # a bed whose cells are stopped at every check moves only by what one check's forces
        # accelerate it to, so it leaves the rest out of equilibrium and creeps away from the
        # platen once loaded (measured: 30 grains quenched from a 14 MPa fill, sigma_v 50 kPa at
        # the rest's end, 0-10 kPa for the loading's first 12,000 steps at 0.1 m/s). The rest has
        # the model's friction: a frictionless bed under a still platen creeps into its voids
        # (measured: the 8-grain test bed's stress fell from 5e4 to 4e2 Pa in a rest, and it went
        # fill, rest, fill nine times); the fill fill_friction again
        *bed_phases.rest_and_fill([styles.pair_coeff(m)], [styles.pair_coeff(m, mu=sc.fill_friction)]),
        # the loading starts from rest: rattlers (grains touching nothing keep their speed, there
        # is no gravity) and what is left of the fill's ringing are stopped; breaking on (the
        # configured G_c), the model's mu
        bed_phases.load_begins([styles.bond_coeff(m), styles.pair_coeff(m), *STOP_CELL_COMMANDS],
                               _dump_commands("load").splitlines()),
    ]
    grading, flags = bed_phases.grading_checks(sc.grading_at, sc.target_stress,
                                               lambda k: _dump_commands(grading_dump_name(k)).splitlines())
    return ([*lines, *grading, *bed_phases.phase_ends(sc.hold_time, sc.unload), bed_phases.CHECK_LOG, bed_phases.DONE],
            [*bed_phases.PHASE_VARIABLES, *flags])


def build_system(cfg: RunConfig, rd: RunDir) -> dict:
    """The bed (tessellation pool, dense start, files) and the box's facts."""
    facts = place_bed(cfg, rd)
    sc = cfg.scenario
    t_d = FILL_DAMPING_PERIODS * facts["shortest_period"]
    return {**facts, "platen_speed": sc.platen_speed, "fill_damping_time": t_d,
            "rest_damping_time": bed_phases.REST_DAMPING_PERIODS * facts["shortest_period"],
            "grading_at": list(sc.grading_at),
            "grading_dumps": [grading_dump_name(k) for k in range(len(sc.grading_at))]}


def render_inputs(cfg: RunConfig, plugin_path: Path, system: dict) -> tuple[str, str, dict, list[str]]:
    """(setup.lammps, resume.lammps, schedule, checkpoint variables) of a compression run."""
    m, sc = cfg.model, cfg.scenario
    dt = system["timestep"]
    window, chunk = settle_windows(sc.check_every, sc.check_every)
    max_windows = max(1, math.ceil(sc.max_time / (window * dt)))
    skin = 0.1 * system["mean_cell_size"]
    comm_cutoff = 2.0 * system["max_bound_radius"] * 1.05 + skin
    r_m = system["r_m"]
    box = system["box"]
    checks, names = phase_checks(cfg)
    phase_setup = "\n".join(f"variable        {n} equal 0" for n in names)
    common = dict(
        package_version=driver.__version__, config_name=cfg.name, plugin_path=plugin_path,
        comm_cutoff=f"{comm_cutoff:.9g}", walls=wall_lines(m, r_m, box), wall_sums=wall_sum_lines(),
        box_x=repr(box[0]), box_y=repr(box[1]), solid_volume=repr(system["solid_volume"]),
        fill_speed=repr(sc.fill_speed), platen_speed=repr(sc.platen_speed), start_stress=repr(sc.start_stress),
        servo_back=repr(bed_phases.SERVO_BACK), rest_above=repr(bed_phases.REST_ABOVE),
        fill_scale=bed_phases.FILL_SCALE,
        fill_damping_time=f"{system['fill_damping_time']:.9g}",
        rest_damping_time=f"{system['rest_damping_time']:.9g}",
        drag=bed_phases.drag(f"{system['fill_damping_time']:.9g}", f"{system['rest_damping_time']:.9g}"),
        check_means=bed_phases.check_means(window),
        rest_speed=repr(sc.fill_speed if sc.rest_speed is None else sc.rest_speed),
        skin=f"{skin:.9g}", steps_per_period=f"{sc.steps_per_period:g}",
        period=f"{system['shortest_period']:.6g}", timestep=f"{dt:.12g}",
        thermo_every=sc.thermo_every, periodic_dumps=periodic_dumps(sc.dump_every),
        record_print=COMPRESS_RECORD.print_text(), record_title=COMPRESS_RECORD.title(), window_steps=window)
    setup = render(
        "bcm_compress.in", role="Fresh start from system.data (setup.lammps; in.lammps runs it whole).",
        system=SYSTEM_FRESH,
        pair_setup=styles.pair_setup(m, r_m, mu=sc.fill_friction) + "  # the fill's friction until the rest",
        bond_setup=styles.bond_setup(m, G_c=BREAKING_OFF) + "  # breaking off while the bed is filled",
        phase_setup=phase_setup, record_target="file thermo.dat",
        start="run             0\n" + _dump_commands("start") + "\n" + bed_phases.CHECK_LOG_TITLE, **common)
    resume = render(
        "bcm_compress.in", role="Start from a checkpoint (resume.lammps: -var checkpoint FILE).",
        system=SYSTEM_RESUME, pair_setup="# pair style, coefficients and counters: from the checkpoint",
        bond_setup="# bond style (G_c of the checkpoint's phase), interface table, reference state: from the "
                   "checkpoint",
        phase_setup=phase_setup + "\n# (the phase, its times and the dumps made: set again from the checkpoint)",
        record_target="append thermo.dat", start="# the phase chain's state: from the checkpoint", **common)
    schedule = settle(window, chunk, max_windows, check=checks, settled_variable="done", advance=[],
                      end=_dump_commands("end").splitlines(),
                      never=("done", f"the bed did not reach the end of its test within max_time = {sc.max_time:g} s "
                                     f"(see thermo.dat's phase): raise scenario.max_time or the platen speeds"))
    return setup, resume, schedule, names


def run_compress(cfg: RunConfig, rd: RunDir, plugin_path: Path) -> tuple[dict, ProgressSpec]:
    """Build the bed and write the run's inputs; returns (system facts, progress spec)."""
    system = build_system(cfg, rd)
    setup, resume, schedule, names = render_inputs(cfg, plugin_path, system)
    system.update(window_steps=schedule["window"], chunk_steps=schedule["chunk"],
                  max_windows=schedule["max_windows"], max_steps=schedule["window"] * schedule["max_windows"])
    atomic_write_json(rd.root / "system.json", system)
    write_session(rd.root, setup, resume, schedule, cfg.execution.checkpoint_steps(), checkpoint_variables=names)
    return system, progress_spec(cfg, system)


def progress_spec(cfg: RunConfig, system: dict) -> ProgressSpec:
    return ProgressSpec(file="thermo.dat", total_steps=system["max_steps"], label=cfg.name,
                        columns={name: COMPRESS_RECORD.column(name) for name in ("time", "broken")})
