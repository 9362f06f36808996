/* angle_style breakable/cr (SPEC 2.2 Eq. 3-4).

   Energy, with dth = theta - theta0 (atom2 = vertex):
     E = k_A S(l1, l2) [dth^2 / 2 - dth^4 / (4 theta_c^2)]
   so that -dE/dtheta = -k_A S (dth - dth^3 / theta_c^2), the torque of SPEC Eq. 3.
   S = 1 for eps <= 0, (1 - eps^2 / eps_c^2)^2 for 0 < eps < eps_c, 0 beyond, with
   eps = max(l1, l2) - 1, eps_c = lambda_c - 1, l = r / r0 of each arm (SPEC Eq. 4).

   Forces are exactly -grad E: the angular part (perpendicular to the arms, in the plane of
   the three atoms, as in angle_style harmonic) plus the radial terms from dS/dl along the
   more stretched arm, equal and opposite on its two atoms. Both parts conserve linear and
   angular momentum, and the total energy is conserved by the dynamics.

   dth without an arc cosine: with c = cos(theta) = d1.d2 / (r1 r2) and s = sin(theta) =
   |d1 x d2| / (r1 r2) (the cross product keeps s accurate near 0 and pi) and the cached
   cos(theta0), sin(theta0),
     sin(dth) = s cos0 - c sin0,   cos(dth) = c cos0 + s sin0,
   and dth = asin(sin dth) by an odd polynomial while |sin dth| < ASIN_XMAX and cos dth > 0
   (every intact angle of a type with theta_c below 17 degrees), atan2(sin dth, cos dth)
   otherwise. Both are exact to rounding, and theta - theta0 lies in [-pi, pi].

   The angle breaks (type set to 0 for good, through the single break path of
   break_events.h) when |dth| >= theta_c (SPEC Eq. 3), and when either of its arm bonds
   breaks: bond_style breakable/cr decides that, and fix breakable/special hands the break to
   every rank at the end of the step (break_with_bond), which breaks the angle with the
   bond's step. This style does not test the stretch itself: past lambda_c an arm has S = 0,
   so the angle exerts no force in the step its bond breaks.

   Storage: theta0, r1_0, r2_0 per atom and angle slot in a hidden fix lazy/store (every
   atom of an angle holds a copy of it, newton_bond being off), filled from the input by fix
   breakable/references (r1_0, r2_0 are the r0 of the two arm bonds); compute() reads a copy
   of the intact entries of neighbor->anglelist. A stored r1_0 of 0 is the value of a slot no
   reference was given for: an error. */

#include "angle_breakable_cr.h"

#include "atom.h"
#include "break_events.h"
#include "breakable_util.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "fix_breakable_special.h"
#include "force.h"
#include "memory.h"
#include "neighbor.h"
#include "update.h"

#include <algorithm>
#include <cmath>
#include <mpi.h>

using namespace LAMMPS_NS;

static constexpr double PI = 3.14159265358979323846;
static constexpr double SMALL = 0.001;    // floor of sin(theta), as in angle_style harmonic

namespace {

using BreakableUtil::Lanes2;
using BreakableUtil::Mask2;
using BreakableUtil::select_lt;
using BreakableUtil::vabs;
using BreakableUtil::vmax;
using BreakableUtil::vsqrt;

#include "angle_breakable_cr_math.h"    // the baseline copy

// sin and cos of theta0 (one range reduction for both where the C library offers it)
inline void sin_cos(double theta, double &s, double &c)
{
#if defined(__GLIBC__)
  sincos(theta, &s, &c);
#else
  s = sin(theta);
  c = cos(theta);
#endif
}

// whether dth = asin(sin dth) by the polynomial applies
inline bool polynomial_range(double sd, double cd)
{
  return (fabs(sd) < ASIN_XMAX) & (cd > 0.0);
}

// dth = theta - theta0 from sin(dth), cos(dth)
inline double delta_theta(double sd, double cd)
{
  return polynomial_range(sd, cd) ? asin_small(sd) : atan2(sd, cd);
}

inline void arms(const double *x1, const double *x2, const double *x3, Angle3<double> &A)
{
  A.d1x = x1[0] - x2[0];
  A.d1y = x1[1] - x2[1];
  A.d1z = x1[2] - x2[2];
  A.d2x = x3[0] - x2[0];
  A.d2y = x3[1] - x2[1];
  A.d2z = x3[2] - x2[2];
}

}    // namespace

