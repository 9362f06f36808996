/* fix bcm/rigid (see fix_bcm_rigid.h and plugins/doc/fix_bcm_rigid.md).

   One step of length h, per cell (m = rmass, I = principal moments, L = space-frame angular
   momentum, q = orientation, tau = atom->torque):
     initial_integrate:  v += (h/2) f/m;  x += h v;  L += (h/2) tau;
                         free rotor over h by NO_SQUISH: with Lb = R(q)^T L, the exact flows
                         of Lb_k^2 / (2 I_k) in the symmetric order 3 (h/2), 2 (h/2), 1 (h),
                         2 (h/2), 3 (h/2). Each flow turns the body by phi = h' Lb_k / I_k about
                         its body axis k (q <- q (cos phi/2, sin phi/2 e_k)) and the body
                         components of L by -phi (L itself is fixed in space).
     pre_force:          forward communication of q, so ghost cells carry the new orientation
     final_integrate:    v += (h/2) f/m;  L += (h/2) tau;
   and omega = R (I^-1 Lb) after every update of q or L. */

#include "fix_bcm_rigid.h"

#include "atom.h"
#include "bcm_orientation.h"
#include "bcm_rigid.h"
#include "breakable_util.h"
#include "comm.h"
#include "error.h"
#include "force.h"
#include "update.h"

#include <algorithm>
#include <cmath>
#include <mpi.h>

using namespace LAMMPS_NS;
using namespace FixConst;

namespace {

// cells whose free rotors are integrated side by side: each cell's arithmetic is the same
// operations in the same order as one at a time, but the cells' chains of dependent
// divisions, sincos and square roots interleave (one cell's step is a single chain)
constexpr int BATCH = 4;

// exact flow of the rotor piece Lb[k]^2 / (2 I_k) over time h (one NO_SQUISH substep), for
// n cells at once; hh = h / 2
template <int k>
inline void rotate_about_body_axis(int n, double hh, const double (*in)[3], double (*q)[4],
                                   double (*lb)[3])
{
  constexpr int a = (k + 1) % 3, b = (k + 2) % 3;
  double half[BATCH], c2[BATCH], s2[BATCH];
  for (int c = 0; c < n; c++) half[c] = hh * lb[c][k] / in[c][k];
  for (int c = 0; c < n; c++) {
    c2[c] = std::cos(half[c]);
    s2[c] = std::sin(half[c]);
  }
  for (int c = 0; c < n; c++) {
    // cos, sin of the full angle
    const double cc = c2[c] * c2[c] - s2[c] * s2[c], s = 2.0 * s2[c] * c2[c];

    // body components of L turn by -phi about axis k (L is fixed in space)
    const double la = lb[c][a], lbb = lb[c][b];
    lb[c][a] = cc * la + s * lbb;
    lb[c][b] = -s * la + cc * lbb;

    // q <- q * (cos(phi/2), sin(phi/2) e_k); vector part of q is q[1..3]
    double *qc = q[c];
    const double w = qc[0], vk = qc[1 + k], va = qc[1 + a], vb = qc[1 + b];
    qc[0] = c2[c] * w - s2[c] * vk;
    qc[1 + k] = c2[c] * vk + s2[c] * w;
    qc[1 + a] = c2[c] * va + s2[c] * vb;
    qc[1 + b] = c2[c] * vb - s2[c] * va;
  }
}

// omega = R I^-1 R^T L of one cell (the cell's q, moments, L and omega rows)
inline void omega_of(const double *q, const double *in, const double *angmom, double *omega)
{
  double R[3][3], lb[3];
  BcmRigid::quat_to_mat(q, R);
  BcmRigid::rotate_back(R, angmom, lb);
  for (int k = 0; k < 3; k++) lb[k] /= in[k];
  BcmRigid::rotate(R, lb, omega);
}

}    // namespace

/* The free rotors of four cells in the four lanes of AVX registers (taken when the processor
   has AVX: BreakableUtil::avx_loops()): each lane is one cell's arithmetic, the same
   operations in the same order as free_rotors() (no FMA: AVX alone), so bit for bit its
   results; sincos one lane at a time. */
