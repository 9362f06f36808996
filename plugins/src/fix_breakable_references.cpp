#include "fix_breakable_references.h"

#include "atom.h"
#include "breakable_util.h"
#include "comm.h"
#include "error.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <mpi.h>
#include <vector>

using namespace LAMMPS_NS;

namespace {

constexpr double PI = 3.14159265358979323846;
constexpr int CHUNK = 65536;    // lines per broadcast
constexpr int NREC = 7;         // kind, tag1, tag2, tag3, three values
constexpr double BOND = 1.0, ANGLE = 2.0;

bool parse_double(const std::string &word, double &value)
{
  char *end = nullptr;
  value = strtod(word.c_str(), &end);
  return end && *end == '\0' && std::isfinite(value);
}

}    // namespace

/* ---------------------------------------------------------------------- */

FixBreakableReferences::FixBreakableReferences(LAMMPS *_lmp, int narg, char **arg) :
    Fix(_lmp, narg, arg)
{
  if (narg != 4)
    error->all(FLERR, "Illegal fix breakable/references command: fix ID group "
                      "breakable/references FILE");
  if (atom->molecular != Atom::MOLECULAR)
    error->all(FLERR, "Fix breakable/references requires a molecular atom style (not a template)");
  file = arg[3];
}

/* ----------------------------------------------------------------------
   after the fix is installed: the stores may be created now
------------------------------------------------------------------------- */

void FixBreakableReferences::post_constructor()
{
  read();
}

/* ----------------------------------------------------------------------
   rank 0 parses CHUNK lines at a time into records of NREC doubles (tags are
   exact in a double), broadcasts them, and every rank fills the slots of its
   owned atoms. A problem found by rank 0 is broadcast and raised on all ranks.
------------------------------------------------------------------------- */

