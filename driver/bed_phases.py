"""The phase chain both beds share (issue 25): the LAMMPS lines that driver/bcm/compress.py and
driver/bpm/compress.py run at each check (0 fill, 1 rest, 2 load, 3 hold, 4 unload, 5 done; each
module's docstring says what its phases do). A check first takes the values it decides on
(SNAPSHOT: p0 is the phase before it, so one check moves one phase at most); each model adds
the ends of its fill and rest, what it does when the loading begins, and, for the BPM, the
platen's next speed. Stresses, times and the dump commands are each model's own (SI for the
BCM, LJ units for the BPM)."""

from __future__ import annotations

from typing import Callable, Sequence

#: the values a check decides on
SNAPSHOT = [
    "variable        p0 equal ${phase}",
    "variable        sv_now equal ${sv}",
    "variable        svb_now equal ${sv_bottom}",
    "variable        ke_now equal ${ke}",
    "variable        el_now equal ${elastic}",
    "variable        t_now equal $(time:%.17g)",
    # the means over the last check window (each model's input: fix check_mean), which the fill's
    # and the rest's rules decide on: at a check the platen's and the bottom's stresses are
    # spikes of grains' blows as often as a stress through the bed (measured: 0, 1.3e5 and 3.2e5 Pa
    # at checks 1,000 steps apart on the 30-grain BCM bed at rest under 5e4 Pa)
    "variable        svm_now equal ${sv_mean}",
    "variable        svbm_now equal ${svb_mean}",
]
#: the phase chain's own checkpoint variables (the grading dumps' flags g1.. come after them)
PHASE_VARIABLES = ["phase", "t_rest", "refills", "t_load", "h_load", "t_hold", "fill_hits"]
#: the rest does not end while the platen carries more than this multiple of start_stress
REST_ABOVE = 2.0
#: the rest ends in the loading when the platen still carries this fraction of start_stress,
#: else in another fill (the bed let go of the platen: not jammed yet)
REST_HOLDS = 0.5
#: the fill ends when the bottom carries 1 - FILL_TOLERANCE of start_stress (the stress has gone
#: through the bed; the platen carries more: the side walls' friction holds part of the load)
FILL_TOLERANCE = 0.2
#: while the bed rests, the servo backs the platen up at most at this fraction of its speed
SERVO_BACK = 0.2
#: the fill ends when the bottom has carried 1 - FILL_TOLERANCE of start_stress at this many checks
#: in a row (a grain the platen pushes strikes the bottom for a few checks; measured: fills ended
#: by such blows left beds that were not jammed: BCM void ratios 0.05-0.1 above the jammed one,
#: a BPM bed of 8 grains loaded from e = 3.0 at zero stress for 350,000 steps)
FILL_CHECKS = 5
#: while the bed rests every element feels a drag -m v / t_d, t_d = REST_DAMPING_PERIODS shortest
#: contact periods: near the critical damping of the bed's slowest modes, so that the rest calms
#: it within rest_time. The BCM's rest with its fill's drag (100 periods) took the kinetic energy
#: down by e^2 only in a 100-period rest: the bed rattled, let go of the platen and went fill, rest,
#: fill at steps_per_period 100; the BPM's rest was quenched (its particles stopped at every check),
#: which kept the fill's push locked in (the bottom at 15 x start_stress as the loading began)
REST_DAMPING_PERIODS = 10.0
#: each time the bed goes back to the fill its speed is halved, at most FILL_HALVINGS times:
#: a fill that ends with the bed in motion leaves it compacted by its blows, not jammed, and its
#: rest lets go of the platen (measured: the 8-grain BPM test bed went fill, rest, fill 19 times at
#: the full fill speed, the fills ending with kinetic energies of 0.5-0.7 of the elastic ones); a
#: slower fill brings the bed to jamming with gentler blows
FILL_HALVINGS = 4
#: the fill speed's factor after `refills` returns to the fill (an equal-style variable)
FILL_SCALE = ('variable        fill_scale equal '
              f'"0.5^(v_refills*(v_refills < {FILL_HALVINGS}) + {FILL_HALVINGS}*(v_refills >= {FILL_HALVINGS}))"')