/* ----------------------------------------------------------------------
   The same arithmetic compiled for AVX, for the 4-lane force loop (loop4),
   which compute() takes when the processor has AVX (checked at run time: the
   library itself is built for baseline x86-64). AVX adds, multiplies,
   divides and square roots round each lane as the SSE2 and scalar
   instructions do, and AVX has no fused multiply-add, so a lane of loop4
   gives the bits of loop() and exact() and takes the same decisions.
------------------------------------------------------------------------- */

#if defined(BRITTLE_AVX_LOOPS)
#pragma GCC push_options
#pragma GCC target("avx")
namespace {
namespace avx {

#include "lanes4_avx.h"

#include "angle_breakable_cr_math.h"    // the AVX copy

}    // namespace avx
}    // namespace
#pragma GCC pop_options
#endif

/* ---------------------------------------------------------------------- */

AngleBreakableCR::AngleBreakableCR(LAMMPS *_lmp) :
    Angle(_lmp), k(nullptr), theta_c(nullptr), lambda_c(nullptr), cached_nanglelist(-1),
    store_index(-1), special(nullptr)
{
  writedata = 1;
  born_matrix_enable = 0;
  avx_loop = BreakableUtil::avx_loops();
  if (domain->box_exist) FixBreakableSpecial::get_or_create(lmp);
}

/* ----------------------------------------------------------------------
   the reference store and fix breakable/special stay (see the bond style)
------------------------------------------------------------------------- */

AngleBreakableCR::~AngleBreakableCR()
{
  if (allocated) {
    memory->destroy(setflag);
    memory->destroy(k);
    memory->destroy(theta_c);
    memory->destroy(lambda_c);
  }
}

/* ---------------------------------------------------------------------- */

void AngleBreakableCR::allocate()
{
  allocated = 1;
  const int n = atom->nangletypes + 1;
  memory->create(k, n, "angle:k");
  memory->create(theta_c, n, "angle:theta_c");
  memory->create(lambda_c, n, "angle:lambda_c");
  memory->create(setflag, n, "angle:setflag");
  params.assign(n, TypeParams{0.0, 0.0, 0.0, 0.0, 0.0});
  for (int i = 1; i < n; i++) setflag[i] = 0;
}

/* ---------------------------------------------------------------------- */

void AngleBreakableCR::derive(int type)
{
  const double ec = lambda_c[type] - 1.0;
  params[type] = TypeParams{k[type], theta_c[type], lambda_c[type],
                            1.0 / (theta_c[type] * theta_c[type]), 1.0 / (ec * ec)};
}

/* ----------------------------------------------------------------------
   angle_coeff T k_A theta_c(degrees) lambda_c
------------------------------------------------------------------------- */

void AngleBreakableCR::coeff(int narg, char **arg)
{
  if (narg != 4)
    error->all(FLERR, "Incorrect args for angle coefficients: "
                      "angle_coeff T k_A theta_c(degrees) lambda_c");
  if (!allocated) allocate();

  int ilo, ihi;
  utils::bounds(FLERR, arg[0], 1, atom->nangletypes, ilo, ihi, error);
  const double k_one = utils::numeric(FLERR, arg[1], false, lmp);
  const double thc_deg = utils::numeric(FLERR, arg[2], false, lmp);
  const double lc_one = utils::numeric(FLERR, arg[3], false, lmp);
  if (!(k_one >= 0.0)) error->all(FLERR, "angle_coeff breakable/cr: k_A must be >= 0");
  if (!(thc_deg > 0.0 && thc_deg <= 180.0))
    error->all(FLERR, "angle_coeff breakable/cr: theta_c must be in (0, 180] degrees");
  if (!(lc_one > 1.0)) error->all(FLERR, "angle_coeff breakable/cr: lambda_c must be > 1");

  int count = 0;
  for (int i = ilo; i <= ihi; i++) {
    k[i] = k_one;
    theta_c[i] = thc_deg * PI / 180.0;
    lambda_c[i] = lc_one;
    derive(i);
    setflag[i] = 1;
    count++;
  }
  if (count == 0) error->all(FLERR, "Incorrect args for angle coefficients");
  if (domain->box_exist) FixBreakableSpecial::get_or_create(lmp);
}

