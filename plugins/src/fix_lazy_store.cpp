/* fix lazy/store: see fix_lazy_store.h and plugins/doc/fix_lazy_store.md. */

#include "fix_lazy_store.h"

#include "atom.h"
#include "error.h"
#include "memory.h"

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <sys/mman.h>

using namespace LAMMPS_NS;

/* ---------------------------------------------------------------------- */

FixLazyStore::FixLazyStore(LAMMPS *lmp, int narg, char **arg) :
    Fix(lmp, narg, arg), ncols(0), index(-1), ghost(false), sized_rows(false), nunsized(0),
    block(nullptr), block_bytes(0)
{
  if ((narg != 7 && narg != 9) || strcmp(arg[5], "ghost") != 0 ||
      (narg == 9 && (strcmp(arg[7], "rows") != 0 || strcmp(arg[8], "sized") != 0)))
    error->all(FLERR, "Illegal fix lazy/store command: fix ID group lazy/store NAME NCOLS ghost "
               "yes|no [rows sized]");
  name = arg[3];
  ncols = utils::inumeric(FLERR, arg[4], false, lmp);
  if (ncols < 1) error->all(FLERR, "fix lazy/store: NCOLS must be >= 1");
  ghost = utils::logical(FLERR, arg[6], false, lmp) != 0;
  sized_rows = narg == 9;
  if (sized_rows && ghost) error->all(FLERR, "fix lazy/store: rows sized needs ghost no");
  int flag = -1, cols = -1;
  if (atom->find_custom(name.c_str(), flag, cols) >= 0)
    error->all(FLERR, "fix lazy/store: per-atom array {} exists already", name);
  index = atom->add_custom(name.c_str(), 1, ncols, ghost ? 1 : 0);
  // add_custom allocated nmax rows of its own (untouched, yet a mapping): this fix's rows
  // replace them
  memory->destroy(atom->darray[index]);
  atom->darray[index] = nullptr;

  restart_peratom = 1;
  // the exchange buffer must hold a whole row and its length (and a sized row's size)
  maxexchange = ncols + 2;
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
  if (sized_rows)
    for (double *row : rows) free(row);
}

/* ----------------------------------------------------------------------
   rows in use (owned + ghost), not the mapping's size: rows never touched cost nothing
------------------------------------------------------------------------- */

double FixLazyStore::memory_usage()
{
  double bytes = (double) rows.capacity() * sizeof(double *);
  if (!sized_rows) return bytes + (double) (atom->nlocal + atom->nghost) * ncols * sizeof(double);
  for (int n : len) bytes += (double) n * sizeof(double);
  return bytes + (double) len.capacity() * sizeof(int);
}

/* ----------------------------------------------------------------------
   nmax rows: the mapping grows in place or moves without copying (mremap); the new rows
   read as zero until written, as fix property/atom's memset rows do
------------------------------------------------------------------------- */

void FixLazyStore::grow_arrays(int nmax)
{
  if (nmax <= (int) rows.size()) return;
  if (sized_rows) {    // a row gets its block when reserved, copied or received
    rows.resize(nmax, nullptr);
    len.resize(nmax, 0);
    atom->darray[index] = rows.data();
    return;
  }
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
  auto *base = static_cast<double *>(block);
  for (int i = 0; i < nmax; i++) rows[i] = base + (size_t) i * ncols;
  atom->darray[index] = rows.data();
}

/* ---------------------------------------------------------------------- */

void FixLazyStore::copy_arrays(int i, int j, int /*delflag*/)
{
  if (i == j) return;
  if (sized_rows) {    // j as long as i (not longer: sorting would spread the longest rows)
    resize_row(j, len[i]);
    if (len[i]) std::memcpy(rows[j], rows[i], sizeof(double) * len[i]);
    return;
  }
  put_row(rows[j], rows[i], extent(rows[i]));
}

/* ----------------------------------------------------------------------
   rows sized: the block of row i n values long, its values kept up to n, zeros after them
------------------------------------------------------------------------- */

void FixLazyStore::resize_row(int i, int n)
{
  if (n == len[i]) return;
  if (n == 0) {
    free(rows[i]);
    rows[i] = nullptr;
  } else {
    auto *p = static_cast<double *>(realloc(rows[i], sizeof(double) * n));
    if (!p) error->one(FLERR, "fix lazy/store: cannot allocate a row of {} values", n);
    if (n > len[i]) std::memset(p + len[i], 0, sizeof(double) * (n - len[i]));
    rows[i] = p;
  }
  len[i] = n;
}