def drag(fill_time: str, rest_time: str) -> str:
    """The drag -m v / t_d on every element, t_d = fill_time in the fill (phase 0), rest_time
    in the rest (phase 1), none from the loading on (the times as the input writes them, in the
    model's units): the lines both models' inputs share."""
    return "\n".join([
        f'variable        drag_rate equal "(v_phase == 0)/{fill_time} + (v_phase == 1)/{rest_time}"',
        'variable        drag_x atom "-v_drag_rate*mass*vx"',
        'variable        drag_y atom "-v_drag_rate*mass*vy"',
        'variable        drag_z atom "-v_drag_rate*mass*vz"',
        "fix             fill_drag all addforce v_drag_x v_drag_y v_drag_z"])


def check_means(window: int) -> str:
    """The means over each check window of the platen's and the bottom's stresses (the input's
    sv and sv_bottom), which SNAPSHOT reads as ${sv_mean} and ${svb_mean}: `fix ave/time` over
    the window's steps, given at its last step (the checks come every window from step 0)."""
    return "\n".join([f"fix             check_mean all ave/time 1 {window} {window} v_sv v_sv_bottom",
                      "variable        sv_mean equal f_check_mean[1]",
                      "variable        svb_mean equal f_check_mean[2]"])


#: the check log, phases.dat: a line per check with the values its rules decided on and the phase it
#: left (the record of why a fill or a rest ended; runfiles.records.read_record reads it)
CHECK_LOG_FILE = "phases.dat"
CHECK_LOG_COLUMNS = ["step", "phase_before", "phase", "sigma_v_mean", "sigma_v_bottom_mean", "ke", "elastic",
                     "fill_hits"]
CHECK_LOG = ('print           "$(step) ${p0} ${phase} ${svm_now} ${svbm_now} ${ke_now} ${el_now} ${fill_hits}" '
             f'append {CHECK_LOG_FILE} screen no')


#: the command (the fresh start's) that begins the check log with its title line; the stresses
#: and energies are in the model's units (SI for the BCM, LJ for the BPM: system.json's units)
CHECK_LOG_TITLE = f'print           "# {" ".join(CHECK_LOG_COLUMNS)}" file {CHECK_LOG_FILE} screen no'


#: the run ends at phase 5 (the schedule's settled variable)
DONE = 'variable        done equal "v_phase == 5"'


def quoted(commands: list[str]) -> str:
    """Commands as the quoted arguments of an `if ... then`."""
    return " ".join(f'"{c}"' for c in commands)


def filled(start: float) -> list[str]:
    """The fill is over: the bottom and the platen carry 1 - FILL_TOLERANCE of start on the mean
    over a check window (the servo has brought the stress through the bed) at FILL_CHECKS checks
    in a row (their count is the checkpoint variable fill_hits: a grain's blow on the bottom is no
    stress through the bed). The bed may still be in motion (asking for more elastic than kinetic
    energy too kept the 30-grain BCM bed, which the platen's blows at 5 m/s keep stirring, in its
    fill for ever): the rest calms it, and a bed that then lets go of the platen is filled again,
    more slowly (FILL_HALVINGS)."""
    reach = (1 - FILL_TOLERANCE) * start
    reached = f"(v_svbm_now >= {reach!r})*(v_svm_now >= {reach!r})"
    return [f"variable        fill_hits equal $((v_p0 == 0)*{reached}*(v_fill_hits+1))",
            f'variable        to_rest equal "v_fill_hits >= {FILL_CHECKS}"']


