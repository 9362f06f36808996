/* Small helpers shared by the breakable Clemmer-Robbins styles: per-atom storage of
   reference geometry in a hidden fix property/atom, and slot look-ups in atom topology. */

#ifndef BRITTLE_BREAKABLE_UTIL_H
#define BRITTLE_BREAKABLE_UTIL_H

#include "atom.h"
#include "error.h"
#include "fix.h"
#include "lammps.h"
#include "modify.h"

#include <string>

namespace LAMMPS_NS {
namespace BreakableUtil {

  // Index into atom->darray of a per-atom array "name" with ncols columns, created as a
  // hidden fix property/atom (id fix_id) so that it migrates with its atoms, follows atom
  // sorting and is written to restart files. A fix of the same id re-created after
  // read_restart gets its stored values back.
  inline int peratom_array(LAMMPS *lmp, const std::string &fix_id, const std::string &name,
                           int ncols)
  {
    if (ncols < 1)
      lmp->error->all(FLERR, "Per-atom store {} needs at least one column", name);
    if (!lmp->modify->get_fix_by_id(fix_id))
      lmp->modify->add_fix(fmt::format("{} all property/atom d2_{} {}", fix_id, name, ncols));
    int flag = -1, cols = -1;
    const int index = lmp->atom->find_custom(name.c_str(), flag, cols);
    if (index < 0 || flag != 1 || cols != ncols)
      lmp->error->all(FLERR,
                      "Per-atom store {} (fix {}) has {} columns, {} needed: the topology per "
                      "atom changed after the reference geometry was stored",
                      name, fix_id, cols, ncols);
    return index;
  }

  // Slot m of the bond of owned atom i with atom tag partner, or -1.
  inline int bond_slot(const Atom *atom, int i, tagint partner)
  {
    const tagint *batom = atom->bond_atom[i];
    for (int m = 0; m < atom->num_bond[i]; m++)
      if (batom[m] == partner) return m;
    return -1;
  }

  // Slot m of the angle (t1, t2, t3) of owned atom i, or -1. Every atom of an angle
  // stores it with the same atom order (newton_bond off), so the order must match.
  inline int angle_slot(const Atom *atom, int i, tagint t1, tagint t2, tagint t3)
  {
    for (int m = 0; m < atom->num_angle[i]; m++)
      if (atom->angle_atom2[i][m] == t2 && atom->angle_atom1[i][m] == t1 &&
          atom->angle_atom3[i][m] == t3)
        return m;
    return -1;
  }

}    // namespace BreakableUtil
}    // namespace LAMMPS_NS

#endif