/* ---------------------------------------------------------------------- */

void AngleBreakableCR::init_style()
{
  if (force->newton_bond)
    error->all(FLERR, "angle_style breakable/cr requires newton_bond off (command: newton on off), "
                      "so that every rank holding an angle stores it and decides its breaking");
  if (atom->molecular != Atom::MOLECULAR)
    error->all(FLERR, "angle_style breakable/cr requires a molecular atom style (not a template)");

  store_index = BreakableUtil::peratom_array(lmp, BreakableUtil::ANGLE_REF_FIX_ID,
                                             BreakableUtil::ANGLE_REF_NAME,
                                             3 * atom->angle_per_atom);
  special = FixBreakableSpecial::get_or_create(lmp);
  cached_nanglelist = -1;
}

/* ----------------------------------------------------------------------
   forces of one intact angle on its owned atoms, energy and virial
------------------------------------------------------------------------- */

template <bool EVFLAG>
inline void AngleBreakableCR::apply(const Ref &R, double a11, double a12, double a22,
                                    const double *d, double eangle, double *const *f,
                                    int nlocal)
{
  double f1[3], f3[3];
  f1[0] = a11 * d[0] + a12 * d[3];
  f1[1] = a11 * d[1] + a12 * d[4];
  f1[2] = a11 * d[2] + a12 * d[5];
  f3[0] = a22 * d[3] + a12 * d[0];
  f3[1] = a22 * d[4] + a12 * d[1];
  f3[2] = a22 * d[5] + a12 * d[2];
  const double f13[3] = {f1[0] + f3[0], f1[1] + f3[1], f1[2] + f3[2]};
  scatter<EVFLAG>(R, f1, f3, f13, d, eangle, f, nlocal);
}

/* ----------------------------------------------------------------------
   add f1 to atom1, f3 to atom3 and -f13 = -(f1 + f3) to the vertex, owned
   atoms only; energy and virial
------------------------------------------------------------------------- */

template <bool EVFLAG>
inline void AngleBreakableCR::scatter(const Ref &R, const double *f1, const double *f3,
                                      const double *f13, const double *d, double eangle,
                                      double *const *f, int nlocal)
{
  // newton_bond is off: each rank adds forces to its owned atoms only
  const int i1 = R.i1, i2 = R.i2, i3 = R.i3;
  if (i1 < nlocal) {
    f[i1][0] += f1[0];
    f[i1][1] += f1[1];
    f[i1][2] += f1[2];
  }
  if (i2 < nlocal) {
    f[i2][0] -= f13[0];
    f[i2][1] -= f13[1];
    f[i2][2] -= f13[2];
  }
  if (i3 < nlocal) {
    f[i3][0] += f3[0];
    f[i3][1] += f3[1];
    f[i3][2] += f3[2];
  }

  if (EVFLAG) {
    double g1[3] = {f1[0], f1[1], f1[2]}, g3[3] = {f3[0], f3[1], f3[2]};
    ev_tally(i1, i2, i3, nlocal, 0, eangle, g1, g3, d[0], d[1], d[2], d[3], d[4], d[5]);
  }
}

/* ----------------------------------------------------------------------
   one angle, every case: its break (bend past theta_c), or its forces with
   dth by the polynomial or by atan2
------------------------------------------------------------------------- */

template <bool EVFLAG>
void AngleBreakableCR::exact(Ref &R, const double *const *x, double *const *f, int nlocal)
{
  const TypeParams &P = params[R.type];
  Angle3<double> A;
  arms(x[R.i1], x[R.i2], x[R.i3], A);
  A.cos0 = R.cos0;
  A.sin0 = R.sin0;
  A.inv_r1_0 = R.inv_r1_0;
  A.inv_r2_0 = R.inv_r2_0;
  A.geometry();
  const double dth = delta_theta(A.sd, A.cd);
  A.forces(dth, P.k, P.inv_thc2, P.inv_ec2);
  // breaking by bending (SPEC 2.2 Eq. 3: |dtheta| >= theta_c), holding the energy of Eq. 3-4
  if (fabs(dth) >= P.theta_c) {
    break_angle(R, A.energy);
    return;
  }
  const double d[6] = {A.d1x, A.d1y, A.d1z, A.d2x, A.d2y, A.d2z};
  apply<EVFLAG>(R, A.a11, A.a12, A.a22, d, A.energy, f, nlocal);
}

