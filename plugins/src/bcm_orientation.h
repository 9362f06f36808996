/* Where a BCM cell's orientation (bcm_rigid.h: unit quaternion, body -> space) lives.

   - atom_style bpm/sphere: the atom style's own quaternion atom->quat. LAMMPS sends it to
     ghost cells with positions, velocities and omega in every step's forward communication
     (comm_modify vel yes), so fix bcm/rigid sends nothing more. A data file sets it with the
     command bcm_orient (bcm_orient.h).
   - atom_style hybrid bond sphere (the layout of files written up to main fc0b266): the
     per-atom array d2_bcm_quat of fix property/atom (ghost yes), which fix bcm/rigid sends to
     ghost cells itself once per step.

   A style finds it once per init() with find() and reads it with of() where it needs it
   (the arrays move when LAMMPS grows them). */

#ifndef BRITTLE_BCM_ORIENTATION_H
#define BRITTLE_BCM_ORIENTATION_H

#include "atom.h"
#include "bcm_rigid.h"
#include "error.h"

namespace BcmOrientation {

constexpr int ATOM_QUAT = -2;    // find()'s answer when the atom style carries the quaternion

/* ATOM_QUAT, or the atom->darray index of d2_bcm_quat (with `ghost yes` when ghosts need it);
   an error naming `who` when there is neither, or both (two orientations would disagree) */
inline int find(LAMMPS_NS::Atom *atom, LAMMPS_NS::Error *error, const char *who, bool ghosts)
{
  int flag = -1, cols = -1, ghost = 0;
  const int index = atom->find_custom_ghost(BcmRigid::QUAT, flag, cols, ghost);
  if (atom->quat_flag) {
    if (index >= 0)
      error->all(FLERR, "{}: the atom style has a quaternion, so d2_{} would be a second "
                        "orientation: drop it from fix property/atom", who, BcmRigid::QUAT);
    return ATOM_QUAT;
  }
  if (index < 0 || flag != 1 || cols != 4 || (ghosts && !ghost))
    error->all(FLERR, "{} needs the cells' orientations: atom_style bpm/sphere (set by "
                      "bcm_orient), or the per-atom array d2_{} with 4 columns{} of fix "
                      "property/atom", who, BcmRigid::QUAT, ghosts ? " and ghost yes" : "");
  return index;
}

/* the orientations, per atom (owned and ghost) */
inline double **of(LAMMPS_NS::Atom *atom, int index)
{
  return index == ATOM_QUAT ? atom->quat : atom->darray[index];
}

}    // namespace BcmOrientation

#endif
