"""A BPM bed in confined compression (issue 25): the grains of model.assembly (driver/bpm/bed.py)
in a rigid box of five fixed planes (`fix wall/gran`: z = 0, x = 0 and L_x, y = 0 and L_y) and a
top platen (driver/bpm/platen.py's moving region plane), every one with the particle-wall law of
model.particle.contact; a chain of phases the driver's checks advance (every
scenario.check_every steps), as the BCM bed's (driver/bcm/compress.py), in LJ units:

0 fill: breaking switched off (bonds and angles with the critical stretch FILL_LAMBDA and the
  angles' critical bend 180 degrees: neither breaks under the fill's small strains), the
  platen servo-controlled by the bottom's stress (down at fill_speed (1 - sigma_bottom /
  start_stress), never up; half as fast at each return to the fill, bed_phases.FILL_HALVINGS
  times at most), every particle damped by a drag -m v / FILL_DAMPING_TIME, until
  the bottom and the platen have carried 1 - FILL_TOLERANCE of start_stress on the mean over a
  check window at FILL_CHECKS checks in a row (driver/bed_phases.py);
1 rest: every particle damped by a stronger drag, -m v / t_d with t_d = REST_DAMPING_PERIODS
  wall contact periods (driver/bed_phases.py); the platen still, or backing up while its stress
  over the last check window is above REST_ABOVE x start_stress, which the rest's end waits
  for (at rest_speed, fill_speed unless set, times the excess in units of start_stress, at most
  SERVO_BACK of it); once the kinetic energy is below rest_ke of the
  elastic energy the bed holds (pairs, bonds, angles, walls) or after rest_time, and the platen
  carries at most REST_ABOVE x start_stress: if the platen carries at least REST_HOLDS of
  start_stress, the particles are stopped, the model's bond and angle coefficients set
  (breaking on) and the start state dumped; else the bed let go of the platen and is filled
  again (phase 0);
2 load: the platen down at platen_speed until target_stress; the atoms and bonds dumped as the
  stress first passes each of grading_at x target_stress;
3 hold (hold_time > 0), 4 unload (up at platen_speed, to start_stress), 5 done: the run ends.

The servo is the BCM bed's, in steps: a region moves by a displacement that is a function of
the step, so the platen's speed is constant between two checks and set anew at each (the
speed, the height and the step of the change are checkpoint variables).

The chunks are `run N pre no` (driver/bpm/platen.py: a set-up would see the platen at rest for
one force evaluation); the changed bond and angle coefficients take effect at once (the styles
derive their constants in `bond_coeff` / `angle_coeff`).
"""

from __future__ import annotations

import math
from pathlib import Path

from driver import bed_phases
from driver.bpm.bed import place_bpm_bed
from driver.bpm.impact import DIAMETER, SYSTEM_FRESH, plane_law_args
from driver.bpm.input_blocks import SYSTEM_RESUME, comm_cutoff, common_values
from driver.runner import ProgressSpec
from driver.schedule import settle, settle_windows, write_session
from driver.templates import render
from runfiles.atomic import atomic_write_json
from runfiles.records import BONDS_DUMP, BPM_COMPRESS_RECORD, atoms_dump

#: critical stretch of bonds and angles while the bed is filled and rests (breaking off)
FILL_LAMBDA = 1.2
#: while the bed is filled every particle feels a drag -m v / FILL_DAMPING_TIME (tau): a grain set
#: moving stops within some ten particle diameters, and the drag on the column the platen pushes
#: stays small (lammps_inputs/bpm_compress.in)
FILL_DAMPING_TIME = 20.0
#: the running integrals of lammps_inputs/bpm_compress.in and the samples they start from, saved
#: with each checkpoint and restored as the base a resumed run adds to (`<name>_base`)
INTEGRALS = ("walls_work", "top_work", "damp_pair", "damp_bond", "walls_pw", "top_pw", "damp_pair_pw",
             "damp_bond_pw", "platen_work", "platen_pc", "platen_half")
