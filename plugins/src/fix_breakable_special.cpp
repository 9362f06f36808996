#include "fix_breakable_special.h"

#include "angle_breakable_cr.h"
#include "atom.h"
#include "bond_breakable_cr.h"
#include "comm.h"
#include "bond.h"
#include "domain.h"
#include "error.h"
#include "force.h"
#include "group.h"
#include "modify.h"
#include "neigh_list.h"
#include "neighbor.h"

#include <algorithm>
#include <mpi.h>

using namespace LAMMPS_NS;
using namespace FixConst;

// The two special-bond bits of a neighbor-list entry (LAMMPS packs them above SBBITS).
static constexpr unsigned SPECIAL_BITS = 3u << SBBITS;

/* ---------------------------------------------------------------------- */

FixBreakableSpecial::FixBreakableSpecial(LAMMPS *_lmp, int narg, char **arg) :
    Fix(_lmp, narg, arg), nbonds_local(0), nangles_local(0), counted_topology(false),
    recording(false)
{
  if (narg != 3) error->all(FLERR, "Illegal fix breakable/special command: takes no arguments");
  vector_flag = 1;
  size_vector = 2;
  global_freq = 1;
  extvector = 0;
  stores_ids = 1;    // it holds atom tags of broken pairs between steps
}

/* ---------------------------------------------------------------------- */

FixBreakableSpecial *FixBreakableSpecial::get_or_create(LAMMPS *lmp)
{
  Fix *ifix = lmp->modify->get_fix_by_id(ID);
  if (!ifix) ifix = lmp->modify->add_fix(fmt::format("{} all breakable/special", ID));
  auto fix = dynamic_cast<FixBreakableSpecial *>(ifix);
  if (!fix)
    lmp->error->all(FLERR, "Fix id {} is taken by a fix of style {}, not breakable/special", ID,
                    ifix->style);
  return fix;
}

/* ---------------------------------------------------------------------- */

int FixBreakableSpecial::setmask()
{
  return PRE_EXCHANGE | PRE_FORCE | END_OF_STEP | MIN_PRE_EXCHANGE | MIN_PRE_FORCE;
}

/* ---------------------------------------------------------------------- */

void FixBreakableSpecial::init()
{
  if (force->newton_bond)
    error->all(FLERR, "Fix breakable/special requires newton_bond off (command: newton on off)");
  if (atom->molecular != Atom::MOLECULAR)
    error->all(FLERR, "Fix breakable/special requires a molecular atom style (not a template)");
  if (!counted_topology) count_broken_in_topology();
  // events are kept only for a log (fix breakable/log sets it again in its own init)
  recording = !modify->get_fix_by_style("^breakable/log$").empty();
}

/* ----------------------------------------------------------------------
   bonds and angles of type 0 present at the first run (read from a restart
   file): each counted once, by the owner of its atom with the smallest tag
------------------------------------------------------------------------- */

void FixBreakableSpecial::count_broken_in_topology()
{
  const int nlocal = atom->nlocal;
  const tagint *tag = atom->tag;
  if (atom->num_bond)
    for (int i = 0; i < nlocal; i++)
      for (int m = 0; m < atom->num_bond[i]; m++)
        if (atom->bond_type[i][m] == 0 && tag[i] < atom->bond_atom[i][m]) nbonds_local++;
  if (atom->num_angle)
    for (int i = 0; i < nlocal; i++)
      for (int m = 0; m < atom->num_angle[i]; m++) {
        if (atom->angle_type[i][m] != 0) continue;
        const tagint t1 = atom->angle_atom1[i][m], t2 = atom->angle_atom2[i][m],
                     t3 = atom->angle_atom3[i][m];
        if (tag[i] == std::min(t1, std::min(t2, t3))) nangles_local++;
      }
  counted_topology = true;
}

/* ----------------------------------------------------------------------
   remove partner from the 1-2 special list of owned atom i; entries after it
   (1-3, 1-4 when present) shift down by one
------------------------------------------------------------------------- */

void FixBreakableSpecial::remove_special12(int i, tagint partner)
{
  int *ns = atom->nspecial[i];
  tagint *slist = atom->special[i];
  int m = 0;
  while (m < ns[0] && slist[m] != partner) m++;
  if (m == ns[0]) return;
  for (; m < ns[2] - 1; m++) slist[m] = slist[m + 1];
  ns[0]--;
  ns[1]--;
  ns[2]--;
}

/* ----------------------------------------------------------------------
   full resync at run setup: a partner whose only bonds with atom i are of
   type 0 (broken) or released by the bond style is not a 1-2 special
   neighbor. Covers special lists rebuilt from the bond arrays since the break
   (read_restart, create_bonds, ...).
------------------------------------------------------------------------- */

void FixBreakableSpecial::resync_special()
{
  const int nlocal = atom->nlocal;
  int **nspecial = atom->nspecial;
  tagint **special = atom->special;
  const int *num_bond = atom->num_bond;
  int **bond_type = atom->bond_type;
  tagint **bond_atom = atom->bond_atom;
  auto *released = dynamic_cast<SpecialReleasedBonds *>(force->bond);

  std::vector<tagint> drop;
  for (int i = 0; i < nlocal; i++) {
    drop.clear();
    for (int s = 0; s < nspecial[i][0]; s++) {
      const tagint partner = special[i][s];
      bool broken = false, intact = false;
      for (int m = 0; m < num_bond[i]; m++) {
        if (bond_atom[i][m] != partner) continue;
        const int type = bond_type[i][m];
        if (type == 0 || (type > 0 && released && released->released(i, m)))
          broken = true;
        else
          intact = true;
      }
      if (broken && !intact) drop.push_back(partner);
    }
    for (tagint partner : drop) remove_special12(i, partner);
  }
}

