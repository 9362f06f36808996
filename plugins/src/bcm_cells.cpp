/* Cell geometry table and contact detection between rounded convex cores (see bcm_cells.h).

   Detection (two cores A, B, reach dcut = 2 r_m; tolerances relative to the cells' size):
   1. Early exit: a face plane of A (or B) with every vertex of the other core at least dcut
      beyond it separates the rounded cells.
   2. Heights h(v, f) of every vertex over every face plane of the other core; hmax(v) is the
      largest. A vertex with hmax >= dcut is farther than dcut from the other core (the
      distance to a convex set is at least the height over any of its face planes).
   3. Candidate feature pairs, each giving one point (p, n, h):
      - vertex-face: f maximises h(v, .) (the face nearest v, also for a vertex that went
        inside the core) and v projects inside f (boundary included); n = normal of f;
      - edge-edge: non-parallel edges whose closest points are interior to both, facing each
        other (n, their common perpendicular, points out of B's edge and into A's); on two
        parallel faces in contact these are the crossings of the faces' edges, which with the
        vertex-face points are the corners of the overlap polygon. A negative h claims that the
        edges cross inside each other: it is kept only when each closest point lies inside the
        other core (the common perpendicular lies in both), since two edges that pass each
        other |h| apart can face each other by the face-normal test with n of the wrong sign;
      - vertex-edge: v outside the other core, closest point interior to the edge, and the
        direction n = (v - q)/|v - q| inside the edge's normal cone (between its two faces'
        normals) and inside the vertex's normal cone (no edge of v heads towards the other
        core, within 1e-3: near-parallel edges in line contact are carried by these points);
      - vertex-vertex: n inside both vertices' normal cones (within 1e-3).
      The regions of these rules overlap a little on their boundaries (a vertex may project up
      to 1e-3 of the cell's size outside a face, the vertex cones have a 1e-3 slack), so that
      degenerate placements (coincident corners, edges parallel within 1e-3) lose no point;
      a point closer than 2e-3 of the cell's size to an earlier one is the same point and is
      dropped (rules in the order above).
   A pair is in contact at a point when -pen < h < dcut (pen = a quarter of the smaller
   bounding radius bounds the interpenetration of the cores taken as contact). */

#include "bcm_cells.h"

#include "atom.h"
#include "bcm_rigid.h"
#include "comm.h"
#include "error.h"
#include "fix.h"
#include "lammps.h"
#include "modify.h"
#include "utils.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cctype>
#include <cstdio>
#include <map>
#include <mpi.h>
#include <string_view>
#include <sys/mman.h>
#include <tuple>

using namespace LAMMPS_NS;
using BcmRigid::cross;
using BcmRigid::dot;

