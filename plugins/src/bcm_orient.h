/* bcm_orient: set the cells' orientations (the quaternion of atom_style bpm/sphere) from a
   per-atom array of fix property/atom, bit for bit.

     bcm_orient d2_NAME

   LAMMPS's data files have no section for the quaternion of atom_style bpm/sphere (read_data
   sets it to the identity); a BCM data file carries each cell's orientation in a section read
   into a 4-column array (fix ID all property/atom d2_NAME 4; read_data ... fix ID NULL
   Section), which this command copies into the atom style. The array can be dropped after
   (unfix ID). See plugins/doc/fix_bcm_rigid.md. */

#ifndef BRITTLE_BCM_ORIENT_H
#define BRITTLE_BCM_ORIENT_H

#include "command.h"

namespace LAMMPS_NS {

class BcmOrient : public Command {
 public:
  BcmOrient(class LAMMPS *lmp) : Command(lmp) {}
  void command(int, char **) override;
};

}    // namespace LAMMPS_NS

#endif
