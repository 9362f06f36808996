/* fix breakable/log: the break-event log of the breakable styles.

     fix ID all breakable/log FILE

   Every break goes through the single break path (break_events.h), which records it once
   over all ranks; at the end of every run command this fix gathers the records on rank 0
   and appends them to FILE, one line per break, sorted by step, kind and atom IDs, after a
   header line naming the columns (written when FILE is new or empty):
     # step time id1 id2 id3 kind x y z energy area
   kind is bond, angle or interface; x y z the midpoint of the two atoms (bond, interface)
   or the vertex (angle); energy what the element held in the evaluation that broke it;
   area the interface area (0 for bonds and angles). Appending makes a run of many `run N`
   commands, and one resumed from a restart file, write one log (the driver drops the lines
   after the checkpoint's step before resuming). See plugins/doc/fix_breakable_log.md. */

#ifndef BRITTLE_FIX_BREAKABLE_LOG_H
#define BRITTLE_FIX_BREAKABLE_LOG_H

#include "fix.h"

#include <string>

namespace LAMMPS_NS {

class FixBreakableLog : public Fix {
 public:
  FixBreakableLog(class LAMMPS *, int, char **);

  int setmask() override { return 0; }
  void init() override;
  void post_run() override;

 private:
  std::string file;
  void write();
};

}    // namespace LAMMPS_NS

#endif
