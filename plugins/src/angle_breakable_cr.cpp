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

   The angle breaks (type set to 0 for good) when |dth| >= theta_c, or when an arm's stretch
   r * (1/r0) exceeds lambda_c: the test bond_style breakable/cr makes on the same pair, with
   the same arithmetic, so an angle goes in the step its bond does (when both use the same
   lambda_c; across periodic images the two references may differ by rounding).

   Storage: theta0, r1_0, r2_0 per atom and angle slot in a hidden fix property/atom (every
   atom of an angle holds a copy of it, newton_bond being off); compute() reads a copy indexed
   like neighbor->anglelist. A stored r1_0 of 0 is the value of a fresh slot: it marks an
   angle whose references have not been taken yet. */

#include "angle_breakable_cr.h"

#include "atom.h"
#include "breakable_util.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "fix_breakable_special.h"
#include "force.h"
#include "memory.h"
#include "neighbor.h"

#include <algorithm>
#include <cmath>
#include <mpi.h>

using namespace LAMMPS_NS;

static constexpr double PI = 3.14159265358979323846;
static constexpr double SMALL = 0.001;    // floor of sin(theta), as in angle_style harmonic
static const char *const STORE_FIX_ID = "BREAKABLE_CR_ANGLE_REF";
static const char *const STORE_NAME = "breakable_cr_angle_ref";

/* ---------------------------------------------------------------------- */

AngleBreakableCR::AngleBreakableCR(LAMMPS *_lmp) :
    Angle(_lmp), k(nullptr), theta_c(nullptr), lambda_c(nullptr), inv_thc2(nullptr),
    inv_ec2(nullptr), cache_valid(false), store_index(-1), special(nullptr)
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
    memory->destroy(inv_thc2);
    memory->destroy(inv_ec2);
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
  memory->create(inv_thc2, n, "angle:inv_thc2");
  memory->create(inv_ec2, n, "angle:inv_ec2");
  memory->create(setflag, n, "angle:setflag");
  for (int i = 1; i < n; i++) setflag[i] = 0;
}

/* ---------------------------------------------------------------------- */

void AngleBreakableCR::derive(int type)
{
  inv_thc2[type] = 1.0 / (theta_c[type] * theta_c[type]);
  const double ec = lambda_c[type] - 1.0;
  inv_ec2[type] = 1.0 / (ec * ec);
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

  store_index =
      BreakableUtil::peratom_array(lmp, STORE_FIX_ID, STORE_NAME, 3 * atom->angle_per_atom);
  special = FixBreakableSpecial::get_or_create(lmp);
  cache_valid = false;
}

/* ---------------------------------------------------------------------- */

