/* bond_style breakable/cr (SPEC 2.2 Eq. 2, bonded part of Eq. 5).

   Conventions: r = bond length, F > 0 repulsive, energy zero at r = r0.
     r < r0:                F = (K / r) ((r0/r)^12 - (r0/r)^6),   K = 6 2^(2/3) u r0^2 / a^2
                            E = (K / 12) ((r0/r)^12 - 2 (r0/r)^6 + 1)
     r0 <= r <= lambda_c r0: F = C1 (r0 - r) + C3 (r0 - r)^3
                            E = C1 (r - r0)^2 / 2 + C3 (r - r0)^4 / 4
     r > lambda_c r0:       the bond breaks (no force from then on); tested as r (1/r0) > lambda_c.
   Damping (not in the energy): F_D = -gamma (1 - r / (lambda_c r0))^2 (rhat . (v_i - v_j)) rhat.

   Reference lengths: r0 of every bond comes from the input (fix breakable/references, from the
   builder's table), the same value on every rank; this style never measures it. It is kept
   per atom and bond slot in a hidden fix lazy/store, so it migrates with atoms and goes to
   restart files; compute() reads a copy of the intact entries of neighbor->bondlist with their
   r0, two bonds at a time. A stored r0 of 0 is the value of a slot no reference was given for.

   Breaking goes through the single break path (break_events.h), which records the event with
   the energy of Eq. 2 at the breaking stretch. r is the same for both orders of the pair, so
   the ranks holding a bond decide alike up to the rounding of periodic images; fix
   breakable/special reconciles them at the end of the step. */

#include "bond_breakable_cr.h"

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

#include <cmath>
#include <cstring>
#include <mpi.h>
#include <utility>

using namespace LAMMPS_NS;

static constexpr double TWO_TWO_THIRDS = 1.5874010519681994;    // 2^(2/3)

namespace {

using BreakableUtil::Lanes2;
using BreakableUtil::Mask2;
using BreakableUtil::select_lt;

#include "bond_breakable_cr_math.h"    // the baseline copy

}    // namespace

/* ----------------------------------------------------------------------
   The same force law compiled for AVX, for the 4-lane force loop (loop4),
   which compute() takes when the processor has AVX (BreakableUtil::avx_loops;
   the library itself is built for baseline x86-64). AVX rounds each lane as
   the SSE2 and scalar instructions do and has no fused multiply-add, so a
   lane of loop4 gives the bits of loop() and exact().
------------------------------------------------------------------------- */

#if defined(BRITTLE_AVX_LOOPS)
#pragma GCC push_options
#pragma GCC target("avx")
namespace {
namespace avx {

#include "lanes4_avx.h"

#include "bond_breakable_cr_math.h"    // the AVX copy

}    // namespace avx
}    // namespace
#pragma GCC pop_options
#endif

/* ---------------------------------------------------------------------- */

BondBreakableCR::BondBreakableCR(LAMMPS *_lmp) :
    Bond(_lmp), lambda_c(nullptr), gamma(nullptr), a(nullptr), u(nullptr), cached_nbondlist(-1),
    store_index(-1), r0_max(0.0), special(nullptr)
{
  partial_flag = 1;    // broken bonds get type 0: the neighbor code must skip them
  writedata = 1;
  born_matrix_enable = 0;
  // single(): svector[0] = power dissipated by the bond's damping (compute bond/local b1)
  single_extra = 1;
  svector = new double[single_extra];
  avx_loop = BreakableUtil::avx_loops();
  // created now when possible so that thermo_style can name f_BREAKABLE_SPECIAL
  if (domain->box_exist) FixBreakableSpecial::get_or_create(lmp);
}

/* ----------------------------------------------------------------------
   the reference-length store and fix breakable/special stay: they carry the
   state of the bonds (and the break counters) if the style is redefined
------------------------------------------------------------------------- */

