/* pair_style cr/repulsion (SPEC 2.2 Eq. 1 and the non-bonded part of Eq. 5).

   Conventions: r = distance, F > 0 repulsive, pair (i, j) of types I, J with coefficients
   u, abar, gamma; everything is cut at abar.
     repulsion (Eq. 1):  F = (12 u / r) ((abar/r)^12 - (abar/r)^6)
                         E = u ((abar/r)^12 - 2 (abar/r)^6 + 1)   (WCA, zero at abar)
     damping (Eq. 5):    F_D = -gamma (1 - r / abar)^2 (rhat . (v_i - v_j)) rhat,
                         not part of the energy; r_max = abar.
   This is lj/cut with sigma = abar 2^(-1/6), epsilon = u, cut at abar and shifted, overlaid
   with dpd/tstat at T = 0, in one pass over the neighbor list and without random numbers.
   Both terms are scaled by the special_lj factor of the pair, as in those styles; a factor
   of 0 (bonded pairs under special_bonds lj 0) skips the pair before its distance is
   computed. */

#include "pair_cr_repulsion.h"

#include "atom.h"
#include "comm.h"
#include "error.h"
#include "force.h"
#include "memory.h"
#include "neigh_list.h"
#include "neighbor.h"

#include <cmath>
#include <mpi.h>

using namespace LAMMPS_NS;

namespace {

/* ----------------------------------------------------------------------
   F / r (damping included) and energy of one pair inside abar, before the
   special factor; dot = (x_i - x_j) . (v_i - v_j). compute() and single()
   both use it.
------------------------------------------------------------------------- */

inline double pair_force(double rsq, double dot, double u, double u12, double abar_sq,
                         double inv_abar, double gamma, double &energy)
{
  const double r2inv = 1.0 / rsq;
  const double a2 = abar_sq * r2inv;    // (abar/r)^2
  const double a6 = a2 * a2 * a2;
  const double a12 = a6 * a6;
  const double w = 1.0 - sqrt(rsq) * inv_abar;
  energy = u * (a12 - 2.0 * a6 + 1.0);
  return (u12 * (a12 - a6) - gamma * w * w * dot) * r2inv;
}

}    // namespace

/* ---------------------------------------------------------------------- */

PairCRRepulsion::PairCRRepulsion(LAMMPS *_lmp) :
    Pair(_lmp), u(nullptr), abar(nullptr), gamma(nullptr), u12(nullptr), abar_sq(nullptr),
    inv_abar(nullptr)
{
  writedata = 1;
  restartinfo = 1;
  single_enable = 1;
  // single(): svector[0] = power dissipated by the pair's damping (compute pair/local p1)
  single_extra = 1;
  svector = new double[single_extra];
}

/* ---------------------------------------------------------------------- */

PairCRRepulsion::~PairCRRepulsion()
{
  delete[] svector;
  svector = nullptr;
  if (allocated) {
    memory->destroy(setflag);
    memory->destroy(cutsq);
    memory->destroy(u);
    memory->destroy(abar);
    memory->destroy(gamma);
    memory->destroy(u12);
    memory->destroy(abar_sq);
    memory->destroy(inv_abar);
  }
}

/* ---------------------------------------------------------------------- */

void PairCRRepulsion::allocate()
{
  allocated = 1;
  const int n = atom->ntypes + 1;
  memory->create(setflag, n, n, "pair:setflag");
  for (int i = 1; i < n; i++)
    for (int j = i; j < n; j++) setflag[i][j] = 0;
  memory->create(cutsq, n, n, "pair:cutsq");
  memory->create(u, n, n, "pair:u");
  memory->create(abar, n, n, "pair:abar");
  memory->create(gamma, n, n, "pair:gamma");
  memory->create(u12, n, n, "pair:u12");
  memory->create(abar_sq, n, n, "pair:abar_sq");
  memory->create(inv_abar, n, n, "pair:inv_abar");
}

/* ----------------------------------------------------------------------
   pair_style cr/repulsion (no settings: each pair's cutoff is its abar)
------------------------------------------------------------------------- */

void PairCRRepulsion::settings(int narg, char **arg)
{
  if (narg != 0)
    error->all(FLERR, "pair_style cr/repulsion takes no arguments (got {}): the cutoff of "
               "each type pair is its abar, given by pair_coeff", arg[0]);
}

/* ----------------------------------------------------------------------
   pair_coeff I J u abar gamma
------------------------------------------------------------------------- */

