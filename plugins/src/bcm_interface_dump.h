/* One frame of an interface dump, written straight from the bond style (fix
   bcm/interfaces/dump, command write_bcm_interfaces; plugins/doc/fix_bcm_interfaces_dump.md).

   The file is the one `dump local` (or `write_dump ... local`) writes from `compute
   property/local batom1 batom2` and `compute bond/local b1 ... bN`, byte for byte: the same
   header, the same rows in the same order, each value printed with "%g " and each row ended
   by a newline. Rows are those of the two computes: the owned atoms of the group in index
   order, their bond slots in order; a bond is listed when its partner is known to the rank
   (owned or ghost) and in the group, when newton_bond is on or the owned atom has the smaller
   ID (newton_bond off stores a bond with both atoms), and when its type is not 0 (a type < 0,
   a bond turned off, is listed with the values single() gives it). The values come from the
   bond style's single(), called once per row as compute bond/local calls it.

   Nothing is held over all interfaces: rank 0 writes its own rows as it makes them, then asks
   every other rank in rank order (the order in which dump local gathers them) for its rows
   in chunks of at most CHUNK_ROWS (keyword chunk), one chunk in flight at a time. */

#ifndef BRITTLE_BCM_INTERFACE_DUMP_H
#define BRITTLE_BCM_INTERFACE_DUMP_H

#include "pointers.h"

#include <string>
#include <vector>

namespace LAMMPS_NS {

class BcmInterfaceDump : protected Pointers {
 public:
  static constexpr int CHUNK_ROWS = 4096;

  // `args`: the values (batom1, batom2, bN: extra value N of the bond style's single()),
  // then the keywords `names` and one column name per value (default: the values'
  // keywords) and `chunk` and the rows per message (default CHUNK_ROWS); `who` names the
  // command or fix in messages
  BcmInterfaceDump(LAMMPS *lmp, const std::vector<std::string> &args, const std::string &who);

  // the bond style gives every value asked for (at init, and before a one-off write)
  void check() const;
  // one frame of the current state into `file` (fopen mode "w" or "a"), the bonds of the
  // atoms of `groupbit`. Collective.
  void write(const std::string &file, const char *mode, int groupbit);

 private:
  enum { BATOM1 = -2, BATOM2 = -1 };    // else: the index of an extra value of single()
  std::vector<int> values;
  std::string columns;                  // the ENTRIES line's names
  std::string who;
  int max_extra = -1;                   // largest extra index asked for
  int chunk_rows = CHUNK_ROWS;          // rows per message to rank 0

  // where a rank's walk over its rows stands: owned atom, bond slot
  struct Cursor {
    int i = 0, m = 0;
  };
  bool listed(int i, int m, int groupbit) const;
  bigint count(int groupbit) const;
  // up to `max` rows from the cursor on into buf (values.size() doubles per row)
  int next_rows(Cursor &c, int groupbit, int max, double *buf) const;
};

}    // namespace LAMMPS_NS

#endif