BondBreakableCR::~BondBreakableCR()
{
  delete[] svector;
  svector = nullptr;
  if (allocated) {
    memory->destroy(setflag);
    memory->destroy(lambda_c);
    memory->destroy(gamma);
    memory->destroy(a);
    memory->destroy(u);
  }
}

/* ---------------------------------------------------------------------- */

void BondBreakableCR::allocate()
{
  allocated = 1;
  const int n = atom->nbondtypes + 1;
  memory->create(lambda_c, n, "bond:lambda_c");
  memory->create(gamma, n, "bond:gamma");
  memory->create(a, n, "bond:a");
  memory->create(u, n, "bond:u");
  memory->create(setflag, n, "bond:setflag");
  params.assign(n, TypeParams{0.0, 0.0, 0.0, 0.0, 0.0, 0.0});
  for (int i = 1; i < n; i++) setflag[i] = 0;
}

/* ---------------------------------------------------------------------- */

void BondBreakableCR::derive(int type)
{
  // SPEC 2.2 Eq. 2: C1 = 36 2^(2/3) u / a^2, C3 = -36 2^(2/3) (lambda_c - 1)^-2 u r0^-2 a^-2
  TypeParams &P = params[type];
  P.lambda_c = lambda_c[type];
  P.gamma = gamma[type];
  P.c1 = 36.0 * TWO_TWO_THIRDS * u[type] / (a[type] * a[type]);
  const double ec = lambda_c[type] - 1.0;
  P.c3r2 = -P.c1 / (ec * ec);
  P.krep = 6.0 * TWO_TWO_THIRDS * u[type] / (a[type] * a[type]);
  P.inv_lc = 1.0 / lambda_c[type];
}

/* ----------------------------------------------------------------------
   bond_coeff T lambda_c gamma [a value] [u value]
------------------------------------------------------------------------- */

void BondBreakableCR::coeff(int narg, char **arg)
{
  if (narg < 3)
    error->all(FLERR, "Incorrect args for bond coefficients: "
                      "bond_coeff T lambda_c gamma [a value] [u value]");
  if (!allocated) allocate();

  int ilo, ihi;
  utils::bounds(FLERR, arg[0], 1, atom->nbondtypes, ilo, ihi, error);

  const double lc_one = utils::numeric(FLERR, arg[1], false, lmp);
  const double gamma_one = utils::numeric(FLERR, arg[2], false, lmp);
  double a_one = 1.0, u_one = 1.0;
  for (int iarg = 3; iarg < narg; iarg += 2) {
    if (iarg + 1 >= narg)
      error->all(FLERR, "bond_coeff breakable/cr: keyword {} needs a value", arg[iarg]);
    if (strcmp(arg[iarg], "a") == 0)
      a_one = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
    else if (strcmp(arg[iarg], "u") == 0)
      u_one = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
    else
      error->all(FLERR, "bond_coeff breakable/cr: unknown keyword {} (known: a, u)", arg[iarg]);
  }
  if (!(lc_one > 1.0)) error->all(FLERR, "bond_coeff breakable/cr: lambda_c must be > 1");
  if (!(gamma_one >= 0.0)) error->all(FLERR, "bond_coeff breakable/cr: gamma must be >= 0");
  if (!(a_one > 0.0)) error->all(FLERR, "bond_coeff breakable/cr: a must be > 0");
  if (!(u_one > 0.0)) error->all(FLERR, "bond_coeff breakable/cr: u must be > 0");

  int count = 0;
  for (int i = ilo; i <= ihi; i++) {
    lambda_c[i] = lc_one;
    gamma[i] = gamma_one;
    a[i] = a_one;
    u[i] = u_one;
    derive(i);
    setflag[i] = 1;
    count++;
  }
  if (count == 0) error->all(FLERR, "Incorrect args for bond coefficients");
  if (domain->box_exist) FixBreakableSpecial::get_or_create(lmp);
}

/* ---------------------------------------------------------------------- */

