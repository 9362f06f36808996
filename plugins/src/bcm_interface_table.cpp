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

using namespace LAMMPS_NS;
using BcmRigid::dot;

namespace {

// restart files begin with this since the table keeps the cells' reference state; files before
// begin with reference_taken, 0 or 1 (their layout: read_restart())
constexpr int RESTART_FORMAT = 2;

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
  order.clear();
  clear_reference();
  geometry_file = file;

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
      itf.off = 0;
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
  long off = 0;
  maxpts = 0;
  area_mean = 0.0;
  for (const Interface &itf : interfaces) area_mean += itf.area;
  if (!interfaces.empty()) area_mean /= (double) interfaces.size();
  for (Interface &itf : interfaces) {
    itf.off = (uint32_t) off;
    off += 3 + 3 * itf.npts;
    if (off > (long) UINT32_MAX)
      error->all(FLERR, "bond_style bcm/griffith: the interface table holds more than {} "
                 "values of geometry", (long) UINT32_MAX);
    maxpts = std::max(maxpts, itf.npts);
  }
  // the body frames of restart files before the cells' reference came without the space frame
  if (off != (long) space.size() && !(reference == BODIES && space.empty()))
    error->all(FLERR, "bond_style bcm/griffith: inconsistent interface table");
  if (reference == BODIES && (long) bodies.size() != 2 * off - 3L * size())
    error->all(FLERR, "bond_style bcm/griffith: inconsistent body frames in the restart file");
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

/* ---------------------------------------------------------------------- */

void BcmInterfaceTable::clear_reference()
{
  reference = NONE;
  std::vector<double>().swap(cells);
  std::vector<tagint>().swap(cell_tags);
  std::vector<double>().swap(bodies);
  box = Box();
  span = 0.0;
}

int BcmInterfaceTable::cell_of(tagint t) const
{
  const long ncell = (long) (cells.size() / NREF);
  if (cell_tags.empty()) return (t >= 1 && t <= ncell) ? (int) (t - 1) : -1;
  const auto it = std::lower_bound(cell_tags.begin(), cell_tags.end(), t);
  return (it == cell_tags.end() || *it != t) ? -1 : (int) (it - cell_tags.begin());
}

/* ----------------------------------------------------------------------
   d to its minimum image in the box of the reference state: the operations
   of Domain::minimum_image() of LAMMPS 22 Jul 2025 (src/domain.cpp; read off
   the installed library) in their order, so that the body frames are those
   it gave. Orthogonal: per periodic dimension, a length added or taken while
   |d| exceeds half of it. Triclinic: z first (carrying yz, xz), then y
   (carrying xy), then x. More than 16 box lengths is an error, as there.
------------------------------------------------------------------------- */

void BcmInterfaceTable::minimum_image(double *d) const
{
  constexpr double MAXIMGCOUNT = 16.0;
  auto check = [&](int k) {
    if (std::fabs(d[k]) > MAXIMGCOUNT * box.prd[k])
      error->one(FLERR, "bond_style bcm/griffith: an interface point or bonded cell lies more "
                 "than {} box lengths from its cell", MAXIMGCOUNT);
  };
  if (!box.triclinic) {
    for (int k = 0; k < 3; k++) {
      if (!box.periodic[k]) continue;
      check(k);
      while (std::fabs(d[k]) > box.prd_half[k]) {
        if (d[k] < 0.0)
          d[k] += box.prd[k];
        else
          d[k] -= box.prd[k];
      }
    }
    return;
  }
  if (box.periodic[2]) {
    check(2);
    while (std::fabs(d[2]) > box.prd_half[2]) {
      if (d[2] < 0.0) {
        d[2] += box.prd[2];
        d[1] += box.yz;
        d[0] += box.xz;
      } else {
        d[2] -= box.prd[2];
        d[1] -= box.yz;
        d[0] -= box.xz;
      }
    }
  }
  if (box.periodic[1]) {
    check(1);
    while (std::fabs(d[1]) > box.prd_half[1]) {
      if (d[1] < 0.0) {
        d[1] += box.prd[1];
        d[0] += box.xy;
      } else {
        d[1] -= box.prd[1];
        d[0] -= box.xy;
      }
    }
  }
  if (box.periodic[0]) {
    check(0);
    while (std::fabs(d[0]) > box.prd_half[0]) {
      if (d[0] < 0.0)
        d[0] += box.prd[0];
      else
        d[0] -= box.prd[0];
    }
  }
}

/* ----------------------------------------------------------------------
   the body frames of interface i from the reference state of its cells:
   b = R^T (p - x) for each cell, p - x by minimum image (the points are
   written near cell 1's centre; in a periodic box either cell may sit,
   wrapped, across the box from them: the nearest image is the cell's own
   point; a no-op in a non-periodic box), the normal in cell 1's frame.
   visit(side, k, d) sees each space-frame difference d = p_k - x before it
   is rotated (take_reference()'s checks). The one computation of the body
   frames: every call gives the same bits.
------------------------------------------------------------------------- */

template <class Visit> void BcmInterfaceTable::frames(int i, double *out, Visit &&visit) const
{
  const Interface &itf = interfaces[i];
  const double *n = &space[itf.off];
  const double *pts = n + 3;
  for (int side = 0; side < 2; side++) {
    const double *ref = &cells[(size_t) NREF * cell_of(side ? itf.tag2 : itf.tag1)];
    double R[3][3];
    BcmRigid::rotation(ref + 3, R);
    if (side == 0) BcmRigid::rotate_back(R, n, out);
    double *b = out + 3 + 3 * itf.npts * side;
    for (int k = 0; k < itf.npts; k++) {
      double d[3];
      for (int c = 0; c < 3; c++) d[c] = pts[3 * k + c] - ref[c];
      minimum_image(d);
      visit(side, k, (const double *) d);
      BcmRigid::rotate_back(R, d, b + 3 * k);
    }
  }
}

void BcmInterfaceTable::body_of(int i, double *out) const
{
  const Interface &itf = interfaces[i];
  if (reference == BODIES) {
    // in order, 3 + 6 npts per interface: 2 off - 3 i values before interface i
    const double *g = &bodies[2L * itf.off - 3L * i];
    std::copy(g, g + 3 + 6 * itf.npts, out);
  } else if (reference == CELLS) {
    frames(i, out, [](int, int, const double *) {});
  } else {
    error->one(FLERR, "bond_style bcm/griffith: body frames asked for before the reference");
  }
}

/* ----------------------------------------------------------------------
   the reference state (the current one, at the first init): the position
   and orientation of every cell of the table, gathered from their owners as
   they are (every rank then holds the same values), and the box. Checks
   that the file fits the cells: each cell owned once and with an
   orientation, each point inside the cell's bounding sphere and on the
   cell's side of the face (n . (p - x1) > 0 > n . (p - x2)).
------------------------------------------------------------------------- */

void BcmInterfaceTable::take_reference(double **quat)
{
  const int nlocal = atom->nlocal;
  const tagint *tag = atom->tag;
  double **x = atom->x;
  const double *radius = atom->radius;
  const int nif = size();
  clear_reference();

  // the cells of the table, in tag order
  std::vector<tagint> tags;
  tags.reserve(2 * (size_t) nif);
  for (const Interface &itf : interfaces) {
    tags.push_back(itf.tag1);
    tags.push_back(itf.tag2);
  }
  std::sort(tags.begin(), tags.end());
  tags.erase(std::unique(tags.begin(), tags.end()), tags.end());
  const long ncell = (long) tags.size();

  // the owned ones: tag; x, quaternion and radius (NREF + 1 values)
  constexpr int NV = NREF + 1;
  std::vector<tagint> mine;
  std::vector<double> mine_v;
  for (int i = 0; i < nlocal; i++) {
    if (!std::binary_search(tags.begin(), tags.end(), tag[i])) continue;
    mine.push_back(tag[i]);
    mine_v.insert(mine_v.end(), x[i], x[i] + 3);
    mine_v.insert(mine_v.end(), quat[i], quat[i] + 4);
    mine_v.push_back(radius[i]);
  }
  const int nprocs = comm->nprocs;
  int nmine = (int) mine.size();
  std::vector<int> count(nprocs), disp(nprocs), vcount(nprocs), vdisp(nprocs);
  MPI_Allgather(&nmine, 1, MPI_INT, count.data(), 1, MPI_INT, world);
  int total = 0;
  for (int r = 0; r < nprocs; r++) {
    disp[r] = total;
    vcount[r] = NV * count[r];
    vdisp[r] = NV * total;
    total += count[r];
  }
  std::vector<tagint> all(total);
  std::vector<double> all_v((size_t) NV * total);
  MPI_Allgatherv(mine.data(), nmine, MPI_LMP_TAGINT, all.data(), count.data(), disp.data(),
                 MPI_LMP_TAGINT, world);
  MPI_Allgatherv(mine_v.data(), NV * nmine, MPI_DOUBLE, all_v.data(), vcount.data(),
                 vdisp.data(), MPI_DOUBLE, world);

  // cells, cell_tags: in tag order; dense tags 1..N need no tag list
  if (!(ncell == 0 || tags.back() == (tagint) ncell)) cell_tags = tags;
  cells.assign((size_t) NREF * ncell, 0.0);
  std::vector<double> rad(ncell, 0.0);
  std::vector<int> owners(ncell, 0);
  for (int k = 0; k < total; k++) {
    const long c = std::lower_bound(tags.begin(), tags.end(), all[k]) - tags.begin();
    if (owners[c]++) continue;
    std::copy(&all_v[(size_t) NV * k], &all_v[(size_t) NV * k] + NREF, &cells[(size_t) NREF * c]);
    rad[c] = all_v[(size_t) NV * k + NREF];
  }
  std::vector<tagint>().swap(tags);
  reference = CELLS;

  box.triclinic = domain->triclinic;
  box.periodic[0] = domain->xperiodic;
  box.periodic[1] = domain->yperiodic;
  box.periodic[2] = domain->zperiodic;
  box.prd[0] = domain->xprd;
  box.prd[1] = domain->yprd;
  box.prd[2] = domain->zprd;
  box.prd_half[0] = domain->xprd_half;
  box.prd_half[1] = domain->yprd_half;
  box.prd_half[2] = domain->zprd_half;
  box.xy = domain->xy;
  box.xz = domain->xz;
  box.yz = domain->yz;

  auto name = [&](int ii) {
    return fmt::format("{}-{}", interfaces[ii].tag1, interfaces[ii].tag2);
  };
  for (int ii = 0; ii < nif; ii++)
    for (int side = 0; side < 2; side++) {
      const tagint t = side ? interfaces[ii].tag2 : interfaces[ii].tag1;
      const int n = owners[cell_of(t)];
      if (n != 1)
        error->all(FLERR, "bond_style bcm/griffith: cell {} of interface {} is {}", t, name(ii),
                   n ? "owned twice" : "not an atom");
    }
  for (int ii = 0; ii < nif; ii++)
    for (tagint t : {interfaces[ii].tag1, interfaces[ii].tag2})
      if (!(BcmRigid::quat_norm2(&cells[(size_t) NREF * cell_of(t) + 3]) > 0.0))
        error->all(FLERR, "bond_style bcm/griffith: a cell of interface {} has no orientation "
                   "(a zero quaternion)", name(ii));
  int bad_radius = nif, bad_side = nif;    // first offending interface of each kind
  std::vector<double> body(BODY_MAX);
  for (int ii = 0; ii < nif && (bad_radius == nif || bad_side == nif); ii++) {
    const Interface &itf = interfaces[ii];
    const double *n = &space[itf.off];
    const double r[2] = {rad[cell_of(itf.tag1)], rad[cell_of(itf.tag2)]};
    frames(ii, body.data(), [&](int side, int, const double *d) {
      if (std::sqrt(dot(d, d)) > 1.01 * r[side]) bad_radius = std::min(bad_radius, ii);
      const double side_sign = dot(d, n);
      if (side == 0 ? side_sign <= 0.0 : side_sign >= 0.0) bad_side = std::min(bad_side, ii);
    });
  }
  if (bad_radius < nif)
    error->all(FLERR, "bond_style bcm/griffith: a point of interface {} lies outside the "
               "bounding radius of its cell: the geometry file does not match the cells",
               name(bad_radius));
  if (bad_side < nif)
    error->all(FLERR, "bond_style bcm/griffith: interface {}: the normal must point from cell "
               "tag1 to cell tag2, with the face between the two cells' centres", name(bad_side));

  span = 0.0;
  for (const Interface &itf : interfaces) {
    const double *x1 = &cells[(size_t) NREF * cell_of(itf.tag1)];
    const double *x2 = &cells[(size_t) NREF * cell_of(itf.tag2)];
    double d[3];
    for (int c = 0; c < 3; c++) d[c] = x2[c] - x1[c];
    minimum_image(d);    // the bonded images are the nearest ones
    span = std::max(span, std::sqrt(dot(d, d)));
  }
}

/* ----------------------------------------------------------------------
   the whole table, reference included (after the style's own settings,
   which the style writes first: the layout of the restart file is theirs
   then this): RESTART_FORMAT, reference, span, the interfaces (tags,
   npts, area), the space frame, the cells (count, tag count, tags, NREF
   values each), the box, the body frames (BODIES only), the file name
------------------------------------------------------------------------- */

void BcmInterfaceTable::write_restart(FILE *fp) const
{
  const int nif = (int) interfaces.size();
  fwrite(&RESTART_FORMAT, sizeof(int), 1, fp);
  fwrite(&reference, sizeof(int), 1, fp);
  fwrite(&span, sizeof(double), 1, fp);
  fwrite(&nif, sizeof(int), 1, fp);
  for (const Interface &itf : interfaces) {
    fwrite(&itf.tag1, sizeof(tagint), 1, fp);
    fwrite(&itf.tag2, sizeof(tagint), 1, fp);
    fwrite(&itf.npts, sizeof(int), 1, fp);
    fwrite(&itf.area, sizeof(double), 1, fp);
  }
  const long nspace = (long) space.size(), ncells = (long) cells.size(),
             ntags = (long) cell_tags.size(), nbodies = (long) bodies.size();
  fwrite(&nspace, sizeof(long), 1, fp);
  fwrite(space.data(), sizeof(double), nspace, fp);
  fwrite(&ncells, sizeof(long), 1, fp);
  fwrite(cells.data(), sizeof(double), ncells, fp);
  fwrite(&ntags, sizeof(long), 1, fp);
  fwrite(cell_tags.data(), sizeof(tagint), ntags, fp);
  fwrite(&box.triclinic, sizeof(int), 1, fp);
  fwrite(box.periodic, sizeof(int), 3, fp);
  fwrite(box.prd, sizeof(double), 3, fp);
  fwrite(box.prd_half, sizeof(double), 3, fp);
  for (const double *t : {&box.xy, &box.xz, &box.yz}) fwrite(t, sizeof(double), 1, fp);
  fwrite(&nbodies, sizeof(long), 1, fp);
  fwrite(bodies.data(), sizeof(double), nbodies, fp);
  const int nname = (int) geometry_file.size();
  fwrite(&nname, sizeof(int), 1, fp);
  fwrite(geometry_file.data(), sizeof(char), nname, fp);
}

/* ----------------------------------------------------------------------
   both layouts: RESTART_FORMAT's (write_restart()), and the one before,
   whose table held the body frames themselves: reference_taken (0, 1),
   span, nif, nspace, nbody, the interfaces, the space frame (nspace: all
   of it before the reference was taken, else none or, in older files, all
   of it), the body frames (nbody, zeros before the reference), the file
   name. Their body frames are kept as read (BODIES) and returned by
   body_of(): the run goes on with the geometry it had.
------------------------------------------------------------------------- */

void BcmInterfaceTable::read_restart(FILE *fp)
{
  auto get = [&](void *buf, size_t size, size_t n) {
    if (n) utils::sfread(FLERR, buf, size, n, fp, nullptr, error);
  };
  auto get_vector = [&](auto &v) {
    long n = 0;
    get(&n, sizeof(long), 1);
    v.resize(n);
    get(v.data(), sizeof(v[0]), n);
  };
  clear_reference();
  int nname = 0;
  if (comm->me == 0) {
    int first = 0, nif = 0;
    get(&first, sizeof(int), 1);
    const bool legacy = first != RESTART_FORMAT;
    if (legacy && first != 0 && first != 1)
      error->one(FLERR, "bond_style bcm/griffith: unknown layout of the interface table in the "
                 "restart file");
    long nspace = 0, nbody = 0;
    if (legacy) {
      reference = first ? BODIES : NONE;
      get(&span, sizeof(double), 1);
      get(&nif, sizeof(int), 1);
      get(&nspace, sizeof(long), 1);
      get(&nbody, sizeof(long), 1);
    } else {
      get(&reference, sizeof(int), 1);
      get(&span, sizeof(double), 1);
      get(&nif, sizeof(int), 1);
    }
    interfaces.resize(nif);
    for (Interface &itf : interfaces) {
      get(&itf.tag1, sizeof(tagint), 1);
      get(&itf.tag2, sizeof(tagint), 1);
      get(&itf.npts, sizeof(int), 1);
      get(&itf.area, sizeof(double), 1);
    }
    if (legacy) {
      space.resize(nspace);
      get(space.data(), sizeof(double), nspace);
      bodies.resize(nbody);
      get(bodies.data(), sizeof(double), nbody);
      if (reference == NONE) std::vector<double>().swap(bodies);    // zeros
      if (reference == BODIES) std::vector<double>().swap(space);    // older files kept it
    } else {
      get_vector(space);
      get_vector(cells);
      get_vector(cell_tags);
      get(&box.triclinic, sizeof(int), 1);
      get(box.periodic, sizeof(int), 3);
      get(box.prd, sizeof(double), 3);
      get(box.prd_half, sizeof(double), 3);
      for (double *t : {&box.xy, &box.xz, &box.yz}) get(t, sizeof(double), 1);
      get_vector(bodies);
    }
    get(&nname, sizeof(int), 1);
    geometry_file.resize(nname);
    get(&geometry_file[0], sizeof(char), nname);
  }
  auto bcast = [&](auto &v, MPI_Datatype type) {
    long n = (long) v.size();
    MPI_Bcast(&n, 1, MPI_LONG, 0, world);
    v.resize(n);
    MPI_Bcast(v.data(), (int) n, type, 0, world);
  };
  MPI_Bcast(&reference, 1, MPI_INT, 0, world);
  MPI_Bcast(&span, 1, MPI_DOUBLE, 0, world);
  MPI_Bcast(&nname, 1, MPI_INT, 0, world);
  geometry_file.resize(nname);
  if (nname) MPI_Bcast(&geometry_file[0], nname, MPI_CHAR, 0, world);
  bcast(cells, MPI_DOUBLE);
  bcast(cell_tags, MPI_LMP_TAGINT);
  bcast(bodies, MPI_DOUBLE);
  MPI_Bcast(&box.triclinic, 1, MPI_INT, 0, world);
  MPI_Bcast(box.periodic, 3, MPI_INT, 0, world);
  MPI_Bcast(box.prd, 3, MPI_DOUBLE, 0, world);
  MPI_Bcast(box.prd_half, 3, MPI_DOUBLE, 0, world);
  for (double *t : {&box.xy, &box.xz, &box.yz}) MPI_Bcast(t, 1, MPI_DOUBLE, 0, world);
  broadcast();    // interfaces and space; the offsets and the look-up
}

/* ---------------------------------------------------------------------- */

double BcmInterfaceTable::memory_usage() const
{
  return (double) (space.capacity() + cells.capacity() + bodies.capacity()) * sizeof(double) +
      (double) cell_tags.capacity() * sizeof(tagint) +
      (double) interfaces.capacity() * sizeof(Interface) + (double) order.capacity() * sizeof(int);
}
