/* The interface table of bond_style bcm/griffith: see bcm_interface_table.h. */

#include "bcm_interface_table.h"

#include "atom.h"
#include "bcm_rigid.h"
#include "comm.h"
#include "domain.h"
#include "error.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <mpi.h>
#include <unordered_map>

using namespace LAMMPS_NS;
using BcmRigid::dot;

namespace {

bool parse_double(const std::string &s, double &out)
{
  if (!utils::is_double(s)) return false;
  out = std::stod(s);
  return std::isfinite(out);
}

}    // namespace

/* ----------------------------------------------------------------------
   one interface per line (comments after '#'):
     tag1 tag2 area nx ny nz npts  x1 y1 z1 ... (npts points)
   space coordinates of the reference state, normal from tag1 to tag2, tag1 < tag2.
   Read on rank 0; a message of the first problem is broadcast and raised on all ranks.
------------------------------------------------------------------------- */

void BcmInterfaceTable::read(const std::string &file)
{
  interfaces.clear();
  space.clear();
  body.clear();
  order.clear();
  geometry_file = file;
  reference_taken = 0;

  std::string problem;
  if (comm->me == 0) {
    std::ifstream in(file);
    if (!in) problem = fmt::format("cannot open geometry file {}", file);
    std::string line;
    int lineno = 0;
    while (problem.empty() && std::getline(in, line)) {
      lineno++;
      const auto words = utils::split_words(utils::trim_comment(line));
      if (words.empty()) continue;
      const std::string where = fmt::format("geometry file {} line {}", file, lineno);
      if (words.size() < 7 || !utils::is_integer(words[0]) || !utils::is_integer(words[1]) ||
          !utils::is_integer(words[6])) {
        problem = where + ": expected `tag1 tag2 area nx ny nz npts x1 y1 z1 ...`";
        break;
      }
      Interface itf;
      itf.tag1 = std::stoll(words[0]);
      itf.tag2 = std::stoll(words[1]);
      itf.npts = std::stoi(words[6]);
      if (!(itf.tag1 > 0 && itf.tag1 < itf.tag2)) {
        problem = where + ": needs 0 < tag1 < tag2 (the normal points from tag1 to tag2)";
        break;
      }
      if (itf.npts < 3) {
        problem = where + fmt::format(": {} points, an interface needs at least 3", itf.npts);
        break;
      }
      if (itf.npts > MAX_POINTS) {
        problem = where + fmt::format(": interface {}-{} has {} points, more than the {} that "
                                      "bond_style bcm/griffith supports",
                                      itf.tag1, itf.tag2, itf.npts, MAX_POINTS);
        break;
      }
      if ((int) words.size() != 7 + 3 * itf.npts) {
        problem = where + fmt::format(": {} numbers for {} points, {} expected", words.size(),
                                      itf.npts, 7 + 3 * itf.npts);
        break;
      }
      double val[3 + 3 * MAX_POINTS + 1];
      bool ok = parse_double(words[2], itf.area);
      for (int k = 0; ok && k < 3; k++) ok = parse_double(words[3 + k], val[k]);
      for (int k = 0; ok && k < 3 * itf.npts; k++) ok = parse_double(words[7 + k], val[3 + k]);
      if (!ok) {
        problem = where + ": a value is not a finite number";
        break;
      }
      if (!(itf.area > 0.0)) {
        problem = where + ": the area must be > 0";
        break;
      }
      const double nn = std::sqrt(dot(val, val));
      if (std::fabs(nn - 1.0) > 1e-6) {
        problem = where + fmt::format(": the normal has length {}, not 1", nn);
        break;
      }
      for (int k = 0; k < 3; k++) val[k] /= nn;
      itf.boff = 0;
      space.insert(space.end(), val, val + 3 + 3 * itf.npts);
      interfaces.push_back(itf);
    }
    if (problem.empty()) {
      std::vector<int> sorted(interfaces.size());
      for (int i = 0; i < (int) sorted.size(); i++) sorted[i] = i;
      std::sort(sorted.begin(), sorted.end(), [&](int a, int b) {
        return key(interfaces[a].tag1, interfaces[a].tag2) < key(interfaces[b].tag1, interfaces[b].tag2);
      });
      for (size_t k = 1; k < sorted.size(); k++) {
        const Interface &a = interfaces[sorted[k - 1]], &b = interfaces[sorted[k]];
        if (a.tag1 == b.tag1 && a.tag2 == b.tag2) {
          problem = fmt::format("geometry file {}: interface {}-{} listed twice", file, a.tag1,
                                a.tag2);
          break;
        }
      }
    }
  }

  space.shrink_to_fit();    // kept for the run: no room left from its growth
  interfaces.shrink_to_fit();
  int nproblem = (int) problem.size();
  MPI_Bcast(&nproblem, 1, MPI_INT, 0, world);
  if (nproblem) {
    problem.resize(nproblem);
    MPI_Bcast(&problem[0], nproblem, MPI_CHAR, 0, world);
    error->all(FLERR, "bond_style bcm/griffith: {}", problem);
  }
  broadcast();
}

