"""The `model:` section of a BCM run (SPEC 1): its keys, defaults and limits."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from driver.assembly import AssemblySection
from driver.schema import _Strict

# The time step is dt = 2 pi sqrt((m_min / 2) / k_max) / steps_per_period (driver/bcm/particle.py
# contact_timestep). The fastest motions are faster than that period says: a whole cell face
# on the plane (k_n and k_t at each of its N points, rocking the cell about its centroid) is up
# to 3.6x faster, and velocity Verlet blows up past omega dt = 2. Measured and derived in
# bench/timestep_study.py (docs/models/bcm-timestep.md).
MIN_STEPS_PER_PERIOD = 12.0


def check_steps_per_period(value: float) -> float:
    """Refuse a time step above the stability limit (a field validator of the BCM scenarios)."""
    if value < MIN_STEPS_PER_PERIOD:
        raise ValueError(f"steps_per_period = {value:g} is below the stability limit {MIN_STEPS_PER_PERIOD:g}: "
                         f"the time step would exceed 2 / omega of the stiffest contacts (a cell face on the plane "
                         f"or on another cell) and the run would blow up; use {MIN_STEPS_PER_PERIOD:g} or more "
                         f"(docs/models/bcm-timestep.md)")
    return value


class CohesiveInterface(_Strict):
    """Glued face between two cells (SPEC 1.2-1.3), whole-interface values, SI units."""

    kn: float = Field(1e7, gt=0.0, description="normal stiffness, N/m")
    kt: float = Field(0.8e7, gt=0.0, description="tangential stiffness, N/m")
    en2: float = Field(0.999, ge=0.0, le=1.0, description="squared normal restitution e_n^2")
    G_c: float = Field(1.0, gt=0.0, description="fracture energy, J/m^2")


class FrictionalContact(_Strict):
    """Cohesionless contact: broken interfaces, cell-cell and cell-plane contacts (SPEC 1.2-1.3)."""

    kn: float = Field(1e8, gt=0.0, description="normal stiffness, N/m")
    kt: float = Field(8e7, gt=0.0, description="tangential stiffness, N/m")
    en2: float = Field(0.001, ge=0.0, le=1.0, description="squared normal restitution e_n^2")
    mu: float = Field(0.3, ge=0.0, description="Coulomb friction coefficient mu_s")


class BrokenInterface(_Strict):
    """The law of a broken interface's closed points (SPEC 1.2, "After breaking"; the options
    of issue 23, docs: the BCM below break-up). Each point of a broken interface is a
    cohesionless frictional contact; these keys say which stiffness, damping and friction it
    has, and what its tangential spring holds at the break."""

    stiffness: Literal["contact", "interface"] = Field(
        "contact", description="k_n, k_t of a closed point: `contact` = the frictional contact's (model.contact, "
                               "whole interface, split over its N_p points; SPEC 1.2 read literally), `interface` = the "
                               "intact interface's own (a closed crack as stiff as the material it cut: forces and "
                               "energy continuous at the break)")
    # interface by default (issue 23): the intact interface's dashpot carries on through the break,
    # as its elastic force does (the shift below); with the contact's e_n the damping force of a
    # closed point would jump ~10^4-fold at the break (alpha 3e-4 -> 0.91, sqrt(k_c/k_p) ~ 3)
    damping: Literal["contact", "interface"] = Field(
        "interface", description="e_n of a closed point: `interface` = model.interface.en2 (the default: the "
                                 "damping force continuous through the break, like the elastic one), `contact` = "
                                 "model.contact.en2 (SPEC 1.2 read literally: the damping force jumps at the break)")
    shear_at_break: Literal["carried", "released"] = Field(
        "carried", description="the tangential spring of a point closed at the break: `carried` into the contact "
                               "(its force kept, then the Coulomb cap: the part above mu f_n lost at once), or "
                               "`released` (the contact starts unloaded; the spring's energy is lost at the switch)")
    normal_at_break: Literal["shifted", "unshifted"] = Field(
        "shifted", description="the normal spring of a point closed at the break: `shifted` keeps its normal force "
                               "(the overlap's reference moved; SPEC 1.2: the switch must not create energy), "
                               "`unshifted` takes the overlap itself under the contact stiffness, as the reference "
                               "code Rockable does: a diagnostic that creates energy at every break in compression "
                               "(a negative W_switch)")
    points: Literal["polygon", "cells"] = Field(
        "polygon", description="where a broken interface touches: `polygon` = the glued face's vertices until "
                               "the cells part (SPEC 1.2; the reference code keeps them too), `cells` = handed to the "
                               "cell-cell contact (the rounded cells' own geometry) at the break itself: a "
                               "diagnostic; a hand-over in compression creates the contact's overlap energy, "
                               "which shows in the impact's balance residual")
    mu: float | None = Field(None, ge=0.0, description="friction coefficient on broken interfaces; null = "
                                                       "model.contact.mu (0 bounds what friction can explain)")


class Plane(_Strict):
    """The rigid plane's contact law (SPEC 1.2, last bullets): the frictional-contact
    parameters of model.contact at each touching cell vertex, or the options below."""

    stiffness: Literal["per_point", "per_cell"] = Field(
        "per_point", description="`per_point`: k_n, k_t at every touching vertex (SPEC 1.2: continuous when vertices "
                                 "come and go); `per_cell`: the cell's k_n, k_t shared by its touching vertices (the "
                                 "energy of a re-split is booked as W_wall_npoints)")
    en2: float | None = Field(None, ge=0.0, le=1.0, description="squared restitution e_n^2 of the plane's contacts; "
                                                                "null = model.contact.en2")


class BCMModel(_Strict):
    """Bonded cell method (SPEC 1): a particle tessellated into rigid Voronoi cells, SI units."""

    kind: Literal["bcm"] = Field("bcm", description="bcm: the bonded cell method")
    shape: Literal["truncated_pentakis_dodecahedron", "cube", "icosphere_like"] = Field(
        "truncated_pentakis_dodecahedron",
        description="parent shape: truncated_pentakis_dodecahedron (GP(3,0), 92 faces: 12 regular pentagons, 20 "
                    "regular hexagons, 60 mirror-symmetric hexagons), cube or icosphere_like")
    diameter: float = Field(2e-3, gt=0.0, description="parent diameter, m")
    diameter_kind: Literal["circumscribed", "equal_volume"] = Field(
        "circumscribed", description="which diameter `diameter` is: of the circumscribed sphere, or of the sphere of "
                                     "the parent's volume")
    n_cells: int = Field(1728, ge=2, le=200_000, description="number of Voronoi cells N_c")
    density: float = Field(6000.0, gt=0.0, description="solid density rho_s, kg/m^3")
    rounding: float = Field(0.02, ge=0.0, lt=0.3,
                            description="rounding radius r_m as a fraction of the mean cell size h = (V/N_c)^(1/3)")
    interface: CohesiveInterface = Field(
        default_factory=CohesiveInterface,
        description="cohesive interfaces: whole-interface stiffness, split over the interface's N_p points")
    contact: FrictionalContact = Field(
        default_factory=FrictionalContact,
        description="frictional contacts: cell-cell and cell-plane (k_n, k_t per contact point), and broken "
                    "interfaces (k_n, k_t of the whole interface, split over its N_p points; model.broken)")
    broken: BrokenInterface = Field(
        default_factory=BrokenInterface,
        description="the law of a broken interface's closed points: stiffness, damping, friction, and what its "
                    "tangential spring keeps at the break")
    plane: Plane = Field(default_factory=Plane, description="the rigid plane's contact law (stiffness per vertex or "
                                                            "per cell, its restitution)")
    griffith_energy: Literal["stored", "rockable", "literal"] = Field(
        "stored", description="energy in the Griffith criterion (SPEC 1.2): what the springs store (default), "
                              "Rockable's N_p-fold sum, or Eq. 5 read literally (1/N_p)")
    interface_stiffness: Literal["per_interface", "per_area"] = Field(
        "per_interface", description="per_interface: every interface has the configured k_n, k_t (the published "
                                     "model); per_area: k_n, k_t times S / <S>, the interface's area over the mean "
                                     "bonded area, so the Griffith threshold is a stress criterion")
    min_interface_area: float = Field(
        0.0, ge=0.0, lt=1.0, description="shared faces smaller than this fraction of the median face area are not "
                                         "bonded (their cells only touch as contacts); 0 = every face bonded, the "
                                         "published model. A_0 and D_w count bonded interfaces only")
    lloyd_tol: float = Field(2e-3, gt=0.0, lt=0.1, description="Lloyd stop: RMS seed step / h")
    lloyd_max_iter: int = Field(400, ge=0, le=10_000, description="Lloyd stop: at most this many iterations")
    assembly: AssemblySection | None = Field(
        None, description="a bed of many grains of this particle (scenario compress): their number, sizes and box; "
                          "each grain is a tessellation of the parent from a cached pool, scaled to its size")
