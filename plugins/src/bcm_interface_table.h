/* The interface table of bond_style bcm/griffith (SPEC 1.2; plugins/doc/bond_bcm_griffith.md,
   "Geometry file"): the geometry of every interface, identical on every rank. Read from the
   geometry file by rank 0 and broadcast; at the first init turned into the body frames of
   the two cells (take_reference()); written whole into restart files, so that a restarted
   run keeps the body-frame geometry of the original reference state. */

#ifndef BRITTLE_BCM_INTERFACE_TABLE_H
#define BRITTLE_BCM_INTERFACE_TABLE_H

#include "pointers.h"

#include <cstdio>
#include <string>
#include <utility>
#include <vector>

namespace LAMMPS_NS {

class BcmInterfaceTable : protected Pointers {
 public:
  static constexpr int MAX_POINTS = 16;    // contact points per interface

  struct Interface {
    tagint tag1, tag2;
    int npts;
    double area;
    long boff;    // into body: normal (3), points in cell 1's frame, then in cell 2's
  };

  explicit BcmInterfaceTable(LAMMPS *lmp) : Pointers(lmp) {}

  // the table of a geometry file (rank 0 reads, every rank gets it); the reference is to
  // be taken again
  void read(const std::string &file);
  // body-frame geometry from the current state of the cells (d2_bcm_quat: atom->darray[iquat])
  void take_reference(int iquat);
  bool has_reference() const { return reference_taken != 0; }

  int find(tagint t1, tagint t2) const;    // index of the interface of two cells, or -1
  int size() const { return (int) interfaces.size(); }
  const Interface &operator[](int i) const { return interfaces[i]; }
  // normal in cell 1's frame (3), then the points in cell 1's frame, then in cell 2's
  const double *body_of(const Interface &itf) const { return &body[itf.boff]; }
  const std::string &file() const { return geometry_file; }
  double mean_area() const { return area_mean; }    // <S> of the table
  int max_points() const { return maxpts; }
  double span_max() const { return span; }

  // everything after the style's own settings in its restart settings
  void write_restart(FILE *fp) const;
  void read_restart(FILE *fp);
  double memory_usage() const;

 private:
  std::vector<Interface> interfaces;
  // reference state, space frame, from the geometry file (normal, then the points, per
  // interface in order): dropped once the body frames are taken
  std::vector<double> space;
  std::vector<double> body;     // normal in cell 1's frame, points in cell 1's, then cell 2's
  std::vector<int> order;       // the interfaces by (tag1, tag2): find()
  std::string geometry_file;
  double area_mean = 0.0;
  int maxpts = 0;              // largest npts of the table: sets the per-slot store size
  int reference_taken = 0;     // body-frame geometry computed
  double span = 0.0;           // largest distance between bonded centres, reference state

  void broadcast();
  void index();
  using Key = std::pair<tagint, tagint>;
  static Key key(tagint t1, tagint t2);
};

}    // namespace LAMMPS_NS

#endif
