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

// asin(x) for |x| < ASIN_XMAX = 0.3 (|dth| < 17.46 degrees): x + x z P(z), z = x^2, P of
// degree 7 interpolating (asin(x) - x) / (x z) at the Chebyshev nodes of [0, 0.09]; relative
// error below 4e-16 (rounding included). Estrin's scheme keeps the dependency chain short.
constexpr double ASIN_XMAX = 0.3;

template <class T> inline T asin_small(T x)
{
  const T z = x * x;
  const T z2 = z * z;
  const T z4 = z2 * z2;
  const T p01 = 0.1666666666666649 + 0.07500000000250932 * z;
  const T p23 = 0.04464285655916009 + 0.03038199601727747 * z;
  const T p45 = 0.02236993042003646 + 0.01740472381582807 * z;
  const T p67 = 0.01330212710356684 + 0.015818111679304542 * z;
  const T p = (p01 + p23 * z2) + (p45 + p67 * z2) * z4;
  return x + x * z * p;
}

// The arithmetic of one angle, on one value or on two lanes. Every path that decides on an
// angle (fast and exact passes, single()) goes through it, so all take the same decisions.
template <class T> struct Angle3 {
  // in: arm vectors d1 = x1 - x2, d2 = x3 - x2, references
  T d1x, d1y, d1z, d2x, d2y, d2z;
  T cos0, sin0, inv_r1_0, inv_r2_0;
  // geometry
  T r1, r2, inv_r12, c, s, l1, l2, sd, cd;

  void geometry()
  {
    // r as bond_style breakable/cr computes it: the stretch tests must agree bit for bit
    r1 = vsqrt(d1x * d1x + d1y * d1y + d1z * d1z);
    r2 = vsqrt(d2x * d2x + d2y * d2y + d2z * d2z);
    const T dot = d1x * d2x + d1y * d2y + d1z * d2z;
    const T cx = d1y * d2z - d1z * d2y;
    const T cy = d1z * d2x - d1x * d2z;
    const T cz = d1x * d2y - d1y * d2x;
    const T b = vsqrt(cx * cx + cy * cy + cz * cz);    // r1 r2 sin(theta)
    inv_r12 = 1.0 / (r1 * r2);
    c = dot * inv_r12;
    s = b * inv_r12;
    l1 = r1 * inv_r1_0;
    l2 = r2 * inv_r2_0;
    sd = s * cos0 - c * sin0;    // sin(theta - theta0)
    cd = c * cos0 + s * sin0;    // cos(theta - theta0)
  }

  // energy and force coefficients at bend dth (SPEC Eq. 3-4): f1 = a11 d1 + a12 d2,
  // f3 = a22 d2 + a12 d1, f2 = -f1 - f3
  T a11, a12, a22, energy;

  void forces(T dth, T k, T inv_thc2, T inv_ec2)
  {
    const T inv_s = 1.0 / vmax(s, T{} + SMALL);
    const T inv_r1 = r2 * inv_r12;
    const T inv_r2 = r1 * inv_r12;

    // S of the more stretched arm, and dS/dl. eps is clamped at 0 (S = 1, dS = 0), q at 0:
    // an arm past lambda_c r0 (its bond breaks in this step) gives S = dS = 0, no force.
    const T eps = vmax(vmax(l1, l2) - 1.0, T{});
    const T q = vmax(1.0 - eps * eps * inv_ec2, T{});
    const T s_fac = q * q;

    // dE/dtheta = k_A S (dth - dth^3 / theta_c^2); E = k_A S g, g = dth^2/2 - dth^4/(4 thc^2)
    const T dth2 = dth * dth;
    const T ks = k * s_fac;
    const T tau = ks * dth * (1.0 - dth2 * inv_thc2);
    const T g = dth2 * (0.5 - 0.25 * dth2 * inv_thc2);
    energy = ks * g;

    // radial term -dE/dr = -k_A g (dS/dl) / r0 along the more stretched arm (arm 1 on a
    // tie), folded into the coefficient of that arm's vector (divided by its length)
    const T fr = 4.0 * k * g * eps * q * inv_ec2;
    const T fr1 = select_lt(l1, l2, T{}, fr * inv_r1_0 * inv_r1);
    const T fr2 = select_lt(l1, l2, fr * inv_r2_0 * inv_r2, T{});

    // angular part as in angle_style harmonic
    const T aa = -tau * inv_s;
    a11 = aa * c * inv_r1 * inv_r1 + fr1;
    a12 = -aa * inv_r12;
    a22 = aa * c * inv_r2 * inv_r2 + fr2;
  }
};

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

/* ---------------------------------------------------------------------- */

AngleBreakableCR::AngleBreakableCR(LAMMPS *_lmp) :
    Angle(_lmp), k(nullptr), theta_c(nullptr), lambda_c(nullptr), cached_nanglelist(-1),
    store_index(-1), special(nullptr)
{
  writedata = 1;
  born_matrix_enable = 0;
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

  // newton_bond is off: each rank adds forces to its owned atoms only
  const int i1 = R.i1, i2 = R.i2, i3 = R.i3;
  if (i1 < nlocal) {
    f[i1][0] += f1[0];
    f[i1][1] += f1[1];
    f[i1][2] += f1[2];
  }
  if (i2 < nlocal) {
    f[i2][0] -= f1[0] + f3[0];
    f[i2][1] -= f1[1] + f3[1];
    f[i2][2] -= f1[2] + f3[2];
  }
  if (i3 < nlocal) {
    f[i3][0] += f3[0];
    f[i3][1] += f3[1];
    f[i3][2] += f3[2];
  }

  if (EVFLAG) ev_tally(i1, i2, i3, nlocal, 0, eangle, f1, f3, d[0], d[1], d[2], d[3], d[4], d[5]);
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

/* ---------------------------------------------------------------------- */

void AngleBreakableCR::compute(int eflag, int vflag)
{
  ev_init(eflag, vflag);

  if (cached_nanglelist < 0 || neighbor->ago == 0 || cached_nanglelist != neighbor->nanglelist)
    rebuild_cache();

  if (evflag)
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