void FixBreakableReferences::read()
{
  const int nlocal = atom->nlocal;
  int ibond = -1, iangle = -1;
  if (atom->bond_per_atom > 0)
    ibond = BreakableUtil::peratom_array(lmp, BreakableUtil::BOND_REF_FIX_ID,
                                         BreakableUtil::BOND_REF_NAME, atom->bond_per_atom);
  if (atom->angle_per_atom > 0)
    iangle = BreakableUtil::peratom_array(lmp, BreakableUtil::ANGLE_REF_FIX_ID,
                                          BreakableUtil::ANGLE_REF_NAME, 3 * atom->angle_per_atom);

  std::ifstream in;
  if (comm->me == 0) in.open(file);
  int lineno = 0;
  std::vector<double> buf;
  while (true) {
    std::string problem;
    buf.clear();
    if (comm->me == 0) {
      if (!in.is_open())
        problem = fmt::format("cannot open {}", file);
      std::string line;
      while (problem.empty() && (int) buf.size() < CHUNK * NREC && std::getline(in, line)) {
        lineno++;
        const auto words = utils::split_words(utils::trim_comment(line));
        if (words.empty()) continue;
        const std::string where = fmt::format("{} line {}", file, lineno);
        const bool is_bond = words[0] == "bond", is_angle = words[0] == "angle";
        const int ntag = is_bond ? 2 : 3, nval = is_bond ? 1 : 3;
        if (!(is_bond || is_angle) || (int) words.size() != 1 + ntag + nval) {
          problem = where + ": expected `bond tag1 tag2 r0` or "
                            "`angle tag1 tag2 tag3 theta0 r1_0 r2_0`";
          break;
        }
        double rec[NREC] = {is_bond ? BOND : ANGLE, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
        for (int k = 0; k < ntag && problem.empty(); k++) {
          if (!utils::is_integer(words[1 + k]) || std::stoll(words[1 + k]) <= 0)
            problem = where + ": atom IDs must be positive integers";
          else
            rec[1 + k] = (double) std::stoll(words[1 + k]);
        }
        for (int k = 0; k < nval && problem.empty(); k++)
          if (!parse_double(words[1 + ntag + k], rec[4 + k]) || !(rec[4 + k] > 0.0))
            problem = where + ": lengths and angles must be finite and > 0";
        if (problem.empty() && is_angle && !(rec[4] <= PI))
          problem = where + ": theta0 must be in (0, pi] radians";
        if (!problem.empty()) break;
        buf.insert(buf.end(), rec, rec + NREC);
      }
    }

    int nproblem = (int) problem.size();
    MPI_Bcast(&nproblem, 1, MPI_INT, 0, world);
    if (nproblem) {
      problem.resize(nproblem);
      MPI_Bcast(&problem[0], nproblem, MPI_CHAR, 0, world);
      error->all(FLERR, "fix breakable/references: {}", problem);
    }
    int n = (int) buf.size();
    MPI_Bcast(&n, 1, MPI_INT, 0, world);
    if (n == 0) break;
    buf.resize(n);
    MPI_Bcast(buf.data(), n, MPI_DOUBLE, 0, world);

    for (int r = 0; r < n; r += NREC) {
      const double *rec = &buf[r];
      const tagint t1 = (tagint) rec[1], t2 = (tagint) rec[2], t3 = (tagint) rec[3];
      if (rec[0] == BOND) {
        if (ibond < 0) continue;
        double **r0s = atom->darray[ibond];
        for (int side = 0; side < 2; side++) {
          const int i = atom->map(side ? t2 : t1);
          if (i < 0 || i >= nlocal) continue;
          const int m = BreakableUtil::bond_slot(atom, i, side ? t1 : t2);
          if (m >= 0) r0s[i][m] = rec[4];
        }
      } else {
        if (iangle < 0) continue;
        double **refs = atom->darray[iangle];
        for (tagint t : {t1, t2, t3}) {
          const int i = atom->map(t);
          if (i < 0 || i >= nlocal) continue;
          // the topology may list the angle in either order of its arms
          int m = BreakableUtil::angle_slot(atom, i, t1, t2, t3);
          if (m >= 0) {
            refs[i][3 * m] = rec[4];
            refs[i][3 * m + 1] = rec[5];
            refs[i][3 * m + 2] = rec[6];
          } else if ((m = BreakableUtil::angle_slot(atom, i, t3, t2, t1)) >= 0) {
            refs[i][3 * m] = rec[4];
            refs[i][3 * m + 1] = rec[6];
            refs[i][3 * m + 2] = rec[5];
          }
        }
      }
    }
  }
  check_complete(ibond, iangle);
}

/* ----------------------------------------------------------------------
   every intact bond and angle of the topology has its references
------------------------------------------------------------------------- */

void FixBreakableReferences::check_complete(int ibond, int iangle)
{
  const int nlocal = atom->nlocal;
  bigint missing[2] = {0, 0};
  std::string first[2];
  if (ibond >= 0) {
    double **r0s = atom->darray[ibond];
    for (int i = 0; i < nlocal; i++)
      for (int m = 0; m < atom->num_bond[i]; m++)
        if (atom->bond_type[i][m] > 0 && !(r0s[i][m] > 0.0) && missing[0]++ == 0)
          first[0] = fmt::format("{}-{}", atom->tag[i], atom->bond_atom[i][m]);
  }
  if (iangle >= 0) {
    double **refs = atom->darray[iangle];
    for (int i = 0; i < nlocal; i++)
      for (int m = 0; m < atom->num_angle[i]; m++)
        if (atom->angle_type[i][m] > 0 && !(refs[i][3 * m + 1] > 0.0) && missing[1]++ == 0)
          first[1] = fmt::format("{}-{}-{}", atom->angle_atom1[i][m], atom->angle_atom2[i][m],
                                 atom->angle_atom3[i][m]);
  }
  bigint total[2];
  MPI_Allreduce(missing, total, 2, MPI_LMP_BIGINT, MPI_SUM, world);
  if (total[0] == 0 && total[1] == 0) return;
  // every rank raises it; the message printed is rank 0's (its examples, if it has any)
  error->all(FLERR, "fix breakable/references: {} has no line for {} bond slot(s) and {} angle "
             "slot(s) of the topology{}{}", file, total[0], total[1],
             first[0].empty() ? "" : ", e.g. bond " + first[0],
             first[1].empty() ? "" : ", e.g. angle " + first[1]);
}