/* ----------------------------------------------------------------------
   the force loop: two cache entries at a time in the two lanes of the common
   case (intact, dth by the polynomial, no break), with no call and no branch
   on the data until the forces are added; an entry outside the common case
   is left untouched in its lane and done by exact() after the loop. A lane
   gives the bits of the scalar arithmetic, so the decisions do not depend on
   which lane or pass an angle is in.
------------------------------------------------------------------------- */

template <bool EVFLAG> void AngleBreakableCR::loop()
{
  const double *const *x = atom->x;
  double *const *f = atom->f;
  const int nlocal = atom->nlocal;
  Ref *ref = cache.data();
  const int nref = (int) cache.size();
  const TypeParams *tp = params.data();
  int *left = deferred.data();
  int nleft = 0;
  const Lanes2 xmax = {ASIN_XMAX, ASIN_XMAX};
  const Lanes2 zero = {0.0, 0.0};

  for (int m = 0; m < nref; m += 2) {
    const int mb = (m + 1 < nref) ? m + 1 : m;    // the last entry alone: both lanes
    const Ref &Ra = ref[m], &Rb = ref[mb];
    const TypeParams &Pa = tp[Ra.type], &Pb = tp[Rb.type];    // type 0: broken, skipped below
    const double *x1a = x[Ra.i1], *x2a = x[Ra.i2], *x3a = x[Ra.i3];
    const double *x1b = x[Rb.i1], *x2b = x[Rb.i2], *x3b = x[Rb.i3];

    Angle3<Lanes2> A;
    A.d1x = Lanes2{x1a[0], x1b[0]} - Lanes2{x2a[0], x2b[0]};
    A.d1y = Lanes2{x1a[1], x1b[1]} - Lanes2{x2a[1], x2b[1]};
    A.d1z = Lanes2{x1a[2], x1b[2]} - Lanes2{x2a[2], x2b[2]};
    A.d2x = Lanes2{x3a[0], x3b[0]} - Lanes2{x2a[0], x2b[0]};
    A.d2y = Lanes2{x3a[1], x3b[1]} - Lanes2{x2a[1], x2b[1]};
    A.d2z = Lanes2{x3a[2], x3b[2]} - Lanes2{x2a[2], x2b[2]};
    A.cos0 = Lanes2{Ra.cos0, Rb.cos0};
    A.sin0 = Lanes2{Ra.sin0, Rb.sin0};
    A.inv_r1_0 = Lanes2{Ra.inv_r1_0, Rb.inv_r1_0};
    A.inv_r2_0 = Lanes2{Ra.inv_r2_0, Rb.inv_r2_0};
    A.geometry();

    // the decisions of exact(), for the common case only
    const Lanes2 theta_c = {Pa.theta_c, Pb.theta_c};
    const Lanes2 dth = asin_small(A.sd);
    const Mask2 ok = (vabs(A.sd) < xmax) & (A.cd > zero) & ~(vabs(dth) >= theta_c);

    A.forces(dth, Lanes2{Pa.k, Pb.k}, Lanes2{Pa.inv_thc2, Pb.inv_thc2},
             Lanes2{Pa.inv_ec2, Pb.inv_ec2});

    if (Ra.type > 0) {
      if (ok[0]) {
        const double d[6] = {A.d1x[0], A.d1y[0], A.d1z[0], A.d2x[0], A.d2y[0], A.d2z[0]};
        apply<EVFLAG>(Ra, A.a11[0], A.a12[0], A.a22[0], d, A.energy[0], f, nlocal);
      } else
        left[nleft++] = m;
    }
    if (mb != m && Rb.type > 0) {
      if (ok[1]) {
        const double d[6] = {A.d1x[1], A.d1y[1], A.d1z[1], A.d2x[1], A.d2y[1], A.d2z[1]};
        apply<EVFLAG>(Rb, A.a11[1], A.a12[1], A.a22[1], d, A.energy[1], f, nlocal);
      } else
        left[nleft++] = mb;
    }
  }
  for (int j = 0; j < nleft; j++) exact<EVFLAG>(ref[left[j]], x, f, nlocal);
}