void BondBreakableCR::init_style()
{
  if (force->newton_bond)
    error->all(FLERR, "bond_style breakable/cr requires newton_bond off (command: newton on off), "
                      "so that every rank holding a bond stores it and decides its breaking");
  if (force->special_lj[1] != 0.0 || force->special_lj[2] != 1.0 || force->special_lj[3] != 1.0 ||
      force->special_coul[1] != 1.0 || force->special_coul[2] != 1.0 ||
      force->special_coul[3] != 1.0)
    error->all(FLERR, "bond_style breakable/cr requires special_bonds lj 0 1 1 coul 1 1 1 "
                      "(bonded pairs stay in the neighbor lists, with pair forces off)");
  if (!comm->ghost_velocity)
    error->all(FLERR, "bond_style breakable/cr requires comm_modify vel yes "
                      "(the bond damping reads ghost-atom velocities)");
  if (atom->molecular != Atom::MOLECULAR)
    error->all(FLERR, "bond_style breakable/cr requires a molecular atom style (not a template)");

  store_index = BreakableUtil::peratom_array(lmp, BreakableUtil::BOND_REF_FIX_ID,
                                             BreakableUtil::BOND_REF_NAME, atom->bond_per_atom);
  special = FixBreakableSpecial::get_or_create(lmp);
  cached_nbondlist = -1;
  r0_max = 0.0;
}

/* ----------------------------------------------------------------------
   force of one intact bond on its owned atoms, energy and virial
------------------------------------------------------------------------- */

template <bool EVFLAG>
inline void BondBreakableCR::apply(const Ref &R, double fbond, double ebond, double delx,
                                   double dely, double delz, double *const *f, int nlocal)
{
  // newton_bond is off: each rank adds forces to its owned atoms only
  const int i1 = R.i1, i2 = R.i2;
  if (i1 < nlocal) {
    f[i1][0] += delx * fbond;
    f[i1][1] += dely * fbond;
    f[i1][2] += delz * fbond;
  }
  if (i2 < nlocal) {
    f[i2][0] -= delx * fbond;
    f[i2][1] -= dely * fbond;
    f[i2][2] -= delz * fbond;
  }
  if (EVFLAG) ev_tally(i1, i2, nlocal, 0, ebond, fbond, delx, dely, delz);
}

/* ----------------------------------------------------------------------
   one bond, every case: its break or its force
------------------------------------------------------------------------- */

template <bool EVFLAG>
void BondBreakableCR::exact(Ref &R, const double *const *x, const double *const *v,
                            double *const *f, int nlocal)
{
  const TypeParams &P = params[R.type];
  const int i1 = R.i1, i2 = R.i2;
  const double delx = x[i1][0] - x[i2][0];
  const double dely = x[i1][1] - x[i2][1];
  const double delz = x[i1][2] - x[i2][2];
  const double rsq = delx * delx + dely * dely + delz * delz;
  const double r = sqrt(rsq);
  const double l = r * R.inv_r0;

  const double dot = delx * (v[i1][0] - v[i2][0]) + dely * (v[i1][1] - v[i2][1]) +
      delz * (v[i1][2] - v[i2][2]);
  double ebond;
  const double fbond = bond_force(r, 1.0 / rsq, l, dot, R.r0, R.inv_r0, P.c1, P.c3r2, P.krep,
                                  P.gamma, P.inv_lc, ebond);
  // SPEC 2.2 Eq. 2: broken for r > lambda_c r0, tested as r * (1/r0) > lambda_c; the event
  // keeps the energy of Eq. 2 at this stretch
  if (l > P.lambda_c) {
    break_bond(R, ebond);
    return;
  }
  apply<EVFLAG>(R, fbond, ebond, delx, dely, delz, f, nlocal);
}

/* ----------------------------------------------------------------------
   the force loop: two cache entries at a time in two lanes, with no call and
   no branch on the data until the forces are added; an entry that breaks is
   left untouched and done by exact() after the loop. A lane gives the bits
   of the scalar arithmetic, so the decisions do not depend on the lane.
------------------------------------------------------------------------- */

