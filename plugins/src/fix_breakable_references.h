/* fix breakable/references: the reference geometry of bond_style and angle_style
   breakable/cr (SPEC 2.2: r0 of every bond, theta0 and the arm lengths r1_0, r2_0 of every
   angle), read from a file the builder writes next to the data file, so that every rank
   holding a bond or an angle uses the same values and no style measures them.

     fix ID all breakable/references FILE

   FILE, one element per line (comments after '#'):
     bond  tag1 tag2 r0
     angle tag1 tag2 tag3 theta0 r1_0 r2_0    (tag2 = vertex, theta0 in radians,
                                               r1_0 = |x1 - x2|, r2_0 = |x3 - x2|)
   Rank 0 reads it in chunks and broadcasts them; each rank writes the values into the
   per-atom stores of its owned atoms (the hidden fix lazy/store of each style, which
   migrates with the atoms and goes to restart files). Read once, when the fix is defined;
   an intact bond or angle of the topology without a line is an error then. See
   plugins/doc/fix_breakable_references.md. */

#ifndef BRITTLE_FIX_BREAKABLE_REFERENCES_H
#define BRITTLE_FIX_BREAKABLE_REFERENCES_H

#include "fix.h"

#include <string>

namespace LAMMPS_NS {

class FixBreakableReferences : public Fix {
 public:
  FixBreakableReferences(class LAMMPS *, int, char **);

  int setmask() override { return 0; }
  void post_constructor() override;

 private:
  std::string file;

  void read();
  void check_complete(int ibond, int iangle);
};

}    // namespace LAMMPS_NS

#endif
