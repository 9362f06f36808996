/* fix lazy/store: a hidden per-atom array of doubles whose memory is paid per atom in use.

     fix ID all lazy/store NAME NCOLS ghost yes|no

   What `fix property/atom d2_NAME NCOLS` does for a per-atom store (the array is
   atom->darray[find_custom(NAME)], it migrates with its atoms, follows atom sorting, goes to
   restart files and, with ghost yes, to ghost atoms at re-neighbouring), with one difference:
   LAMMPS sizes per-atom arrays for atom->nmax rows, at least 16384 per rank (AtomVec's
   DELTA), and fix property/atom zeroes them all, so a wide store costs 16384 rows even for a
   300-cell particle. Here the rows live in an anonymous memory mapping: rows never written
   are never resident (the kernel hands out zero pages when a row is first touched, which is
   the zero start fix property/atom gives by memset), and growing it (mremap) copies nothing.
   Resident memory thus follows the atoms a rank holds. Linux only (mmap/mremap).
   Created by the styles that own the store (plugins/src/breakable_util.h); see
   plugins/doc/fix_lazy_store.md. */

#ifndef BRITTLE_FIX_LAZY_STORE_H
#define BRITTLE_FIX_LAZY_STORE_H

#include "fix.h"

#include <string>
#include <vector>

namespace LAMMPS_NS {

class FixLazyStore : public Fix {
 public:
  FixLazyStore(class LAMMPS *, int, char **);
  ~FixLazyStore() override;

  int setmask() override { return 0; }
  double memory_usage() override;

  void grow_arrays(int) override;
  void copy_arrays(int, int, int) override;
  int pack_border(int, int *, double *) override;
  int unpack_border(int, int, double *) override;
  int pack_exchange(int, double *) override;
  int unpack_exchange(int, double *) override;
  int pack_restart(int, double *) override;
  void unpack_restart(int, int) override;
  int size_restart(int) override;
  int maxsize_restart() override;

 private:
  // a row's length up to its last value that is not +0.0; a row set to n values then zeros,
  // writing nothing beyond what either extent covers (untouched pages cost no memory)
  size_t extent(const double *row) const;
  void put_row(double *dest, const double *src, size_t n);
  std::string name;
  int ncols;
  int index;                    // into atom->darray
  bool ghost;
  void *block;                  // the mapping: nrows rows of ncols doubles
  size_t block_bytes;
  std::vector<double *> rows;   // atom->darray[index] points at rows.data()
};

}    // namespace LAMMPS_NS

#endif