template <bool EVFLAG> void BondBreakableCR::loop()
{
  const double *const *x = atom->x;
  const double *const *v = atom->v;
  double *const *f = atom->f;
  const int nlocal = atom->nlocal;
  Ref *ref = cache.data();
  const int nref = (int) cache.size();
  const TypeParams *tp = params.data();
  int *left = deferred.data();
  int nleft = 0;

  for (int m = 0; m < nref; m += 2) {
    const int mb = (m + 1 < nref) ? m + 1 : m;    // the last entry alone: both lanes
    const Ref &Ra = ref[m], &Rb = ref[mb];
    const TypeParams &Pa = tp[Ra.type], &Pb = tp[Rb.type];    // type 0: broken, skipped below
    const double *x1a = x[Ra.i1], *x2a = x[Ra.i2], *x1b = x[Rb.i1], *x2b = x[Rb.i2];
    const double *v1a = v[Ra.i1], *v2a = v[Ra.i2], *v1b = v[Rb.i1], *v2b = v[Rb.i2];

    const Lanes2 delx = Lanes2{x1a[0], x1b[0]} - Lanes2{x2a[0], x2b[0]};
    const Lanes2 dely = Lanes2{x1a[1], x1b[1]} - Lanes2{x2a[1], x2b[1]};
    const Lanes2 delz = Lanes2{x1a[2], x1b[2]} - Lanes2{x2a[2], x2b[2]};
    const Lanes2 rsq = delx * delx + dely * dely + delz * delz;
    const Lanes2 r = BreakableUtil::vsqrt(rsq);
    const Lanes2 inv_r0 = {Ra.inv_r0, Rb.inv_r0};
    const Lanes2 l = r * inv_r0;
    const Mask2 intact = ~(l > Lanes2{Pa.lambda_c, Pb.lambda_c});
    const Lanes2 dot = delx * (Lanes2{v1a[0], v1b[0]} - Lanes2{v2a[0], v2b[0]}) +
        dely * (Lanes2{v1a[1], v1b[1]} - Lanes2{v2a[1], v2b[1]}) +
        delz * (Lanes2{v1a[2], v1b[2]} - Lanes2{v2a[2], v2b[2]});
    Lanes2 ebond;
    const Lanes2 fbond = bond_force(r, 1.0 / rsq, l, dot, Lanes2{Ra.r0, Rb.r0}, inv_r0,
                                    Lanes2{Pa.c1, Pb.c1}, Lanes2{Pa.c3r2, Pb.c3r2},
                                    Lanes2{Pa.krep, Pb.krep}, Lanes2{Pa.gamma, Pb.gamma},
                                    Lanes2{Pa.inv_lc, Pb.inv_lc}, ebond);

    if (Ra.type > 0) {
      if (intact[0])
        apply<EVFLAG>(Ra, fbond[0], ebond[0], delx[0], dely[0], delz[0], f, nlocal);
      else
        left[nleft++] = m;
    }
    if (mb != m && Rb.type > 0) {
      if (intact[1])
        apply<EVFLAG>(Rb, fbond[1], ebond[1], delx[1], dely[1], delz[1], f, nlocal);
      else
        left[nleft++] = mb;
    }
  }
  for (int j = 0; j < nleft; j++) exact<EVFLAG>(ref[left[j]], x, v, f, nlocal);
}

/* ----------------------------------------------------------------------
   loop() on four cache entries at a time, in the four lanes of AVX
------------------------------------------------------------------------- */

