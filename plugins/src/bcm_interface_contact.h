/* One point of a broken bond_style bcm/griffith interface as a cohesionless frictional contact
   (SPEC 1.2 Eq. 1, 7; plugins/doc/bond_bcm_griffith.md, "Broken interface"): the state of the
   point (contact reference shift, slip offset in cell 1's body frame, in-contact flag) around
   the contact law. */

#ifndef BRITTLE_BCM_INTERFACE_CONTACT_H
#define BRITTLE_BCM_INTERFACE_CONTACT_H

#include "bcm_interface_kinematics.h"
#include "bcm_interface_state.h"
#include "bcm_rigid.h"

#include <cmath>

namespace BcmInterfaceContact {

using namespace BcmInterfaceState;
using BcmRigid::dot;

// per-point constants of a broken interface's contact law
struct Constants {
  double kc, ktc, cc, mu;    // k_n,c / N_p, k_t,c / N_p, 2 alpha_c sqrt(k_n,c m) / N_p, mu
};

// what a contact point gives besides its forces
struct Energy {
  double fric = 0.0;      // dissipated by friction at this evaluation
  double stored = 0.0;    // the point's springs' energy
};

/* One point of a broken interface as a cohesionless frictional contact (SPEC 1.2 Eq. 1, 7;
   plugins/doc/bond_bcm_griffith.md, "Broken interface"), state pt (C_*): closed while the
   gap g = dn - s < 0. Sets F (on cell 2) and its damping part fd. */
inline Energy point(const Constants &k, const BcmInterfaceKinematics::Pair &p,
                    const BcmInterfaceKinematics::Point &q, double *pt, double *fd, double *F)
{
  Energy out;
  const double kc = k.kc, ktc = k.ktc, cc = k.cc, muf = k.mu;
  const double *n = p.n;
  const double gap = q.dn - pt[C_SHIFT];
  if (gap < 0.0) {
    double slip[3], u[3];
    if (pt[C_TOUCH] == 0.0) {    // contact onset: the tangential spring starts unloaded
      BcmRigid::rotate_back(p.R1, q.dt, pt + C_SLIP);
      pt[C_TOUCH] = 1.0;
    }
    const double fn_el = -kc * gap;
    double fn = fn_el - cc * dot(q.dv, n);
    if (fn < 0.0) fn = 0.0;    // damping may not pull
    BcmRigid::rotate(p.R1, pt + C_SLIP, slip);
    for (int c = 0; c < 3; c++) u[c] = q.dt[c] - slip[c];
    const double uu = dot(u, u);
    const double limit = muf * fn;
    if (ktc * ktc * uu > limit * limit) {
      // Coulomb limit: the spring is brought back to |k_tc u| = mu f_n along u, the
      // rest of the tangential displacement becomes slip. Dissipated: the mean of the
      // force magnitudes at the last and this evaluation times the slip, which is the
      // work of the force less the change of the spring energy over the step
      const double len = std::sqrt(uu);
      const double scale = limit / (ktc * len);
      out.fric = 0.5 * (pt[C_FT] + limit) * len * (1.0 - scale);
      for (int c = 0; c < 3; c++) {
        u[c] *= scale;
        slip[c] = q.dt[c] - u[c];
      }
      BcmRigid::rotate_back(p.R1, slip, pt + C_SLIP);
    }
    for (int c = 0; c < 3; c++) {
      fd[c] = (fn - fn_el) * n[c];
      F[c] = fn * n[c] - ktc * u[c];
    }
    pt[C_FT] = ktc * std::sqrt(dot(u, u));
    out.stored = 0.5 * kc * gap * gap + 0.5 * ktc * dot(u, u);
  } else {
    if (pt[C_TOUCH] != 0.0) {    // opening: the tangential spring slips free (f_n = 0)
      double slip[3], u[3];
      BcmRigid::rotate(p.R1, pt + C_SLIP, slip);
      for (int c = 0; c < 3; c++) u[c] = q.dt[c] - slip[c];
      out.fric = 0.5 * pt[C_FT] * std::sqrt(dot(u, u));
      pt[C_TOUCH] = 0.0;
    }
    pt[C_FT] = 0.0;
    for (int c = 0; c < 3; c++) F[c] = fd[c] = 0.0;
  }
  return out;
}

}    // namespace BcmInterfaceContact

#endif
