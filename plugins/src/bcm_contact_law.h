/* The frictional-contact law of the BCM contacts (pair_style bcm/contact between cells,
   fix bcm/wall against the plane, the points of a broken interface of bond_style
   bcm/griffith; SPEC 1.2 Eq. 1, 2, 7), in one place: the three call BcmContactLaw::point()
   for each contact point and add nothing to the law.

   A fixed stiffness per contact point (SPEC 1.2, last bullet: "state the per-point
   stiffness"): the configured k_n and k_t are those of ONE point, whatever the number N of
   points that carry the contact (1 for a vertex, 2 for an edge on a face, the corners of the
   overlap polygon of a face-face contact). A point enters and leaves the contact at zero
   overlap, hence at zero elastic force and zero stored energy, so the contact's elastic
   force is continuous in time and derives from the springs' energy: the law neither creates
   nor destroys energy when N changes (an edge rolling onto a face). A contact of N points at
   equal overlaps is N times stiffer than one point (time step: plugins/doc/pair_bcm_contact.md).
   A broken interface is the exception: its N_p points are fixed, and its configured k_n,c,
   k_t,c are those of the whole interface, N_p points of k_n,c / N_p (bond_style bcm/griffith).

   Per point, overlap o = -delta >= 0, normal velocity v_n = d delta/dt (> 0 separating):
     f_n = k_n o - gamma v_n, clamped at f_n >= 0 (damping may not pull)       (Eq. 1)
     gamma = 2 alpha sqrt(k_n m / N)                                              (Eq. 1, 2)
     f_t = -k_t u_t, |f_t| <= mu f_n (Coulomb, per point; bcm_friction.h)         (Eq. 7)
   with m the reduced mass of the contact (the cell's mass against the plane) shared equally
   by its N points, so that a contact whose N points move together (a face landing flat: N
   springs k_n, mass m) has the damping ratio alpha of Eq. 2, and rebounds with e_n, for any
   N. gamma depends on N: when N changes, the damping force of the other points changes with
   it; the damping force only ever dissipates (its power is -gamma v_n^2 <= 0, or -k_n o v_n
   <= 0 under the clamp), and its work is measured exactly by the styles (bcm_kick_work.h),
   so this changes how fast energy is dissipated, never the energy balance. */

#ifndef BRITTLE_BCM_CONTACT_LAW_H
#define BRITTLE_BCM_CONTACT_LAW_H

#include "bcm_friction.h"

#include <cmath>

namespace BcmContactLaw {

// SPEC 1.2 Eq. 2: damping ratio alpha from the restitution coefficient e = sqrt(e^2)
// (alpha = 1, critical, for e = 0)
inline double damping_ratio(double e2)
{
  if (e2 <= 0.0) return 1.0;
  const double le = std::log(std::sqrt(e2));
  return -le / std::sqrt(le * le + M_PI * M_PI);
}

// SPEC 1.2 Eq. 1: damping coefficient of one point of a contact of np points, reduced mass m
inline double damping(double alpha, double kn, double m, int np)
{
  return 2.0 * alpha * std::sqrt(kn * m / np);
}

struct Point {
  double fn;       // normal force (>= 0), along the contact normal
  double fel;      // its elastic part k_n o; fn - fel is the damping part (clamp included)
  double ft[3];    // tangential force
  double ftm;      // |f_t|, the ft_before of the point's next step
  double slip;     // energy dissipated by the Coulomb cap (counted on advancing steps)
  double stored;   // the point's springs' energy, k_n o^2 / 2 + k_t |u_t|^2 / 2
  bool capped;     // the Coulomb limit brought u back (the rest of the displacement slipped)
};

/* One contact point: overlap o = -delta >= 0, normal velocity vn (> 0 separating), damping
   coefficient gamma (damping()), per-point stiffnesses kn, kt, Coulomb coefficient mu. u is
   the tangential spring u_t, already carried into the current tangent plane and advanced
   over the step by the caller (kt = 0: no tangential force, u untouched); the Coulomb limit
   brings it back to |k_t u_t| = mu f_n. ft_before = |f_t| at the point's last step (the
   trapezoidal slip work, bcm_friction.h). */
inline Point point(double kn, double kt, double gamma, double mu, double o, double vn, double *u,
                   double ft_before)
{
  Point r{};
  r.fel = kn * o;
  r.fn = r.fel - gamma * vn;
  if (r.fn < 0.0) r.fn = 0.0;
  if (kt > 0.0) r.slip = BcmFriction::coulomb(u, r.ft, kt, mu * r.fn, ft_before, r.capped);
  r.ftm = std::sqrt(r.ft[0] * r.ft[0] + r.ft[1] * r.ft[1] + r.ft[2] * r.ft[2]);
  r.stored = 0.5 * kn * o * o;
  if (kt > 0.0) r.stored += 0.5 * kt * (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
  return r;
}

}    // namespace BcmContactLaw

#endif
