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
   The per-interface values live in the bond style's working copy, laid out in bondlist
   order; they travel with their cells and go to restart files through the style's per-atom
   store, whose rows the style composes from the working copy when they leave. This fix
   tells the style when atoms may move (pre_exchange) and keeps a replaced style's working
   copy for the next. The vector is summed from that copy (BondBcmGriffith::tally()). */

#ifndef BRITTLE_FIX_BCM_GRIFFITH_H
#define BRITTLE_FIX_BCM_GRIFFITH_H

#include "bond_bcm_griffith.h"
#include "fix.h"

#include <memory>

namespace LAMMPS_NS {

class FixBcmGriffith : public Fix {
 public:
  static constexpr const char *ID = "BCM_GRIFFITH";

  FixBcmGriffith(class LAMMPS *, int, char **);

  int setmask() override;
  void post_run() override;
  void setup_pre_exchange() override;
  void pre_exchange() override;
  void min_pre_exchange() override;
  double compute_vector(int) override;

  // the fix with id BCM_GRIFFITH, created first if absent (needs a simulation box)
  static FixBcmGriffith *get_or_create(class LAMMPS *);
  // the working copy of a bond style being replaced, until the next one takes it
  std::unique_ptr<BondBcmGriffith::Parked> parked;

 private:
  double totals[BondBcmGriffith::NVECTOR];
  void before_exchange();
  bigint cached_step, cached_evaluations;
  bool cached;
};

}    // namespace LAMMPS_NS

#endif