namespace {

constexpr int MAX_FEATURES = 1 << 20;    // vertices, faces, edges per cell (key fields)
constexpr double PARALLEL_SIN = 1.0e-3;  // edges closer than this to parallel: no edge-edge
constexpr double VERTEX_SLACK = 1.0e-3;  // slack of the vertex normal-cone tests
constexpr double CONE_TOL = 1.0e-9;      // slack of the edge normal-cone tests
constexpr double PARAM_TOL = 1.0e-9;     // interior of an edge: parameter in (tol, 1 - tol)
constexpr double INSIDE_REL = 1.0e-3;    // a vertex may project this far (x the smaller
                                         // bounding radius) outside a face
constexpr double MERGE_REL = 2.0e-3;     // points closer than this (x the same) are one

// One table per (instance, file content); a style holds a shared_ptr, this a weak one.
using CacheKey = std::tuple<LAMMPS *, std::size_t, std::size_t>;
std::map<CacheKey, std::weak_ptr<const BcmCells>> &table_cache()
{
  static std::map<CacheKey, std::weak_ptr<const BcmCells>> cache;
  return cache;
}

// whitespace tokens of the text, read in place one at a time, with their line numbers; '#'
// starts a comment
struct Tokens {
  struct Tok {
    const char *p;
    int n, line;
    std::string str() const { return std::string(p, n); }
  };
  const char *s, *end;
  int line = 1;
  Tokens(const char *text, std::size_t n) : s(text), end(text + n) {}
  // past blanks and comments: true while a token follows
  bool skip()
  {
    while (s < end) {
      if (*s == '#') {
        while (s < end && *s != '\n') s++;
      } else if (*s == '\n') {
        line++;
        s++;
      } else if (std::isspace(static_cast<unsigned char>(*s))) {
        s++;
      } else {
        return true;
      }
    }
    return false;
  }
  bool done() { return !skip(); }
  int next_line()
  {
    skip();
    return line;
  }
  Tok next()
  {
    skip();
    const char *b = s;
    while (s < end && *s != '#' && !std::isspace(static_cast<unsigned char>(*s))) s++;
    return Tok{b, static_cast<int>(s - b), line};
  }
};

// a file's text in an anonymous mapping of its own: given back to the system whole when
// freed (a heap block of this size may stay in the process after free)
class MappedText {
 public:
  explicit MappedText(std::size_t n) : n_(n)
  {
    if (n_) {
      void *p = mmap(nullptr, n_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
      p_ = p == MAP_FAILED ? nullptr : static_cast<char *>(p);
    }
  }
  ~MappedText()
  {
    if (p_) munmap(p_, n_);
  }
  MappedText(const MappedText &) = delete;
  MappedText &operator=(const MappedText &) = delete;
  char *data() { return p_; }
  const char *data() const { return p_; }
  std::size_t size() const { return n_; }
  bool ok() const { return p_ || !n_; }

 private:
  char *p_ = nullptr;
  std::size_t n_;
};

inline void sub3(const double *a, const double *b, double *c)
{
  c[0] = a[0] - b[0];
  c[1] = a[1] - b[1];
  c[2] = a[2] - b[2];
}

inline double len3(const double *a)
{
  return std::sqrt(dot(a, a));
}

}    // namespace

/* ---------------------------------------------------------------------- */

std::shared_ptr<const BcmCells> BcmCells::load(LAMMPS *lmp, const std::string &file)
{
  // rank 0 reads the whole file, every rank gets its text (in a mapping given back when the
  // table is built: the text is as large as the table)
  long long nbytes = -1;
  FILE *fp = nullptr;
  if (lmp->comm->me == 0) {
    fp = fopen(file.c_str(), "rb");
    if (fp && fseek(fp, 0, SEEK_END) == 0) nbytes = ftell(fp);
    if (fp && nbytes >= 0) rewind(fp);
  }
  MPI_Bcast(&nbytes, 1, MPI_LONG_LONG, 0, lmp->world);
  if (nbytes < 0) {
    if (fp) fclose(fp);
    lmp->error->all(FLERR, "Cannot open BCM cells file {}", file);
  }
  MappedText text(static_cast<std::size_t>(nbytes));
  int ok = text.ok();
  if (fp) {
    if (ok && nbytes > 0 && fread(text.data(), 1, nbytes, fp) != static_cast<std::size_t>(nbytes))
      ok = 0;
    fclose(fp);
  }
  int all_ok = 0;
  MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, lmp->world);
  if (!all_ok) lmp->error->all(FLERR, "Cannot read BCM cells file {}", file);
  const long long chunk = 1LL << 30;
  for (long long off = 0; off < nbytes; off += chunk) {
    const int n = static_cast<int>(std::min(chunk, nbytes - off));
    MPI_Bcast(text.data() + off, n, MPI_CHAR, 0, lmp->world);
  }

  const std::string_view view(text.data(), text.size());
  const CacheKey key{lmp, std::hash<std::string_view>()(view), view.size()};
  auto &cache = table_cache();
  for (auto it = cache.begin(); it != cache.end();)    // forget tables nobody holds
    it = it->second.expired() ? cache.erase(it) : std::next(it);
  auto found = cache.find(key);
  if (found != cache.end()) {
    if (auto shared = found->second.lock()) return shared;
  }
  auto table = std::make_shared<BcmCells>();
  table->source = file;
  table->parse(lmp, text.data(), text.size());
  cache[key] = table;
  return table;
}

/* ----------------------------------------------------------------------
   bcm/cells NCELLS, then per cell: TAG NV NF, NV lines x y z, NF lines K i0 .. i(K-1)
------------------------------------------------------------------------- */

