"""The LAMMPS style lines of a BCM model section (SPEC 1.2): the cell-cell contacts, the
Griffith interfaces with the law of their broken points, and the rigid plane. One place, so
that the impact and the calibration block render the same model alike."""

from __future__ import annotations


def pair_setup(model, r_m: float) -> str:
    """`pair_style bcm/contact` and its coefficients: contacts between cells that share no
    interface (SPEC 1.2), the frictional-contact parameters."""
    c = model.contact
    return (f"pair_style      bcm/contact cells cells.txt rm {r_m:.12g}\n"
            f"pair_coeff      * * {c.kn} {c.kt} {c.en2} {c.mu}")


def bond_setup(model, G_c: float | None = None) -> str:
    """`bond_style bcm/griffith` and its coefficients (SPEC 1.2 Eq. 1-7): the interfaces, the
    Griffith convention, their stiffness mode and the law of their broken points
    (model.broken); G_c overrides model.interface.G_c."""
    c, i, b = model.contact, model.interface, model.broken
    G_c = i.G_c if G_c is None else G_c
    mu = c.mu if b.mu is None else b.mu
    return (f"bond_style      bcm/griffith geometry interfaces.txt energy {model.griffith_energy} "
            f"stiffness {model.interface_stiffness} broken_stiffness {b.stiffness} broken_damping {b.damping} "
            f"break_shear {b.shear_at_break} break_normal {b.normal_at_break} broken_points {b.points}\n"
            f"bond_coeff      1 {i.kn} {i.kt} {i.en2} {G_c:g} {c.kn} {c.kt} {c.en2} {mu}")


def wall_setup(model, r_m: float, fix_id: str = "plane") -> str:
    """`fix bcm/wall`: the rigid plane z = 0 under the contact law (model.contact) with the
    options of model.plane."""
    c, p = model.contact, model.plane
    en2 = c.en2 if p.en2 is None else p.en2
    return (f"fix             {fix_id} all bcm/wall cells cells.txt rm {r_m:.12g} plane zlo 0.0 "
            f"{c.kn} {c.kt} {en2} {c.mu} stiffness {p.stiffness}")