#: the platen's state, set at each change of its speed (checkpoint variables)
PLATEN_STATE = ("top_zs", "top_ns", "top_v", "top_vb", "platen_corr")
STOP_PARTICLES = '"velocity all set 0.0 0.0 0.0"'


def grading_dump_name(k: int) -> str:
    """Dump name of the k-th grading stress (0-based): dumps/atoms.grade<k+1>.lammpstrj."""
    return f"grade{k + 1}"


def dump_commands(name: str) -> list[str]:
    """write_dump of the atoms (with their grain) and the intact bonds now, into dumps/*.<name>."""
    atoms = atoms_dump(3, grain=True)
    return [f"write_dump      all custom dumps/atoms.{name}.lammpstrj {atoms.args()} modify sort id {atoms.modify()}",
            f"write_dump      all local dumps/bonds.{name}.lammpstrj {BONDS_DUMP.args()} modify {BONDS_DUMP.modify()}"]


def platen_to(name: str) -> list[str]:
    """The commands (between runs, at step N) that set the platen's speed (a/tau, down positive)
    to the value of the constant variable `name` from the next step on: its height and step
    now, the old speed as the backward one of step N, and the correction of step N's work sample
    (taken with the old forward velocity: dt F_N (v_old - v_new) / 2, the input's platen_corr)."""
    return [f"variable        platen_corr equal $(v_platen_corr+0.5*dt*c_top_f[2]*(v_top_v-v_{name}))",
            "variable        top_zs equal $(v_top_z)", "variable        top_vb equal $(v_top_v)",
            "variable        top_ns equal $(step)", f"variable        top_v equal ${{{name}}}"]


def coefficients(m, fill: bool) -> list[str]:
    """The bond and angle coefficients: breaking off (FILL_LAMBDA, 180 degrees) or the model's."""
    if fill:
        return [f"bond_coeff 1 {FILL_LAMBDA!r} {m.gamma!r}", f"angle_coeff 1 {m.k_A!r} 180.0 {FILL_LAMBDA!r}"]
    return [f"bond_coeff 1 {m.lambda_c!r} {m.gamma!r}", f"angle_coeff 1 {m.k_A!r} {m.theta_c_deg!r} {m.lambda_c!r}"]


def phase_checks(cfg, system: dict) -> tuple[list[str], list[str]]:
    """(check lines, checkpoint variables) of the phase chain (module docstring), on the values
    at the check (p0: the phase before it, so one check moves one phase at most); stresses in
    u/a^3, times in tau."""
    m, sc = cfg.model, cfg.scenario
    un = system["units"]
    stress = un["a"] ** 3 / un["u"]  # Pa -> u/a^3
    speed = un["tau"] / un["a"]  # m/s -> a/tau
    start, target = sc.start_stress * stress, sc.target_stress * stress
    v_fill, v_load = sc.fill_speed * speed, sc.platen_speed * speed
    # the rest's servo speed: scenario.rest_speed, else fill_speed (module docstring)
    v_rest = (sc.fill_speed if sc.rest_speed is None else sc.rest_speed) * speed
    back = bed_phases.SERVO_BACK
    lines = [
        *bed_phases.SNAPSHOT,
        *bed_phases.filled(start),
        # the rest also waits for the servo to bring the platen's stress down to REST_ABOVE x
        # start_stress (a fast fill leaves it far above: 8 MPa after a 20 m/s fill of 30 grains)
        bed_phases.rested(sc.rest_ke, sc.rest_time / un["tau"], start),
        *bed_phases.transitions(start, target, sc.hold_time / un["tau"]),
        *bed_phases.rest_and_fill(),
        bed_phases.load_begins([*coefficients(m, fill=False), STOP_PARTICLES.strip('"')], dump_commands("load")),
    ]
    grading, flags = bed_phases.grading_checks(sc.grading_at, target, lambda k: dump_commands(grading_dump_name(k)))
    lines += [
        *grading, *bed_phases.phase_ends(sc.hold_time, sc.unload), bed_phases.CHECK_LOG,
        # the platen's speed for the next window, of the phase now: the fill servo-controlled by
        # the bottom's stress (full speed until the stress goes through the bed, then slowing,
        # never up; slower at each return to the fill), the rest still, or backing up while the
        # platen's stress over the window is above REST_ABOVE x start, which the rest's end
        # waits for (at rest_speed times the excess in units of start, at most SERVO_BACK of it: a
        # rest that pushes the bed agitates it, one that backs up from start_stress on
        # overshoots: both measured on the BCM bed), the loading and unloading at platen_speed,
        # else still
        f'variable        rest_err equal "{bed_phases.REST_ABOVE!r} - v_svm_now/{start!r}"',
        bed_phases.FILL_SCALE,
        f'variable        v_next equal "(v_phase == 0)*{v_fill!r}*v_fill_scale*ternary(v_svb_now < {start!r}, '
        f'1 - v_svb_now/{start!r}, 0) + (v_phase == 1)*{v_rest!r}*ternary(v_rest_err < {-back!r}, '
        f'{-back!r}, (v_rest_err < 0)*v_rest_err) + (v_phase == 2)*{v_load!r} - (v_phase == 4)*{v_load!r}"',
        "variable        v_new equal $(v_v_next:%.17g)",
        *platen_to("v_new"),
        bed_phases.DONE,
    ]
    return lines, [*bed_phases.PHASE_VARIABLES, *flags]