/* ----------------------------------------------------------------------
   loop() on four cache entries at a time, in the four lanes of AVX
------------------------------------------------------------------------- */

#if defined(BRITTLE_AVX_LOOPS)
#pragma GCC push_options
#pragma GCC target("avx")
template <bool EVFLAG> void AngleBreakableCR::loop4()
{
  using avx::Lanes4;
  using avx::Mask4;
  const double *const *x = atom->x;
  double *const *f = atom->f;
  const int nlocal = atom->nlocal;
  Ref *ref = cache.data();
  const int nref = (int) cache.size();
  const TypeParams *tp = params.data();
  int *left = deferred.data();
  int nleft = 0;
  const Lanes4 xmax = {avx::ASIN_XMAX, avx::ASIN_XMAX, avx::ASIN_XMAX, avx::ASIN_XMAX};
  const Lanes4 zero = {0.0, 0.0, 0.0, 0.0};

  for (int m = 0; m < nref; m += 4) {
    // past the end, a lane repeats the last entry and is skipped below
    const int last = nref - 1;
    const int e[4] = {m, m + 1 < nref ? m + 1 : last, m + 2 < nref ? m + 2 : last,
                      m + 3 < nref ? m + 3 : last};
    const Ref *R[4] = {&ref[e[0]], &ref[e[1]], &ref[e[2]], &ref[e[3]]};
    const TypeParams *P[4] = {&tp[R[0]->type], &tp[R[1]->type], &tp[R[2]->type],
                              &tp[R[3]->type]};    // type 0: broken, skipped below
    const bool one_type = P[1] == P[0] && P[2] == P[0] && P[3] == P[0];
    const double *x1[4], *x2[4], *x3[4];
    for (int k = 0; k < 4; k++) {
      x1[k] = x[R[k]->i1];
      x2[k] = x[R[k]->i2];
      x3[k] = x[R[k]->i3];
    }
    avx::Angle3<Lanes4> A;
    const Lanes4 x2x = {x2[0][0], x2[1][0], x2[2][0], x2[3][0]};
    const Lanes4 x2y = {x2[0][1], x2[1][1], x2[2][1], x2[3][1]};
    const Lanes4 x2z = {x2[0][2], x2[1][2], x2[2][2], x2[3][2]};
    A.d1x = Lanes4{x1[0][0], x1[1][0], x1[2][0], x1[3][0]} - x2x;
    A.d1y = Lanes4{x1[0][1], x1[1][1], x1[2][1], x1[3][1]} - x2y;
    A.d1z = Lanes4{x1[0][2], x1[1][2], x1[2][2], x1[3][2]} - x2z;
    A.d2x = Lanes4{x3[0][0], x3[1][0], x3[2][0], x3[3][0]} - x2x;
    A.d2y = Lanes4{x3[0][1], x3[1][1], x3[2][1], x3[3][1]} - x2y;
    A.d2z = Lanes4{x3[0][2], x3[1][2], x3[2][2], x3[3][2]} - x2z;
    A.cos0 = Lanes4{R[0]->cos0, R[1]->cos0, R[2]->cos0, R[3]->cos0};
    A.sin0 = Lanes4{R[0]->sin0, R[1]->sin0, R[2]->sin0, R[3]->sin0};
    A.inv_r1_0 = Lanes4{R[0]->inv_r1_0, R[1]->inv_r1_0, R[2]->inv_r1_0, R[3]->inv_r1_0};
    A.inv_r2_0 = Lanes4{R[0]->inv_r2_0, R[1]->inv_r2_0, R[2]->inv_r2_0, R[3]->inv_r2_0};
    A.geometry();

    // the decisions of exact(), for the common case only
    // per-type parameters: one broadcast when the four entries share a type (the usual case)
    Lanes4 theta_c, kk, inv_thc2, inv_ec2;
    if (one_type) {
      const TypeParams &Q = *P[0];
      theta_c = Lanes4{} + Q.theta_c;
      kk = Lanes4{} + Q.k;
      inv_thc2 = Lanes4{} + Q.inv_thc2;
      inv_ec2 = Lanes4{} + Q.inv_ec2;
    } else {
      theta_c = Lanes4{P[0]->theta_c, P[1]->theta_c, P[2]->theta_c, P[3]->theta_c};
      kk = Lanes4{P[0]->k, P[1]->k, P[2]->k, P[3]->k};
      inv_thc2 = Lanes4{P[0]->inv_thc2, P[1]->inv_thc2, P[2]->inv_thc2, P[3]->inv_thc2};
      inv_ec2 = Lanes4{P[0]->inv_ec2, P[1]->inv_ec2, P[2]->inv_ec2, P[3]->inv_ec2};
    }

    // the decisions of exact(), for the common case only
    const Lanes4 dth = avx::asin_small(A.sd);
    const Mask4 ok =
        (avx::vabs(A.sd) < xmax) & (A.cd > zero) & ~(avx::vabs(dth) >= theta_c);

    A.forces(dth, kk, inv_thc2, inv_ec2);

    // the forces of apply(), in the four lanes
    const Lanes4 f1x = A.a11 * A.d1x + A.a12 * A.d2x;
    const Lanes4 f1y = A.a11 * A.d1y + A.a12 * A.d2y;
    const Lanes4 f1z = A.a11 * A.d1z + A.a12 * A.d2z;
    const Lanes4 f3x = A.a22 * A.d2x + A.a12 * A.d1x;
    const Lanes4 f3y = A.a22 * A.d2y + A.a12 * A.d1y;
    const Lanes4 f3z = A.a22 * A.d2z + A.a12 * A.d1z;
    const Lanes4 f13x = f1x + f3x, f13y = f1y + f3y, f13z = f1z + f3z;

    for (int k = 0; k < 4; k++) {
      if ((k > 0 && m + k >= nref) || R[k]->type <= 0) continue;
      if (ok[k]) {
        const double f1[3] = {f1x[k], f1y[k], f1z[k]};
        const double f3[3] = {f3x[k], f3y[k], f3z[k]};
        const double f13[3] = {f13x[k], f13y[k], f13z[k]};
        double d[6];
        if (EVFLAG) {
          d[0] = A.d1x[k], d[1] = A.d1y[k], d[2] = A.d1z[k];
          d[3] = A.d2x[k], d[4] = A.d2y[k], d[5] = A.d2z[k];
        }
        scatter<EVFLAG>(*R[k], f1, f3, f13, d, A.energy[k], f, nlocal);
      } else
        left[nleft++] = e[k];
    }
  }
  for (int j = 0; j < nleft; j++) exact<EVFLAG>(ref[left[j]], x, f, nlocal);
}
#pragma GCC pop_options
#else
template <bool EVFLAG> void AngleBreakableCR::loop4()
{
  loop<EVFLAG>();
}
#endif