void BcmCells::parse(LAMMPS *lmp, const char *text, std::size_t size)
{
  Tokens tk(text, size);
  Error *error = lmp->error;
  auto next = [&](const char *what) -> Tokens::Tok {
    if (tk.done()) error->all(FLERR, "BCM cells file {}: ends early, expected {}", source, what);
    return tk.next();
  };
  auto next_int = [&](const char *what) -> long long {
    const Tokens::Tok t = next(what);
    char *end = nullptr;
    const long long v = std::strtoll(t.p, &end, 10);
    if (end != t.p + t.n)
      error->all(FLERR, "BCM cells file {} line {}: expected {} (an integer), got '{}'", source,
                 t.line, what, t.str());
    return v;
  };
  auto next_double = [&](const char *what) -> double {
    const Tokens::Tok t = next(what);
    char *end = nullptr;
    const double v = std::strtod(t.p, &end);
    if (end != t.p + t.n || !std::isfinite(v))
      error->all(FLERR, "BCM cells file {} line {}: expected {} (a number), got '{}'", source,
                 t.line, what, t.str());
    return v;
  };

  const Tokens::Tok magic = next("the header 'bcm/cells NCELLS'");
  if (magic.str() != "bcm/cells")
    error->all(FLERR, "BCM cells file {} line {}: must start with 'bcm/cells NCELLS', got '{}'",
               source, magic.line, magic.str());
  const long long ncells = next_int("the number of cells");
  if (ncells < 1) error->all(FLERR, "BCM cells file {}: the number of cells must be >= 1", source);
  cells.reserve(ncells);
  std::vector<std::pair<tagint, int>> tag_line;    // per cell: its tag and header line
  tag_line.reserve(ncells);

  for (long long ic = 0; ic < ncells; ic++) {
    const int line = tk.done() ? -1 : tk.next_line();
    const long long tag = next_int("a cell header 'TAG NV NF'");
    const long long nv = next_int("the number of vertices");
    const long long nf = next_int("the number of faces");
    if (tag < 1 || nv < 4 || nf < 4 || nv >= MAX_INDEX || nf >= MAX_INDEX)
      error->all(FLERR,
                 "BCM cells file {} line {}: bad cell header '{} {} {}' (tag >= 1, "
                 "4 <= NV, NF < {})",
                 source, line, tag, nv, nf, MAX_INDEX);
    tag_line.emplace_back(static_cast<tagint>(tag), line);

    Cell c{};
    c.nv = static_cast<int>(nv);
    c.nf = static_cast<int>(nf);
    c.v0 = static_cast<int>(vert.size() / 3);
    c.f0 = static_cast<int>(plane.size() / 4);
    c.e0 = static_cast<int>(edge.size() / 4);
    for (long long k = 0; k < 3 * nv; k++) vert.push_back(next_double("a vertex coordinate"));
    for (long long f = 0; f < nf; f++) {
      const int fline = tk.done() ? -1 : tk.next_line();
      const long long m = next_int("the number of vertices of a face");
      if (m < 3 || m > nv)
        error->all(FLERR, "BCM cells file {} line {}: cell {} face {} has {} vertices", source,
                   fline, tag, f, m);
      face_first.push_back(static_cast<int>(face_vert.size()));
      for (long long k = 0; k < m; k++) {
        const long long iv = next_int("a vertex index");
        if (iv < 0 || iv >= nv)
          error->all(FLERR,
                     "BCM cells file {} line {}: cell {} face {}: vertex index {} out of 0..{}",
                     source, fline, tag, f, iv, nv - 1);
        face_vert.push_back(static_cast<Index>(iv));
      }
      plane.insert(plane.end(), 4, 0.0);
    }
    finish_cell(lmp, static_cast<tagint>(tag), c);
    cells.push_back(c);
  }
  if (!tk.done())
    error->all(FLERR, "BCM cells file {} line {}: text after the last of {} cells", source,
               tk.next_line(), ncells);
  face_first.push_back(static_cast<int>(face_vert.size()));
  adj_first.push_back(static_cast<int>(adj.size()));
  std::vector<int> order(cells.size());
  for (int i = 0; i < (int) order.size(); i++) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return tag_line[a].first < tag_line[b].first; });
  sorted_tag.resize(order.size());
  for (size_t k = 0; k < order.size(); k++) {
    sorted_tag[k] = tag_line[order[k]].first;
    if (k > 0 && sorted_tag[k] == sorted_tag[k - 1])
      error->all(FLERR, "BCM cells file {} line {}: cell {} appears twice", source,
                 tag_line[order[k]].second, sorted_tag[k]);
  }
  index_of_sorted = std::move(order);
  // the table is kept for the run: no room left from the vectors' growth
  for (auto *v : {&vert, &plane}) v->shrink_to_fit();
  for (auto *v : {&face_first, &adj_first}) v->shrink_to_fit();
  for (auto *v : {&face_vert, &edge, &adj}) v->shrink_to_fit();
  cells.shrink_to_fit();
}

/* ----------------------------------------------------------------------
   face planes, edges and vertex adjacency of the cell just read, with the checks
   that the contact rules rely on: planar faces, a closed surface in which every
   edge joins exactly two faces traversing it in opposite directions, convexity
   (which also catches faces ordered clockwise seen from outside)
------------------------------------------------------------------------- */