/* ----------------------------------------------------------------------
   rank 0's table to every rank, then the derived offsets and look-up
------------------------------------------------------------------------- */

void BcmInterfaceTable::broadcast()
{
  int nif = (int) interfaces.size();
  MPI_Bcast(&nif, 1, MPI_INT, 0, world);
  std::vector<tagint> tags(2 * nif);
  std::vector<int> npts(nif);
  std::vector<double> area(nif);
  if (comm->me == 0)
    for (int i = 0; i < nif; i++) {
      tags[2 * i] = interfaces[i].tag1;
      tags[2 * i + 1] = interfaces[i].tag2;
      npts[i] = interfaces[i].npts;
      area[i] = interfaces[i].area;
    }
  MPI_Bcast(tags.data(), 2 * nif, MPI_LMP_TAGINT, 0, world);
  MPI_Bcast(npts.data(), nif, MPI_INT, 0, world);
  MPI_Bcast(area.data(), nif, MPI_DOUBLE, 0, world);
  long nspace = (long) space.size();
  MPI_Bcast(&nspace, 1, MPI_LONG, 0, world);
  space.resize(nspace);
  MPI_Bcast(space.data(), (int) nspace, MPI_DOUBLE, 0, world);

  interfaces.resize(nif);
  for (int i = 0; i < nif; i++) {
    interfaces[i].tag1 = tags[2 * i];
    interfaces[i].tag2 = tags[2 * i + 1];
    interfaces[i].npts = npts[i];
    interfaces[i].area = area[i];
  }
  index();
}

/* ---------------------------------------------------------------------- */

void BcmInterfaceTable::index()
{
  long soff = 0, boff = 0;
  maxpts = 0;
  area_mean = 0.0;
  for (const Interface &itf : interfaces) area_mean += itf.area;
  if (!interfaces.empty()) area_mean /= (double) interfaces.size();
  for (int i = 0; i < (int) interfaces.size(); i++) {
    Interface &itf = interfaces[i];
    itf.boff = boff;
    soff += 3 + 3 * itf.npts;
    boff += 3 + 6 * itf.npts;
    maxpts = std::max(maxpts, itf.npts);
  }
  // the space frame is gone once the reference is taken (restart files written since hold none)
  if (soff != (long) space.size() && !(reference_taken && space.empty()))
    error->all(FLERR, "bond_style bcm/griffith: inconsistent interface table");
  body.resize(boff, 0.0);
  order.resize(interfaces.size());
  for (int i = 0; i < (int) order.size(); i++) order[i] = i;
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return key(interfaces[a].tag1, interfaces[a].tag2) < key(interfaces[b].tag1, interfaces[b].tag2);
  });
  order.shrink_to_fit();
}

/* ---------------------------------------------------------------------- */

BcmInterfaceTable::Key BcmInterfaceTable::key(tagint t1, tagint t2)
{
  return {t1, t2};
}

int BcmInterfaceTable::find(tagint t1, tagint t2) const
{
  if (t1 > t2) std::swap(t1, t2);
  const Key k{t1, t2};
  const auto it = std::lower_bound(order.begin(), order.end(), k, [&](int a, const Key &b) {
    return key(interfaces[a].tag1, interfaces[a].tag2) < b;
  });
  if (it == order.end() || interfaces[*it].tag1 != t1 || interfaces[*it].tag2 != t2) return -1;
  return *it;
}

/* ----------------------------------------------------------------------
   body-frame geometry from the reference state (the current one, at the
   first init): b = R^T (p - x) for each cell of each interface, normal in
   cell 1's frame. The owner of each cell fills its part; a sum over ranks
   gives the whole table to every rank. Checks that the file fits the cells:
   each point inside the cell's bounding sphere and on the cell's side of the
   face (n . (p - x1) > 0 > n . (p - x2)).
------------------------------------------------------------------------- */

