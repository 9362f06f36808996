#include "fix_bcm_griffith.h"

#include "bond_bcm_griffith.h"
#include "error.h"
#include "force.h"
#include "modify.h"
#include "output.h"
#include "update.h"

#include <mpi.h>

using namespace LAMMPS_NS;

/* ---------------------------------------------------------------------- */

FixBcmGriffith::FixBcmGriffith(LAMMPS *_lmp, int narg, char **arg) :
    Fix(_lmp, narg, arg), totals{}, cached_step(-1), cached_evaluations(-1), cached(false)
{
  if (narg != 3) error->all(FLERR, "Illegal fix bcm/griffith command: takes no arguments");
  vector_flag = 1;
  size_vector = BondBcmGriffith::NVECTOR;
  global_freq = 1;
  extvector = 0;
}

/* ---------------------------------------------------------------------- */

FixBcmGriffith *FixBcmGriffith::get_or_create(LAMMPS *lmp)
{
  Fix *ifix = lmp->modify->get_fix_by_id(ID);
  if (!ifix) ifix = lmp->modify->add_fix(fmt::format("{} all bcm/griffith", ID));
  auto fix = dynamic_cast<FixBcmGriffith *>(ifix);
  if (!fix)
    lmp->error->all(FLERR, "Fix id {} is taken by a fix of style {}, not bcm/griffith", ID,
                    ifix->style);
  return fix;
}

/* ---------------------------------------------------------------------- */

int FixBcmGriffith::setmask()
{
  return FixConst::PRE_EXCHANGE | FixConst::MIN_PRE_EXCHANGE | FixConst::POST_RUN;
}

/* ----------------------------------------------------------------------
   after a run, the copies of interfaces evaluated on another rank brought up
   to date, so that a restart file or data written now holds the live state
   (collective)
------------------------------------------------------------------------- */

void FixBcmGriffith::post_run()
{
  auto bond = dynamic_cast<BondBcmGriffith *>(force->bond_match("bcm/griffith"));
  if (bond) bond->sync_copies();
}

/* ----------------------------------------------------------------------
   atoms may migrate or be sorted now: the bond style's entries no longer
   match their indices until it rebuilds them
------------------------------------------------------------------------- */

void FixBcmGriffith::before_exchange()
{
  auto bond = dynamic_cast<BondBcmGriffith *>(force->bond_match("bcm/griffith"));
  if (bond) bond->atoms_may_move();
}

void FixBcmGriffith::setup_pre_exchange()
{
  before_exchange();
}

void FixBcmGriffith::pre_exchange()
{
  before_exchange();
}

void FixBcmGriffith::min_pre_exchange()
{
  before_exchange();
}

/* ----------------------------------------------------------------------
   all entries at once, summed over ranks; recomputed when the step or the
   bond style's evaluation count changed (both identical on every rank, so
   every rank takes the same branch of this collective call)
------------------------------------------------------------------------- */

double FixBcmGriffith::compute_vector(int n)
{
  auto bond = dynamic_cast<BondBcmGriffith *>(force->bond_match("bcm/griffith"));
  if (!bond) error->all(FLERR, "Fix bcm/griffith needs bond_style bcm/griffith");
  if (!cached || cached_step != update->ntimestep ||
      cached_evaluations != bond->evaluations()) {
    double local[BondBcmGriffith::NVECTOR] = {};
    bond->tally(local);
    MPI_Allreduce(local, totals, BondBcmGriffith::NVECTOR, MPI_DOUBLE, MPI_SUM, world);
    cached = true;
    cached_step = update->ntimestep;
    cached_evaluations = bond->evaluations();
  }
  return totals[n];
}
