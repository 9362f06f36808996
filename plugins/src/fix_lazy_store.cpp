/* fix lazy/store: see fix_lazy_store.h and plugins/doc/fix_lazy_store.md. */

#include "fix_lazy_store.h"

#include "atom.h"
#include "error.h"
#include "memory.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <sys/mman.h>

using namespace LAMMPS_NS;

/* ---------------------------------------------------------------------- */

FixLazyStore::FixLazyStore(LAMMPS *lmp, int narg, char **arg) :
    Fix(lmp, narg, arg), ncols(0), index(-1), ghost(false), block(nullptr), block_bytes(0)
{
  if (narg != 7 || strcmp(arg[5], "ghost") != 0)
    error->all(FLERR, "Illegal fix lazy/store command: fix ID group lazy/store NAME NCOLS ghost "
               "yes|no");
  name = arg[3];
  ncols = utils::inumeric(FLERR, arg[4], false, lmp);
  if (ncols < 1) error->all(FLERR, "fix lazy/store: NCOLS must be >= 1");
  ghost = utils::logical(FLERR, arg[6], false, lmp) != 0;
  int flag = -1, cols = -1;
  if (atom->find_custom(name.c_str(), flag, cols) >= 0)
    error->all(FLERR, "fix lazy/store: per-atom array {} exists already", name);
  index = atom->add_custom(name.c_str(), 1, ncols, ghost ? 1 : 0);
  // add_custom allocated nmax rows of its own (untouched, yet a mapping): this fix's rows
  // replace them
  memory->destroy(atom->darray[index]);
  atom->darray[index] = nullptr;

  restart_peratom = 1;
  maxexchange = ncols + 1;            // the exchange buffer must hold a whole row and its length
  if (ghost) comm_border = ncols + 1;

  grow_arrays(atom->nmax);
  atom->add_callback(Atom::GROW);
  atom->add_callback(Atom::RESTART);
  if (ghost) atom->add_callback(Atom::BORDER);
}

/* ---------------------------------------------------------------------- */

FixLazyStore::~FixLazyStore()
{
  atom->delete_callback(id, Atom::GROW);
  atom->delete_callback(id, Atom::RESTART);
  if (ghost) atom->delete_callback(id, Atom::BORDER);
  // the rows are this fix's, not LAMMPS's memory: Atom must not free them
  atom->darray[index] = nullptr;
  atom->remove_custom(index, 1, ncols);
  if (block) munmap(block, block_bytes);
}

/* ----------------------------------------------------------------------
   rows in use (owned + ghost), not the mapping's size: rows never touched cost nothing
------------------------------------------------------------------------- */

double FixLazyStore::memory_usage()
{
  return (double) (atom->nlocal + atom->nghost) * ncols * sizeof(double) +
      (double) rows.capacity() * sizeof(double *);
}

/* ----------------------------------------------------------------------
   nmax rows: the mapping grows in place or moves without copying (mremap); the new rows
   read as zero until written, as fix property/atom's memset rows do
------------------------------------------------------------------------- */

void FixLazyStore::grow_arrays(int nmax)
{
  if (nmax <= (int) rows.size()) return;
  const size_t row_bytes = sizeof(double) * (size_t) ncols;
  const size_t page = 4096;
  const size_t bytes = ((size_t) nmax * row_bytes + page - 1) / page * page;
  void *p = block ? mremap(block, block_bytes, bytes, MREMAP_MAYMOVE)
                  : mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1,
                         0);
  if (p == MAP_FAILED)
    error->one(FLERR, "fix lazy/store: cannot map {} bytes for per-atom array {}", bytes, name);
  block = p;
  block_bytes = bytes;
  rows.resize(nmax);
  rowlen.resize(nmax, 0);
  auto *base = static_cast<double *>(block);
  for (int i = 0; i < nmax; i++) rows[i] = base + (size_t) i * ncols;
  atom->darray[index] = rows.data();
}

/* ---------------------------------------------------------------------- */

void FixLazyStore::copy_arrays(int i, int j, int /*delflag*/)
{
  if (i != j) put_row(j, rows[i], length(i));
}

/* ----------------------------------------------------------------------
   the length of a row up to its last value that is not +0.0 (all bits zero): the rest of the
   row reads as zeros whether its pages were ever touched or not
------------------------------------------------------------------------- */