void BcmCells::finish_cell(LAMMPS *lmp, tagint tag, Cell &c)
{
  Error *error = lmp->error;
  const double *V = &vert[3 * c.v0];
  double rb = 0.0;
  for (int k = 0; k < c.nv; k++) rb = std::max(rb, len3(V + 3 * k));
  if (!(rb > 0.0)) error->all(FLERR, "BCM cells file {}: cell {} has no extent", source, tag);
  c.rbound = rb;
  // planarity tolerance: the driver's erosion merges vertices closer than up to 1e-4 of the
  // cell's size when a face nearly vanishes (driver/bcm/tessellation.py erode), which leaves a
  // face off its plane by as much; far below the rounding radius r_m (~0.02 of the cell size)
  const double tol = 5.0e-4 * rb;

  auto face_range = [&](int f, int &b, int &e) {
    b = face_first[c.f0 + f];
    e = (c.f0 + f + 1 < static_cast<int>(face_first.size())) ? face_first[c.f0 + f + 1]
                                                             : static_cast<int>(face_vert.size());
  };

  std::map<std::pair<int, int>, int> directed;    // (a, b) -> face traversing a->b
  for (int f = 0; f < c.nf; f++) {
    int b, e;
    face_range(f, b, e);
    // Newell's normal: for a planar loop, twice the vector area
    double nrm[3] = {0.0, 0.0, 0.0};
    for (int k = b; k < e; k++) {
      const double *p = V + 3 * face_vert[k];
      const double *q = V + 3 * face_vert[(k + 1 < e) ? k + 1 : b];
      nrm[0] += (p[1] - q[1]) * (p[2] + q[2]);
      nrm[1] += (p[2] - q[2]) * (p[0] + q[0]);
      nrm[2] += (p[0] - q[0]) * (p[1] + q[1]);
    }
    const double area2 = len3(nrm);
    if (!(area2 > 1.0e-14 * rb * rb))
      error->all(FLERR, "BCM cells file {}: cell {} face {} has no area (merge or drop it)",
                 source, tag, f);
    double *pl = &plane[4 * (c.f0 + f)];
    for (int d = 0; d < 3; d++) pl[d] = nrm[d] / area2;
    double off = 0.0;
    for (int k = b; k < e; k++) off += dot(pl, V + 3 * face_vert[k]);
    pl[3] = off / (e - b);
    for (int k = b; k < e; k++)
      if (std::fabs(dot(pl, V + 3 * face_vert[k]) - pl[3]) > tol)
        error->all(FLERR, "BCM cells file {}: cell {} face {} is not planar", source, tag, f);
    for (int k = b; k < e; k++) {
      const int va = face_vert[k], vb = face_vert[(k + 1 < e) ? k + 1 : b];
      if (va == vb)
        error->all(FLERR, "BCM cells file {}: cell {} face {} repeats vertex {}", source, tag, f,
                   va);
      if (!directed.emplace(std::make_pair(va, vb), f).second)
        error->all(FLERR,
                   "BCM cells file {}: cell {}: edge {}-{} is traversed twice in the same "
                   "direction (faces must all be counter-clockwise seen from outside)",
                   source, tag, va, vb);
    }
  }

  // edges: each directed pair must have its reverse
  std::vector<std::vector<int>> nbr(c.nv);
  for (const auto &d : directed) {
    const int va = d.first.first, vb = d.first.second;
    auto rev = directed.find(std::make_pair(vb, va));
    if (rev == directed.end())
      error->all(FLERR,
                 "BCM cells file {}: cell {}: edge {}-{} belongs to one face only (the surface "
                 "must be closed)",
                 source, tag, va, vb);
    if (va < vb) {
      edge.insert(edge.end(), {static_cast<Index>(va), static_cast<Index>(vb),
                               static_cast<Index>(d.second), static_cast<Index>(rev->second)});
      nbr[va].push_back(vb);
      nbr[vb].push_back(va);
    }
  }
  c.ne = static_cast<int>(edge.size() / 4) - c.e0;
  if (c.ne >= MAX_FEATURES)
    error->all(FLERR, "BCM cells file {}: cell {} has too many edges", source, tag);
  if (c.nv - c.ne + c.nf != 2)
    error->all(FLERR, "BCM cells file {}: cell {} is not a closed polyhedron (V - E + F = {})",
               source, tag, c.nv - c.ne + c.nf);
  for (int k = 0; k < c.nv; k++) {
    if (nbr[k].size() < 3)
      error->all(FLERR, "BCM cells file {}: cell {} vertex {} is on fewer than 3 edges", source,
                 tag, k);
    adj_first.push_back(static_cast<int>(adj.size()));
    adj.insert(adj.end(), nbr[k].begin(), nbr[k].end());
  }

  // convexity: every vertex on the inner side of every face plane
  for (int f = 0; f < c.nf; f++) {
    const double *pl = &plane[4 * (c.f0 + f)];
    for (int k = 0; k < c.nv; k++)
      if (dot(pl, V + 3 * k) - pl[3] > tol)
        error->all(FLERR,
                   "BCM cells file {}: cell {} is not convex, or its face {} is not "
                   "counter-clockwise seen from outside (vertex {} is beyond its plane)",
                   source, tag, f, k);
  }
}

/* ---------------------------------------------------------------------- */

double BcmCells::memory_usage() const
{
  return sizeof(double) * (vert.capacity() + plane.capacity()) +
      sizeof(int) * (face_first.capacity() + adj_first.capacity()) +
      sizeof(Index) * (face_vert.capacity() + edge.capacity() + adj.capacity()) +
      sizeof(Cell) * cells.capacity() + sizeof(tagint) * sorted_tag.capacity() +
      sizeof(int) * index_of_sorted.capacity();
}

/* ---------------------------------------------------------------------- */