void BcmInterfaceTable::take_reference(int iquat)
{
  const int nlocal = atom->nlocal;
  const tagint *tag = atom->tag;
  double **x = atom->x;
  double **quat = atom->darray[iquat];
  const double *radius = atom->radius;

  std::unordered_map<tagint, int> owned;
  owned.reserve(nlocal);
  for (int i = 0; i < nlocal; i++) owned[tag[i]] = i;

  // this rank's part into body, zeros elsewhere, then summed over ranks in place
  std::fill(body.begin(), body.end(), 0.0);
  const int nif = (int) interfaces.size();
  std::vector<int> found(2 * nif, 0);
  enum { BAD_QUAT, BAD_RADIUS, BAD_SIDE, NBAD };
  int bad[NBAD] = {nif, nif, nif};    // first offending interface per kind
  std::vector<double> centres(6 * (size_t) nif, 0.0);

  long soff = 0;
  for (int ii = 0; ii < nif; ii++) {
    const Interface &itf = interfaces[ii];
    const double *n = &space[soff];
    soff += 3 + 3 * itf.npts;
    const double *pts = n + 3;
    double *out = &body[itf.boff];
    for (int side = 0; side < 2; side++) {
      const auto it = owned.find(side ? itf.tag2 : itf.tag1);
      if (it == owned.end()) continue;
      const int i = it->second;
      found[2 * ii + side] = 1;
      for (int c = 0; c < 3; c++) centres[6 * ii + 3 * side + c] = x[i][c];
      if (!(BcmRigid::quat_norm2(quat[i]) > 0.0)) {
        bad[BAD_QUAT] = std::min(bad[BAD_QUAT], ii);
        continue;
      }
      double R[3][3];
      BcmRigid::rotation(quat[i], R);
      if (side == 0) BcmRigid::rotate_back(R, n, out);
      double *b = out + 3 + 3 * itf.npts * side;
      for (int k = 0; k < itf.npts; k++) {
        double d[3];
        for (int c = 0; c < 3; c++) d[c] = pts[3 * k + c] - x[i][c];
        // the points are written near cell 1's centre; in a periodic box either cell may
        // sit (wrapped) across the box from them: the nearest image is the cell's own point
        // (a no-op in a non-periodic box)
        domain->minimum_image(FLERR, d);
        const double dist = std::sqrt(dot(d, d));
        if (dist > 1.01 * radius[i]) bad[BAD_RADIUS] = std::min(bad[BAD_RADIUS], ii);
        const double side_sign = dot(d, n);
        if (side == 0 ? side_sign <= 0.0 : side_sign >= 0.0)
          bad[BAD_SIDE] = std::min(bad[BAD_SIDE], ii);
        BcmRigid::rotate_back(R, d, b + 3 * k);
      }
    }
  }

  int first[NBAD];
  MPI_Allreduce(bad, first, NBAD, MPI_INT, MPI_MIN, world);
  std::vector<int> nfound(2 * nif);
  MPI_Allreduce(found.data(), nfound.data(), 2 * nif, MPI_INT, MPI_SUM, world);
  for (int ii = 0; ii < nif; ii++)
    for (int side = 0; side < 2; side++)
      if (nfound[2 * ii + side] != 1)
        error->all(FLERR, "bond_style bcm/griffith: cell {} of interface {}-{} is {}",
                   side ? interfaces[ii].tag2 : interfaces[ii].tag1, interfaces[ii].tag1,
                   interfaces[ii].tag2, nfound[2 * ii + side] ? "owned twice" : "not an atom");
  auto name = [&](int ii) {
    return fmt::format("{}-{}", interfaces[ii].tag1, interfaces[ii].tag2);
  };
  if (first[BAD_QUAT] < nif)
    error->all(FLERR, "bond_style bcm/griffith: a cell of interface {} has no orientation "
               "(zero d2_{})", name(first[BAD_QUAT]), BcmRigid::QUAT);
  if (first[BAD_RADIUS] < nif)
    error->all(FLERR, "bond_style bcm/griffith: a point of interface {} lies outside the "
               "bounding radius of its cell: the geometry file does not match the cells",
               name(first[BAD_RADIUS]));
  if (first[BAD_SIDE] < nif)
    error->all(FLERR, "bond_style bcm/griffith: interface {}: the normal must point from cell "
               "tag1 to cell tag2, with the face between the two cells' centres",
               name(first[BAD_SIDE]));

  MPI_Allreduce(MPI_IN_PLACE, body.data(), (int) body.size(), MPI_DOUBLE, MPI_SUM, world);
  std::vector<double> both(centres.size());
  MPI_Allreduce(centres.data(), both.data(), (int) both.size(), MPI_DOUBLE, MPI_SUM, world);
  span = 0.0;
  for (int ii = 0; ii < nif; ii++) {
    double d[3];
    for (int c = 0; c < 3; c++) d[c] = both[6 * ii + 3 + c] - both[6 * ii + c];
    domain->minimum_image(FLERR, d);    // the bonded images are the nearest ones
    span = std::max(span, std::sqrt(dot(d, d)));
  }
  reference_taken = 1;
  // the space frame has served: the body frames are the geometry from now on (restart files
  // keep them)
  std::vector<double>().swap(space);
}