void PairCRRepulsion::coeff(int narg, char **arg)
{
  if (narg != 5)
    error->all(FLERR, "Incorrect args for pair coefficients: pair_coeff I J u abar gamma");
  if (!allocated) allocate();

  int ilo, ihi, jlo, jhi;
  utils::bounds(FLERR, arg[0], 1, atom->ntypes, ilo, ihi, error);
  utils::bounds(FLERR, arg[1], 1, atom->ntypes, jlo, jhi, error);
  const double u_one = utils::numeric(FLERR, arg[2], false, lmp);
  const double abar_one = utils::numeric(FLERR, arg[3], false, lmp);
  const double gamma_one = utils::numeric(FLERR, arg[4], false, lmp);
  if (!(u_one >= 0.0)) error->all(FLERR, "pair_coeff cr/repulsion: u must be >= 0");
  if (!(abar_one > 0.0)) error->all(FLERR, "pair_coeff cr/repulsion: abar must be > 0");
  if (!(gamma_one >= 0.0)) error->all(FLERR, "pair_coeff cr/repulsion: gamma must be >= 0");

  int count = 0;
  for (int i = ilo; i <= ihi; i++)
    for (int j = (jlo > i ? jlo : i); j <= jhi; j++) {
      u[i][j] = u_one;
      abar[i][j] = abar_one;
      gamma[i][j] = gamma_one;
      setflag[i][j] = 1;
      count++;
    }
  if (count == 0) error->all(FLERR, "Incorrect args for pair coefficients");
}

/* ---------------------------------------------------------------------- */

void PairCRRepulsion::init_style()
{
  if (!comm->ghost_velocity)
    error->all(FLERR, "pair_style cr/repulsion requires comm_modify vel yes "
                      "(the damping reads ghost-atom velocities)");
  neighbor->add_request(this);
}

/* ----------------------------------------------------------------------
   unset I != J pairs mix: abar arithmetic (the sum of the two radii when
   abar_II, abar_JJ are diameters), u and gamma geometric
------------------------------------------------------------------------- */

double PairCRRepulsion::init_one(int i, int j)
{
  if (setflag[i][j] == 0) {
    abar[i][j] = 0.5 * (abar[i][i] + abar[j][j]);
    u[i][j] = sqrt(u[i][i] * u[j][j]);
    gamma[i][j] = sqrt(gamma[i][i] * gamma[j][j]);
  }
  abar[j][i] = abar[i][j];
  u[j][i] = u[i][j];
  gamma[j][i] = gamma[i][j];
  u12[i][j] = u12[j][i] = 12.0 * u[i][j];
  abar_sq[i][j] = abar_sq[j][i] = abar[i][j] * abar[i][j];
  inv_abar[i][j] = inv_abar[j][i] = 1.0 / abar[i][j];
  return abar[i][j];
}

/* ---------------------------------------------------------------------- */

void PairCRRepulsion::compute(int eflag, int vflag)
{
  ev_init(eflag, vflag);

  if (evflag) {
    if (eflag) {
      if (force->newton_pair)
        eval<true, true, true>();
      else
        eval<true, true, false>();
    } else {
      if (force->newton_pair)
        eval<true, false, true>();
      else
        eval<true, false, false>();
    }
  } else {
    if (force->newton_pair)
      eval<false, false, true>();
    else
      eval<false, false, false>();
  }

  if (vflag_fdotr) virial_fdotr_compute();
}

/* ---------------------------------------------------------------------- */

template <bool EVFLAG, bool EFLAG, bool NEWTON_PAIR> void PairCRRepulsion::eval()
{
  const double *const *x = atom->x;
  const double *const *v = atom->v;
  double *const *f = atom->f;
  const int *type = atom->type;
  const int nlocal = atom->nlocal;
  const double *special_lj = force->special_lj;
  const int inum = list->inum;
  const int *ilist = list->ilist;
  const int *numneigh = list->numneigh;
  int **firstneigh = list->firstneigh;
  double evdwl = 0.0;

  for (int ii = 0; ii < inum; ii++) {
    const int i = ilist[ii];
    const double xtmp = x[i][0], ytmp = x[i][1], ztmp = x[i][2];
    const double vxtmp = v[i][0], vytmp = v[i][1], vztmp = v[i][2];
    const int itype = type[i];
    const double *cutsqi = cutsq[itype];
    const double *ui = u[itype], *u12i = u12[itype], *abar_sqi = abar_sq[itype];
    const double *inv_abari = inv_abar[itype], *gammai = gamma[itype];
    const int *jlist = firstneigh[i];
    const int jnum = numneigh[i];
    double fxtmp = 0.0, fytmp = 0.0, fztmp = 0.0;

    for (int jj = 0; jj < jnum; jj++) {
      int j = jlist[jj];
      const double factor = special_lj[sbmask(j)];
      if (factor == 0.0) continue;    // bonded: no pair interaction at all
      j &= NEIGHMASK;

      const double delx = xtmp - x[j][0];
      const double dely = ytmp - x[j][1];
      const double delz = ztmp - x[j][2];
      const double rsq = delx * delx + dely * dely + delz * delz;
      const int jtype = type[j];
      if (rsq >= cutsqi[jtype]) continue;

      const double dot =
          delx * (vxtmp - v[j][0]) + dely * (vytmp - v[j][1]) + delz * (vztmp - v[j][2]);
      double energy;
      const double fpair = factor *
          pair_force(rsq, dot, ui[jtype], u12i[jtype], abar_sqi[jtype], inv_abari[jtype],
                     gammai[jtype], energy);

      fxtmp += delx * fpair;
      fytmp += dely * fpair;
      fztmp += delz * fpair;
      if (NEWTON_PAIR || j < nlocal) {
        f[j][0] -= delx * fpair;
        f[j][1] -= dely * fpair;
        f[j][2] -= delz * fpair;
      }
      if (EFLAG) evdwl = factor * energy;
      if (EVFLAG) ev_tally(i, j, nlocal, NEWTON_PAIR, evdwl, 0.0, fpair, delx, dely, delz);
    }
    f[i][0] += fxtmp;
    f[i][1] += fytmp;
    f[i][2] += fztmp;
  }
}