#if defined(BRITTLE_AVX_LOOPS)
#pragma GCC push_options
#pragma GCC target("avx")
template <bool EVFLAG> void BondBreakableCR::loop4()
{
  using avx::Lanes4;
  using avx::Mask4;
  const double *const *x = atom->x;
  const double *const *v = atom->v;
  double *const *f = atom->f;
  const int nlocal = atom->nlocal;
  Ref *ref = cache.data();
  const int nref = (int) cache.size();
  const TypeParams *tp = params.data();
  int *left = deferred.data();
  int nleft = 0;

  for (int m = 0; m < nref; m += 4) {
    // past the end, a lane repeats the last entry and is skipped below
    const int last = nref - 1;
    const int e[4] = {m, m + 1 < nref ? m + 1 : last, m + 2 < nref ? m + 2 : last,
                      m + 3 < nref ? m + 3 : last};
    const Ref *R[4] = {&ref[e[0]], &ref[e[1]], &ref[e[2]], &ref[e[3]]};
    const TypeParams *P[4] = {&tp[R[0]->type], &tp[R[1]->type], &tp[R[2]->type],
                              &tp[R[3]->type]};    // type 0: broken, skipped below
    const double *x1[4], *x2[4], *v1[4], *v2[4];
    for (int k = 0; k < 4; k++) {
      x1[k] = x[R[k]->i1];
      x2[k] = x[R[k]->i2];
      v1[k] = v[R[k]->i1];
      v2[k] = v[R[k]->i2];
    }
    const Lanes4 delx = Lanes4{x1[0][0], x1[1][0], x1[2][0], x1[3][0]} -
        Lanes4{x2[0][0], x2[1][0], x2[2][0], x2[3][0]};
    const Lanes4 dely = Lanes4{x1[0][1], x1[1][1], x1[2][1], x1[3][1]} -
        Lanes4{x2[0][1], x2[1][1], x2[2][1], x2[3][1]};
    const Lanes4 delz = Lanes4{x1[0][2], x1[1][2], x1[2][2], x1[3][2]} -
        Lanes4{x2[0][2], x2[1][2], x2[2][2], x2[3][2]};
    const Lanes4 rsq = delx * delx + dely * dely + delz * delz;
    const Lanes4 r = avx::vsqrt(rsq);
    const Lanes4 inv_r0 = {R[0]->inv_r0, R[1]->inv_r0, R[2]->inv_r0, R[3]->inv_r0};
    const Lanes4 l = r * inv_r0;
    // per-type parameters: one broadcast when the four entries share a type (the usual case)
    Lanes4 lc, c1, c3r2, krep, gam, inv_lc;
    if (P[1] == P[0] && P[2] == P[0] && P[3] == P[0]) {
      const TypeParams &Q = *P[0];
      lc = Lanes4{} + Q.lambda_c;
      c1 = Lanes4{} + Q.c1;
      c3r2 = Lanes4{} + Q.c3r2;
      krep = Lanes4{} + Q.krep;
      gam = Lanes4{} + Q.gamma;
      inv_lc = Lanes4{} + Q.inv_lc;
    } else {
      lc = Lanes4{P[0]->lambda_c, P[1]->lambda_c, P[2]->lambda_c, P[3]->lambda_c};
      c1 = Lanes4{P[0]->c1, P[1]->c1, P[2]->c1, P[3]->c1};
      c3r2 = Lanes4{P[0]->c3r2, P[1]->c3r2, P[2]->c3r2, P[3]->c3r2};
      krep = Lanes4{P[0]->krep, P[1]->krep, P[2]->krep, P[3]->krep};
      gam = Lanes4{P[0]->gamma, P[1]->gamma, P[2]->gamma, P[3]->gamma};
      inv_lc = Lanes4{P[0]->inv_lc, P[1]->inv_lc, P[2]->inv_lc, P[3]->inv_lc};
    }
    const Mask4 intact = ~(l > lc);
    const Lanes4 dot = delx * (Lanes4{v1[0][0], v1[1][0], v1[2][0], v1[3][0]} -
                               Lanes4{v2[0][0], v2[1][0], v2[2][0], v2[3][0]}) +
        dely * (Lanes4{v1[0][1], v1[1][1], v1[2][1], v1[3][1]} -
                Lanes4{v2[0][1], v2[1][1], v2[2][1], v2[3][1]}) +
        delz * (Lanes4{v1[0][2], v1[1][2], v1[2][2], v1[3][2]} -
                Lanes4{v2[0][2], v2[1][2], v2[2][2], v2[3][2]});
    Lanes4 ebond;
    const Lanes4 fbond = avx::bond_force(
        r, 1.0 / rsq, l, dot, Lanes4{R[0]->r0, R[1]->r0, R[2]->r0, R[3]->r0}, inv_r0, c1,
        c3r2, krep, gam, inv_lc, ebond);

    for (int k = 0; k < 4; k++) {
      if ((k > 0 && m + k >= nref) || R[k]->type <= 0) continue;
      if (intact[k])
        apply<EVFLAG>(*R[k], fbond[k], ebond[k], delx[k], dely[k], delz[k], f, nlocal);
      else
        left[nleft++] = e[k];
    }
  }
  for (int j = 0; j < nleft; j++) exact<EVFLAG>(ref[left[j]], x, v, f, nlocal);
}
#pragma GCC pop_options
#else
template <bool EVFLAG> void BondBreakableCR::loop4()
{
  loop<EVFLAG>();
}
#endif