def rested(rest_ke: float, rest_time: float, start: float) -> str:
    """The rest is over: the kinetic energy is below rest_ke of the elastic energy the bed holds
    (the bed in equilibrium) or rest_time has passed since the rest began, and the platen carries
    at most REST_ABOVE x start on the window's mean (a fast fill leaves it far above
    start_stress: the servo first backs it up, else the loading would start above its target)."""
    return (f'variable        rested equal "(v_p0 == 1) && ((v_ke_now <= {rest_ke!r}*v_el_now) || '
            f'(v_t_now >= v_t_rest + {rest_time!r})) && (v_svm_now <= {REST_ABOVE * start!r})"')


def transitions(start: float, target: float, hold_time: float) -> list[str]:
    """After the model's `rested`: to the loading (the platen still carries REST_HOLDS x start on
    the window's mean) or back to the fill (a bed that let go of the platen while it rested was
    not jammed yet),
    to the hold at the target, to the unloading after hold_time, done back at start. (Asking the
    bottom to carry it too kept the BCM bed of 2026-12-03, whose rest pushed the platen down and
    rattled, out of its loading: 30 grains went fill, rest, fill for 45,000 steps.)"""
    hold = REST_HOLDS * start
    return [
        f'variable        to_load equal "v_rested && (v_svm_now >= {hold!r})"',
        f'variable        to_fill equal "v_rested && (v_svm_now < {hold!r})"',
        f'variable        to_hold equal "(v_p0 == 2) && (v_sv_now >= {target!r})"',
        f'variable        to_unload equal "(v_p0 == 3) && (v_t_now >= v_t_hold + {hold_time!r})"',
        f'variable        to_done equal "(v_p0 == 4) && (v_sv_now <= {start!r})"',
    ]


def rest_and_fill(rest_begins: Sequence[str] = (), fill_begins: Sequence[str] = ()) -> list[str]:
    """The rest and the fill begun, each with the model's own commands (the BCM's contact
    friction: the model's in the rest, fill_friction in the fill)."""
    return [
        'if              "${to_rest} > 0" then "variable phase equal 1" "variable t_rest equal ${t_now}"'
        + "".join(f' "{c}"' for c in rest_begins),
        'if              "${to_fill} > 0" then "variable phase equal 0" "variable refills equal $(v_refills+1)"'
        + "".join(f' "{c}"' for c in fill_begins),
    ]


def load_begins(switch_on: list[str], dumps: list[str]) -> str:
    """The loading begun: the model's `switch_on` commands (breaking on, the particles stopped),
    the loading's start time and height, the start state dumped."""
    return ('if              "${to_load} > 0" then "variable phase equal 2" ' + quoted(switch_on)
            + ' "variable t_load equal ${t_now}" "variable h_load equal ${height}" ' + quoted(dumps))


def grading_checks(grading_at: list[float], target: float, dumps: Callable[[int], list[str]]
                   ) -> tuple[list[str], list[str]]:
    """(lines, flags): the state dumped (dumps(k)) the first time the loading's stress passes
    each of grading_at x target; the flags g1.. are checkpoint variables."""
    lines, names = [], []
    for k, frac in enumerate(grading_at):
        g = f"g{k + 1}"
        lines += [f'variable        {g}_now equal "(v_{g} == 0) && (v_p0 == 2) && (v_sv_now >= {frac * target!r})"',
                  f'if              "${{{g}_now}} > 0" then "variable {g} equal 1" ' + quoted(dumps(k))]
        names.append(g)
    return lines, names


def phase_ends(hold_time: float, unload: bool) -> list[str]:
    """The target reached (to the hold, the unloading or the end), the hold over, the unloading
    done."""
    after_target = 3 if hold_time > 0 else (4 if unload else 5)
    after_hold = 4 if unload else 5
    return [
        f'if              "${{to_hold}} > 0" then "variable phase equal {after_target}" '
        '"variable t_hold equal ${t_now}"',
        f'if              "${{to_unload}} > 0" then "variable phase equal {after_hold}"',
        'if              "${to_done} > 0" then "variable phase equal 5"',
    ]