/* ----------------------------------------------------------------------
   the whole table, reference included (after the style's own settings,
   which the style writes first: the layout of the restart file is theirs
   then this)
------------------------------------------------------------------------- */

void BcmInterfaceTable::write_restart(FILE *fp) const
{
  const int nif = (int) interfaces.size();
  const long nspace = (long) space.size(), nbody = (long) body.size();
  fwrite(&reference_taken, sizeof(int), 1, fp);
  fwrite(&span, sizeof(double), 1, fp);
  fwrite(&nif, sizeof(int), 1, fp);
  fwrite(&nspace, sizeof(long), 1, fp);
  fwrite(&nbody, sizeof(long), 1, fp);
  for (const Interface &itf : interfaces) {
    fwrite(&itf.tag1, sizeof(tagint), 1, fp);
    fwrite(&itf.tag2, sizeof(tagint), 1, fp);
    fwrite(&itf.npts, sizeof(int), 1, fp);
    fwrite(&itf.area, sizeof(double), 1, fp);
  }
  fwrite(space.data(), sizeof(double), nspace, fp);
  fwrite(body.data(), sizeof(double), nbody, fp);
  const int nname = (int) geometry_file.size();
  fwrite(&nname, sizeof(int), 1, fp);
  fwrite(geometry_file.data(), sizeof(char), nname, fp);
}

/* ---------------------------------------------------------------------- */

void BcmInterfaceTable::read_restart(FILE *fp)
{
  int nif = 0, nname = 0;
  long nspace = 0, nbody = 0;
  if (comm->me == 0) {
    utils::sfread(FLERR, &reference_taken, sizeof(int), 1, fp, nullptr, error);
    utils::sfread(FLERR, &span, sizeof(double), 1, fp, nullptr, error);
    utils::sfread(FLERR, &nif, sizeof(int), 1, fp, nullptr, error);
    utils::sfread(FLERR, &nspace, sizeof(long), 1, fp, nullptr, error);
    utils::sfread(FLERR, &nbody, sizeof(long), 1, fp, nullptr, error);
    interfaces.resize(nif);
    for (Interface &itf : interfaces) {
      utils::sfread(FLERR, &itf.tag1, sizeof(tagint), 1, fp, nullptr, error);
      utils::sfread(FLERR, &itf.tag2, sizeof(tagint), 1, fp, nullptr, error);
      utils::sfread(FLERR, &itf.npts, sizeof(int), 1, fp, nullptr, error);
      utils::sfread(FLERR, &itf.area, sizeof(double), 1, fp, nullptr, error);
    }
    space.resize(nspace);
    body.resize(nbody);
    utils::sfread(FLERR, space.data(), sizeof(double), nspace, fp, nullptr, error);
    utils::sfread(FLERR, body.data(), sizeof(double), nbody, fp, nullptr, error);
    utils::sfread(FLERR, &nname, sizeof(int), 1, fp, nullptr, error);
    geometry_file.resize(nname);
    if (nname) utils::sfread(FLERR, &geometry_file[0], sizeof(char), nname, fp, nullptr, error);
  }
  MPI_Bcast(&reference_taken, 1, MPI_INT, 0, world);
  MPI_Bcast(&span, 1, MPI_DOUBLE, 0, world);
  MPI_Bcast(&nbody, 1, MPI_LONG, 0, world);
  MPI_Bcast(&nname, 1, MPI_INT, 0, world);
  geometry_file.resize(nname);
  if (nname) MPI_Bcast(&geometry_file[0], nname, MPI_CHAR, 0, world);
  std::vector<double> saved_body = body;
  saved_body.resize(nbody);
  MPI_Bcast(saved_body.data(), (int) nbody, MPI_DOUBLE, 0, world);
  broadcast();    // interfaces and space; resets the offsets and the look-up
  body = saved_body;
  if (reference_taken) std::vector<double>().swap(space);    // older files kept it
}

/* ---------------------------------------------------------------------- */

double BcmInterfaceTable::memory_usage() const
{
  return (double) (space.capacity() + body.capacity()) * sizeof(double) +
      (double) interfaces.capacity() * sizeof(Interface) + (double) order.capacity() * sizeof(int);
}