/* ---------------------------------------------------------------------- */

void FixBreakableSpecial::setup_pre_exchange()
{
  if (auto *r = dynamic_cast<SpecialReleasedBonds *>(force->bond)) r->before_special_update();
  resync_special();
  broken_since_exchange.clear();
  broken_since_force.clear();    // the setup rebuilds every neighbor list from the specials
}

/* ----------------------------------------------------------------------
   before atoms migrate: owned atoms forget their broken partners
------------------------------------------------------------------------- */

void FixBreakableSpecial::pre_exchange()
{
  if (auto *r = dynamic_cast<SpecialReleasedBonds *>(force->bond)) r->before_special_update();
  const int nlocal = atom->nlocal;
  for (const auto &p : broken_since_exchange) {
    const int i = atom->map(p.first);
    const int j = atom->map(p.second);
    if (i >= 0 && i < nlocal) remove_special12(i, p.second);
    if (j >= 0 && j < nlocal) remove_special12(j, p.first);
  }
  broken_since_exchange.clear();
}

/* ---------------------------------------------------------------------- */

void FixBreakableSpecial::setup_pre_force(int vflag)
{
  pre_force(vflag);
}

/* ---------------------------------------------------------------------- */

void FixBreakableSpecial::pre_force(int /*vflag*/)
{
  if (!broken_since_force.empty()) clear_neighbor_bits();
}

/* ----------------------------------------------------------------------
   clear the special bits of pairs broken since the last pre_force in every
   perpetual neighbor list that owns its storage (copies share their parent's),
   for the owned atoms of each pair. With newton_bond off both owners broke the
   bond, so each rank fixes its own atoms' lists.
------------------------------------------------------------------------- */

void FixBreakableSpecial::clear_neighbor_bits()
{
  const int nlocal = atom->nlocal;
  const tagint *tag = atom->tag;
  const int *type = atom->type;
  const int *mask = atom->mask;
  const int includebit = neighbor->includegroup ? group->bitmask[neighbor->includegroup] : 0;

  for (int l = 0; l < neighbor->nlist; l++) {
    NeighList *list = neighbor->lists[l];
    if (!list || list->occasional || (list->copy && !list->trim) || list->kokkos) continue;
    if (!list->firstneigh || !list->numneigh) continue;

    for (const auto &p : broken_since_force) {
      for (int side = 0; side < 2; side++) {
        const tagint partner = side ? p.first : p.second;
        const int i = atom->map(side ? p.second : p.first);
        if (i < 0 || i >= nlocal || i >= list->maxatom) continue;
        if (list->iskip && list->iskip[type[i]]) continue;
        if (includebit && !(mask[i] & includebit)) continue;
        int *jlist = list->firstneigh[i];
        const int jnum = list->numneigh[i];
        for (int jj = 0; jj < jnum; jj++) {
          const int j = jlist[jj] & NEIGHMASK;
          if (tag[j] == partner)
            jlist[jj] = static_cast<int>(static_cast<unsigned>(jlist[jj]) & ~SPECIAL_BITS);
        }
      }
    }
  }
  broken_since_force.clear();
}

/* ---------------------------------------------------------------------- */

void FixBreakableSpecial::add_broken_bond(tagint tag1, tagint tag2, int count)
{
  broken_since_exchange.emplace_back(tag1, tag2);
  broken_since_force.emplace_back(tag1, tag2);
  nbonds_local += count;
}

/* ---------------------------------------------------------------------- */

double FixBreakableSpecial::compute_vector(int n)
{
  bigint local[2] = {nbonds_local, nangles_local};
  bigint total[2];
  MPI_Allreduce(local, total, 2, MPI_LMP_BIGINT, MPI_SUM, world);
  return static_cast<double>(total[n]);
}

/* ---------------------------------------------------------------------- */

std::vector<BreakEvent> FixBreakableSpecial::take_events()
{
  std::vector<BreakEvent> out;
  out.swap(events);
  return out;
}

/* ----------------------------------------------------------------------
   after the forces of the run setup and of every step (see the header)
------------------------------------------------------------------------- */

void FixBreakableSpecial::setup(int /*vflag*/)
{
  exchange();
}

void FixBreakableSpecial::end_of_step()
{
  exchange();
}

/* ----------------------------------------------------------------------
   every rank's bond breaks of this evaluation to every rank. Collective: one
   MPI_Allreduce per step, and an MPI_Allgatherv in the steps with breaks.
------------------------------------------------------------------------- */

void FixBreakableSpecial::exchange()
{
  auto *bond = dynamic_cast<BondBreakableCR *>(force->bond);
  if (!bond) {
    decided.clear();
    return;
  }
  const int mine = (int) decided.size() * BreakEvent::NFIELD;
  int total = 0;
  MPI_Allreduce(&mine, &total, 1, MPI_INT, MPI_SUM, world);
  if (total == 0) return;

  std::vector<int> counts(comm->nprocs), displs(comm->nprocs, 0);
  MPI_Allgather(&mine, 1, MPI_INT, counts.data(), 1, MPI_INT, world);
  for (int p = 1; p < comm->nprocs; p++) displs[p] = displs[p - 1] + counts[p - 1];
  std::vector<BreakEvent> all(total / BreakEvent::NFIELD);
  MPI_Allgatherv(decided.empty() ? nullptr : decided.data()->data(), mine, MPI_DOUBLE,
                 all.data()->data(), counts.data(), displs.data(), MPI_DOUBLE, world);
  decided.clear();

  // the bonds first, so that an angle broken with its bond is recorded after it
  for (const BreakEvent &ev : all) bond->break_if_intact(ev);
  auto *angle = dynamic_cast<AngleBreakableCR *>(force->angle);
  if (angle)
    for (const BreakEvent &ev : all) angle->break_with_bond(ev);
}
