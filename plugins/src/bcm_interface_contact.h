/* One point of a broken bond_style bcm/griffith interface as a cohesionless frictional contact
   (SPEC 1.2 Eq. 1, 7; plugins/doc/bond_bcm_griffith.md, "Broken interface"): the state of the
   point (contact reference shift, slip offset in cell 1's body frame, in-contact flag) around
   the contact law shared with pair_style bcm/contact and fix bcm/wall (bcm_contact_law.h). */

#ifndef BRITTLE_BCM_INTERFACE_CONTACT_H
#define BRITTLE_BCM_INTERFACE_CONTACT_H

#include "bcm_contact_law.h"
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
  double slip = 0.0;      // length of the Coulomb slip at this evaluation
  double fn = 0.0;        // normal force (>= 0) while closed
  bool closed = false;    // the point is a closed contact
};

/* One point of a broken interface as a cohesionless frictional contact (SPEC 1.2 Eq. 1, 7;
   plugins/doc/bond_bcm_griffith.md, "Broken interface"), state pt (C_*): closed while the
   gap g = dn - s < 0, under the contact law of the contact styles (bcm_contact_law.h) with
   overlap -g and the tangential spring u = dt - R1 sigma, sigma the slip offset kept in cell
   1's body frame (the spring turns with the contact and stays in its tangent plane). Sets F
   (on cell 2) and its damping part fd. */
inline Energy point(const Constants &k, const BcmInterfaceKinematics::Pair &p,
                    const BcmInterfaceKinematics::Point &q, double *pt, double *fd, double *F)
{
  Energy out;
  const double *n = p.n;
  const double gap = q.dn - pt[C_SHIFT];
  double slip[3], u[3];
  if (gap < 0.0) {
    if (pt[C_TOUCH] == 0.0) {    // contact onset: the tangential spring starts unloaded
      BcmRigid::rotate_back(p.R1, q.dt, pt + C_SLIP);
      pt[C_TOUCH] = 1.0;
    }
    BcmRigid::rotate(p.R1, pt + C_SLIP, slip);
    for (int c = 0; c < 3; c++) u[c] = q.dt[c] - slip[c];
    const BcmContactLaw::Point law =
        BcmContactLaw::point(k.kc, k.ktc, k.cc, k.mu, -gap, dot(q.dv, n), u, pt[C_FT]);
    if (law.capped) {    // the rest of the tangential displacement became slip
      double moved = 0.0;
      for (int c = 0; c < 3; c++) {
        const double next = q.dt[c] - u[c];
        moved += (next - slip[c]) * (next - slip[c]);
        slip[c] = next;
      }
      BcmRigid::rotate_back(p.R1, slip, pt + C_SLIP);
      out.slip = std::sqrt(moved);
    }
    for (int c = 0; c < 3; c++) {
      fd[c] = (law.fn - law.fel) * n[c];
      F[c] = law.fn * n[c] + law.ft[c];
    }
    pt[C_FT] = law.ftm;
    out.fric = law.slip;
    out.stored = law.stored;
    out.fn = law.fn;
    out.closed = true;
  } else {
    if (pt[C_TOUCH] != 0.0) {    // opening: the tangential spring slips free (f_n = 0)
      BcmRigid::rotate(p.R1, pt + C_SLIP, slip);
      for (int c = 0; c < 3; c++) u[c] = q.dt[c] - slip[c];
      out.fric = BcmFriction::release(pt[C_FT], u);
      pt[C_TOUCH] = 0.0;
    }
    pt[C_FT] = 0.0;
    for (int c = 0; c < 3; c++) F[c] = fd[c] = 0.0;
  }
  return out;
}

}    // namespace BcmInterfaceContact

#endif
