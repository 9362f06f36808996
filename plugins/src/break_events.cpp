#include "break_events.h"

#include "atom.h"
#include "breakable_util.h"
#include "domain.h"
#include "fix_breakable_special.h"
#include "neighbor.h"
#include "update.h"

#include <algorithm>

using namespace LAMMPS_NS;

/* ---------------------------------------------------------------------- */

double BreakPath::current_time(LAMMPS *lmp)
{
  const Update *update = lmp->update;
  return update->atime + (double) (update->ntimestep - update->atimestep) * update->dt;
}

/* ---------------------------------------------------------------------- */

void BreakPath::bond(LAMMPS *lmp, FixBreakableSpecial *special, int n, double energy,
                     bool decided, const BreakEvent *from)
{
  Atom *atom = lmp->atom;
  int *row = lmp->neighbor->bondlist[n];
  const int i1 = row[0], i2 = row[1];
  const int nlocal = atom->nlocal;
  const tagint t1 = atom->tag[i1], t2 = atom->tag[i2];

  row[2] = 0;
  if (i1 < nlocal) {
    const int m = BreakableUtil::bond_slot(atom, i1, t2);
    if (m >= 0) atom->bond_type[i1][m] = 0;
  }
  if (i2 < nlocal) {
    const int m = BreakableUtil::bond_slot(atom, i2, t1);
    if (m >= 0) atom->bond_type[i2][m] = 0;
  }
  const bool counts = ((t1 < t2) ? i1 : i2) < nlocal;
  special->add_broken_bond(t1, t2, counts ? 1 : 0);

  BreakEvent ev;
  if (from) {
    ev = *from;
  } else {
    const double *x1 = atom->x[i1], *x2 = atom->x[i2];
    ev.step = (double) lmp->update->ntimestep;
    ev.time = current_time(lmp);
    ev.id1 = (double) std::min(t1, t2);
    ev.id2 = (double) std::max(t1, t2);
    ev.id3 = 0.0;
    ev.kind = BreakEvent::BOND;
    // of the closest images (the bond list's), then wrapped into a periodic box
    ev.x = 0.5 * (x1[0] + x2[0]);
    ev.y = 0.5 * (x1[1] + x2[1]);
    ev.z = 0.5 * (x1[2] + x2[2]);
    lmp->domain->remap(&ev.x);
    ev.energy = energy;
    ev.area = 0.0;
  }
  if (decided) special->add_decided(ev);
  if (counts) special->record(ev);
}

/* ---------------------------------------------------------------------- */

void BreakPath::angle(LAMMPS *lmp, FixBreakableSpecial *special, int n, double energy,
                      bigint step, double time)
{
  Atom *atom = lmp->atom;
  int *row = lmp->neighbor->anglelist[n];
  const int i1 = row[0], i2 = row[1], i3 = row[2];
  const int nlocal = atom->nlocal;
  const tagint *tag = atom->tag;
  const tagint t1 = tag[i1], t2 = tag[i2], t3 = tag[i3];

  row[3] = 0;
  for (int idx : {i1, i2, i3}) {
    if (idx >= nlocal) continue;
    const int m = BreakableUtil::angle_slot(atom, idx, t1, t2, t3);
    if (m >= 0) atom->angle_type[idx][m] = 0;
  }
  int lowest = i1;
  if (t2 < tag[lowest]) lowest = i2;
  if (t3 < tag[lowest]) lowest = i3;
  const bool counts = lowest < nlocal;
  special->add_broken_angle(counts ? 1 : 0);
  if (!counts) return;

  BreakEvent ev;
  ev.step = (double) step;
  ev.time = time;
  ev.id1 = (double) t1;
  ev.id2 = (double) t2;
  ev.id3 = (double) t3;
  ev.kind = BreakEvent::ANGLE;
  ev.x = atom->x[i2][0];    // the vertex, wrapped into a periodic box
  ev.y = atom->x[i2][1];
  ev.z = atom->x[i2][2];
  lmp->domain->remap(&ev.x);
  ev.energy = energy;
  ev.area = 0.0;
  special->record(ev);
}

/* ---------------------------------------------------------------------- */

void BreakPath::interface(LAMMPS *lmp, FixBreakableSpecial *special, int c1, int c2,
                          double energy, double area)
{
  Atom *atom = lmp->atom;
  if (c1 >= atom->nlocal) return;    // recorded by the owner of the cell with the smaller tag
  const double *x1 = atom->x[c1], *x2 = atom->x[c2];
  BreakEvent ev;
  ev.step = (double) lmp->update->ntimestep;
  ev.time = current_time(lmp);
  ev.id1 = (double) atom->tag[c1];
  ev.id2 = (double) atom->tag[c2];
  ev.id3 = 0.0;
  ev.kind = BreakEvent::INTERFACE;
  ev.x = 0.5 * (x1[0] + x2[0]);    // midpoint of the two cell centres
  ev.y = 0.5 * (x1[1] + x2[1]);
  ev.z = 0.5 * (x1[2] + x2[2]);
  lmp->domain->remap(&ev.x);
  ev.energy = energy;
  ev.area = area;
  special->record(ev);
}
