/* The single break path of the breakable styles and the record of each break.

   Every breakable style breaks an element through these functions: bond_style and
   angle_style breakable/cr (SPEC 2.2) set its type to 0 here, in the neighbor list entry and
   in every copy held by an owned atom, and tell fix breakable/special; bond_style
   bcm/griffith (SPEC 1.2), whose interfaces keep their type, only records the event.

   An event is recorded once over all ranks: by the rank owning the atom with the smallest
   tag of the element (with newton_bond off that rank holds the element). The records wait
   in fix breakable/special until fix breakable/log gathers and writes them. */

#ifndef BRITTLE_BREAK_EVENTS_H
#define BRITTLE_BREAK_EVENTS_H

#include "lmptype.h"

namespace LAMMPS_NS {

class LAMMPS;
class FixBreakableSpecial;

// One break, all fields as doubles so that a record travels as a block of NFIELD doubles
// (tags are exact in a double up to 2^53).
struct BreakEvent {
  enum Kind { BOND = 1, ANGLE = 2, INTERFACE = 3 };
  static constexpr int NFIELD = 11;

  double step;          // time step of the force evaluation that broke it
  double time;          // simulation time of that step
  double id1, id2, id3; // atom tags; bond and interface: id1 < id2, id3 = 0; angle: as listed
                        // (id2 = vertex)
  double kind;          // Kind
  double x, y, z;       // bond, interface: midpoint of the two atoms; angle: the vertex;
                        // wrapped into a periodic box
  double energy;        // energy the element held in that evaluation
  double area;          // interface area (BCM); 0 otherwise

  const double *data() const { return &step; }
  double *data() { return &step; }
};
static_assert(sizeof(BreakEvent) == BreakEvent::NFIELD * sizeof(double), "packed record");

namespace BreakPath {

  // The bond of row n of neighbor->bondlist (local atoms i1, i2 of the row) breaks in this
  // evaluation holding energy `energy`. decided: this rank took the decision itself (it is
  // then sent to the other ranks, see FixBreakableSpecial::exchange); otherwise `from` is
  // the event another rank decided, whose step, energy and midpoint are kept.
  void bond(LAMMPS *lmp, FixBreakableSpecial *special, int n, double energy, bool decided,
            const BreakEvent *from = nullptr);

  // The angle of row n of neighbor->anglelist breaks holding `energy`; step and time of the
  // event (the current step, or the step of the bond whose break takes the angle with it).
  void angle(LAMMPS *lmp, FixBreakableSpecial *special, int n, double energy, bigint step,
             double time);

  // A BCM interface between cells c1 < c2 (by tag; local indices) switches to broken; it
  // keeps its bond type (bond_style bcm/griffith goes on computing it as contacts).
  void interface(LAMMPS *lmp, FixBreakableSpecial *special, int c1, int c2, double energy,
                 double area);

  // simulation time of the current step
  double current_time(LAMMPS *lmp);

}    // namespace BreakPath
}    // namespace LAMMPS_NS

#endif