/* ---------------------------------------------------------------------- */

void AngleBreakableCR::compute(int eflag, int vflag)
{
  ev_init(eflag, vflag);

  if (cached_nanglelist < 0 || neighbor->ago == 0 || cached_nanglelist != neighbor->nanglelist)
    rebuild_cache();

  if (avx_loop) {
    if (evflag)
      loop4<true>();
    else
      loop4<false>();
  } else if (evflag)
    loop<true>();
  else
    loop<false>();
}

/* ----------------------------------------------------------------------
   the cache entry, then the single break path
------------------------------------------------------------------------- */

void AngleBreakableCR::break_angle(Ref &R, double energy, bigint step, double time)
{
  R.type = 0;
  BreakPath::angle(lmp, special, R.n, energy, step, time);
}

void AngleBreakableCR::break_angle(Ref &R, double energy)
{
  break_angle(R, energy, update->ntimestep, BreakPath::current_time(lmp));
}

/* ----------------------------------------------------------------------
   the bond of ev (broken on some rank in this step, fix breakable/special)
   takes every angle having it as an arm with it: the angles at vertex id1
   with an arm to id2 and those at id2 with an arm to id1, found through the
   vertex index over every image of the vertex. Recorded with the bond's step
   and the energy the angle held in this step's evaluation.
------------------------------------------------------------------------- */

