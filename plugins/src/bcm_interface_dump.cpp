#include "bcm_interface_dump.h"

#include "atom.h"
#include "bond.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "force.h"
#include "update.h"
#include "utils.h"

#include <algorithm>
#include <cstdio>
#include <mpi.h>

using namespace LAMMPS_NS;

/* ---------------------------------------------------------------------- */

BcmInterfaceDump::BcmInterfaceDump(LAMMPS *_lmp, const std::vector<std::string> &args,
                                   const std::string &_who) :
    Pointers(_lmp), who(_who)
{
  std::vector<std::string> names;
  size_t k = 0;
  for (; k < args.size() && args[k] != "names" && args[k] != "chunk"; k++) {
    const std::string &a = args[k];
    if (a == "batom1") {
      values.push_back(BATOM1);
    } else if (a == "batom2") {
      values.push_back(BATOM2);
    } else if (utils::strmatch(a, "^b\\d+$")) {
      const int n = utils::inumeric(FLERR, a.substr(1), false, lmp);
      if (n < 1) error->all(FLERR, "{}: no value {} (extra values count from b1)", who, a);
      values.push_back(n - 1);
      max_extra = std::max(max_extra, n - 1);
    } else {
      error->all(FLERR, "{}: unknown value {} (batom1, batom2, bN)", who, a);
    }
  }
  if (values.empty()) error->all(FLERR, "{}: no values to write", who);
  names.assign(args.begin(), args.begin() + k);
  while (k < args.size()) {
    if (args[k] == "names") {
      if (k + values.size() >= args.size())
        error->all(FLERR, "{}: names needs one name per value ({})", who, values.size());
      names.assign(args.begin() + k + 1, args.begin() + k + 1 + values.size());
      k += 1 + values.size();
    } else if (args[k] == "chunk") {
      if (k + 1 >= args.size()) error->all(FLERR, "{}: chunk needs a number of rows", who);
      chunk_rows = utils::inumeric(FLERR, args[k + 1], false, lmp);
      if (chunk_rows < 1) error->all(FLERR, "{}: chunk must be >= 1, not {}", who, args[k + 1]);
      k += 2;
    } else {
      error->all(FLERR, "{}: unknown keyword {} (names, chunk)", who, args[k]);
    }
  }
  for (const std::string &name : names) columns += (columns.empty() ? "" : " ") + name;
}

/* ---------------------------------------------------------------------- */

void BcmInterfaceDump::check() const
{
  if (atom->molecular != Atom::MOLECULAR)
    error->all(FLERR, "{} needs bonds stored with the atoms (a molecular atom style)", who);
  if (!force->bond) error->all(FLERR, "{} needs a bond style", who);
  if (max_extra >= force->bond->single_extra)
    error->all(FLERR, "{}: bond style {} gives {} extra values, b{} asked for", who,
               force->bond_style, force->bond->single_extra, max_extra + 1);
}

/* ----------------------------------------------------------------------
   bond slot m of owned atom i is a row: the rules of compute property/local
   and compute bond/local
------------------------------------------------------------------------- */

bool BcmInterfaceDump::listed(int i, int m, int groupbit) const
{
  if (!(atom->mask[i] & groupbit)) return false;
  const int j = atom->map(atom->bond_atom[i][m]);
  if (j < 0 || !(atom->mask[j] & groupbit)) return false;
  if (force->newton_bond == 0 && atom->tag[i] > atom->tag[j]) return false;
  return atom->bond_type[i][m] != 0;
}

/* ---------------------------------------------------------------------- */

bigint BcmInterfaceDump::count(int groupbit) const
{
  bigint n = 0;
  for (int i = 0; i < atom->nlocal; i++)
    for (int m = 0; m < atom->num_bond[i]; m++) n += listed(i, m, groupbit);
  return n;
}

/* ---------------------------------------------------------------------- */

int BcmInterfaceDump::next_rows(Cursor &c, int groupbit, int max, double *buf) const
{
  const int nv = (int) values.size();
  double **x = atom->x;
  Bond *bond = force->bond;
  int n = 0;
  while (n < max && c.i < atom->nlocal) {
    if (c.m >= atom->num_bond[c.i]) {
      c.i++;
      c.m = 0;
      continue;
    }
    const int i = c.i, m = c.m++;
    if (!listed(i, m, groupbit)) continue;
    const int j = atom->map(atom->bond_atom[i][m]);
    if (max_extra >= 0) {
      // single() as compute bond/local calls it: the minimum-image distance, once per row
      double dx = x[i][0] - x[j][0], dy = x[i][1] - x[j][1], dz = x[i][2] - x[j][2];
      domain->minimum_image(FLERR, dx, dy, dz);
      double fbond;
      bond->single(atom->bond_type[i][m], dx * dx + dy * dy + dz * dz, i, j, fbond);
    }
    double *row = buf + (long) n * nv;
    for (int k = 0; k < nv; k++) {
      if (values[k] == BATOM1)
        row[k] = (double) atom->tag[i];
      else if (values[k] == BATOM2)
        row[k] = (double) atom->bond_atom[i][m];
      else
        row[k] = bond->svector[values[k]];
    }
    n++;
  }
  if (n != max) error->one(FLERR, "{}: fewer rows than counted on rank {}", who, comm->me);
  return n;
}

