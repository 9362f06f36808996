"""The `model.particle:` sub-section of a BPM run: the particle of an impact (SPEC 3), in SI.

A BPM particle is a jammed packing (LJ units, a = m = u = 1) clipped to the BCM parent shape
(driver/bcm/particle.py: parent_shape, the same `shape`, `diameter` and `diameter_kind`).
Its SI scale comes from the calibration's units (driver/calibration: BpmUnits, calibration.json
`bpm.units`): length a (m), mass m (kg), energy u (J), time tau = a sqrt(m / u). The run itself
is in LJ units; the driver converts the scenario's SI values (velocity, times) and the plane's
contact law into them, and the analysis converts every measure back to SI.

Defaults (until the calibration fills them in): a = d / 12 (about 1100 particles in the 2 mm
parent), m = rho_s a^3 / n* with rho_s = 6000 kg/m^3 and n* = 6 phi / pi = 1.26 particles per
a^3 (phi = 0.66, the 3D packing default), u = E a^3 / E* with E = 10 GPa and E* = 100 u/a^3 (the
network's Young's modulus near k_A = 4, runs/bpm_moduli_3d).
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from driver.bcm.section import FrictionalContact
from driver.schema import _Strict

_A_DEFAULT = 2e-3 / 12.0


class BPMUnits(_Strict):
    """The LJ units of the BPM in SI (calibration.json `bpm.units`, same key names)."""

    length_a_m: float = Field(_A_DEFAULT, gt=0.0, description="length unit a (particle diameter), m")
    mass_m_kg: float = Field(6000.0 * _A_DEFAULT ** 3 / 1.2605, gt=0.0, description="mass unit m (particle mass), kg")
    energy_u_J: float = Field(1e10 * _A_DEFAULT ** 3 / 100.0, gt=0.0, description="energy unit u, J")
    time_tau_s: float | None = Field(
        None, gt=0.0, description="time unit tau = a sqrt(m / u), s: optional (calibration.json carries it); "
                                  "when given it must agree with a, m, u to 1e-6")

    @model_validator(mode="after")
    def _consistent_tau(self) -> "BPMUnits":
        tau = self.length_a_m * (self.mass_m_kg / self.energy_u_J) ** 0.5
        if self.time_tau_s is not None and abs(self.time_tau_s / tau - 1.0) > 1e-6:
            raise ValueError(f"time_tau_s = {self.time_tau_s:.6g} s disagrees with a sqrt(m / u) = {tau:.6g} s")
        return self


class BPMParticle(_Strict):
    """The BPM particle of an impact: the BCM parent shape and size (SPEC 1.1, 3), in SI."""

    shape: Literal["truncated_pentakis_dodecahedron", "cube", "icosphere_like"] = Field(
        "truncated_pentakis_dodecahedron", description="parent shape, as model.shape of the BCM")
    diameter: float = Field(2e-3, gt=0.0, description="parent diameter d, m (as the BCM's model.diameter)")
    diameter_kind: Literal["circumscribed", "equal_volume"] = Field(
        "circumscribed", description="which diameter d is, as the BCM's model.diameter_kind")
    units: BPMUnits = Field(default_factory=BPMUnits, description="LJ units in SI (from the calibration)")
    contact: FrictionalContact = Field(
        default_factory=FrictionalContact,
        description="particle-plane contact (SPEC 1.2-1.3), SI: k_n, k_t (N/m), e_n^2, mu; a sphere of "
                    "diameter a against the plane, damping 2 alpha sqrt(k_n m) with the particle's mass m")
    G_c: float = Field(1.0, gt=0.0, description="fracture energy, J/m^2, for W_f = 2 A G_c and W_s (SPEC 1.5); "
                                                 "from the calibration, G_c = K_IC^2 / E'")
    margin: float = Field(2.0, ge=1.5, le=20.0, description="packing box side = circumscribed diameter / a + "
                                                           "2 margin: the parent stays this many a clear of the "
                                                           "periodic boundaries, beyond the longest bond")
