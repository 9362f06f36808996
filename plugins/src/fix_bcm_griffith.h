/* fix bcm/griffith: the interface counters of bond_style bcm/griffith as a global vector.

   Created internally (id BCM_GRIFFITH) by the bond style, so that thermo and fix print can
   name f_BCM_GRIFFITH[k]. Summed over ranks, each interface counted once:
     [1] intact interfaces            [5] elastic energy stored in the interfaces (intact
     [2] broken interfaces                springs and contact springs of broken ones)
     [3] broken area A                [6] energy dissipated by damping
     [4] fracture energy W_f = 2 A G_c [7] energy dissipated by friction (sliding)
                                      [8] energy dissipated at the switch to contacts
   Broken interfaces, as they are at the last evaluation (the diagnostics of the broken law):
     [9] broken interfaces with a closed point   [12] cumulative Coulomb slip of their points, m
     [10] their closed points                    [13] energy their damping dissipated after
     [11] normal force those points carry, N          the break (part of [6])
   The per-interface values live in the bond style's per-atom store, so they migrate with
   their cells and carry on through restart files. The bond style works on a copy of them
   laid out in bondlist order; this fix has it written back to the store before atoms move
   (pre_exchange), before a dump or a restart file of a step (they may read the store) and
   after a run. The vector is summed from that copy (BondBcmGriffith::tally()): a record
   needs no write-back. */

#ifndef BRITTLE_FIX_BCM_GRIFFITH_H
#define BRITTLE_FIX_BCM_GRIFFITH_H

#include "bond_bcm_griffith.h"
#include "fix.h"

namespace LAMMPS_NS {

class FixBcmGriffith : public Fix {
 public:
  static constexpr const char *ID = "BCM_GRIFFITH";

  FixBcmGriffith(class LAMMPS *, int, char **);

  int setmask() override;
  void setup_pre_exchange() override;
  void pre_exchange() override;
  void min_pre_exchange() override;
  void end_of_step() override;
  void post_run() override;
  double compute_vector(int) override;

  // the fix with id BCM_GRIFFITH, created first if absent (needs a simulation box)
  static FixBcmGriffith *get_or_create(class LAMMPS *);

 private:
  double totals[BondBcmGriffith::NVECTOR];
  void sync();
  void before_exchange();
  bigint cached_step, cached_evaluations;
  bool cached;
};

}    // namespace LAMMPS_NS

#endif
