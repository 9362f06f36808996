/* fix bcm/interfaces/dump: the interface dump of a BCM run every N steps, written straight
   from the bond style, holding nothing over all interfaces (bcm_interface_dump.h).

     fix ID group bcm/interfaces/dump N FILE value ... [names name ...]

   value: batom1, batom2, bN (extra value N of the bond style's single(): bond_style
   bcm/griffith gives 13). Writes what `compute property/local batom1 batom2`, `compute
   bond/local b1 ...` over the group and `dump ID all local N FILE ...` (with dump_modify
   colname for the names) write, at the same steps: at the setup of a run whose step is a
   multiple of N, unless this fix wrote that step already, and at every multiple of N during
   the run. A `*` in FILE is replaced by the step (one file per frame); without it the frames
   follow each other in one file, emptied at the first one. See
   plugins/doc/fix_bcm_interfaces_dump.md. */

#ifndef BRITTLE_FIX_BCM_INTERFACES_DUMP_H
#define BRITTLE_FIX_BCM_INTERFACES_DUMP_H

#include "bcm_interface_dump.h"
#include "fix.h"

#include <memory>
#include <string>

namespace LAMMPS_NS {

class FixBcmInterfacesDump : public Fix {
 public:
  FixBcmInterfacesDump(class LAMMPS *, int, char **);

  int setmask() override;
  void init() override;
  void setup(int) override;
  void end_of_step() override;

 private:
  std::string file;
  std::unique_ptr<BcmInterfaceDump> writer;
  bigint last_step = -1;    // the step written last by this fix (-1: none yet)
  bool started = false;     // FILE without `*`: its first frame is written
  void write_frame();
};

}    // namespace LAMMPS_NS

#endif
