/* fix breakable/special: the special-list bookkeeping of broken bonds, shared by the
   breakable Clemmer-Robbins styles and bond_style bcm/griffith.

   Created internally (id BREAKABLE_SPECIAL) by bond_style and angle_style breakable/cr, and
   by bond_style bcm/griffith (which hands retired interfaces over to the pair style).
   - Broken bonds leave the 1-2 special lists of their atoms at the next reneighboring
     (pre_exchange), and at every run setup the special lists are re-synchronised with the
     bond types (type 0 = broken), so restarts and special rebuilds cannot revive them.
     A bond style that keeps some broken bonds at their type (bond_style bcm/griffith: a
     retired interface keeps its counters) names them through SpecialReleasedBonds; the
     resync drops those too.
   - Until then, pre_force clears the special bits of the broken pair in the perpetual pair
     neighbor lists, so the non-bonded repulsion acts from the step after the break.
   - Global vector (cumulative, summed over ranks): [1] bonds broken, [2] angles broken
     (breakable/cr; bond_style bcm/griffith counts its breaks in fix bcm/griffith).
     The count starts, at the first run, from the broken (type 0) bonds and angles the
     topology already holds, so that it carries on across write_restart / read_restart.
   - Break events (break_events.h): the single break path records each one here, on one
     rank, while fix breakable/log is defined; the log takes them at the end of every run.
   - With bond_style breakable/cr, at the end of every step (and of every run setup) the
     bond breaks decided on each rank are sent to all ranks: a rank that holds one of those
     bonds still intact (the two ranks holding a bond saw its atoms through different
     periodic images, which may round the stretch differently) breaks it too, and every
     rank breaks the angles having it as an arm (SPEC 2.2: an angle breaks when either of
     its bonds does), recorded at the bond's step. A rank holding only the third atom of
     such an angle has no copy of the bond: this exchange is how it learns of the break. */

#ifndef BRITTLE_FIX_BREAKABLE_SPECIAL_H
#define BRITTLE_FIX_BREAKABLE_SPECIAL_H

#include "break_events.h"
#include "fix.h"

#include <utility>
#include <vector>

namespace LAMMPS_NS {

// Implemented by a bond style whose bonds may stop joining their atoms while keeping a bond
// type > 0: released(i, m) says whether bond slot m of owned atom i no longer makes its
// atoms 1-2 special neighbours (it stays so through restarts: the style's own per-atom
// state says it).
class SpecialReleasedBonds {
 public:
  virtual bool released(int i, int m) = 0;
  // called on every rank (collective) before the special lists are brought up to date: at
  // every re-neighbouring (pre_exchange) and run setup (setup_pre_exchange). A style whose
  // ranks keep copies of a bond's state that only one rank evaluates brings them up to date
  // here, and reports the bonds released since through add_broken_bond() (bond_style
  // bcm/griffith: BondBcmGriffith::sync_copies())
  virtual void before_special_update() {}

 protected:
  ~SpecialReleasedBonds() = default;    // never deleted through this interface
};

class FixBreakableSpecial : public Fix {
 public:
  static constexpr const char *ID = "BREAKABLE_SPECIAL";

  FixBreakableSpecial(class LAMMPS *, int, char **);

  int setmask() override;
  void init() override;
  void setup_pre_exchange() override;
  void pre_exchange() override;
  void setup_pre_force(int) override;
  void pre_force(int) override;
  void min_pre_exchange() override { pre_exchange(); }
  void min_pre_force(int vflag) override { pre_force(vflag); }
  void setup(int) override;
  void end_of_step() override;
  double compute_vector(int) override;

  // called by the styles' single break path; count = 1 on exactly one rank per broken bond
  // (count 0 for a bond released without being counted as a break)
  void add_broken_bond(tagint tag1, tagint tag2, int count);
  void add_broken_angle(int count) { nangles_local += count; }

  // break events: record() keeps this rank's share for fix breakable/log (only while one
  // is defined); add_decided() queues a bond break decided here for the other ranks
  void record(const BreakEvent &ev)
  {
    if (recording) events.push_back(ev);
  }
  void add_decided(const BreakEvent &ev) { decided.push_back(ev); }
  void set_recording(bool on) { recording = on; }
  std::vector<BreakEvent> take_events();

  // the fix with id BREAKABLE_SPECIAL, created first if absent (needs a simulation box)
  static FixBreakableSpecial *get_or_create(class LAMMPS *);

 private:
  using TagPair = std::pair<tagint, tagint>;
  std::vector<TagPair> broken_since_exchange;    // pending special-list removals
  std::vector<TagPair> broken_since_force;       // pending neighbor-list bit clears
  bigint nbonds_local, nangles_local;            // breaks counted on this rank
  bool counted_topology;                         // broken ones already in the topology counted
  std::vector<BreakEvent> events;                // recorded on this rank, not yet logged
  std::vector<BreakEvent> decided;               // bond breaks decided here, not yet sent
  bool recording;

  void exchange();

  void count_broken_in_topology();

  void remove_special12(int i, tagint partner);
  void resync_special();
  void clear_neighbor_bits();
};

}    // namespace LAMMPS_NS

#endif