/* ---------------------------------------------------------------------- */

void BondBreakableCR::compute(int eflag, int vflag)
{
  ev_init(eflag, vflag);

  if (cached_nbondlist < 0 || neighbor->ago == 0 || cached_nbondlist != neighbor->nbondlist)
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
   a break decided on this rank: the cache entry, then the single break path
------------------------------------------------------------------------- */

void BondBreakableCR::break_bond(Ref &R, double energy)
{
  R.type = 0;
  BreakPath::bond(lmp, special, R.n, energy, true);
}

/* ----------------------------------------------------------------------
   a bond break decided on some rank (fix breakable/special, end of step): if
   an owned atom here still holds the bond intact, this rank had not decided
   it (rounding of another image), and breaks it now with that event's record
------------------------------------------------------------------------- */

void BondBreakableCR::break_if_intact(const BreakEvent &ev)
{
  const tagint t1 = (tagint) ev.id1, t2 = (tagint) ev.id2;
  const int nlocal = atom->nlocal;
  bool intact = false;
  for (int side = 0; side < 2 && !intact; side++) {
    const int i = atom->map(side ? t2 : t1);
    if (i < 0 || i >= nlocal) continue;
    const int m = BreakableUtil::bond_slot(atom, i, side ? t1 : t2);
    intact = m >= 0 && atom->bond_type[i][m] > 0;
  }
  if (!intact) return;

  const tagint *tag = atom->tag;
  for (Ref &R : cache) {
    if (R.type <= 0) continue;
    const tagint a = tag[R.i1], b = tag[R.i2];
    if ((a == t1 && b == t2) || (a == t2 && b == t1)) {
      R.type = 0;
      BreakPath::bond(lmp, special, R.n, ev.energy, false, &ev);
      return;
    }
  }
  error->one(FLERR, "bond_style breakable/cr: bond {}-{} held by an owned atom is not in the "
             "bond list", t1, t2);
}

/* ----------------------------------------------------------------------
   copy the intact bondlist entries and their r0 into the cache. With
   newton_bond off the neighbor code lists a bond from its owned atom i
   (first in the entry), walking i's bond slots in order: a cursor over i's
   slots finds each entry's slot with tag compares only, falling back to a
   full search when the order differs. Broken entries (type 0) are left out of
   the cache; an intact one without a reference length is an error.
------------------------------------------------------------------------- */

void BondBreakableCR::rebuild_cache()
{
  double **r0s = atom->darray[store_index];
  const tagint *tag = atom->tag;
  const int *num_bond = atom->num_bond;
  tagint **bond_atom = atom->bond_atom;
  const int nlocal = atom->nlocal;
  int **bondlist = neighbor->bondlist;
  const int nbondlist = neighbor->nbondlist;

  cache.resize(nbondlist);
  int nref = 0, owner = -1, m = 0;
  for (int n = 0; n < nbondlist; n++) {
    int i1 = bondlist[n][0], i2 = bondlist[n][1];
    const int type = bondlist[n][2];
    if (i1 >= nlocal) std::swap(i1, i2);
    if (i1 >= nlocal)
      error->one(FLERR, "bond_style breakable/cr: bond {}-{} has no owned atom", tag[i1], tag[i2]);
    const tagint partner = tag[i2];
    if (i1 != owner) {
      owner = i1;
      m = 0;
    }
    while (m < num_bond[i1] && bond_atom[i1][m] != partner) m++;
    if (m == num_bond[i1] && (m = BreakableUtil::bond_slot(atom, i1, partner)) < 0)
      error->one(FLERR, "bond_style breakable/cr: bond {}-{} of the bond list is not in the "
                 "atom's bond arrays", tag[i1], partner);
    const double r0 = r0s[i1][m];
    m++;
    if (type <= 0) continue;

    if (!(r0 > 0.0))
      error->one(FLERR, "bond_style breakable/cr: bond {}-{} has no reference length: the "
                 "references file of fix breakable/references does not list it", tag[i1],
                 tag[i2]);
    Ref &R = cache[nref++];
    R.i1 = bondlist[n][0];    // the list's order: the sign convention of the virial
    R.i2 = bondlist[n][1];
    R.type = type;
    R.n = n;
    R.r0 = r0;
    R.inv_r0 = 1.0 / r0;
  }
  cache.resize(nref);
  deferred.resize(nref);
  cached_nbondlist = nbondlist;
}

/* ----------------------------------------------------------------------
   ghost atoms must reach stretched bonds: lambda_c times the largest r0
   (the current length of a bond without a reference, which is an error at
   its first force evaluation). Collective on the first call of a run, which
   Comm::setup makes on all ranks.
------------------------------------------------------------------------- */

double BondBreakableCR::equilibrium_distance(int type)
{
  if (!allocated || !setflag[type]) return 0.0;
  if (r0_max == 0.0) {
    double local = 0.0;
    double **x = atom->x;
    double **r0s = (store_index >= 0) ? atom->darray[store_index] : nullptr;
    for (int i = 0; i < atom->nlocal; i++)
      for (int m = 0; m < atom->num_bond[i]; m++) {
        if (atom->bond_type[i][m] == 0) continue;
        double r = r0s ? r0s[i][m] : 0.0;
        if (r == 0.0) {
          int j = atom->map(atom->bond_atom[i][m]);
          if (j < 0) continue;
          double dx = x[i][0] - x[j][0], dy = x[i][1] - x[j][1], dz = x[i][2] - x[j][2];
          domain->minimum_image(FLERR, dx, dy, dz);
          r = sqrt(dx * dx + dy * dy + dz * dz);
        }
        if (r > local) local = r;
      }
    MPI_Allreduce(&local, &r0_max, 1, MPI_DOUBLE, MPI_MAX, world);
  }
  return lambda_c[type] * r0_max;
}

/* ---------------------------------------------------------------------- */

void BondBreakableCR::write_restart(FILE *fp)
{
  const int n = atom->nbondtypes;
  fwrite(&lambda_c[1], sizeof(double), n, fp);
  fwrite(&gamma[1], sizeof(double), n, fp);
  fwrite(&a[1], sizeof(double), n, fp);
  fwrite(&u[1], sizeof(double), n, fp);
}

/* ---------------------------------------------------------------------- */

void BondBreakableCR::read_restart(FILE *fp)
{
  allocate();
  const int n = atom->nbondtypes;
  if (comm->me == 0) {
    utils::sfread(FLERR, &lambda_c[1], sizeof(double), n, fp, nullptr, error);
    utils::sfread(FLERR, &gamma[1], sizeof(double), n, fp, nullptr, error);
    utils::sfread(FLERR, &a[1], sizeof(double), n, fp, nullptr, error);
    utils::sfread(FLERR, &u[1], sizeof(double), n, fp, nullptr, error);
  }
  MPI_Bcast(&lambda_c[1], n, MPI_DOUBLE, 0, world);
  MPI_Bcast(&gamma[1], n, MPI_DOUBLE, 0, world);
  MPI_Bcast(&a[1], n, MPI_DOUBLE, 0, world);
  MPI_Bcast(&u[1], n, MPI_DOUBLE, 0, world);
  for (int i = 1; i <= n; i++) {
    derive(i);
    setflag[i] = 1;
  }
}

/* ---------------------------------------------------------------------- */

void BondBreakableCR::write_data(FILE *fp)
{
  for (int i = 1; i <= atom->nbondtypes; i++)
    fmt::print(fp, "{} {} {} a {} u {}\n", i, lambda_c[i], gamma[i], a[i], u[i]);
}

/* ----------------------------------------------------------------------
   r0 of the bond between atoms i and j, from an owned atom's copy
------------------------------------------------------------------------- */

double BondBreakableCR::reference_length(int i, int j)
{
  if (store_index < 0)
    error->one(FLERR, "bond_style breakable/cr: single() before the first run");
  double **r0s = atom->darray[store_index];
  const tagint *tag = atom->tag;
  const int nlocal = atom->nlocal;
  int m;
  double r0 = 0.0;
  if (i < nlocal && (m = BreakableUtil::bond_slot(atom, i, tag[j])) >= 0)
    r0 = r0s[i][m];
  else if (j < nlocal && (m = BreakableUtil::bond_slot(atom, j, tag[i])) >= 0)
    r0 = r0s[j][m];
  else
    error->one(FLERR, "bond_style breakable/cr: atoms {} and {} share no bond on this rank",
               tag[i], tag[j]);
  if (!(r0 > 0.0))
    error->one(FLERR, "bond_style breakable/cr: bond {}-{} has no reference length (fix "
               "breakable/references)", tag[i], tag[j]);
  return r0;
}

/* ----------------------------------------------------------------------
   force / r (damping included, as compute() applies it) and energy of the
   bond between atoms i and j; zero beyond lambda_c r0. svector[0]: the power
   the damping dissipates, gamma w^2 (rhat . (v_i - v_j))^2 >= 0
------------------------------------------------------------------------- */

double BondBreakableCR::single(int type, double rsq, int i, int j, double &fforce)
{
  fforce = 0.0;
  svector[0] = 0.0;
  if (type <= 0) return 0.0;
  const TypeParams &P = params[type];
  const double r0 = reference_length(i, j);
  const double r = sqrt(rsq);
  const double inv_r0 = 1.0 / r0;
  const double l = r * inv_r0;
  if (l > P.lambda_c) return 0.0;

  double dot = 0.0;
  if (atom->v) {
    double **x = atom->x;
    double **v = atom->v;
    dot = (x[i][0] - x[j][0]) * (v[i][0] - v[j][0]) + (x[i][1] - x[j][1]) * (v[i][1] - v[j][1]) +
        (x[i][2] - x[j][2]) * (v[i][2] - v[j][2]);
  }
  double ebond;
  fforce = bond_force(r, 1.0 / rsq, l, dot, r0, inv_r0, P.c1, P.c3r2, P.krep, P.gamma, P.inv_lc,
                      ebond);
  const double w = 1.0 - l * P.inv_lc;
  svector[0] = P.gamma * w * w * dot * dot / rsq;
  return ebond;
}

/* ---------------------------------------------------------------------- */

double BondBreakableCR::memory_usage()
{
  return Bond::memory_usage() + (double) cache.capacity() * sizeof(Ref) +
      (double) deferred.capacity() * sizeof(int) + (double) params.capacity() * sizeof(TypeParams);
}