void LAMMPS_NS::bcm_place_cell(const BcmCells &table, const BcmCells::Cell &c, const double *x,
                               const double *q, double *vert, double *plane)
{
  double R[3][3];
  BcmRigid::rotation(q, R);
  const double *bv = &table.vert[3 * c.v0];
  for (int k = 0; k < c.nv; k++) {
    BcmRigid::rotate(R, bv + 3 * k, vert + 3 * k);
    for (int d = 0; d < 3; d++) vert[3 * k + d] += x[d];
  }
  const double *bp = &table.plane[4 * c.f0];
  for (int f = 0; f < c.nf; f++) {
    BcmRigid::rotate(R, bp + 4 * f, plane + 4 * f);
    plane[4 * f + 3] = bp[4 * f + 3] + dot(plane + 4 * f, x);
  }
}


/* ---------------------------------------------------------------------- */

int LAMMPS_NS::bcm_peratom_array(LAMMPS *lmp, const std::string &fix_id, const std::string &name,
                                 int ncols, bool ghost)
{
  if (!lmp->modify->get_fix_by_id(fix_id))
    lmp->modify->add_fix(fmt::format("{} all lazy/store {} {} ghost {}", fix_id, name, ncols,
                                     ghost ? "yes" : "no"));
  int flag = -1, cols = -1, ghostflag = -1;
  const int index = lmp->atom->find_custom_ghost(name.c_str(), flag, cols, ghostflag);
  if (index < 0 || flag != 1 || cols != ncols || (ghost && !ghostflag))
    lmp->error->all(FLERR,
                    "Per-atom store {} (fix {}) has {} columns{}, {} needed: the style's slot "
                    "count changed after the store was created, or the store comes from a "
                    "restart file of another slot layout",
                    name, fix_id, cols, ghost && !ghostflag ? " without ghost" : "", ncols);
  return index;
}

/* ====================================================================== */
/* contact detection                                                      */
/* ====================================================================== */

namespace {

struct Side {
  const BcmCells &t;
  const BcmCells::Cell &c;
  const double *x, *vert, *plane;
  explicit Side(const BcmSpaceCell &s) :
      t(*s.table), c(*s.cell), x(s.x), vert(s.vert), plane(s.plane)
  {
  }
  const double *v(int k) const { return vert + 3 * k; }
  const double *n(int f) const { return plane + 4 * f; }
  const BcmCells::Index *e(int ie) const { return &t.edge[4 * (c.e0 + ie)]; }
  int face_begin(int f) const { return t.face_first[c.f0 + f]; }
  int face_end(int f) const { return t.face_first[c.f0 + f + 1]; }
  int adj_begin(int k) const { return t.adj_first[c.v0 + k]; }
  int adj_end(int k) const { return t.adj_first[c.v0 + k + 1]; }
};

// a face plane of S with every vertex of O at least dcut beyond it
bool separated(const Side &S, const Side &O, double dcut)
{
  for (int f = 0; f < S.c.nf; f++) {
    const double *pl = S.n(f);
    const double hc = dot(pl, O.x) - pl[3];
    if (hc - O.c.rbound >= dcut) return true;
    // the origin (the cell's centroid) lies inside the core, so some vertex is at most hc
    // above the plane: no separation by this plane
    if (hc < dcut) continue;
    bool all = true;
    for (int k = 0; k < O.c.nv && all; k++) all = dot(pl, O.v(k)) - pl[3] >= dcut;
    if (all) return true;
  }
  return false;
}

// heights of O's vertices over S's face planes: h[k nfS + f]; hmax[k]
void heights(const Side &S, const Side &O, std::vector<double> &h, std::vector<double> &hmax)
{
  const int nf = S.c.nf;
  h.resize(static_cast<std::size_t>(O.c.nv) * nf);
  hmax.resize(O.c.nv);
  for (int k = 0; k < O.c.nv; k++) {
    const double *v = O.v(k);
    double m = -HUGE_VAL;
    for (int f = 0; f < nf; f++) {
      const double *pl = S.n(f);
      const double val = dot(pl, v) - pl[3];
      h[static_cast<std::size_t>(k) * nf + f] = val;
      m = std::max(m, val);
    }
    hmax[k] = m;
  }
}

// largest height of p over the face planes of S: <= 0 when p lies inside S's core
double height_over(const Side &S, const double *p)
{
  double m = -HUGE_VAL;
  for (int f = 0; f < S.c.nf; f++) m = std::max(m, dot(S.n(f), p) - S.n(f)[3]);
  return m;
}

// v projects inside face f of S (boundary within tol included)
bool inside_face(const Side &S, int f, const double *v, double tol)
{
  const double *nf = S.n(f);
  const int b = S.face_begin(f), e = S.face_end(f);
  for (int k = b; k < e; k++) {
    const double *w0 = S.v(S.t.face_vert[k]);
    const double *w1 = S.v(S.t.face_vert[(k + 1 < e) ? k + 1 : b]);
    double ed[3], rel[3], cr[3];
    sub3(w1, w0, ed);
    sub3(v, w0, rel);
    cross(ed, rel, cr);
    if (dot(cr, nf) < -tol * len3(ed)) return false;
  }
  return true;
}

// edges of S that may come within dcut of O: not both ends dcut beyond one of O's planes
void live_edges(const Side &S, const Side &O, const std::vector<double> &h, double dcut,
                std::vector<int> &live)
{
  live.clear();
  const int nfo = O.c.nf;
  for (int ie = 0; ie < S.c.ne; ie++) {
    const BcmCells::Index *ed = S.e(ie);
    const double *ha = &h[static_cast<std::size_t>(ed[0]) * nfo];
    const double *hb = &h[static_cast<std::size_t>(ed[1]) * nfo];
    bool cut = false;
    for (int f = 0; f < nfo && !cut; f++) cut = ha[f] >= dcut && hb[f] >= dcut;
    if (!cut) live.push_back(ie);
  }
}

// n lies in the normal cone of vertex k of S within the slack (sign = +1), or -n does
// (sign = -1): no edge from k heads against n
bool vertex_cone(const Side &S, int k, const double *n, double sign)
{
  const double *v = S.v(k);
  for (int m = S.adj_begin(k); m < S.adj_end(k); m++) {
    double d[3];
    sub3(S.v(S.t.adj[m]), v, d);
    if (sign * dot(d, n) < -VERTEX_SLACK * len3(d)) return false;
  }
  return true;
}

// n lies in the normal cone of edge ie of S (between the normals of its two faces)
bool edge_cone(const Side &S, int ie, const double *n)
{
  const BcmCells::Index *ed = S.e(ie);
  double w[3];
  sub3(S.v(ed[1]), S.v(ed[0]), w);
  const double wl = len3(w);
  for (double &c : w) c /= wl;
  double g1[3], g2[3];
  cross(S.n(ed[2]), w, g1);    // into the face that traverses a -> b
  cross(w, S.n(ed[3]), g2);    // into the face that traverses b -> a
  return dot(n, g1) <= CONE_TOL && dot(n, g2) <= CONE_TOL;
}

struct Collector {
  std::vector<BcmContactPoint> &out;
  std::size_t first;
  double merge2;
  int add(const double *p, const double *n, double h, int64_t kind, int ia, int ib)
  {
    for (std::size_t m = first; m < out.size(); m++) {
      double d[3];
      sub3(out[m].p, p, d);
      if (dot(d, d) < merge2) return 0;
    }
    BcmContactPoint c;
    for (int k = 0; k < 3; k++) {
      c.p[k] = p[k];
      c.n[k] = n[k];
    }
    c.h = h;
    c.key = (kind << 40) | (static_cast<int64_t>(ia) << 20) | static_cast<int64_t>(ib);
    out.push_back(c);
    return 1;
  }
};

}    // namespace