void AngleBreakableCR::compute(int eflag, int vflag)
{
  ev_init(eflag, vflag);

  if (!cache_valid || neighbor->ago == 0 || (int) cache.size() != neighbor->nanglelist)
    rebuild_cache();

  double **x = atom->x;
  double **f = atom->f;
  int **anglelist = neighbor->anglelist;
  const int nanglelist = neighbor->nanglelist;
  const int nlocal = atom->nlocal;
  const Ref *ref = cache.data();
  double eangle = 0.0, f1[3], f3[3];

  // Angles go in blocks of three passes: geometry, then the arc cosines in a loop of their
  // own, then forces. acos() is a library call, after which no floating-point register
  // survives: in a single pass every value live across it goes to the stack and back,
  // while the tight loop of calls keeps nothing live and lets consecutive calls overlap.
  constexpr int BLOCK = 64;
  double del[BLOCK][6], len[BLOCK][3], cosine[BLOCK], theta[BLOCK];

  for (int nb = 0; nb < nanglelist; nb += BLOCK) {
    const int nblock = std::min(BLOCK, nanglelist - nb);

    for (int b = 0; b < nblock; b++) {
      const int *al = anglelist[nb + b];
      if (al[3] <= 0) {
        cosine[b] = 1.0;
        continue;
      }
      const double *x1 = x[al[0]], *x2 = x[al[1]], *x3 = x[al[2]];
      double *d = del[b];
      d[0] = x1[0] - x2[0];
      d[1] = x1[1] - x2[1];
      d[2] = x1[2] - x2[2];
      d[3] = x3[0] - x2[0];
      d[4] = x3[1] - x2[1];
      d[5] = x3[2] - x2[2];
      const double r1 = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
      const double r2 = sqrt(d[3] * d[3] + d[4] * d[4] + d[5] * d[5]);
      const double inv_r12 = 1.0 / (r1 * r2);
      double c = (d[0] * d[3] + d[1] * d[4] + d[2] * d[5]) * inv_r12;
      c = std::min(std::max(c, -1.0), 1.0);
      len[b][0] = r1;
      len[b][1] = r2;
      len[b][2] = inv_r12;
      cosine[b] = c;
    }

    for (int b = 0; b < nblock; b++) theta[b] = acos(cosine[b]);

    for (int b = 0; b < nblock; b++) {
      const int n = nb + b;
      const int type = anglelist[n][3];
      if (type <= 0) continue;
      const int i1 = anglelist[n][0];
      const int i2 = anglelist[n][1];
      const int i3 = anglelist[n][2];
      const Ref &R = ref[n];
      const double delx1 = del[b][0], dely1 = del[b][1], delz1 = del[b][2];
      const double delx2 = del[b][3], dely2 = del[b][4], delz2 = del[b][5];
      const double r1 = len[b][0], r2 = len[b][1], inv_r12 = len[b][2];
      const double c = cosine[b];

      // breaking with an arm's bond (SPEC 2.2: "or when either of its bonds breaks"): the
      // stretch l = r / r0 is computed as the bond style does (r times the same 1/r0), so
      // both make the same decision on the same pair
      const double l1 = r1 * R.inv_r1_0;
      const double l2 = r2 * R.inv_r2_0;
      if (l1 > lambda_c[type] || l2 > lambda_c[type]) {
        break_angle(n, i1, i2, i3);
        continue;
      }

      const double dth = theta[b] - R.theta0;

      // breaking by bending (SPEC 2.2 Eq. 3: |dtheta| >= theta_c)
      if (fabs(dth) >= theta_c[type]) {
        break_angle(n, i1, i2, i3);
        continue;
      }

      const double inv_s = 1.0 / std::max(sqrt(1.0 - c * c), SMALL);
      const double inv_r1 = r2 * inv_r12;
      const double inv_r2 = r1 * inv_r12;
      const double c11 = c * inv_r1 * inv_r1;
      const double c22 = c * inv_r2 * inv_r2;

      // SPEC Eq. 4: S of the more stretched arm, and dS/dl. Without branches: which arm is
      // longer, and whether it is stretched at all, change at random from angle to angle.
      // eps is clamped at 0 (S = 1, dS = 0); q at 0 only matters by rounding, the arms being
      // within lambda_c r0 here.
      const bool arm1 = (l1 >= l2);
      const double eps = std::max((arm1 ? l1 : l2) - 1.0, 0.0);
      const double q = std::max(1.0 - eps * eps * inv_ec2[type], 0.0);
      const double s_fac = q * q;
      // dS/dr of the stretched arm, over its length: dS/dl / (r0 r)
      const double ds_r = -4.0 * eps * q * inv_ec2[type] *
          (arm1 ? R.inv_r1_0 * inv_r1 : R.inv_r2_0 * inv_r2);
      const double sel1 = arm1 ? 1.0 : 0.0;

      // SPEC Eq. 3: dE/dtheta = k_A S (dth - dth^3 / theta_c^2); E = k_A S g with
      // g = dth^2/2 - dth^4/(4 theta_c^2)
      const double dth2 = dth * dth;
      const double ks = k[type] * s_fac;
      const double tau = ks * dth * (1.0 - dth2 * inv_thc2[type]);
      const double g = dth2 * (0.5 - 0.25 * dth2 * inv_thc2[type]);

      // angular part as in angle_style harmonic; the radial term -dE/dr = -k_A g dS/dr along
      // the more stretched arm is folded into the coefficient of that arm's vector
      const double aa = -tau * inv_s;
      const double fr = -k[type] * g * ds_r;
      const double a11 = aa * c11 + sel1 * fr;
      const double a12 = -aa * inv_r12;
      const double a22 = aa * c22 + (1.0 - sel1) * fr;

      f1[0] = a11 * delx1 + a12 * delx2;
      f1[1] = a11 * dely1 + a12 * dely2;
      f1[2] = a11 * delz1 + a12 * delz2;
      f3[0] = a22 * delx2 + a12 * delx1;
      f3[1] = a22 * dely2 + a12 * dely1;
      f3[2] = a22 * delz2 + a12 * delz1;
      if (eflag) eangle = ks * g;

      // newton_bond is off: each rank adds forces to its owned atoms only
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

      if (evflag)
        ev_tally(i1, i2, i3, nlocal, 0, eangle, f1, f3, delx1, dely1, delz1, delx2, dely2, delz2);
    }
  }
}

/* ----------------------------------------------------------------------
   the single break path: type 0 in the list and in every owned copy; the
   rank owning the atom with the smallest tag counts it, so it counts once
------------------------------------------------------------------------- */