void AngleBreakableCR::break_with_bond(const BreakEvent &ev)
{
  if (cached_nanglelist < 0) return;    // no angle computed yet: none of this rank's
  const tagint *tag = atom->tag;
  const tagint ta = (tagint) ev.id1, tb = (tagint) ev.id2;
  for (int side = 0; side < 2; side++) {
    const tagint vertex = side ? tb : ta, other = side ? ta : tb;
    for (int j = atom->map(vertex); j >= 0; j = atom->sametag[j]) {
      if (j >= (int) vertex_head.size()) continue;
      for (int e = vertex_head[j]; e >= 0; e = vertex_next[e]) {
        Ref &R = cache[e];
        if (R.type <= 0 || (tag[R.i1] != other && tag[R.i3] != other)) continue;
        break_angle(R, energy_now(R), (bigint) ev.step, ev.time);
      }
    }
  }
}

/* ----------------------------------------------------------------------
   energy of an intact cache entry now, with the arithmetic of compute()
------------------------------------------------------------------------- */

double AngleBreakableCR::energy_now(const Ref &R) const
{
  const TypeParams &P = params[R.type];
  double **x = atom->x;
  Angle3<double> A;
  arms(x[R.i1], x[R.i2], x[R.i3], A);
  A.cos0 = R.cos0;
  A.sin0 = R.sin0;
  A.inv_r1_0 = R.inv_r1_0;
  A.inv_r2_0 = R.inv_r2_0;
  A.geometry();
  A.forces(delta_theta(A.sd, A.cd), P.k, P.inv_thc2, P.inv_ec2);
  return A.energy;
}

/* ----------------------------------------------------------------------
   copy the intact anglelist entries and their references into the cache.
   With newton_bond off the neighbor code lists an angle from its owned atom
   with the smallest local index (the smallest of the entry's three indices),
   walking that atom's angle slots in order: a cursor over its slots finds each
   entry's slot with tag compares only, falling back to a full search when the
   order differs. Broken entries (type 0) are left out of the cache; an intact
   one without references is an error. The vertex index lists the entries by
   the local index of their vertex (break_with_bond).
------------------------------------------------------------------------- */

void AngleBreakableCR::rebuild_cache()
{
  double **refs = atom->darray[store_index];
  const tagint *tag = atom->tag;
  const int *num_angle = atom->num_angle;
  tagint **angle_atom1 = atom->angle_atom1;
  tagint **angle_atom2 = atom->angle_atom2;
  tagint **angle_atom3 = atom->angle_atom3;
  const int nlocal = atom->nlocal;
  int **anglelist = neighbor->anglelist;
  const int nanglelist = neighbor->nanglelist;

  cache.resize(nanglelist);
  int nref = 0, owner = -1, m = 0;
  for (int n = 0; n < nanglelist; n++) {
    const int a1 = anglelist[n][0], a2 = anglelist[n][1], a3 = anglelist[n][2];
    const int type = anglelist[n][3];
    const tagint t1 = tag[a1], t2 = tag[a2], t3 = tag[a3];
    const int i = std::min(a1, std::min(a2, a3));
    if (i >= nlocal)
      error->one(FLERR, "angle_style breakable/cr: angle {}-{}-{} has no owned atom", t1, t2, t3);
    if (i != owner) {
      owner = i;
      m = 0;
    }
    while (m < num_angle[i] && !(angle_atom2[i][m] == t2 && angle_atom1[i][m] == t1 &&
                                 angle_atom3[i][m] == t3))
      m++;
    if (m == num_angle[i] && (m = BreakableUtil::angle_slot(atom, i, t1, t2, t3)) < 0)
      error->one(FLERR, "angle_style breakable/cr: angle {}-{}-{} of the angle list is not in "
                 "the atom's angle arrays", t1, t2, t3);
    const double *src = &refs[i][3 * m];
    m++;
    if (type <= 0) continue;

    if (!(src[1] > 0.0 && src[2] > 0.0))
      error->one(FLERR, "angle_style breakable/cr: angle {}-{}-{} has no reference geometry: "
                 "the references file of fix breakable/references does not list it", t1, t2,
                 t3);

    Ref &R = cache[nref++];
    R.i1 = a1;
    R.i2 = a2;
    R.i3 = a3;
    R.type = type;
    R.n = n;
    sin_cos(src[0], R.sin0, R.cos0);
    R.inv_r1_0 = 1.0 / src[1];
    R.inv_r2_0 = 1.0 / src[2];
  }
  cache.resize(nref);
  deferred.resize(nref);
  cached_nanglelist = nanglelist;

  vertex_head.assign(atom->nlocal + atom->nghost, -1);
  vertex_next.resize(nref);
  for (int e = nref - 1; e >= 0; e--) {
    vertex_next[e] = vertex_head[cache[e].i2];
    vertex_head[cache[e].i2] = e;
  }
}

