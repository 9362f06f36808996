/* The interface table of bond_style bcm/griffith (SPEC 1.2; plugins/doc/bond_bcm_griffith.md,
   "Geometry file"): the geometry of every interface, identical on every rank. Read from the
   geometry file by rank 0 and broadcast. It keeps that file's space-frame geometry (normal and
   points of the reference state) and, from the first init (take_reference()), the reference
   state of the cells (position, orientation) and box: the body frames of an interface's two
   cells are computed from these whenever they are asked for (body_of()), the same
   arithmetic every time. Written whole into restart files, so that a restarted run keeps the
   original reference. */

#ifndef BRITTLE_BCM_INTERFACE_TABLE_H
#define BRITTLE_BCM_INTERFACE_TABLE_H

#include "pointers.h"

#include <cstdint>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

namespace LAMMPS_NS {

class BcmInterfaceTable : protected Pointers {
 public:
  static constexpr int MAX_POINTS = 16;    // contact points per interface
  // the longest body-frame geometry of an interface (body_of())
  static constexpr int BODY_MAX = 3 + 6 * MAX_POINTS;

  struct Interface {    // 24 bytes: every rank holds every interface
    tagint tag1, tag2;
    double area;
    uint32_t off;    // into space: normal (3), then the points (3 npts); checked in index()
    int npts;
  };

  explicit BcmInterfaceTable(LAMMPS *lmp) : Pointers(lmp) {}

  // the table of a geometry file (rank 0 reads, every rank gets it); the reference is to
  // be taken again
  void read(const std::string &file);
  // the reference state from the current state of the cells (x, orientations quat:
  // bcm_orientation.h) and the box; checks that the geometry fits the cells
  void take_reference(double **quat);
  bool has_reference() const { return reference != NONE; }

  int find(tagint t1, tagint t2) const;    // index of the interface of two cells, or -1
  int size() const { return (int) interfaces.size(); }
  const Interface &operator[](int i) const { return interfaces[i]; }
  // the body-frame geometry of interface i into out (3 + 6 npts): the normal in cell 1's
  // frame, then the points in cell 1's frame, then in cell 2's; needs the reference
  void body_of(int i, double *out) const;
  const std::string &file() const { return geometry_file; }
  double mean_area() const { return area_mean; }    // <S> of the table
  int max_points() const { return maxpts; }
  double span_max() const { return span; }

  // everything after the style's own settings in its restart settings
  void write_restart(FILE *fp) const;
  void read_restart(FILE *fp);
  double memory_usage() const;

 private:
  // what the body frames are computed from: nothing yet (before the first init); the
  // reference state of the cells; or (restart files written before the cells' reference was
  // kept) the body frames themselves, as read
  enum Reference { NONE = 0, CELLS = 1, BODIES = 2 };
  // minimum image in the box of the reference state: Domain::minimum_image's arithmetic
  // (LAMMPS 22 Jul 2025) on a copy of that box, which a later run may have deformed
  struct Box {
    int triclinic = 0;
    int periodic[3] = {0, 0, 0};
    double prd[3] = {0.0, 0.0, 0.0}, prd_half[3] = {0.0, 0.0, 0.0};
    double xy = 0.0, xz = 0.0, yz = 0.0;
  };
  static constexpr int NREF = 7;    // per cell: x (3), orientation (4)

  std::vector<Interface> interfaces;
  // reference state, space frame, from the geometry file: per interface in order the normal
  // (tag1 to tag2), then the points
  std::vector<double> space;
  // reference state of the cells of the interfaces, NREF values per cell, in tag order
  std::vector<double> cells;
  std::vector<tagint> cell_tags;    // their tags; empty when they are 1..N (cell t at t - 1)
  Box box;
  std::vector<double> bodies;    // BODIES only: per interface 3 + 6 npts, in order
  std::vector<int> order;        // the interfaces by (tag1, tag2): find()
  std::string geometry_file;
  double area_mean = 0.0;
  int maxpts = 0;           // largest npts of the table: sets the per-slot store size
  int reference = NONE;
  double span = 0.0;    // largest distance between bonded centres, reference state

  void broadcast();
  void index();
  void clear_reference();
  int cell_of(tagint t) const;    // index into cells of a cell of the table, or -1
  void minimum_image(double *d) const;
  template <class Visit> void frames(int i, double *out, Visit &&visit) const;
  using Key = std::pair<tagint, tagint>;
  static Key key(tagint t1, tagint t2);
};

}    // namespace LAMMPS_NS

#endif