void AngleBreakableCR::break_angle(int n, int i1, int i2, int i3)
{
  const int nlocal = atom->nlocal;
  const tagint *tag = atom->tag;
  const tagint t1 = tag[i1], t2 = tag[i2], t3 = tag[i3];
  neighbor->anglelist[n][3] = 0;
  for (int idx : {i1, i2, i3}) {
    if (idx >= nlocal) continue;
    const int m = BreakableUtil::angle_slot(atom, idx, t1, t2, t3);
    if (m >= 0) atom->angle_type[idx][m] = 0;
  }
  int lowest = i1;
  if (t2 < tag[lowest]) lowest = i2;
  if (t3 < tag[lowest]) lowest = i3;
  special->add_broken_angle(lowest < nlocal ? 1 : 0);
}

/* ----------------------------------------------------------------------
   theta0, r1_0, r2_0 of the angle a1-a2-a3 (closest images) from the current
   geometry, with the arithmetic of compute()
------------------------------------------------------------------------- */

void AngleBreakableCR::capture(int a1, int a2, int a3, double *dest)
{
  double **x = atom->x;
  const double d1[3] = {x[a1][0] - x[a2][0], x[a1][1] - x[a2][1], x[a1][2] - x[a2][2]};
  const double d2[3] = {x[a3][0] - x[a2][0], x[a3][1] - x[a2][1], x[a3][2] - x[a2][2]};
  const double r1 = sqrt(d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2]);
  const double r2 = sqrt(d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2]);
  if (!(r1 > 0.0 && r2 > 0.0))
    error->one(FLERR, "angle_style breakable/cr: angle {}-{}-{} has an arm of zero length",
               atom->tag[a1], atom->tag[a2], atom->tag[a3]);
  const double c = (d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2]) * (1.0 / (r1 * r2));
  dest[0] = acos(std::min(std::max(c, -1.0), 1.0));
  dest[1] = r1;
  dest[2] = r2;
}

/* ----------------------------------------------------------------------
   copy the references of every anglelist entry into the cache. With
   newton_bond off the neighbor code lists an angle from its owned atom with
   the smallest local index (the smallest of the entry's three indices),
   walking that atom's angle slots in order: a cursor over its slots finds each
   entry's slot with tag compares only, falling back to a full search when the
   order differs. An angle whose references are not yet taken gets them here
   from the current geometry (in the setup of its first run), in every copy
   owned on this rank.
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
  int owner = -1, m = 0;
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

    double *src = &refs[i][3 * m];
    if (src[1] == 0.0 && type > 0) {
      capture(a1, a2, a3, src);
      for (int other : {a1, a2, a3}) {
        int slot;
        if (other == i || other >= nlocal ||
            (slot = BreakableUtil::angle_slot(atom, other, t1, t2, t3)) < 0)
          continue;
        double *copy = &refs[other][3 * slot];
        if (copy[1] == 0.0)
          for (int c = 0; c < 3; c++) copy[c] = src[c];
      }
    }

    Ref &R = cache[n];
    R.theta0 = src[0];
    R.inv_r1_0 = (src[1] > 0.0) ? 1.0 / src[1] : 0.0;
    R.inv_r2_0 = (src[2] > 0.0) ? 1.0 / src[2] : 0.0;
    m++;
  }
  cache_valid = true;
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
   atom's copy; zero once a breaking criterion is met
------------------------------------------------------------------------- */

double AngleBreakableCR::single(int type, int i1, int i2, int i3)
{
  if (type <= 0) return 0.0;
  if (store_index < 0)
    error->one(FLERR, "angle_style breakable/cr: references are taken in the first run");
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

  double **x = atom->x;
  const double d1[3] = {x[i1][0] - x[i2][0], x[i1][1] - x[i2][1], x[i1][2] - x[i2][2]};
  const double d2[3] = {x[i3][0] - x[i2][0], x[i3][1] - x[i2][1], x[i3][2] - x[i2][2]};
  const double r1 = sqrt(d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2]);
  const double r2 = sqrt(d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2]);
  const double l1 = r1 * (1.0 / ref[1]), l2 = r2 * (1.0 / ref[2]);
  if (l1 > lambda_c[type] || l2 > lambda_c[type]) return 0.0;
  double c = (d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2]) / (r1 * r2);
  if (c > 1.0) c = 1.0;
  if (c < -1.0) c = -1.0;
  const double dth = acos(c) - ref[0];
  if (fabs(dth) >= theta_c[type]) return 0.0;

  const double eps = std::max(l1, l2) - 1.0;
  double s_fac = 1.0;
  if (eps > 0.0) {
    const double q = std::fmax(0.0, 1.0 - eps * eps * inv_ec2[type]);
    s_fac = q * q;
  }
  const double dth2 = dth * dth;
  return k[type] * s_fac * dth2 * (0.5 - 0.25 * dth2 * inv_thc2[type]);
}

/* ---------------------------------------------------------------------- */

double AngleBreakableCR::memory_usage()
{
  return Angle::memory_usage() + (double) cache.capacity() * sizeof(Ref);
}
