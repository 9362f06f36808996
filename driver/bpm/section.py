"""The `model:` section of a BPM run (SPEC 2.1-2.2): its keys, defaults and limits."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from driver.assembly import AssemblySection
from driver.bpm.particle_section import BPMParticle
from driver.schema import _Strict

#: Default nominal packing fractions, just above jamming (see driver/bpm/packing.py).
DEFAULT_PHI = {2: 0.86, 3: 0.66}
#: The two 3D preparations (model.packing) and the factor s by which each scales the jammed
#: packing of driver/bpm/packing.py (positions and box; particle diameters stay a):
#: `contact`: nearest neighbours in contact, at about a (the repulsion's diameter);
#: `lj_minimum`: nearest neighbours at about 2^(1/6) a, the minimum of a Lennard-Jones
#: potential of sigma = a, as LJ-style initialisations prepare them. Same topology, number
#: densities in ratio s^3 = 2^(1/2).
PACKING_SCALE = {"contact": 1.0, "lj_minimum": 2.0 ** (1.0 / 6.0)}
#: SPEC 2.1: 3D bonds are the Delaunay edges shorter than 5/4 * 2^(1/6) a. Its expected counts
#: (about 11 bonds and 24 angles per particle) are those of a packing whose nearest neighbours
#: lie at about 2^(1/6) a (`lj_minimum`), with the cut read literally; on the `contact` packing
#: the same topology needs 5/4 a (5/4 * 2^(1/6) a there gives 13.4 and 33.8, measured).
#: The default cut follows the packing: 5/4 a * PACKING_SCALE[packing].
MAX_BOND_LENGTH_3D = 1.25


class BPMModel(_Strict):
    """Clemmer-Robbins bonded particle model (SPEC 2.1-2.2), LJ reduced units (a = m = u = 1)."""

    kind: Literal["bpm"] = Field("bpm", description="bpm: the Clemmer-Robbins bonded particle model")
    dimension: Literal[2, 3] = Field(2, description="2: bidisperse disks; 3: monodisperse spheres")
    L: float = Field(24.0, ge=6.0, le=5000.0, description="periodic box side, in particle diameters a")
    packing_fraction: float | None = Field(
        None, gt=0.3, lt=0.95,
        description="area/volume fraction before relaxation; default just above jamming, DEFAULT_PHI (filled "
                    "in when the config is read)")
    lambda_c: float = Field(1.05, gt=1.0, le=2.0, description="critical bond stretch r/r0 (Eq. 2)")
    theta_c_deg: float = Field(10.0, gt=0.0, lt=180.0, description="critical angle change (Eq. 3), degrees")
    k_A: float = Field(4.0, ge=0.0, le=100.0, description="angle stiffness (Eq. 3), units of u")
    gamma: float = Field(50.0, ge=0.0, description="damping (Eq. 5), units sqrt(m u)/a")
    timestep: float = Field(0.005, gt=0.0, le=0.02, description="velocity-Verlet step, units sqrt(m a^2/u)")
    packing: Literal["contact", "lj_minimum"] | None = Field(
        None, description="3D only: contact (nearest neighbours at about a, the default) or lj_minimum (at about "
                          "2^(1/6) a: the contact packing scaled by 2^(1/6), box side still L); both keep the "
                          "repulsion diameter a. Filled in when the config is read; refused in 2D, which has one "
                          "preparation")
    bond_max_length: float | None = Field(
        None, gt=1.0, description="3D Delaunay edge cut; default 5/4 a on the contact packing, 5/4 * 2^(1/6) a on "
                                  "lj_minimum (SPEC 2.1, MAX_BOND_LENGTH_3D * PACKING_SCALE, filled in when the "
                                  "config is read); not used in 2D, where it stays empty")
    skin: float = Field(0.3, gt=0.0, le=2.0, description="neighbour-list skin, units of a")
    particle: BPMParticle | None = Field(
        None, description="scenarios impact, crush and compress: the particle (parent shape and size, SI units, "
                          "plane contact, G_c; driver/bpm/particle_section.py), filled with its defaults when the "
                          "config is read; in a bed (model.assembly) the grains' shape, units and the walls' contact")
    assembly: AssemblySection | None = Field(
        None, description="scenario compress only: the bed of grains (number, sizes, box; driver/assembly.py), "
                          "each grain a particle of model.particle at its own diameter (driver/bpm/bed.py)")

    @model_validator(mode="after")
    def _resolve_defaults(self) -> "BPMModel":
        # config.resolved.yaml holds the values the run uses, not null
        if self.packing_fraction is None:
            self.packing_fraction = DEFAULT_PHI[self.dimension]
        if self.dimension == 2:
            # the 2D bidisperse packing has one preparation: a choice here would be ignored
            if self.packing is not None:
                raise ValueError(f"packing = {self.packing!r}: a 3D option (the 2D packing has one preparation); "
                                 "leave it out in 2D")
            return self
        if self.packing is None:
            self.packing = "contact"
        if self.bond_max_length is None:
            self.bond_max_length = MAX_BOND_LENGTH_3D * PACKING_SCALE[self.packing]
        return self
