/* Rigid-cell conventions shared by the BCM styles (integrator, interfaces, contacts, wall).

   A BCM cell is one atom of `atom_style hybrid bond sphere`: x, v, f, rmass, radius (a
   bounding radius, for neighbour lists only), omega (space-frame angular velocity, kept up
   to date by the integrator for output) and torque. Its orientation and full inertia live in
   per-atom arrays of `fix property/atom` declared by the input before read_data:
       d2_bcm_quat 4     unit quaternion (w, x, y, z) rotating body frame -> space frame
       d2_bcm_inertia 3  principal moments (body axes are the principal axes)
       d2_bcm_angmom 3   angular momentum in the space frame
   with `ghost yes`; the integrator forward-communicates d2_bcm_quat every step, so ghost
   cells always carry their current orientation. A material point b (body frame) of cell i
   is at  x_i + R(q_i) b  in space. */

#ifndef BRITTLE_BCM_RIGID_H
#define BRITTLE_BCM_RIGID_H

#include <cmath>

namespace BcmRigid {

constexpr const char *QUAT = "bcm_quat";
constexpr const char *INERTIA = "bcm_inertia";
constexpr const char *ANGMOM = "bcm_angmom";

/* rotation matrix R(q) of a unit quaternion q = (w, x, y, z) */
inline void quat_to_mat(const double *q, double R[3][3])
{
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  R[0][0] = w * w + x * x - y * y - z * z;
  R[0][1] = 2.0 * (x * y - w * z);
  R[0][2] = 2.0 * (x * z + w * y);
  R[1][0] = 2.0 * (x * y + w * z);
  R[1][1] = w * w - x * x + y * y - z * z;
  R[1][2] = 2.0 * (y * z - w * x);
  R[2][0] = 2.0 * (x * z - w * y);
  R[2][1] = 2.0 * (y * z + w * x);
  R[2][2] = w * w - x * x - y * y + z * z;
}

/* out = R b (body -> space) */
inline void rotate(const double R[3][3], const double *b, double *out)
{
  for (int k = 0; k < 3; k++) out[k] = R[k][0] * b[0] + R[k][1] * b[1] + R[k][2] * b[2];
}

/* out = R^T s (space -> body) */
inline void rotate_back(const double R[3][3], const double *s, double *out)
{
  for (int k = 0; k < 3; k++) out[k] = R[0][k] * s[0] + R[1][k] * s[1] + R[2][k] * s[2];
}

inline void cross(const double *a, const double *b, double *out)
{
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}

inline double dot(const double *a, const double *b)
{
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

inline double quat_norm2(const double *q)
{
  return q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
}

inline void normalize_quat(double *q)
{
  const double n = 1.0 / std::sqrt(quat_norm2(q));
  for (int k = 0; k < 4; k++) q[k] *= n;
}

/* R of a stored orientation q, normalised first (q itself is left as it is); a zero q (a
   cell without orientation) gives R = 0 */
inline void rotation(const double *q, double R[3][3])
{
  double u[4] = {q[0], q[1], q[2], q[3]};
  if (quat_norm2(u) > 0.0) normalize_quat(u);
  quat_to_mat(u, R);
}

}    // namespace BcmRigid

#endif
