/* SPEC 1.2 Eq. 7 for the BCM contacts (pair_style bcm/contact, fix bcm/wall, the broken
   interfaces of bond_style bcm/griffith): the Coulomb limit of a tangential spring and the
   energy its slip dissipates, in one place. */

#ifndef BRITTLE_BCM_FRICTION_H
#define BRITTLE_BCM_FRICTION_H

#include <cmath>

namespace BcmFriction {

/* Tangential force ft = -kt u of the spring u; if |ft| > fmax = mu f_n, the spring goes back
   along itself to |ft| = fmax (capped) and the rest is slip. Returns the energy dissipated by
   that slip: the mean of the force magnitudes at the last evaluation (ft_before) and now,
   times the slip -- the trapezoidal work of the force over the step less the change of the
   spring energy. */
inline double coulomb(double *u, double *ft, double kt, double fmax, double ft_before,
                      bool &capped)
{
  for (int d = 0; d < 3; d++) ft[d] = -kt * u[d];
  const double ftm = std::sqrt(ft[0] * ft[0] + ft[1] * ft[1] + ft[2] * ft[2]);
  capped = !(ftm <= fmax);
  if (!capped) return 0.0;
  const double scale = fmax / ftm;
  for (int d = 0; d < 3; d++) {
    ft[d] *= scale;
    u[d] = -ft[d] / kt;
  }
  return 0.5 * (ft_before + fmax) * (ftm - fmax) / kt;
}

/* A point that stops touching (f_n has come down to 0): its spring u slips free. The same
   trapezoidal rule, |f_t| going from ft_before to 0 over the slip |u|: 0.5 ft_before |u|. */
inline double release(double ft_before, const double *u)
{
  return 0.5 * ft_before * std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
}

}    // namespace BcmFriction

#endif