void FixLazyStore::reserve(int i, int n)
{
  if (!sized_rows) return;    // every row holds NCOLS values
  if (n > ncols) error->one(FLERR, "fix lazy/store: a row of {} values in a store of {}", n, ncols);
  if (n > len[i]) resize_row(i, n);
}

/* ----------------------------------------------------------------------
   the length of a row up to its last value that is not +0.0 (all bits zero): the rest of the
   row reads as zeros whether its pages were ever touched or not
------------------------------------------------------------------------- */

size_t FixLazyStore::extent(const double *row, size_t n)
{
  while (n > 0) {
    uint64_t bits;
    std::memcpy(&bits, row + n - 1, sizeof(bits));
    if (bits) break;
    n--;
  }
  return n;
}

/* ----------------------------------------------------------------------
   dest becomes the n values of src followed by zeros, bit for bit, writing only where dest
   has (or gets) a value: pages of a row beyond both extents stay untouched (no memory)
------------------------------------------------------------------------- */

void FixLazyStore::put_row(double *dest, const double *src, size_t n)
{
  const size_t old = extent(dest);
  if (n) std::memmove(dest, src, sizeof(double) * n);
  if (old > n) std::memset(dest + n, 0, sizeof(double) * (old - n));
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
    const size_t len = extent(row);
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
    put_row(rows[first + k], buf + m, len);
    m += (int) len;
  }
  return m;
}

/* ---------------------------------------------------------------------- */

int FixLazyStore::pack_exchange(int i, double *buf)
{
  if (sized_rows) {    // the row's size, then its values as far as its last one
    const size_t n = extent(rows[i], len[i]);
    buf[0] = (double) len[i];
    buf[1] = (double) n;
    if (n) std::memcpy(buf + 2, rows[i], sizeof(double) * n);
    return (int) n + 2;
  }
  const size_t n = extent(rows[i]);
  buf[0] = (double) n;
  std::memcpy(buf + 1, rows[i], sizeof(double) * n);
  return (int) n + 1;
}

/* ---------------------------------------------------------------------- */

int FixLazyStore::unpack_exchange(int nlocal, double *buf)
{
  if (sized_rows) {
    const int size = (int) buf[0], n = (int) buf[1];
    resize_row(nlocal, size);
    if (size) {
      if (n) std::memcpy(rows[nlocal], buf + 2, sizeof(double) * n);
      std::memset(rows[nlocal] + n, 0, sizeof(double) * (size - n));
    }
    return n + 2;
  }
  const size_t n = (size_t) buf[0];
  put_row(rows[nlocal], buf + 1, n);
  return (int) n + 1;
}

/* ----------------------------------------------------------------------
   restart: the row after its length, as fix property/atom writes a per-atom array
------------------------------------------------------------------------- */

int FixLazyStore::pack_restart(int i, double *buf)
{
  if (sized_rows) {    // the count, the row's size (negative: no row of NCOLS begins so), values
    buf[0] = len[i] + 2;
    buf[1] = -(len[i] + 1.0);
    if (len[i]) std::memcpy(buf + 2, rows[i], sizeof(double) * len[i]);
    return len[i] + 2;
  }
  buf[0] = ncols + 1;
  std::memcpy(buf + 1, rows[i], sizeof(double) * ncols);
  return ncols + 1;
}

/* ---------------------------------------------------------------------- */

void FixLazyStore::unpack_restart(int nlocal, int nth)
{
  double **extra = atom->extra;
  int m = 0;    // skip the values of the fixes before this one
  for (int k = 0; k < nth; k++) m += static_cast<int>(extra[nlocal][m]);
  const double *in = &extra[nlocal][m + 1];
  const int count = static_cast<int>(extra[nlocal][m]) - 1;
  if (sized_rows) {
    // a sized row (its size, then its values), or a whole row of NCOLS from a store whose
    // rows were not sized: as long as its values reach
    const bool own = count > 0 && in[0] < 0.0;
    const int size = own ? static_cast<int>(-in[0]) - 1 : (int) extent(in, count);
    if (own)
      in++;
    else
      nunsized++;
    resize_row(nlocal, size);
    if (size) std::memcpy(rows[nlocal], in, sizeof(double) * size);
    return;
  }
  put_row(rows[nlocal], in, extent(in, std::min(count, ncols)));
}

/* ---------------------------------------------------------------------- */

int FixLazyStore::size_restart(int nlocal)
{
  return sized_rows ? len[nlocal] + 2 : ncols + 1;
}

int FixLazyStore::maxsize_restart()
{
  return ncols + 2;
}