/* ---------------------------------------------------------------------- */

void PairCRRepulsion::write_restart(FILE *fp)
{
  for (int i = 1; i <= atom->ntypes; i++)
    for (int j = i; j <= atom->ntypes; j++) {
      fwrite(&setflag[i][j], sizeof(int), 1, fp);
      if (setflag[i][j]) {
        fwrite(&u[i][j], sizeof(double), 1, fp);
        fwrite(&abar[i][j], sizeof(double), 1, fp);
        fwrite(&gamma[i][j], sizeof(double), 1, fp);
      }
    }
}

/* ---------------------------------------------------------------------- */

void PairCRRepulsion::read_restart(FILE *fp)
{
  allocate();
  const int me = comm->me;
  for (int i = 1; i <= atom->ntypes; i++)
    for (int j = i; j <= atom->ntypes; j++) {
      if (me == 0) utils::sfread(FLERR, &setflag[i][j], sizeof(int), 1, fp, nullptr, error);
      MPI_Bcast(&setflag[i][j], 1, MPI_INT, 0, world);
      if (setflag[i][j]) {
        if (me == 0) {
          utils::sfread(FLERR, &u[i][j], sizeof(double), 1, fp, nullptr, error);
          utils::sfread(FLERR, &abar[i][j], sizeof(double), 1, fp, nullptr, error);
          utils::sfread(FLERR, &gamma[i][j], sizeof(double), 1, fp, nullptr, error);
        }
        MPI_Bcast(&u[i][j], 1, MPI_DOUBLE, 0, world);
        MPI_Bcast(&abar[i][j], 1, MPI_DOUBLE, 0, world);
        MPI_Bcast(&gamma[i][j], 1, MPI_DOUBLE, 0, world);
      }
    }
}

/* ---------------------------------------------------------------------- */

void PairCRRepulsion::write_data(FILE *fp)
{
  for (int i = 1; i <= atom->ntypes; i++)
    fmt::print(fp, "{} {} {} {}\n", i, u[i][i], abar[i][i], gamma[i][i]);
}

/* ---------------------------------------------------------------------- */

void PairCRRepulsion::write_data_all(FILE *fp)
{
  for (int i = 1; i <= atom->ntypes; i++)
    for (int j = i; j <= atom->ntypes; j++)
      fmt::print(fp, "{} {} {} {} {}\n", i, j, u[i][j], abar[i][j], gamma[i][j]);
}

/* ----------------------------------------------------------------------
   energy and F / r of one pair, damping included as compute() applies it
   (the velocities of i and j are read when atoms have them); svector[0]: the
   power the damping dissipates, gamma w^2 (rhat . (v_i - v_j))^2 >= 0
------------------------------------------------------------------------- */

double PairCRRepulsion::single(int i, int j, int itype, int jtype, double rsq,
                               double /*factor_coul*/, double factor_lj, double &fforce)
{
  fforce = 0.0;
  svector[0] = 0.0;
  if (factor_lj == 0.0 || rsq >= cutsq[itype][jtype]) return 0.0;
  double dot = 0.0;
  if (atom->v) {
    double **x = atom->x;
    double **v = atom->v;
    dot = (x[i][0] - x[j][0]) * (v[i][0] - v[j][0]) + (x[i][1] - x[j][1]) * (v[i][1] - v[j][1]) +
        (x[i][2] - x[j][2]) * (v[i][2] - v[j][2]);
  }
  double energy;
  fforce = factor_lj *
      pair_force(rsq, dot, u[itype][jtype], u12[itype][jtype], abar_sq[itype][jtype],
                 inv_abar[itype][jtype], gamma[itype][jtype], energy);
  const double w = 1.0 - sqrt(rsq) * inv_abar[itype][jtype];
  svector[0] = factor_lj * gamma[itype][jtype] * w * w * dot * dot / rsq;
  return factor_lj * energy;
}