size_t FixLazyStore::extent(const double *row) const
{
  size_t n = (size_t) ncols;
  while (n > 0) {
    uint64_t bits;
    std::memcpy(&bits, row + n - 1, sizeof(bits));
    if (bits) break;
    n--;
  }
  return n;
}

/* ----------------------------------------------------------------------
   zeros over n values from p: whole pages given back to the kernel (they read as zeros and
   cost no memory until written again), the rest written
------------------------------------------------------------------------- */

static void zero_values(double *p, size_t n)
{
  const uintptr_t page = 4096;
  const uintptr_t a = (uintptr_t) p, b = (uintptr_t) (p + n);
  const uintptr_t lo = (a + page - 1) / page * page, hi = b / page * page;
  if (hi > lo && madvise((void *) lo, hi - lo, MADV_DONTNEED) == 0) {
    std::memset(p, 0, lo - a);
    std::memset((void *) hi, 0, b - hi);
  } else {
    std::memset(p, 0, sizeof(double) * n);
  }
}

/* ----------------------------------------------------------------------
   row j becomes the n values of src followed by zeros, bit for bit, writing only where it
   has (or gets) a value: pages of a row beyond both extents stay untouched (no memory)
------------------------------------------------------------------------- */

void FixLazyStore::put_row(int j, const double *src, size_t n)
{
  double *dest = rows[j];
  const size_t old = length(j);
  if (n) std::memmove(dest, src, sizeof(double) * n);
  if (old > n) zero_values(dest + n, old - n);
  rowlen[j] = n;
}

/* ----------------------------------------------------------------------
   border and exchange buffers carry a row as its extent, then that many values
   (comm_border and maxexchange bound it by NCOLS + 1)
------------------------------------------------------------------------- */

int FixLazyStore::pack_border(int n, int *list, double *buf)
{
  int m = 0;
  for (int k = 0; k < n; k++) {
    const double *row = rows[list[k]];
    const size_t len = length(list[k]);
    buf[m++] = (double) len;
    std::memcpy(buf + m, row, sizeof(double) * len);
    m += (int) len;
  }
  return m;
}

/* ---------------------------------------------------------------------- */

int FixLazyStore::unpack_border(int n, int first, double *buf)
{
  int m = 0;
  for (int k = 0; k < n; k++) {
    const size_t len = (size_t) buf[m++];
    put_row(first + k, buf + m, len);
    m += (int) len;
  }
  return m;
}

/* ---------------------------------------------------------------------- */

int FixLazyStore::pack_exchange(int i, double *buf)
{
  size_t len = length(i);
  if (owner)
    len = owner->compose(i, rows[i], len, buf + 1);
  else
    std::memcpy(buf + 1, rows[i], sizeof(double) * len);
  buf[0] = (double) len;
  return (int) len + 1;
}

/* ---------------------------------------------------------------------- */

int FixLazyStore::unpack_exchange(int nlocal, double *buf)
{
  const size_t len = (size_t) buf[0];
  put_row(nlocal, buf + 1, len);
  return (int) len + 1;
}

/* ----------------------------------------------------------------------
   restart: the row after its length, as fix property/atom writes a per-atom array
------------------------------------------------------------------------- */

int FixLazyStore::pack_restart(int i, double *buf)
{
  buf[0] = ncols + 1;
  if (owner) {
    const size_t len = owner->compose(i, rows[i], length(i), buf + 1);
    std::memset(buf + 1 + len, 0, sizeof(double) * (ncols - len));
  } else {
    std::memcpy(buf + 1, rows[i], sizeof(double) * ncols);
  }
  return ncols + 1;
}

/* ---------------------------------------------------------------------- */

void FixLazyStore::unpack_restart(int nlocal, int nth)
{
  double **extra = atom->extra;
  int m = 0;    // skip the values of the fixes before this one
  for (int k = 0; k < nth; k++) m += static_cast<int>(extra[nlocal][m]);
  put_row(nlocal, &extra[nlocal][m + 1], extent(&extra[nlocal][m + 1]));
}

/* ---------------------------------------------------------------------- */

int FixLazyStore::size_restart(int /*nlocal*/)
{
  return ncols + 1;
}

int FixLazyStore::maxsize_restart()
{
  return ncols + 1;
}
