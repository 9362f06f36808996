#include "fix_breakable_log.h"

#include "break_events.h"
#include "comm.h"
#include "error.h"
#include "fix_breakable_special.h"

#include <algorithm>
#include <cstdio>
#include <mpi.h>
#include <tuple>
#include <vector>

using namespace LAMMPS_NS;

static const char *const KIND_NAME[] = {"?", "bond", "angle", "interface"};

/* ---------------------------------------------------------------------- */

FixBreakableLog::FixBreakableLog(LAMMPS *_lmp, int narg, char **arg) : Fix(_lmp, narg, arg)
{
  if (narg != 4)
    error->all(FLERR, "Illegal fix breakable/log command: fix ID group breakable/log FILE");
  file = arg[3];
}

/* ----------------------------------------------------------------------
   fix breakable/special records events while a fix of this style exists
------------------------------------------------------------------------- */

void FixBreakableLog::init()
{
  FixBreakableSpecial::get_or_create(lmp)->set_recording(true);
}

/* ---------------------------------------------------------------------- */

void FixBreakableLog::post_run()
{
  write();
}

/* ----------------------------------------------------------------------
   this run's records from every rank to rank 0, appended to the file
------------------------------------------------------------------------- */

void FixBreakableLog::write()
{
  std::vector<BreakEvent> mine = FixBreakableSpecial::get_or_create(lmp)->take_events();
  const int n = (int) mine.size() * BreakEvent::NFIELD;
  std::vector<int> counts(comm->nprocs, 0), displs(comm->nprocs, 0);
  MPI_Gather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, world);
  int total = 0;
  for (int p = 0; p < comm->nprocs; p++) {
    displs[p] = total;
    total += counts[p];
  }
  std::vector<BreakEvent> all(comm->me == 0 ? total / BreakEvent::NFIELD : 0);
  MPI_Gatherv(mine.empty() ? nullptr : mine.data()->data(), n, MPI_DOUBLE,
              all.empty() ? nullptr : all.data()->data(), counts.data(), displs.data(),
              MPI_DOUBLE, 0, world);

  int ok = 1;
  if (comm->me == 0) {
    // the same order on any number of ranks
    std::sort(all.begin(), all.end(), [](const BreakEvent &a, const BreakEvent &b) {
      return std::tie(a.step, a.kind, a.id1, a.id2, a.id3) <
          std::tie(b.step, b.kind, b.id1, b.id2, b.id3);
    });
    FILE *fp = fopen(file.c_str(), "a");
    if (!fp) {
      ok = 0;
    } else {
      fseek(fp, 0, SEEK_END);
      if (ftell(fp) == 0) fputs("# step time id1 id2 id3 kind x y z energy area\n", fp);
      for (const BreakEvent &e : all) {
        const int kind = (e.kind >= 1 && e.kind <= 3) ? (int) e.kind : 0;
        fmt::print(fp, "{} {:.17g} {} {} {} {} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g}\n",
                   (bigint) e.step, e.time, (tagint) e.id1, (tagint) e.id2, (tagint) e.id3,
                   KIND_NAME[kind], e.x, e.y, e.z, e.energy, e.area);
      }
      ok = fclose(fp) == 0;
    }
  }
  MPI_Bcast(&ok, 1, MPI_INT, 0, world);
  if (!ok) error->all(FLERR, "fix breakable/log: cannot write {}", file);
}