#if defined(BRITTLE_AVX_LOOPS)
#pragma GCC push_options
#pragma GCC target("avx")
namespace {
namespace avx {
#include "lanes4_avx.h"
using V = Lanes4;

// R(q), as BcmRigid::quat_to_mat
inline void quat_to_mat(const V *q, V R[3][3])
{
  const V w = q[0], x = q[1], y = q[2], z = q[3];
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

template <int k>
inline void rotate_about_body_axis(V hh, const V *in, V *q, V *lb)
{
  constexpr int a = (k + 1) % 3, b = (k + 2) % 3;
  const V half = hh * lb[k] / in[k];
  V c2, s2;
  for (int c = 0; c < 4; c++) {
    c2[c] = std::cos(half[c]);
    s2[c] = std::sin(half[c]);
  }
  const V cc = c2 * c2 - s2 * s2, s = 2.0 * s2 * c2;
  const V la = lb[a], lbb = lb[b];
  lb[a] = cc * la + s * lbb;
  lb[b] = -s * la + cc * lbb;
  const V w = q[0], vk = q[1 + k], va = q[1 + a], vb = q[1 + b];
  q[0] = c2 * w - s2 * vk;
  q[1 + k] = c2 * vk + s2 * w;
  q[1 + a] = c2 * va + s2 * vb;
  q[1 + b] = c2 * vb - s2 * va;
}

// four cells' orientations, inertia and angular momenta in the lanes; R(q) and the body-frame
// angular momentum lb = R^T L
inline void gather_body(const int *batch, double **quat, double **inertia, double **angmom, V *q,
                        V *in, V *lb, V R[3][3])
{
  V L[3];
  for (int c = 0; c < 4; c++) {
    const int i = batch[c];
    for (int k = 0; k < 4; k++) q[k][c] = quat[i][k];
    for (int k = 0; k < 3; k++) {
      in[k][c] = inertia[i][k];
      L[k][c] = angmom[i][k];
    }
  }
  quat_to_mat(q, R);
  for (int k = 0; k < 3; k++) lb[k] = R[0][k] * L[0] + R[1][k] * L[1] + R[2][k] * L[2];
}

void free_rotors4(const int *batch, double **quat, double **inertia, double **angmom,
                  double **omega, double quarter, double whole)
{
  V q[4], in[3], lb[3], R[3][3];
  gather_body(batch, quat, inertia, angmom, q, in, lb, R);
  const V hq = {quarter, quarter, quarter, quarter}, hw = {whole, whole, whole, whole};
  rotate_about_body_axis<2>(hq, in, q, lb);
  rotate_about_body_axis<1>(hq, in, q, lb);
  rotate_about_body_axis<0>(hw, in, q, lb);
  rotate_about_body_axis<1>(hq, in, q, lb);
  rotate_about_body_axis<2>(hq, in, q, lb);

  const V n = 1.0 / vsqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  for (int k = 0; k < 4; k++) q[k] *= n;
  quat_to_mat(q, R);
  for (int k = 0; k < 3; k++) lb[k] /= in[k];
  V om[3];
  for (int k = 0; k < 3; k++) om[k] = R[k][0] * lb[0] + R[k][1] * lb[1] + R[k][2] * lb[2];
  for (int c = 0; c < 4; c++) {
    const int i = batch[c];
    for (int k = 0; k < 4; k++) quat[i][k] = q[k][c];
    for (int k = 0; k < 3; k++) omega[i][k] = om[k][c];
  }
}

// omega = R I^-1 R^T L of four cells, as omega_of()
void omegas4(const int *batch, double **quat, double **inertia, double **angmom, double **omega)
{
  V q[4], in[3], lb[3], R[3][3];
  gather_body(batch, quat, inertia, angmom, q, in, lb, R);
  for (int k = 0; k < 3; k++) lb[k] /= in[k];
  V om[3];
  for (int k = 0; k < 3; k++) om[k] = R[k][0] * lb[0] + R[k][1] * lb[1] + R[k][2] * lb[2];
  for (int c = 0; c < 4; c++)
    for (int k = 0; k < 3; k++) omega[batch[c]][k] = om[k][c];
}

}    // namespace avx
}    // namespace
#pragma GCC pop_options
#endif

/* ---------------------------------------------------------------------- */

FixBcmRigid::FixBcmRigid(LAMMPS *_lmp, int narg, char **arg) :
    Fix(_lmp, narg, arg), dtv(0.0), dtf(0.0), iquat(-1), iinertia(-1), iangmom(-1),
    comm_with_omega(0), send_quat(true), avx_loop(false)
{
  if (narg != 3)
    error->all(FLERR, "Illegal fix bcm/rigid command: takes no arguments (fix ID group bcm/rigid)");
  time_integrate = 1;
  scalar_flag = 1;
  global_freq = 1;
  extscalar = 1;
  comm_forward = 7;    // quaternion, plus omega in the setup communication
  avx_loop = BreakableUtil::avx_loops();
}

/* ---------------------------------------------------------------------- */

int FixBcmRigid::setmask()
{
  return INITIAL_INTEGRATE | PRE_FORCE | FINAL_INTEGRATE;
}

/* ----------------------------------------------------------------------
   index of the per-atom array d2_<name> with ncols columns
------------------------------------------------------------------------- */

int FixBcmRigid::find_array(const char *name, int ncols)
{
  int flag = -1, cols = -1, ghost = 0;
  const int index = atom->find_custom_ghost(name, flag, cols, ghost);
  if (index < 0 || flag != 1 || cols != ncols)
    error->all(FLERR,
               "Fix bcm/rigid requires the per-atom array d2_{} with {} columns: declare "
               "`fix ID all property/atom d2_{} {} d2_{} {} ghost yes` before read_data",
               name, ncols, BcmRigid::INERTIA, 3, BcmRigid::ANGMOM, 3);
  if (!ghost)
    error->all(FLERR, "Fix bcm/rigid requires d2_{} with `ghost yes` (ghost cells need it)", name);
  return index;
}

/* ---------------------------------------------------------------------- */

void FixBcmRigid::init()
{
  if (!atom->rmass || !atom->omega || !atom->torque)
    error->all(FLERR, "Fix bcm/rigid requires per-atom rmass, omega and torque "
                      "(atom_style bpm/sphere)");
  iquat = BcmOrientation::find(atom, error, "Fix bcm/rigid", true);
  // atom_style bpm/sphere with comm_modify vel yes: the orientations travel with the
  // positions and velocities (bcm_orientation.h)
  send_quat = !(iquat == BcmOrientation::ATOM_QUAT && comm->ghost_velocity);
  iinertia = find_array(BcmRigid::INERTIA, 3);
  iangmom = find_array(BcmRigid::ANGMOM, 3);
  reset_dt();

  // every cell needs positive principal moments, a mass and an orientation; the smallest
  // offending atom ID over all ranks is named
  double **quat = BcmOrientation::of(atom, iquat);
  double **inertia = atom->darray[iinertia];
  const double *rmass = atom->rmass;
  const int *mask = atom->mask;
  const tagint *tag = atom->tag;
  const int nlocal = atom->nlocal;
  tagint bad_moment = MAXTAGINT, bad_quat = MAXTAGINT, bad_mass = MAXTAGINT;
  for (int i = 0; i < nlocal; i++) {
    if (!(mask[i] & groupbit)) continue;
    const double *in = inertia[i];
    if (!(in[0] > 0.0 && in[1] > 0.0 && in[2] > 0.0 && std::isfinite(in[0] + in[1] + in[2])))
      bad_moment = std::min(bad_moment, tag[i]);
    if (!(rmass[i] > 0.0)) bad_mass = std::min(bad_mass, tag[i]);
    const double qq = BcmRigid::quat_norm2(quat[i]);
    if (!(qq > 0.0) || !std::isfinite(qq)) bad_quat = std::min(bad_quat, tag[i]);
  }
  tagint local[3] = {bad_moment, bad_quat, bad_mass}, global[3];
  MPI_Allreduce(local, global, 3, MPI_LMP_TAGINT, MPI_MIN, world);
  if (global[0] != MAXTAGINT)
    error->all(FLERR, "Fix bcm/rigid: atom {} has a zero or negative principal moment in d2_{}",
               global[0], BcmRigid::INERTIA);
  if (global[1] != MAXTAGINT)
    error->all(FLERR, "Fix bcm/rigid: atom {} has no orientation (a zero quaternion)",
               global[1]);
  if (global[2] != MAXTAGINT)
    error->all(FLERR, "Fix bcm/rigid: atom {} has no positive mass", global[2]);

  // Orientations from a data file are normalised here; one already of unit length (the
  // integrator keeps them so) is left bit for bit as it is, so that an extra init() (a
  // write_restart between two runs) does not change a run's trajectory in the last bit.
  for (int i = 0; i < nlocal; i++)
    if (mask[i] & groupbit) {
      if (std::fabs(BcmRigid::quat_norm2(quat[i]) - 1.0) > 1e-14)
        BcmRigid::normalize_quat(quat[i]);
      set_omega(i);
    }
}

/* ---------------------------------------------------------------------- */

void FixBcmRigid::reset_dt()
{
  dtv = update->dt;
  dtf = 0.5 * update->dt * force->ftm2v;
}

/* ----------------------------------------------------------------------
   omega = R I^-1 R^T L of owned atom i
------------------------------------------------------------------------- */

void FixBcmRigid::set_omega(int i)
{
  omega_of(BcmOrientation::of(atom, iquat)[i], atom->darray[iinertia][i],
           atom->darray[iangmom][i], atom->omega[i]);
}

/* ----------------------------------------------------------------------
   ghosts get the orientations and angular velocities set by init(), unless
   LAMMPS's own communication of the setup carried them (send_quat false)
------------------------------------------------------------------------- */

void FixBcmRigid::setup_pre_force(int /*vflag*/)
{
  if (!send_quat) return;
  comm_with_omega = 1;
  comm->forward_comm(this, 7);
  comm_with_omega = 0;
}

/* ---------------------------------------------------------------------- */

void FixBcmRigid::initial_integrate(int /*vflag*/)
{
  double **x = atom->x;
  double **v = atom->v;
  double **f = atom->f;
  double **torque = atom->torque;
  const double *rmass = atom->rmass;
  const int *mask = atom->mask;
  double **angmom = atom->darray[iangmom];
  const int nlocal = atom->nlocal;

  int batch[BATCH], n = 0;
  for (int i = 0; i < nlocal; i++) {
    if (!(mask[i] & groupbit)) continue;
    const double dtfm = dtf / rmass[i];
    for (int k = 0; k < 3; k++) {
      v[i][k] += dtfm * f[i][k];
      x[i][k] += dtv * v[i][k];
      angmom[i][k] += dtf * torque[i][k];
    }
    batch[n++] = i;
    if (n == BATCH) {
#if defined(BRITTLE_AVX_LOOPS)
      if (avx_loop)
        avx::free_rotors4(batch, BcmOrientation::of(atom, iquat), atom->darray[iinertia], angmom,
                          atom->omega, 0.5 * (0.5 * dtv), 0.5 * dtv);
      else
#endif
        free_rotors(batch, n);
      n = 0;
    }
  }
  if (n) free_rotors(batch, n);
}

/* ----------------------------------------------------------------------
   the free rotor over the step of the n owned cells batch[] (n <= BATCH), side by side
------------------------------------------------------------------------- */

void FixBcmRigid::free_rotors(const int *batch, int n)
{
  double **omega = atom->omega;
  double **quat = BcmOrientation::of(atom, iquat);
  double **inertia = atom->darray[iinertia];
  double **angmom = atom->darray[iangmom];
  double q[BATCH][4], in[BATCH][3], lb[BATCH][3];

  for (int c = 0; c < n; c++) {
    const int i = batch[c];
    for (int k = 0; k < 4; k++) q[c][k] = quat[i][k];
    for (int k = 0; k < 3; k++) in[c][k] = inertia[i][k];
    double R[3][3];
    BcmRigid::quat_to_mat(q[c], R);
    BcmRigid::rotate_back(R, angmom[i], lb[c]);
  }
  const double quarter = 0.5 * (0.5 * dtv), whole = 0.5 * dtv;    // half of each substep
  rotate_about_body_axis<2>(n, quarter, in, q, lb);
  rotate_about_body_axis<1>(n, quarter, in, q, lb);
  rotate_about_body_axis<0>(n, whole, in, q, lb);
  rotate_about_body_axis<1>(n, quarter, in, q, lb);
  rotate_about_body_axis<2>(n, quarter, in, q, lb);

  for (int c = 0; c < n; c++) {
    const int i = batch[c];
    BcmRigid::normalize_quat(q[c]);
    for (int k = 0; k < 4; k++) quat[i][k] = q[c][k];
    // the space-frame L is unchanged by the free rotor: it is kept as is (exactly conserved
    // without torques); omega from the body components the rotor carried along
    double R[3][3];
    BcmRigid::quat_to_mat(q[c], R);
    for (int k = 0; k < 3; k++) lb[c][k] /= in[c][k];
    BcmRigid::rotate(R, lb[c], omega[i]);
  }
}

/* ----------------------------------------------------------------------
   after the positions moved (and before any force): ghost orientations, unless LAMMPS's
   own communication carried them. Ghost velocities and omega travel with comm_modify vel yes.
------------------------------------------------------------------------- */

void FixBcmRigid::pre_force(int /*vflag*/)
{
  if (send_quat) comm->forward_comm(this, 4);
}

/* ---------------------------------------------------------------------- */

void FixBcmRigid::final_integrate()
{
  double **v = atom->v;
  double **f = atom->f;
  double **torque = atom->torque;
  const double *rmass = atom->rmass;
  const int *mask = atom->mask;
  double **angmom = atom->darray[iangmom];
  double **quat = BcmOrientation::of(atom, iquat);
  double **inertia = atom->darray[iinertia];
  double **omega = atom->omega;
  const int nlocal = atom->nlocal;

  int batch[BATCH], n = 0;    // cells whose omega is still to be set (AVX: 4 at a time)
  for (int i = 0; i < nlocal; i++) {
    if (!(mask[i] & groupbit)) continue;
    const double dtfm = dtf / rmass[i];
    for (int k = 0; k < 3; k++) {
      v[i][k] += dtfm * f[i][k];
      angmom[i][k] += dtf * torque[i][k];
    }
#if defined(BRITTLE_AVX_LOOPS)
    if (avx_loop) {
      batch[n++] = i;
      if (n == BATCH) {
        avx::omegas4(batch, quat, inertia, angmom, omega);
        n = 0;
      }
      continue;
    }
#endif
    omega_of(quat[i], inertia[i], angmom[i], omega[i]);
  }
  for (int c = 0; c < n; c++) {
    const int i = batch[c];
    omega_of(quat[i], inertia[i], angmom[i], omega[i]);
  }
}

/* ----------------------------------------------------------------------
   rotational kinetic energy of the group, sum over cells of Lb_k^2 / (2 I_k)
------------------------------------------------------------------------- */

double FixBcmRigid::compute_scalar()
{
  double **quat = BcmOrientation::of(atom, iquat);
  double **inertia = atom->darray[iinertia];
  double **angmom = atom->darray[iangmom];
  const int *mask = atom->mask;
  const int nlocal = atom->nlocal;

  double local = 0.0;
  for (int i = 0; i < nlocal; i++) {
    if (!(mask[i] & groupbit)) continue;
    double R[3][3], lb[3];
    BcmRigid::quat_to_mat(quat[i], R);
    BcmRigid::rotate_back(R, angmom[i], lb);
    for (int k = 0; k < 3; k++) local += 0.5 * lb[k] * lb[k] / inertia[i][k];
  }
  double total = 0.0;
  MPI_Allreduce(&local, &total, 1, MPI_DOUBLE, MPI_SUM, world);
  return total * force->mvv2e;
}

/* ---------------------------------------------------------------------- */

int FixBcmRigid::pack_forward_comm(int n, int *list, double *buf, int /*pbc_flag*/,
                                   int * /*pbc*/)
{
  double **quat = BcmOrientation::of(atom, iquat);
  double **omega = atom->omega;
  int m = 0;
  for (int ii = 0; ii < n; ii++) {
    const int j = list[ii];
    for (int k = 0; k < 4; k++) buf[m++] = quat[j][k];
    if (comm_with_omega)
      for (int k = 0; k < 3; k++) buf[m++] = omega[j][k];
  }
  return m;
}

/* ---------------------------------------------------------------------- */

void FixBcmRigid::unpack_forward_comm(int n, int first, double *buf)
{
  double **quat = BcmOrientation::of(atom, iquat);
  double **omega = atom->omega;
  int m = 0;
  const int last = first + n;
  for (int i = first; i < last; i++) {
    for (int k = 0; k < 4; k++) quat[i][k] = buf[m++];
    if (comm_with_omega)
      for (int k = 0; k < 3; k++) omega[i][k] = buf[m++];
  }
}
