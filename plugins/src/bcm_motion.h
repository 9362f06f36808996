/* Motion certificates (issue 27): a bound on how far the points of two rigid cells have moved
   relative to each other since a reference moment, to skip a test whose outcome holds while
   they have moved less than a margin (pair_style bcm/contact: cores apart; bond_style
   bcm/griffith: a broken interface's points open).

   The pair's relative position and orientation in cell 1's body frame,
   P = R_1^T (x_2 - x_1) and M = q_1^* q_2 (R(M) = R_1^T R_2), are kept at the reference
   (P1, M1, in single precision). Seen from cell 1, a point b of cell 2 (body frame) sits at
   P + R(M) b, so it has moved by at most |P - P1| + |R(M) - R(M1)| |b|; a point a of cell 1
   seen from cell 2 sits at R(M)^T (a - P) and has moved by at most
   |P - P1| + |R(M) - R(M1)| (|P1| + |a|). |R(M) - R(M1)| = 2 |Im(M1^* M)| (the chord of
   the relative rotation) for unit quaternions. A height over a plane of one cell, or a gap
   along one cell's normal, of a point of the other thus moves by less than that bound times
   the point's lever arm: the caller gives the lever arm and the margin (the least such
   height or gap less the threshold of its test), and the certificate holds while
   bound < margin. The margin is stored less allowances for the single precision of P1 and
   M1 (1.2e-7 |P1| and 3e-7 times the lever arm: each component relative 2^-24) and for the
   round-off of the quantities it bounds (1e-9 of the lever arm, |P1| and the given size
   `scale`, and 1e-13 of the coordinates). Quaternions more than 1e-12 from unit length get
   none (fix bcm/rigid normalises them every step). 36 bytes. */

#ifndef BRITTLE_BCM_MOTION_H
#define BRITTLE_BCM_MOTION_H

#include "bcm_rigid.h"

#include <algorithm>
#include <cmath>

namespace BcmMotion {

// P = R_1^T (x_2 - x_1) and M = q_1^* q_2 of unit quaternions; false when one is not unit
inline bool relative_state(const double *x1, const double *x2, const double *q1,
                           const double *q2, double *P, double *M)
{
  if (std::fabs(BcmRigid::quat_norm2(q1) - 1.0) > 1.0e-12 ||
      std::fabs(BcmRigid::quat_norm2(q2) - 1.0) > 1.0e-12)
    return false;
  const double D[3] = {x2[0] - x1[0], x2[1] - x1[1], x2[2] - x1[2]};
  // R(q)^T D = D - 2 w (u x D) + 2 u x (u x D), q = (w, u)
  const double w = q1[0], u[3] = {q1[1], q1[2], q1[3]};
  double t[3], t2[3];
  BcmRigid::cross(u, D, t);
  BcmRigid::cross(u, t, t2);
  for (int d = 0; d < 3; d++) P[d] = D[d] - 2.0 * w * t[d] + 2.0 * t2[d];
  // q_1^* q_2 = (w_1 w_2 + u_1 . u_2, w_1 u_2 - w_2 u_1 - u_1 x u_2)
  const double *u2 = q2 + 1;
  double c[3];
  BcmRigid::cross(u, u2, c);
  M[0] = w * q2[0] + BcmRigid::dot(u, u2);
  for (int d = 0; d < 3; d++) M[1 + d] = w * u2[d] - q2[0] * u[d] - c[d];
  return true;
}

struct Cert {
  float p[3], q[4];    // P1, M1
  float margin = -1.0f;    // <= 0: none
  float lever;
};

// a certificate of margin m (> 0 needed) at the current positions and orientations, for
// heights or gaps of points of cell 2 within r2 of its centre seen from cell 1 and of points
// of cell 1 within r1 of its centre seen from cell 2 (r < 0: no such point); scale: the
// cells' size (round-off allowance); false (and c.margin = -1) when none can be given
inline bool certify(Cert &c, const double *x1, const double *x2, const double *q1,
                    const double *q2, double m, double r2, double r1, double scale)
{
  c.margin = -1.0f;
  double P[3], M[4];
  if (!(m > 0.0) || !relative_state(x1, x2, q1, q2, P, M)) return false;
  const double plen = std::sqrt(BcmRigid::dot(P, P));
  const double lever = std::max(r2 >= 0.0 ? r2 : 0.0, r1 >= 0.0 ? plen + r1 : 0.0);
  const double margin = m - 1.2e-7 * plen - 3.0e-7 * lever - 1.0e-9 * (lever + plen + scale) -
      1.0e-13 * (std::fabs(x1[0]) + std::fabs(x1[1]) + std::fabs(x1[2]) + std::fabs(x2[0]) +
                 std::fabs(x2[1]) + std::fabs(x2[2]));
  if (!(margin > 0.0)) return false;
  float mf = static_cast<float>(margin);
  if (static_cast<double>(mf) > margin) mf = std::nextafter(mf, 0.0f);
  float lf = static_cast<float>(lever);
  if (static_cast<double>(lf) < lever) lf = std::nextafter(lf, HUGE_VALF);
  if (!(mf > 0.0f)) return false;
  for (int d = 0; d < 3; d++) c.p[d] = static_cast<float>(P[d]);
  for (int d = 0; d < 4; d++) c.q[d] = static_cast<float>(M[d]);
  c.lever = lf;
  c.margin = mf;
  return true;
}

// the cells have moved relative to each other by less than the certificate's margin
inline bool holds(const Cert &c, const double *x1, const double *x2, const double *q1,
                  const double *q2)
{
  if (!(c.margin > 0.0f)) return false;
  double P[3], M[4];
  if (!relative_state(x1, x2, q1, q2, P, M)) return false;
  const double dp[3] = {P[0] - c.p[0], P[1] - c.p[1], P[2] - c.p[2]};
  // |R(M) - R(M1)| = 2 |Im(M1^* M)|
  const double w1 = c.q[0], u1[3] = {c.q[1], c.q[2], c.q[3]};
  double cr[3], im[3];
  BcmRigid::cross(u1, M + 1, cr);
  for (int d = 0; d < 3; d++) im[d] = w1 * M[1 + d] - M[0] * u1[d] - cr[d];
  const double moved =
      std::sqrt(BcmRigid::dot(dp, dp)) + 2.0 * std::sqrt(BcmRigid::dot(im, im)) * c.lever;
  return moved < c.margin;
}

}    // namespace BcmMotion

#endif
