"""The scenario sections several units share (a config holds one section per scenario kind):
`impact` (the BCM and BPM impacts, driver/scenarios/bcm_impact.py and bpm_impact.py), `crush`
(a particle between platens, driver/scenarios/bcm_crush.py and bpm_crush.py) and `calibrate`
(the BPM calibration tests, driver/scenarios/bpm_calibrate.py; the BCM block's tests extend it,
driver/scenarios/bcm_calibrate.py). Here, below the units, so that no unit imports a sibling
unit for its section."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, field_validator

from driver.bcm.section import check_steps_per_period
from driver.schema import _Strict


class ImpactScenario(_Strict):
    """One particle hits a rigid plane (SPEC 1.4)."""

    kind: Literal["impact"] = Field("impact", description="impact: one particle hits a rigid plane")
    velocity: float = Field(4.5, gt=0.0, le=100.0, description="impact velocity v_0 normal to the plane, m/s")
    gap: float = Field(1e-3, ge=0.0, lt=1.0, description="initial gap to the plane, fraction of the diameter")
    # below 12 refused (check_steps_per_period). 50 by the time-step study (bench/timestep_study.py,
    # docs/models/bcm-timestep.md): the largest value whose run energy balance stays below 1e-4 with a
    # margin of 2 in every case measured (a 100-cell particle at 10 m/s: 1.1e-4 at 30, 8.6e-5 at
    # 40, 4.1e-5 at 50), the outcome within the 100-step reference's seed-to-seed spread
    steps_per_period: float = Field(50.0, gt=0.0, description="time step = shortest contact period / this")
    max_time: float = Field(5e-4, gt=0.0, description="hard stop on simulated time, s")
    settle_window: float = Field(5e-6, gt=0.0, description="window over which the outcome must not change, s")
    ke_tolerance: float = Field(1e-3, gt=0.0, lt=1.0,
                                description="settled when kinetic energy changes by less than this fraction "
                                            "over a window with no break and the plane unloaded")
    thermo_every: int = Field(10, ge=1, description="steps between energy records: 10 samples a 2 µs contact "
                                                   "at 50 points or more for time steps up to 4e-9 s")
    dump_every: int = Field(0, ge=0, description="steps between cell dumps; 0 = start and end only")

    _stable = field_validator("steps_per_period")(check_steps_per_period)


class CrushScenario(_Strict):
    """One particle crushed between a fixed lower platen and an upper one coming down at constant
    speed until it breaks (SPEC 4.1)."""

    kind: Literal["crush"] = Field("crush", description="crush: one particle squeezed between two platens, the "
                                                         "upper one moving down at constant speed")
    # Quasi-static (SPEC 4.1: F_c unchanged when v_p is halved) needs the time to the peak to be
    # many times the particle's slowest elastic period. The 2 mm, 80-200-cell particle of the
    # default model breaks after a platen travel u_c of 2-3 micrometres (44-58 N on a loading
    # stiffness of ~2e7 N/m); its slowest mode, its own compression (half its 2.5e-5 kg on
    # 2e7 N/m), has a period of ~5e-6 s, its ringing between the platens' contacts ~2e-6 s
    # (measured in the platens' force difference), and a wave crosses it in ~1e-6 s. At
    # 0.02 m/s the peak comes after ~1.3e-4 s, some 25 of those periods; halving it moves F_c by
    # 1 % (tests/test_bcm_crush.py, docs/scenarios/crush.md).
    platen_speed: float = Field(0.02, gt=0.0, le=10.0,
                                description="speed v_p of the upper platen towards the lower one, m/s; the default "
                                            "0.02 is quasi-static for the default 2 mm particle: the peak comes "
                                            "after ~1.3e-4 s (a travel of 2-3 µm), some 25 of its slowest elastic "
                                            "periods (~5e-6 s: its own compression) and a hundred wave crossings "
                                            "(~1e-6 s); halving it moves F_c by about 1 %. Scale it with the "
                                            "particle's size and wave speed")
    stop_after_drop: float = Field(0.2, gt=0.0, lt=1.0,
                                   description="stop once, after the peak, the upper platen's force has fallen "
                                               "below this fraction of the largest force so far (and at least one "
                                               "interface has broken: chatter at first touch is no peak)")
    max_strain: float = Field(0.3, gt=0.0, le=0.9,
                              description="stop when the platen has travelled this fraction of the particle's "
                                          "height between the platens (a particle that never drops)")
    max_time: float = Field(2e-3, gt=0.0, description="hard stop on simulated time, s (with max_strain: the "
                                                       "earlier of the two); the default is 15 times the BCM "
                                                       "example's time to its drop (1.3e-4 s at 0.02 m/s) and 10 "
                                                       "times the BPM example's (2e-4 s at 0.25 m/s): raise it "
                                                       "with a slower platen")
    gap: float = Field(0.0, ge=0.0, lt=0.01,
                       description="initial gap between the upper platen and the particle's highest point, "
                                   "fraction of the diameter (the lower platen touches the lowest point at zero "
                                   "overlap)")
    # as the impact's (ImpactScenario): the time-step study holds for the same contacts
    steps_per_period: float = Field(50.0, gt=0.0, description="time step = shortest contact period / this")
    check_every: int = Field(500, ge=1, description="steps between two checks of the stop rule (the peak is "
                                                    "tracked at the checks, so the stop is conservative; the "
                                                    "analysis reads the full record)")
    thermo_every: int = Field(20, ge=1, description="steps between records (force, energies, breaks)")
    dump_every: int = Field(0, ge=0, description="steps between cell dumps; 0 = start and end only")

    _stable = field_validator("steps_per_period")(check_steps_per_period)


class CompressScenario(_Strict):
    """A bed of grains (model.assembly) in a rigid box, compressed by its top platen (issue 25):
    the dense start (the platen down fast with breaking off to start_stress, then at rest), the
    loading at platen_speed to target_stress, an optional hold and unloading."""

    kind: Literal["compress"] = Field("compress", description="compress: a bed of grains in a rigid box, its top "
                                                               "platen coming down (confined, oedometric)")
    platen_speed: float = Field(0.05, gt=0.0, le=10.0,
                                description="speed of the top platen while loading and unloading, m/s; quasi-static "
                                            "when the inertial number I = (v/H) d sqrt(rho/sigma_v) stays below "
                                            "1e-3 (reported by the analysis)")
    target_stress: float = Field(5e6, gt=0.0, description="vertical stress on the platen where loading ends, Pa")
    start_stress: float = Field(5e4, gt=0.0, description="vertical stress of the dense start, Pa: the platen comes "
                                                          "down at fill_speed with breaking off until it is reached")
    fill_speed: float = Field(0.5, gt=0.0, le=50.0,
                              description="speed of the platen while the bed is brought to its dense start, m/s "
                                          "(breaking off: only the start's geometry comes out of it)")
    fill_friction: float = Field(0.0, ge=0.0, description="BCM: Coulomb friction of the cell contacts while the bed "
                                                             "is filled (0: frictionless, which packs it dense but "
                                                             "must bring it to its frictionless jamming); "
                                                             "model.contact.mu from the rest on (the BPM's "
                                                             "particles have no friction: 0 only)")
    rest_speed: float | None = Field(None, gt=0.0, le=10.0,
                                     description="fastest the platen's servo moves it while the bed rests, m/s "
                                                 "(None: fill_speed); set "
                                                 "it to compare loadings at several platen speeds from one and the "
                                                 "same start")
    rest_ke: float = Field(1e-3, gt=0.0, lt=1.0,
                           description="the dense start is at rest, and breaking switched on, once the kinetic "
                                       "energy is below this fraction of the elastic energy the bed holds (or after "
                                       "rest_time)")
    rest_time: float = Field(2e-4, gt=0.0, description="the longest the bed rests before loading, s")
    hold_time: float = Field(0.0, ge=0.0, description="time the platen holds still at the target stress, s")
    unload: bool = Field(True, description="after the target (and the hold), the platen goes back up at platen_speed "
                                           "until the stress is down to start_stress")
    grading_at: list[float] = Field(
        default_factory=lambda: [0.25, 0.5, 1.0],
        description="fractions of target_stress at which the cells and interfaces are dumped while loading "
                    "(grading curves, breakage); the start and end states are always dumped")
    max_time: float = Field(0.05, gt=0.0, description="hard stop on simulated time, s")
    steps_per_period: float = Field(50.0, gt=0.0, description="time step = shortest contact period / this")
    check_every: int = Field(200, ge=1, description="steps between two checks of the phase (its changes come at "
                                                    "checks: the stress may pass a threshold by one check's travel)")
    thermo_every: int = Field(100, ge=1, description="steps between records")
    dump_every: int = Field(0, ge=0, description="steps between cell dumps; 0 = at the grading stresses, the start "
                                                 "and the end only")

    _stable = field_validator("steps_per_period")(check_steps_per_period)

    @field_validator("grading_at")
    @classmethod
    def _fractions(cls, v: list[float]) -> list[float]:
        if any(not 0.0 < x <= 1.0 for x in v):
            raise ValueError(f"grading_at: fractions of target_stress in (0, 1] (got {v})")
        return sorted(set(v))


class CalibrateScenario(_Strict):
    """A calibration test of the model's material (SPEC 2.3)."""

    kind: Literal["calibrate"] = Field("calibrate", description="calibrate: a calibration test, chosen by `test`")
    test: Literal["moduli", "mode1", "mode2", "crack_speed"] = Field(
        "moduli", description="moduli: B, G, E, nu by compression and simple shear at strain_rate, then at half of "
                              "it (the rate check); mode1: K_IC of a free sample with an elliptic void, pulled "
                              "apart; mode2: K_IIC of a periodic sample with the void at 45 degrees, pure shear; "
                              "crack_speed: the mode1 pull, for the crack's speed against the Rayleigh speed "
                              "(needs B_reference, G_reference)")
    strain_rate: float = Field(1e-4, gt=0.0, le=0.1, description="moduli: true strain rate of the compression, shear "
                                                                 "rate of the shear phases; mode1: nominal strain "
                                                                 "rate of the pull (grip separation speed / L); "
                                                                 "mode2: true strain rate of the pure shear (x "
                                                                 "at +rate, y at -rate); units 1/tau")
    max_strain: float = Field(0.005, gt=0.0, le=0.02, description="largest volumetric (compression) or shear "
                                                                  "strain of a phase; the fit range")
    void: bool = Field(True, description="mode1, mode2: cut the elliptic void (false is refused: the toughness is "
                                         "measured at its tips)")
    void_axes: tuple[float, float] = Field((20.0, 2.0), description="mode1, mode2: full axes of the elliptic void, "
                                                                     "major then minor, units of a (mode1: major "
                                                                     "along x, the pull along y; mode2: major at 45 "
                                                                     "degrees from x)")
    grip_width: float = Field(2.0, gt=0.0, description="mode1: width of the top and bottom strips moved as grips, "
                                                        "units of a")
    thickness: float = Field(
        5.0, ge=4.0, le=1000.0,
        description="mode1, mode2, 3D: thickness T of the slab, periodic along z, the void a cylinder through it "
                    "(SPEC 2.3), units of a; at least 4 a (driver/bpm/slab.py); not used in 2D")
    max_pull_strain: float = Field(0.05, gt=0.0, le=0.5, description="mode1: nominal strain (grip displacement / "
                                                                      "L) at which the pull ends")
    B_reference: float | None = Field(None, gt=0.0, description="mode1: bulk modulus of the material (from a moduli "
                                                                "run), with G_reference for the Rayleigh speed the "
                                                                "crack speed is compared with")
    G_reference: float | None = Field(None, gt=0.0, description="mode1: shear modulus of the material (from a "
                                                                "moduli run); mode2: with it, the peak is flagged "
                                                                "when it comes within 5 shear-wave crossings")
    band_width: float = Field(4.0, gt=0.0, description="mode2: full width of the band of breakable bonds (bond "
                                                        "midpoints within band_width / 2 of the void's 45-degree "
                                                        "line, across the periodic box), units of a")
    max_shear_strain: float = Field(0.05, gt=0.0, le=0.5, description="mode2: true strain of the pure shear at "
                                                                       "which the run ends")
    K_IC_reference: float | None = Field(None, gt=0.0, description="mode2: K_IC of the material (from a mode1 run "
                                                                   "with the same k_A, lambda_c, theta_c), for "
                                                                   "K_IIC / K_IC; none: not reported")
    E_reference: float | None = Field(None, gt=0.0, description="mode1: Young's modulus of the material (from a "
                                                                "moduli run), for K_IC / E; none: not reported")
    thermo_every: int = Field(50, ge=1, description="steps between stress records")
    dump_every: Literal[0] = Field(0, description="no periodic dumps in a calibration test")