/* ----------------------------------------------------------------------
   the header of dump local (ENTRIES), then the rows of rank 0, then those of
   each other rank in rank order, a chunk at a time
------------------------------------------------------------------------- */

void BcmInterfaceDump::write(const std::string &file, const char *mode, int groupbit)
{
  check();
  const int me = comm->me, nprocs = comm->nprocs;
  const int nv = (int) values.size();
  bigint mine = count(groupbit);
  std::vector<bigint> counts(me == 0 ? nprocs : 0);
  MPI_Gather(&mine, 1, MPI_LMP_BIGINT, counts.data(), 1, MPI_LMP_BIGINT, 0, world);

  FILE *fp = nullptr;
  int ok = 1;
  if (me == 0) {
    fp = fopen(file.c_str(), mode);
    ok = fp != nullptr;
  }
  MPI_Bcast(&ok, 1, MPI_INT, 0, world);
  if (!ok) error->all(FLERR, "{}: cannot open {}", who, file);

  std::vector<double> buf((size_t) std::min<bigint>(chunk_rows, std::max<bigint>(mine, 1)) * nv);
  Cursor cursor;
  if (me == 0) {
    bigint total = 0;
    for (bigint c : counts) total += c;
    fprintf(fp, "ITEM: TIMESTEP\n" BIGINT_FORMAT "\nITEM: NUMBER OF ENTRIES\n" BIGINT_FORMAT "\n",
            update->ntimestep, total);
    char bounds[16];
    domain->boundary_string(bounds);
    if (domain->triclinic) {
      fprintf(fp, "ITEM: BOX BOUNDS xy xz yz %s\n", bounds);
      const double tilt[3] = {domain->xy, domain->xz, domain->yz};
      for (int d = 0; d < 3; d++)
        fprintf(fp, "%-1.16e %-1.16e %-1.16e\n", domain->boxlo_bound[d], domain->boxhi_bound[d],
                tilt[d]);
    } else {
      fprintf(fp, "ITEM: BOX BOUNDS %s\n", bounds);
      for (int d = 0; d < 3; d++)
        fprintf(fp, "%-1.16e %-1.16e\n", domain->boxlo[d], domain->boxhi[d]);
    }
    fprintf(fp, "ITEM: ENTRIES %s\n", columns.c_str());

    auto print = [&](int n) {
      for (long r = 0; r < (long) n * nv; r += nv) {
        for (int k = 0; k < nv; k++) fprintf(fp, "%g ", buf[r + k]);
        fputc('\n', fp);
      }
    };
    for (bigint left = mine; left > 0;) {
      const int n = next_rows(cursor, groupbit, (int) std::min<bigint>(left, chunk_rows), buf.data());
      print(n);
      left -= n;
    }
    for (int p = 1; p < nprocs; p++) {
      const size_t need = (size_t) std::min<bigint>(chunk_rows, counts[p]) * nv;
      if (buf.size() < need) buf.resize(need);
      for (bigint left = counts[p]; left > 0;) {
        const int n = (int) std::min<bigint>(left, chunk_rows);
        int go = 1;
        MPI_Send(&go, 1, MPI_INT, p, 0, world);
        MPI_Recv(buf.data(), n * nv, MPI_DOUBLE, p, 0, world, MPI_STATUS_IGNORE);
        print(n);
        left -= n;
      }
    }
    ok = !ferror(fp);
    ok = (fclose(fp) == 0) && ok;
  } else {
    // one chunk at a time, each when rank 0 asks for it: rank 0 never holds more than one
    for (bigint left = mine; left > 0;) {
      const int n = next_rows(cursor, groupbit, (int) std::min<bigint>(left, chunk_rows), buf.data());
      int go;
      MPI_Recv(&go, 1, MPI_INT, 0, 0, world, MPI_STATUS_IGNORE);
      MPI_Send(buf.data(), n * nv, MPI_DOUBLE, 0, 0, world);
      left -= n;
    }
  }
  MPI_Bcast(&ok, 1, MPI_INT, 0, world);
  if (!ok) error->all(FLERR, "{}: writing {} failed", who, file);
}