def wall_lines(law: dict, box_a: list[float]) -> str:
    """The fixed planes: the bottom (z = 0) and the two pairs of side planes."""
    args = plane_law_args(law)
    return "\n".join([f"fix             bottom all wall/gran {args} zplane 0.0 NULL contacts",
                      f"fix             xw all wall/gran {args} xplane 0.0 {box_a[0]!r} contacts",
                      f"fix             yw all wall/gran {args} yplane 0.0 {box_a[1]!r} contacts"])


def build_system(cfg, rd) -> dict:
    """The bed (packing pool, dense start, files) and the box's facts."""
    facts = place_bpm_bed(cfg, rd)
    sc = cfg.scenario
    return {**facts, "platen_speed": sc.platen_speed, "grading_at": list(sc.grading_at),
            "grading_dumps": [grading_dump_name(k) for k in range(len(sc.grading_at))]}


def render_inputs(cfg, plugin_path: Path, system: dict) -> tuple[str, str, dict, list[str]]:
    """(setup.lammps, resume.lammps, schedule, checkpoint variables) of a BPM compression run."""
    m, sc = cfg.model, cfg.scenario
    un, law, dt = system["units"], system["plane"], system["timestep"]
    window, chunk = settle_windows(sc.check_every, sc.check_every)
    max_windows = max(1, math.ceil(sc.max_time / un["tau"] / (window * dt)))
    box_a = system["box_a"]
    checks, names = phase_checks(cfg, system)
    rest_t = bed_phases.REST_DAMPING_PERIODS * law["period"]
    v_fill = sc.fill_speed * un["tau"] / un["a"]
    state = {"top_zs": repr(box_a[2]), "top_ns": "0", "top_v": repr(v_fill), "top_vb": "0.0", "platen_corr": "0.0"}
    phase_setup = "\n".join([*(f"variable        {n} equal 0" for n in names),
                             *(f"variable        {n} equal {v}" for n, v in state.items())])
    periodic = "compute         bl all property/local batom1 batom2 btype"
    if sc.dump_every > 0:
        atoms = atoms_dump(3, grain=True)
        periodic += (f"\ndump            atoms all custom {sc.dump_every} dumps/atoms.*.lammpstrj {atoms.args()}\n"
                     f"dump_modify     atoms sort id {atoms.modify()}\n"
                     f"dump            bonds all local {sc.dump_every} dumps/bonds.*.lammpstrj {BONDS_DUMP.args()}\n"
                     f"dump_modify     bonds {BONDS_DUMP.modify()}")
    pair = f"pair_coeff      1 1 1.0 {DIAMETER!r} {m.gamma:.12g}"
    fill_styles = "\n".join(["pair_style      cr/repulsion", pair, "",
                             "# breaking off while the bed is filled (the model's coefficients from the loading on)",
                             "bond_style      breakable/cr", "angle_style     breakable/cr",
                             *coefficients(m, fill=True)])
    common = common_values(
        # the ghosts reach the angles' arms at the larger of the fill's and the model's critical stretch
        cfg, plugin_path, comm_cutoff(m.model_copy(update={"lambda_c": max(m.lambda_c, FILL_LAMBDA)}),
                                      system["max_r0"], DIAMETER), sc.thermo_every, BPM_COMPRESS_RECORD,
        a_m=f"{un['a']:.6g}", m_kg=f"{un['m']:.6g}", u_J=f"{un['u']:.6g}", tau_s=f"{un['tau']:.17g}",
        timestep=f"{dt:.12g}", steps_per_period=f"{sc.steps_per_period:g}", kn=f"{law['kn']:.12g}",
        kt=f"{law['kt']:.12g}", eta_n=f"{law['eta_n']:.12g}", mu=f"{law['mu']:.12g}", wall_law=plane_law_args(law),
        walls=wall_lines(law, box_a), fill_damping_time=repr(FILL_DAMPING_TIME), rest_damping_time=repr(rest_t),
        drag=bed_phases.drag(repr(FILL_DAMPING_TIME), repr(rest_t)), check_means=bed_phases.check_means(window),
        box_x=repr(box_a[0]),
        box_y=repr(box_a[1]), top_h0=repr(box_a[2]),
        solid_volume=repr(system["solid_volume_a3"]), phase_setup=phase_setup, periodic_dumps=periodic,
        window_steps=window)
    setup = render(
        "bpm_compress.in", role="Fresh start from system.data (setup.lammps; in.lammps runs it whole).",
        system=SYSTEM_FRESH, styles=fill_styles, record_target="file thermo.dat", step0=0,
        start="\n".join(["run             0", *dump_commands("start"), bed_phases.CHECK_LOG_TITLE]), **common)
    resume = render(
        "bpm_compress.in", role="Start from a checkpoint (resume.lammps: -var checkpoint FILE).",
        system=SYSTEM_RESUME, styles="# pair, bond and angle styles with their coefficients (the phase's): from the "
                                     "checkpoint",
        record_target="append thermo.dat", step0="$(step)",
        start="# the phase chain's and the platen's state: from the checkpoint", **common)
    schedule = settle(window, chunk, max_windows, check=checks, settled_variable="done", advance=[],
                      end=dump_commands("end"), pre_no=True,
                      never=("done", f"the bed did not reach the end of its test within max_time = {sc.max_time:g} s "
                                     f"(see thermo.dat's phase): raise scenario.max_time or the platen speeds"))
    return setup, resume, schedule, [*names, *PLATEN_STATE]


def run_compress(cfg, rd, plugin_path: Path) -> tuple[dict, ProgressSpec]:
    """Build the bed and write the run's inputs; returns (system facts, progress spec)."""
    system = build_system(cfg, rd)
    setup, resume, schedule, names = render_inputs(cfg, plugin_path, system)
    system.update(window_steps=schedule["window"], chunk_steps=schedule["chunk"],
                  max_windows=schedule["max_windows"], max_steps=schedule["window"] * schedule["max_windows"])
    atomic_write_json(rd.root / "system.json", system)
    write_session(rd.root, setup, resume, schedule, cfg.execution.checkpoint_steps(),
                  checkpoint_variables=[*names, *INTEGRALS], restore_as={n: f"{n}_base" for n in INTEGRALS})
    return system, progress_spec(cfg, system)


def progress_spec(cfg, system: dict) -> ProgressSpec:
    """The progress fields of a BPM bed: the time and the bonds broken."""
    return ProgressSpec(file="thermo.dat", total_steps=system["max_steps"], label=cfg.name,
                        columns={name: BPM_COMPRESS_RECORD.column(name) for name in ("time", "bonds_broken")})
