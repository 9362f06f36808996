"""From measured calibration curves to a model's parameters (issue 12, point 3): pure functions.

A curve is a parameter x (k_A, lambda_c, k_t / k_n, G_c) against a measured property y (nu,
K_IC / E, released energy), the means over seeds at each x. `invert` finds the x whose y is the
target by linear interpolation between measured points, never beyond them: a target outside the
measured range is out of the model's reach, and the nearest reachable value is given with it
(nothing is clipped silently).

BPM (SPEC 2; LJ units a, m, u from SI):
    a = diameter / particles_across (or particle_size)
    k_A from nu(k_A);  E*, n* = E and number density (per a^d) of the network at that k_A
    m = rho a^3 / n*   (2D: a slab of thickness a, n* per a^2)
    u = E a^3 / E*     (2D: the 2D modulus E* in u / a^2 over the thickness a)
    tau = a sqrt(m / u)
    lambda_c from (K_IC / E)*(lambda_c) = K_IC / (E sqrt(a)), K_IC* in u / a^(5/2) (2D:
      u / a^(3/2) per thickness a); K_IC of a target given by G_c: sqrt(G_c E').
BCM (SPEC 1; springs in N/m, cells of size h): a block of cells scaled by h with k_n, k_t
fixed has moduli scaled by 1 / h (every spring force is k delta, every stress force / h^2,
every strain delta / h), so the curves are measured once at a reference (k_n0, h0) as
e(k_t / k_n) = E h / k_n and nu(k_t / k_n):
    k_t / k_n from nu;  k_n = E h / e;  k_t = (k_t / k_n) k_n
    interface G_c from the fracture curve: released energy per new crack area against G_c
      (linear through zero), G_c = target G_c / slope.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np


@dataclass(frozen=True)
class Inverse:
    """The parameter x at which a curve reaches `target`, or the nearest it can."""

    x: float
    y: float          # the curve's value at x: the target when reached
    target: float
    reached: bool
    note: str         # why not reached, or that the curve is not monotonic; '' otherwise

    def as_dict(self) -> dict:
        return asdict(self)


def invert(xs, ys, target: float, x_name: str, y_name: str) -> Inverse:
    """The x where the piecewise-linear curve (xs, ys) equals `target` (first crossing by
    increasing x); out of range: the measured point nearest the target, reached = False."""
    x = np.asarray(xs, float)
    y = np.asarray(ys, float)
    order = np.argsort(x)
    x, y = x[order], y[order]
    if len(x) == 0 or not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise ValueError(f"the curve of {y_name} against {x_name} is empty or has non-finite points")
    if len(x) == 1:
        ok = math.isclose(y[0], target, rel_tol=1e-9)
        return Inverse(float(x[0]), float(y[0]), target, ok, "" if ok else
                       f"{y_name} = {target:.4g} is out of reach: one point measured ({y_name} = {y[0]:.4g} at "
                       f"{x_name} = {x[0]:.4g})")
    d = y - target
    hits = [i for i in range(len(x) - 1) if d[i] == 0.0 or d[i] * d[i + 1] < 0.0] + \
           ([len(x) - 1] if d[-1] == 0.0 else [])
    monotone = bool(np.all(np.diff(y) > 0) or np.all(np.diff(y) < 0))
    shape = "" if monotone else f" (the measured {y_name} is not monotonic in {x_name}: the first crossing is used)"
    if hits:
        i = hits[0]
        if i == len(x) - 1 or d[i] == 0.0:
            return Inverse(float(x[i]), float(y[i]), target, True, shape.strip(" ()"))
        t = d[i] / (d[i] - d[i + 1])
        return Inverse(float(x[i] + t * (x[i + 1] - x[i])), float(target), target, True, shape.strip(" ()"))
    k = int(np.argmin(np.abs(d)))
    return Inverse(float(x[k]), float(y[k]), target, False,
                   f"{y_name} = {target:.4g} is out of reach: over {x_name} from {x[0]:.4g} to {x[-1]:.4g} the "
                   f"model gives {y_name} from {y.min():.4g} to {y.max():.4g}; nearest reachable {y[k]:.4g} at "
                   f"{x_name} = {x[k]:.4g}")


def interpolate(xs, ys, x: float) -> float:
    """The piecewise-linear curve at x (inside the measured range: x comes from `invert`)."""
    order = np.argsort(np.asarray(xs, float))
    return float(np.interp(x, np.asarray(xs, float)[order], np.asarray(ys, float)[order]))


# ----------------------------------------------------------------------------------------- BPM
@dataclass(frozen=True)
class BpmUnits:
    """The LJ units of the BPM in SI: length a (m), mass m (kg), energy u (J), time tau (s)."""

    a: float
    m: float
    u: float

    @property
    def tau(self) -> float:
        return self.a * math.sqrt(self.m / self.u)

    def as_dict(self) -> dict:
        return {"length_a_m": self.a, "mass_m_kg": self.m, "energy_u_J": self.u, "time_tau_s": self.tau}


def bpm_elastic(nu: float, E: float, density: float, a: float, k_A, nu_curve, E_curve, n_curve
                ) -> tuple[Inverse, BpmUnits, dict]:
    """k_A from nu, then the units (module docstring): (k_A's inverse, units, the network's
    reduced E* and n* at k_A)."""
    inv = invert(k_A, nu_curve, nu, "k_A", "nu")
    E_red = interpolate(k_A, E_curve, inv.x)
    n_red = interpolate(k_A, n_curve, inv.x)
    units = BpmUnits(a=a, m=density * a ** 3 / n_red, u=E * a ** 3 / E_red)
    return inv, units, {"E_reduced": E_red, "number_density_reduced": n_red}


def bpm_lambda_c(K_IC: float, E: float, a: float, lambda_c, K_red_curve, E_red: float) -> Inverse:
    """lambda_c where the network's K_IC* / E* equals the target's K_IC / (E sqrt(a)); the curve
    is interpolated in log(K_IC* / E*) against log(lambda_c - 1), where it is nearly a line
    (K_IC ~ E sqrt(a) (lambda_c - 1): the strain at failure is the bonds' break strain)."""
    lc = np.asarray(lambda_c, float)
    ratio = np.asarray(K_red_curve, float) / E_red
    if np.any(lc <= 1.0) or np.any(ratio <= 0.0):
        raise ValueError("the mode-I curve needs lambda_c > 1 and K_IC > 0 at every point")
    target = K_IC / (E * math.sqrt(a))
    inv = invert(np.log(lc - 1.0), np.log(ratio), math.log(target), "log(lambda_c - 1)", "log(K_IC / (E sqrt(a)))")
    note = inv.note
    if not inv.reached:
        k = int(np.argmin(np.abs(np.log(ratio) - math.log(target))))
        note = (f"K_IC / (E sqrt(a)) = {target:.4g} is out of reach: over lambda_c from {lc.min():.4g} to "
                f"{lc.max():.4g} the network gives {ratio.min():.4g} to {ratio.max():.4g}; nearest reachable "
                f"{ratio[k]:.4g} at lambda_c = {lc[k]:.4g}")
    return Inverse(1.0 + math.exp(inv.x), math.exp(inv.y), target, inv.reached, note)


# ----------------------------------------------------------------------------------------- BCM
def bcm_elastic(nu: float, E: float, h: float, ratio, nu_curve, e_curve) -> tuple[Inverse, dict]:
    """k_t / k_n from nu, then k_n = E h / e(k_t / k_n) and k_t (module docstring)."""
    inv = invert(ratio, nu_curve, nu, "k_t/k_n", "nu")
    e = interpolate(ratio, e_curve, inv.x)
    kn = E * h / e
    return inv, {"kn": kn, "kt": inv.x * kn, "kt_over_kn": inv.x, "E_h_over_kn": e, "cell_size_m": h}


def through_zero_slope(x, y) -> tuple[float, float]:
    """(slope, its standard error) of y = s x by least squares."""
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    s = float(x @ y / (x @ x))
    if len(x) < 2:
        return s, float("nan")
    resid = y - s * x
    return s, float(math.sqrt(resid @ resid / (len(x) - 1) / (x @ x)))
