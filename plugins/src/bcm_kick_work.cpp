/* Exact work of forces over the half kicks of velocity Verlet (see bcm_kick_work.h). */

#include "bcm_kick_work.h"

#include "atom.h"
#include "bcm_rigid.h"
#include "error.h"
#include "update.h"

using namespace LAMMPS_NS;
using BcmRigid::dot;

int BcmKickWork::evaluation_kind(LAMMPS *lmp)
{
  if (lmp->update->whichflag != 1) return NONE;
  return lmp->update->setupflag ? SETUP : STEP;
}

double BcmKickWork::power(LAMMPS *lmp, const Entry &e, int ia, int ib)
{
  double **v = lmp->atom->v, **omega = lmp->atom->omega;
  double p = dot(e.f, v[ia]) + dot(e.ta, omega[ia]);
  if (ib >= 0) p += dot(e.tb, omega[ib]) - dot(e.f, v[ib]);
  return p;
}

double BcmKickWork::kicks(LAMMPS *lmp, const char *style, int nkicks) const
{
  double w = 0.0;
  for (const Entry &e : entries) {
    const int ia = lmp->atom->map(e.a);
    const int ib = e.b > 0 ? lmp->atom->map(e.b) : -1;
    if (ia < 0 || (e.b > 0 && ib < 0))
      lmp->error->one(FLERR, "{}: cell {} touched at the last force evaluation is neither "
                      "owned nor a ghost here: the work of its force cannot be settled",
                      style, ia < 0 ? e.a : e.b);
    w += e.p + power(lmp, e, ia, ib);
  }
  return 0.25 * nkicks * last_dt * w;
}

void BcmKickWork::begin(LAMMPS *lmp, const char *style)
{
  const int kind = evaluation_kind(lmp);
  if (last_kind != NONE && kind != NONE) {
    const int nkicks = (last_kind == STEP) + (kind == STEP);
    if (nkicks) settled += kicks(lmp, style, nkicks);
  }
  entries.clear();
  pending_power = 0.0;
  last_kind = kind;
  last_dt = lmp->update->dt;
}

void BcmKickWork::add(LAMMPS *lmp, int i, int j, const double *F, const double *ti,
                      const double *tj)
{
  Entry e;
  e.a = lmp->atom->tag[i];
  e.b = j >= 0 ? lmp->atom->tag[j] : 0;
  for (int d = 0; d < 3; d++) {
    e.f[d] = F[d];
    e.ta[d] = ti[d];
    e.tb[d] = tj ? tj[d] : 0.0;
  }
  e.p = power(lmp, e, i, j);
  pending_power += e.p;
  entries.push_back(e);
}

double BcmKickWork::work() const
{
  return settled + (last_kind == STEP ? 0.5 * last_dt * pending_power : 0.0);
}

double BcmKickWork::work_closed(LAMMPS *lmp, const char *style) const
{
  // the same sum as begin() at a run's setup (one kick), so that a run resumed from a
  // restart file carries on with the very number the uninterrupted run would have
  return last_kind == STEP ? settled + kicks(lmp, style, 1) : settled;
}

void BcmKickWork::restore(double w)
{
  entries.clear();
  pending_power = 0.0;
  last_kind = NONE;
  settled = w;
}

/* ---------------------------------------------------------------------- */

void BcmPrescribedWork::begin(LAMMPS *lmp, double dx)
{
  const int kind = BcmKickWork::evaluation_kind(lmp);
  if (last_kind != BcmKickWork::NONE && kind != BcmKickWork::NONE) {
    if (last_kind == BcmKickWork::STEP) settled += 0.5 * force * dx_last;
    if (kind == BcmKickWork::STEP) settled += 0.5 * force * dx;
  }
  force = 0.0;
  dx_last = dx;
  last_kind = kind;
}

double BcmPrescribedWork::work() const
{
  return settled + (last_kind == BcmKickWork::STEP ? 0.5 * force * dx_last : 0.0);
}

void BcmPrescribedWork::restore(double w)
{
  force = 0.0;
  dx_last = 0.0;
  last_kind = BcmKickWork::NONE;
  settled = w;
}