bool LAMMPS_NS::bcm_cores_apart(const BcmSpaceCell &sa, const BcmSpaceCell &sb, double dcut)
{
  const Side A(sa), B(sb);
  return separated(A, B, dcut) || separated(B, A, dcut);
}

namespace {

// the largest margin over the face planes of S: min(hc, least vertex height) - dcut of O
double apart_margin(const Side &S, const Side &O, double dcut, double best)
{
  for (int f = 0; f < S.c.nf; f++) {
    const double *pl = S.n(f);
    const double hc = dot(pl, O.x) - pl[3];
    // the centre's height counts too (separated() skips a plane with the centre below
    // dcut), so hc - dcut bounds this plane's margin
    if (hc - dcut <= best) continue;
    double m = hc - dcut;
    for (int k = 0; k < O.c.nv && m > best; k++) m = std::min(m, dot(pl, O.v(k)) - pl[3] - dcut);
    if (m > best) best = m;
  }
  return best;
}

}    // namespace

double LAMMPS_NS::bcm_apart_margin(const BcmSpaceCell &sa, const BcmSpaceCell &sb, double dcut,
                                   int &side)
{
  const Side A(sa), B(sb);
  const double ma = apart_margin(A, B, dcut, -HUGE_VAL);
  const double mb = apart_margin(B, A, dcut, ma);
  side = mb > ma ? 1 : 0;
  return std::max(ma, mb);
}

namespace {

// over O's planes (heights h of S's vertices, their largest hmax): the least over S's edges
// of the edge's best plane (the larger height of its lower end), and the least hmax
void dead_margins(const Side &S, const Side &O, const std::vector<double> &h,
                  const std::vector<double> &hmax, double &edges, double &verts)
{
  const int nfo = O.c.nf;
  edges = HUGE_VAL;
  for (int ie = 0; ie < S.c.ne; ie++) {
    const BcmCells::Index *ed = S.e(ie);
    const double *ha = &h[static_cast<std::size_t>(ed[0]) * nfo];
    const double *hb = &h[static_cast<std::size_t>(ed[1]) * nfo];
    double best = -HUGE_VAL;
    for (int f = 0; f < nfo; f++) best = std::max(best, std::min(ha[f], hb[f]));
    edges = std::min(edges, best);
  }
  verts = HUGE_VAL;
  for (int k = 0; k < S.c.nv; k++) verts = std::min(verts, hmax[k]);
}

}    // namespace

