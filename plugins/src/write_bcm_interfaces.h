/* write_bcm_interfaces: one interface dump of the current state, written straight from the
   bond style, holding nothing over all interfaces (bcm_interface_dump.h).

     write_bcm_interfaces group FILE value ... [names name ...]

   value: batom1, batom2, bN (extra value N of the bond style's single()). Writes what
   `write_dump all local FILE c_ID1[1] ... modify colname ...` writes from `compute ID1 group
   property/local batom1 batom2` and `compute ID2 group bond/local b1 ...`. A `*` in FILE is
   replaced by the step. See plugins/doc/fix_bcm_interfaces_dump.md. */

#ifndef BRITTLE_WRITE_BCM_INTERFACES_H
#define BRITTLE_WRITE_BCM_INTERFACES_H

#include "command.h"

namespace LAMMPS_NS {

class WriteBcmInterfaces : public Command {
 public:
  WriteBcmInterfaces(class LAMMPS *lmp) : Command(lmp) {}
  void command(int, char **) override;
};

}    // namespace LAMMPS_NS

#endif
