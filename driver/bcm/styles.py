"""The LAMMPS style lines of a BCM model section (SPEC 1.2): the cell-cell contacts, the
Griffith interfaces with the law of their broken points, and the rigid plane (at rest, or a
moving platen, SPEC 4.1). One place, so
that the impact and the calibration block render the same model alike."""

from __future__ import annotations

import math


def pair_setup(model, r_m: float, mu: float | None = None) -> str:
    """`pair_style bcm/contact` and its coefficients: contacts between cells that share no
    interface (SPEC 1.2), the frictional-contact parameters."""
    return f"pair_style      bcm/contact cells cells.txt rm {r_m:.12g}\n" + pair_coeff(model, mu)


def pair_coeff(model, mu: float | None = None) -> str:
    """The cell contacts' `pair_coeff` line (model.contact; mu overrides its friction)."""
    c = model.contact
    return f"pair_coeff      * * {c.kn} {c.kt} {c.en2} {c.mu if mu is None else mu}"


def bond_setup(model, G_c: float | None = None) -> str:
    """`bond_style bcm/griffith` and its coefficients (SPEC 1.2 Eq. 1-7): the interfaces, the
    Griffith convention, their stiffness mode and the law of their broken points
    (model.broken); G_c overrides model.interface.G_c."""
    b = model.broken
    return (f"bond_style      bcm/griffith geometry interfaces.txt energy {model.griffith_energy} "
            f"stiffness {model.interface_stiffness} broken_stiffness {b.stiffness} broken_damping {b.damping} "
            f"break_shear {b.shear_at_break} break_normal {b.normal_at_break} broken_points {b.points}\n"
            + bond_coeff(model, G_c))


def bond_coeff(model, G_c: float | None = None) -> str:
    """The interfaces' `bond_coeff` line (model.interface, model.contact for their broken
    points, model.broken.mu); G_c overrides model.interface.G_c."""
    c, i, b = model.contact, model.interface, model.broken
    G_c = i.G_c if G_c is None else G_c
    mu = c.mu if b.mu is None else b.mu
    return f"bond_coeff      1 {i.kn} {i.kt} {i.en2} {G_c:g} {c.kn} {c.kt} {c.en2} {mu}"


#: the faces of fix bcm/wall: plane x[axis] = coord, the cells above (lo) or below (hi) it
WALL_FACES = ("xlo", "xhi", "ylo", "yhi", "zlo", "zhi")


def wall_setup(model, r_m: float, fix_id: str = "plane", face: str = "zlo", coord: float = 0.0,
               velocity: float | str | None = None) -> str:
    """`fix bcm/wall`: a rigid plane under the contact law (model.contact) with the options of
    model.plane; by default the impact's plane z = 0, the cells above it. `face` and `coord`
    place it (plugins/doc/fix_bcm_wall.md); `velocity` makes it a platen moving along its axis
    (SPEC 4.1): a number, m/s along +x, +y or +z (a `zhi` platen pressing down on the cells
    has velocity < 0), or the name of an equal-style LAMMPS variable giving that velocity at
    every step (rendered `v_name`: to hold the platen still or unload it within a run)."""
    if face not in WALL_FACES:
        raise ValueError(f"wall face {face!r}: one of {', '.join(WALL_FACES)}")
    c, p = model.contact, model.plane
    en2 = c.en2 if p.en2 is None else p.en2
    line = (f"fix             {fix_id} all bcm/wall cells cells.txt rm {r_m:.12g} plane {face} {coord!r} "
            f"{c.kn} {c.kt} {en2} {c.mu} stiffness {p.stiffness}")
    if velocity is None:
        return line
    if isinstance(velocity, str):
        if not velocity.isidentifier():
            raise ValueError(f"platen velocity variable {velocity!r}: not a LAMMPS variable name")
        return f"{line} velocity v_{velocity}"
    if isinstance(velocity, bool) or not isinstance(velocity, (int, float)) or not math.isfinite(velocity):
        raise ValueError(f"platen velocity {velocity!r}: a finite number (m/s) or a variable's name")
    return f"{line} velocity {float(velocity)!r}"