/* ----------------------------------------------------------------------
   every angle has its own theta0: there is no per-type equilibrium angle.
   The value is only read by SHAKE/RATTLE and angle_write, which this style
   does not support.
------------------------------------------------------------------------- */

double AngleBreakableCR::equilibrium_angle(int /*type*/)
{
  return PI;
}

/* ---------------------------------------------------------------------- */

void AngleBreakableCR::write_restart(FILE *fp)
{
  const int n = atom->nangletypes;
  fwrite(&k[1], sizeof(double), n, fp);
  fwrite(&theta_c[1], sizeof(double), n, fp);
  fwrite(&lambda_c[1], sizeof(double), n, fp);
}

/* ---------------------------------------------------------------------- */

void AngleBreakableCR::read_restart(FILE *fp)
{
  allocate();
  const int n = atom->nangletypes;
  if (comm->me == 0) {
    utils::sfread(FLERR, &k[1], sizeof(double), n, fp, nullptr, error);
    utils::sfread(FLERR, &theta_c[1], sizeof(double), n, fp, nullptr, error);
    utils::sfread(FLERR, &lambda_c[1], sizeof(double), n, fp, nullptr, error);
  }
  MPI_Bcast(&k[1], n, MPI_DOUBLE, 0, world);
  MPI_Bcast(&theta_c[1], n, MPI_DOUBLE, 0, world);
  MPI_Bcast(&lambda_c[1], n, MPI_DOUBLE, 0, world);
  for (int i = 1; i <= n; i++) {
    derive(i);
    setflag[i] = 1;
  }
}

/* ---------------------------------------------------------------------- */

void AngleBreakableCR::write_data(FILE *fp)
{
  for (int i = 1; i <= atom->nangletypes; i++)
    fmt::print(fp, "{} {} {} {}\n", i, k[i], theta_c[i] * 180.0 / PI, lambda_c[i]);
}

/* ----------------------------------------------------------------------
   energy of the angle i1-i2-i3 (closest images), references from an owned
   atom's copy; zero once bent past theta_c (S = 0 makes it zero past lambda_c)
------------------------------------------------------------------------- */

double AngleBreakableCR::single(int type, int i1, int i2, int i3)
{
  if (type <= 0) return 0.0;
  if (store_index < 0)
    error->one(FLERR, "angle_style breakable/cr: single() before the first run");
  double **refs = atom->darray[store_index];
  const tagint *tag = atom->tag;
  const double *ref = nullptr;
  for (int idx : {i1, i2, i3}) {
    if (ref || idx >= atom->nlocal) continue;
    const int m = BreakableUtil::angle_slot(atom, idx, tag[i1], tag[i2], tag[i3]);
    if (m >= 0) ref = &refs[idx][3 * m];
  }
  if (!ref || !(ref[1] > 0.0))
    error->one(FLERR, "angle_style breakable/cr: no reference geometry for angle {}-{}-{}",
               tag[i1], tag[i2], tag[i3]);

  // the arithmetic of compute(), so that the two agree to the last bit
  const TypeParams &P = params[type];
  double **x = atom->x;
  Angle3<double> A;
  arms(x[i1], x[i2], x[i3], A);
  sin_cos(ref[0], A.sin0, A.cos0);
  A.inv_r1_0 = 1.0 / ref[1];
  A.inv_r2_0 = 1.0 / ref[2];
  A.geometry();
  const double dth = delta_theta(A.sd, A.cd);
  if (fabs(dth) >= P.theta_c) return 0.0;
  A.forces(dth, P.k, P.inv_thc2, P.inv_ec2);
  return A.energy;
}

/* ---------------------------------------------------------------------- */

double AngleBreakableCR::memory_usage()
{
  return Angle::memory_usage() + (double) cache.capacity() * sizeof(Ref) +
      (double) (deferred.capacity() + vertex_head.capacity() + vertex_next.capacity()) *
      sizeof(int) + (double) params.capacity() * sizeof(TypeParams);
}