double LAMMPS_NS::bcm_dead_margin(const BcmSpaceCell &sa, const BcmSpaceCell &sb, double dcut,
                                  const BcmContactWork &work)
{
  const Side A(sa), B(sb);
  double ea, va, eb, vb;
  dead_margins(A, B, work.ha, work.hmaxa, ea, va);
  dead_margins(B, A, work.hb, work.hmaxb, eb, vb);
  // (every vertex ends an edge, so the dead edges of one core already put its vertices
  // dcut above a plane of the other; both kept for certainty)
  return std::min(std::min(va, vb), std::max(ea, eb)) - dcut;
}

int LAMMPS_NS::bcm_find_contacts(const BcmSpaceCell &sa, const BcmSpaceCell &sb, double dcut,
                                 BcmContactWork &work, std::vector<BcmContactPoint> &out,
                                 bool apart_tested)
{
  const Side A(sa), B(sb);
  if (!apart_tested && (separated(A, B, dcut) || separated(B, A, dcut))) return 0;

  const double scale = A.c.rbound + B.c.rbound;
  const double rmin = std::min(A.c.rbound, B.c.rbound);
  const double tol = 1.0e-9 * scale;
  const double tiny = 1.0e-12 * scale;
  const double inside_tol = INSIDE_REL * rmin;
  const double merge = MERGE_REL * rmin;
  const double pen = 0.25 * rmin;
  Collector col{out, out.size(), merge * merge};
  int count = 0;

  heights(B, A, work.ha, work.hmaxa);    // A's vertices over B's planes
  heights(A, B, work.hb, work.hmaxb);    // B's vertices over A's planes
  const int nfa = A.c.nf, nfb = B.c.nf;

  // vertex of A on face of B
  for (int k = 0; k < A.c.nv; k++) {
    const double hm = work.hmaxa[k];
    if (hm >= dcut || hm <= -pen) continue;
    const double *v = A.v(k);
    for (int f = 0; f < nfb; f++) {
      const double h = work.ha[static_cast<std::size_t>(k) * nfb + f];
      if (h < hm - tol || !inside_face(B, f, v, inside_tol)) continue;
      const double *n = B.n(f);
      const double p[3] = {v[0] - 0.5 * h * n[0], v[1] - 0.5 * h * n[1], v[2] - 0.5 * h * n[2]};
      count += col.add(p, n, h, BCM_VF, k, f);
    }
  }
  // vertex of B on face of A
  for (int k = 0; k < B.c.nv; k++) {
    const double hm = work.hmaxb[k];
    if (hm >= dcut || hm <= -pen) continue;
    const double *v = B.v(k);
    for (int f = 0; f < nfa; f++) {
      const double h = work.hb[static_cast<std::size_t>(k) * nfa + f];
      if (h < hm - tol || !inside_face(A, f, v, inside_tol)) continue;
      const double *nf = A.n(f);
      const double n[3] = {-nf[0], -nf[1], -nf[2]};
      const double p[3] = {v[0] - 0.5 * h * nf[0], v[1] - 0.5 * h * nf[1],
                           v[2] - 0.5 * h * nf[2]};
      count += col.add(p, n, h, BCM_FV, f, k);
    }
  }

  live_edges(A, B, work.ha, dcut, work.livea);
  live_edges(B, A, work.hb, dcut, work.liveb);

  // edge of A across edge of B
  for (const int ea : work.livea) {
    const BcmCells::Index *eda = A.e(ea);
    const double *a0 = A.v(eda[0]);
    double u[3];
    sub3(A.v(eda[1]), a0, u);
    const double uu = dot(u, u);
    double suma[3];
    for (int d = 0; d < 3; d++) suma[d] = A.n(eda[2])[d] + A.n(eda[3])[d];
    for (const int eb : work.liveb) {
      const BcmCells::Index *edb = B.e(eb);
      const double *b0 = B.v(edb[0]);
      double w[3], r[3], cr[3];
      sub3(B.v(edb[1]), b0, w);
      sub3(a0, b0, r);
      cross(u, w, cr);
      const double crn2 = dot(cr, cr), ww = dot(w, w);
      if (crn2 <= PARALLEL_SIN * PARALLEL_SIN * uu * ww) continue;
      const double uw = dot(u, w), ur = dot(u, r), wr = dot(w, r);
      const double s = (uw * wr - ww * ur) / crn2;
      const double t = (uu * wr - uw * ur) / crn2;
      if (s <= PARAM_TOL || s >= 1.0 - PARAM_TOL || t <= PARAM_TOL || t >= 1.0 - PARAM_TOL)
        continue;
      const double crn = std::sqrt(crn2);
      double n[3] = {cr[0] / crn, cr[1] / crn, cr[2] / crn};
      double sumb[3];
      for (int d = 0; d < 3; d++) sumb[d] = B.n(edb[2])[d] + B.n(edb[3])[d];
      double sa_ = dot(n, suma), sb_ = dot(n, sumb);
      if (sb_ - sa_ < 0.0) {
        for (double &c : n) c = -c;
        sa_ = -sa_;
        sb_ = -sb_;
      }
      if (sb_ < 0.0 || sa_ > 0.0) continue;    // the edges do not face each other
      double pa[3], pb[3], p[3];
      for (int d = 0; d < 3; d++) {
        pa[d] = a0[d] + s * u[d];
        pb[d] = b0[d] + t * w[d];
        p[d] = 0.5 * (pa[d] + pb[d]);
      }
      double dp[3];
      sub3(pa, pb, dp);
      const double h = dot(n, dp);
      if (h >= dcut || h <= -pen) continue;
      // an interpenetration of depth -h only if the edges do cross inside each other
      if (h < 0.0 && (height_over(B, pa) > tol || height_over(A, pb) > tol)) continue;
      count += col.add(p, n, h, BCM_EE, ea, eb);
    }
  }

  // vertex of A against edge of B, and vertex of A against vertex of B
  for (int k = 0; k < A.c.nv; k++) {
    const double hm = work.hmaxa[k];
    if (hm >= dcut || hm <= 0.0) continue;
    const double *v = A.v(k);
    for (const int eb : work.liveb) {
      const BcmCells::Index *edb = B.e(eb);
      const double *b0 = B.v(edb[0]);
      double w[3], r[3];
      sub3(B.v(edb[1]), b0, w);
      sub3(v, b0, r);
      const double t = dot(r, w) / dot(w, w);
      if (t <= PARAM_TOL || t >= 1.0 - PARAM_TOL) continue;
      double q[3], dv[3];
      for (int d = 0; d < 3; d++) q[d] = b0[d] + t * w[d];
      sub3(v, q, dv);
      const double dist = len3(dv);
      if (dist >= dcut || dist <= tiny) continue;
      const double n[3] = {dv[0] / dist, dv[1] / dist, dv[2] / dist};
      if (!edge_cone(B, eb, n) || !vertex_cone(A, k, n, 1.0)) continue;
      const double p[3] = {0.5 * (v[0] + q[0]), 0.5 * (v[1] + q[1]), 0.5 * (v[2] + q[2])};
      count += col.add(p, n, dist, BCM_VE, k, eb);
    }
  }
  for (int l = 0; l < B.c.nv; l++) {
    const double hm = work.hmaxb[l];
    if (hm >= dcut || hm <= 0.0) continue;
    const double *v = B.v(l);
    for (const int ea : work.livea) {
      const BcmCells::Index *eda = A.e(ea);
      const double *a0 = A.v(eda[0]);
      double u[3], r[3];
      sub3(A.v(eda[1]), a0, u);
      sub3(v, a0, r);
      const double t = dot(r, u) / dot(u, u);
      if (t <= PARAM_TOL || t >= 1.0 - PARAM_TOL) continue;
      double q[3], dv[3];
      for (int d = 0; d < 3; d++) q[d] = a0[d] + t * u[d];
      sub3(q, v, dv);
      const double dist = len3(dv);
      if (dist >= dcut || dist <= tiny) continue;
      const double n[3] = {dv[0] / dist, dv[1] / dist, dv[2] / dist};
      const double mn[3] = {-n[0], -n[1], -n[2]};
      if (!edge_cone(A, ea, mn) || !vertex_cone(B, l, n, -1.0)) continue;
      const double p[3] = {0.5 * (v[0] + q[0]), 0.5 * (v[1] + q[1]), 0.5 * (v[2] + q[2])};
      count += col.add(p, n, dist, BCM_EV, ea, l);
    }
  }
  for (int k = 0; k < A.c.nv; k++) {
    const double hma = work.hmaxa[k];
    if (hma >= dcut || hma <= 0.0) continue;
    const double *va = A.v(k);
    for (int l = 0; l < B.c.nv; l++) {
      const double hmb = work.hmaxb[l];
      if (hmb >= dcut || hmb <= 0.0) continue;
      const double *vb = B.v(l);
      double dv[3];
      sub3(va, vb, dv);
      const double dist = len3(dv);
      if (dist >= dcut || dist <= tiny) continue;
      const double n[3] = {dv[0] / dist, dv[1] / dist, dv[2] / dist};
      if (!vertex_cone(A, k, n, 1.0) || !vertex_cone(B, l, n, -1.0)) continue;
      const double p[3] = {0.5 * (va[0] + vb[0]), 0.5 * (va[1] + vb[1]),
                           0.5 * (va[2] + vb[2])};
      count += col.add(p, n, dist, BCM_VV, k, l);
    }
  }
  return count;
}
