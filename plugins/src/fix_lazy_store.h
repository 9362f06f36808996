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
  // The owner of a store may keep the values of the atoms a rank holds in a copy of its own
  // (bond_style bcm/griffith: its working copy, the only live one). The rows then hold only
  // what arrived with atoms (exchange, restart file) until the owner takes it, and what the
  // owner hands back (set()); whenever a row leaves (exchange, restart file) the owner
  // composes it. Rows untouched cost no memory.
  class Owner {
   public:
    // atom i's row into out[0 .. NCOLS), from the owner's copy and the stored row (its first
    // n values; zeros after them): returns its length, the values after it zero and unwritten
    virtual size_t compose(int i, const double *stored, size_t n, double *out) = 0;

   protected:
    ~Owner() = default;    // not deleted through this interface
  };

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

  // the owner (nullptr: none, the rows are the values, as for fix property/atom)
  void set_owner(Owner *o) { owner = o; }
  Owner *get_owner() const { return owner; }
  int columns() const { return ncols; }
  // with an owner: the length of atom i's row (its values after it are zero)
  size_t length(int i) const { return owner ? rowlen[i] : extent(rows[i]); }
  const double *row(int i) const { return rows[i]; }
  // atom i's row becomes src[0 .. n) then zeros; whole pages emptied are given back
  void set(int i, const double *src, size_t n) { put_row(i, src, n); }

 private:
  // a row's length up to its last value that is not +0.0; a row set to n values then zeros,
  // writing nothing beyond what either extent covers (untouched pages cost no memory)
  size_t extent(const double *row) const;
  void put_row(int j, const double *src, size_t n);
  Owner *owner = nullptr;
  // per row, its length as this fix wrote it (exact while the rows are written only through
  // this fix: with an owner)
  std::vector<size_t> rowlen;
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
