/* bond_style bcm/griffith (SPEC 1.2; see plugins/doc/bond_bcm_griffith.md).

   Cell 1 / cell 2 = the cell with the smaller / larger atom ID; n points from 1 to 2.
   Per point k of an interface with N_p points (body-frame anchors b1, b2 in cells 1 and 2):
     r2 = R2 b2, p2 = x2 + r2, p1 = x1 + R1 b1, delta = p2 - p1, n = R1 n_body,
     dn = delta . n (> 0 gap), dt = delta - dn n,
     dv = v2 + w2 x r2 - v1 - w1 x (p2 - x1): the velocity of p2 relative to the point of
          cell 1 at p2, i.e. the rate of delta seen from cell 1's rotating frame
          (dv . n = d(dn)/dt exactly).
   Every force of a point acts on cell 2 at p2 and, reversed, on cell 1 at the same point p2.
   For an energy E(delta, vectors carried by cell 1) this gives exactly -grad E (the torque of
   -F at p2 on cell 1 is the arm p1 - x1 plus the turn of n: (k_p - k_tp) dn (delta x n) for the
   intact spring), and forces that share their point of action conserve angular momentum.

   Per-slot state (per atom and bond slot, in a hidden fix property/atom): header, then the
   damping force of each point at the last evaluation (damping-work quadrature), then per point
   the contact reference shift s, the slip offset sigma (cell 1's body frame), the in-contact
   flag and the last tangential contact force (friction work). The force loop works on a copy
   of the state in bondlist order (rebuilt at reneighboring, written back by sync_store()).

   Retirement. The points of a broken interface are anchored to the two faces that were glued:
   they stand for the contact of those faces only while the cells are near each other. Far
   apart, the face plane of a turning cell 1 can sweep past a partner's anchors millimetres
   away and close a point there, with the whole separation as lever arm (a force from nothing,
   and a damping that turns unstable at that effective mass). So once the cells' bounding
   spheres part, |x2 - x1| >= r1 + r2 (atom->radius holds the rounded cell: pair bcm/contact
   checks it), the interface is retired for good: its points open and are never evaluated
   again, what they store is counted as lost at this switch (W_switch, as at the break), and
   the pair leaves the 1-2 special lists (fix breakable/special), so that if the cells meet
   again they touch through pair_style bcm/contact, the polyhedral contact of SPEC 1.2. The
   bond keeps its type, its area stays in the broken area and W_f, its counters in the sums.
   Every rank holding the bond (newton_bond off: the owners of both cells) decides alike, from
   the same positions and radii of both cells; the partner is still a ghost when the spheres
   part, the communication cutoff reaching beyond r1 + r2 (pair bcm/contact's cutoff is twice
   the largest radius). The retired state lives in the per-slot header (restart files keep
   it), and fix breakable/special reads it at every run setup (released()). */

#include "bond_bcm_griffith.h"

#include "atom.h"
#include "bcm_rigid.h"
#include "break_events.h"
#include "breakable_util.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "fix_bcm_griffith.h"
#include "force.h"
#include "memory.h"
#include "neighbor.h"
#include "update.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <mpi.h>
#include <unordered_map>

using namespace LAMMPS_NS;
using BcmRigid::cross;
using BcmRigid::dot;

static const char *const STORE_FIX_ID = "BCM_GRIFFITH_STATE";
static const char *const STORE_NAME = "bcm_griffith_state";
static constexpr double MY_PI = 3.14159265358979323846;

namespace {

// slot header
enum {
  H_BROKEN,        // INTACT, BROKEN or RETIRED
  H_BREAK_STEP,    // step of the break
  H_BREAK_TIME,    // simulation time of the break
  H_E_BREAK,       // elastic energy stored by the interface just before the switch
  H_E_EL,          // elastic energy stored now (intact springs or contact springs)
  H_W_DAMP,        // cumulative energy dissipated by damping
  H_W_FRIC,        // cumulative energy dissipated by friction
  H_W_SWITCH,      // energy dissipated at the switch (see compute())
  H_LAST_KIND,     // kind of the last evaluation (EvalKind)
  H_LAST_DT,       // time step of the last evaluation
  H_PD,            // power dissipated by damping at the last evaluation, -sum F_d . dv
  NHEAD
};

// After the header, the damping forces of the last evaluation, 3 per point (F_d on cell 2:
// the only per-point state an intact interface reads and writes, kept together), then the
// contact state of the points of a broken interface, NCONTACT per point:
enum {
  C_SHIFT,        // s: contact overlap reference
  C_SLIP,         // sigma (3): slip offset in cell 1's body frame, u_t = dt - R1 sigma
  C_TOUCH = 4,    // 1 while the point is a closed contact
  C_FT,           // magnitude of the tangential contact force at the last evaluation
  NCONTACT
};
constexpr int NPOINT = 3 + NCONTACT;    // doubles per point in a slot

// H_BROKEN: the points are the intact interface's springs; frictional contacts; nothing (the
// pair is the pair style's)
constexpr double INTACT = 0.0, BROKEN = 1.0, RETIRED = 2.0;

// record of a bondlist entry in the working copy: these constants, the slot's header and
// damping forces (NHEAD + 3 N_p), the geometry (normal in cell 1's frame, then b1, b2 per
// point: 3 + 6 N_p)
enum {
  K_AREA,    // S
  K_KP,      // k_n / N_p
  K_KTP,     // k_t / N_p
  K_CP,      // 2 alpha sqrt(k_n m) / N_p
  K_KC,      // contact k_n / N_p
  K_KTC,     // contact k_t / N_p
  K_CC,      // contact 2 alpha_c sqrt(k_n,c m) / N_p
  NCONST
};
inline long record_size(int npts) { return NCONST + NHEAD + 3 * npts + 3 + 6 * npts; }

// what the last force evaluation was: it decides which half kicks used its damping force
enum EvalKind { EVAL_NONE = 0, EVAL_SETUP = 1, EVAL_STEP = 2 };

// SPEC 1.2 Eq. 2: damping ratio from the restitution coefficient e = sqrt(e^2)
double damping_ratio(double e2)
{
  if (e2 <= 0.0) return 1.0;
  const double le = std::log(std::sqrt(e2));
  return -le / std::sqrt(le * le + MY_PI * MY_PI);
}

bool parse_double(const std::string &s, double &out)
{
  if (!utils::is_double(s)) return false;
  out = std::stod(s);
  return std::isfinite(out);
}

}    // namespace

/* ---------------------------------------------------------------------- */

BondBcmGriffith::BondBcmGriffith(LAMMPS *_lmp) :
    Bond(_lmp), kn(nullptr), kt(nullptr), en2(nullptr), gc(nullptr), kn_c(nullptr),
    kt_c(nullptr), en2_c(nullptr), mu(nullptr), alpha(nullptr), alpha_c(nullptr),
    convention(STORED), stiffness(PER_INTERFACE), mean_area(0.0), maxpts(0), reference_taken(0), span_max(0.0), cache_store(nullptr),
    cache_valid(false), dirty(false),
    store_index(-1), slot_size(0), iquat(-1), nevaluations(0), special(nullptr)
{
  writedata = 1;
  born_matrix_enable = 0;
  single_extra = 6;
  svector = new double[single_extra];
  // created now when possible so that thermo_style can name f_BCM_GRIFFITH
  if (domain->box_exist) FixBcmGriffith::get_or_create(lmp);
}

/* ---------------------------------------------------------------------- */

BondBcmGriffith::~BondBcmGriffith()
{
  delete[] svector;
  svector = nullptr;
  if (allocated) {
    memory->destroy(setflag);
    memory->destroy(kn);
    memory->destroy(kt);
    memory->destroy(en2);
    memory->destroy(gc);
    memory->destroy(kn_c);
    memory->destroy(kt_c);
    memory->destroy(en2_c);
    memory->destroy(mu);
    memory->destroy(alpha);
    memory->destroy(alpha_c);
  }
}

/* ---------------------------------------------------------------------- */

void BondBcmGriffith::allocate()
{
  allocated = 1;
  const int n = atom->nbondtypes + 1;
  memory->create(kn, n, "bond:kn");
  memory->create(kt, n, "bond:kt");
  memory->create(en2, n, "bond:en2");
  memory->create(gc, n, "bond:gc");
  memory->create(kn_c, n, "bond:kn_c");
  memory->create(kt_c, n, "bond:kt_c");
  memory->create(en2_c, n, "bond:en2_c");
  memory->create(mu, n, "bond:mu");
  memory->create(alpha, n, "bond:alpha");
  memory->create(alpha_c, n, "bond:alpha_c");
  memory->create(setflag, n, "bond:setflag");
  for (int i = 1; i < n; i++) setflag[i] = 0;
}

/* ----------------------------------------------------------------------
   bond_style bcm/griffith geometry FILE [energy stored|rockable|literal]
                           [stiffness per_interface|per_area]
------------------------------------------------------------------------- */

void BondBcmGriffith::settings(int narg, char **arg)
{
  std::string file;
  convention = STORED;
  stiffness = PER_INTERFACE;
  for (int iarg = 0; iarg < narg; iarg += 2) {
    if (iarg + 1 >= narg)
      error->all(FLERR, "bond_style bcm/griffith: keyword {} needs a value", arg[iarg]);
    if (strcmp(arg[iarg], "geometry") == 0) {
      file = arg[iarg + 1];
    } else if (strcmp(arg[iarg], "stiffness") == 0) {
      if (strcmp(arg[iarg + 1], "per_interface") == 0)
        stiffness = PER_INTERFACE;
      else if (strcmp(arg[iarg + 1], "per_area") == 0)
        stiffness = PER_AREA;
      else
        error->all(FLERR, "bond_style bcm/griffith: unknown stiffness {} (known: per_interface, per_area)",
                   arg[iarg + 1]);
    } else if (strcmp(arg[iarg], "energy") == 0) {
      if (strcmp(arg[iarg + 1], "stored") == 0)
        convention = STORED;
      else if (strcmp(arg[iarg + 1], "rockable") == 0)
        convention = ROCKABLE;
      else if (strcmp(arg[iarg + 1], "literal") == 0)
        convention = LITERAL;
      else
        error->all(FLERR, "bond_style bcm/griffith: unknown energy convention {} "
                   "(known: stored, rockable, literal)", arg[iarg + 1]);
    } else {
      error->all(FLERR, "bond_style bcm/griffith: unknown keyword {} (known: geometry, energy, stiffness)",
                 arg[iarg]);
    }
  }
  if (file.empty())
    error->all(FLERR, "bond_style bcm/griffith requires `geometry FILE` (the interface table)");
  geometry_file = file;
  read_geometry(file);
  reference_taken = 0;
  cache_valid = false;
}

/* ----------------------------------------------------------------------
   one interface per line (comments after '#'):
     tag1 tag2 area nx ny nz npts  x1 y1 z1 ... (npts points)
   space coordinates of the reference state, normal from tag1 to tag2, tag1 < tag2.
   Read on rank 0; a message of the first problem is broadcast and raised on all ranks.
------------------------------------------------------------------------- */

void BondBcmGriffith::read_geometry(const std::string &file)
{
  interfaces.clear();
  space.clear();
  body.clear();
  lookup.clear();

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
      if (lookup.count(key(itf.tag1, itf.tag2))) {
        problem = where + fmt::format(": interface {}-{} listed twice", itf.tag1, itf.tag2);
        break;
      }
      for (int k = 0; k < 3; k++) val[k] /= nn;
      itf.soff = (long) space.size();
      itf.boff = 0;
      space.insert(space.end(), val, val + 3 + 3 * itf.npts);
      lookup[key(itf.tag1, itf.tag2)] = (int) interfaces.size();
      interfaces.push_back(itf);
    }
  }

  int nproblem = (int) problem.size();
  MPI_Bcast(&nproblem, 1, MPI_INT, 0, world);
  if (nproblem) {
    problem.resize(nproblem);
    MPI_Bcast(&problem[0], nproblem, MPI_CHAR, 0, world);
    error->all(FLERR, "bond_style bcm/griffith: {}", problem);
  }
  broadcast_geometry();
}

/* ----------------------------------------------------------------------
   rank 0's table to every rank, then the derived offsets and look-up
------------------------------------------------------------------------- */

void BondBcmGriffith::broadcast_geometry()
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
  index_geometry();
}

/* ---------------------------------------------------------------------- */

void BondBcmGriffith::index_geometry()
{
  lookup.clear();
  long soff = 0, boff = 0;
  maxpts = 0;
  mean_area = 0.0;
  for (const Interface &itf : interfaces) mean_area += itf.area;
  if (!interfaces.empty()) mean_area /= (double) interfaces.size();
  for (int i = 0; i < (int) interfaces.size(); i++) {
    Interface &itf = interfaces[i];
    itf.soff = soff;
    itf.boff = boff;
    soff += 3 + 3 * itf.npts;
    boff += 3 + 6 * itf.npts;
    maxpts = std::max(maxpts, itf.npts);
    lookup[key(itf.tag1, itf.tag2)] = i;
  }
  if (soff != (long) space.size())
    error->all(FLERR, "bond_style bcm/griffith: inconsistent interface table");
  body.resize(boff, 0.0);
}

/* ---------------------------------------------------------------------- */

long long BondBcmGriffith::key(tagint t1, tagint t2)
{
  return (static_cast<long long>(t1) << 32) ^ static_cast<long long>(t2);
}

int BondBcmGriffith::find_interface(tagint t1, tagint t2) const
{
  if (t1 > t2) std::swap(t1, t2);
  const auto it = lookup.find(key(t1, t2));
  return it == lookup.end() ? -1 : it->second;
}

/* ----------------------------------------------------------------------
   bond_coeff T kn kt en2 Gc kn_c kt_c en2_c mu
------------------------------------------------------------------------- */

void BondBcmGriffith::coeff(int narg, char **arg)
{
  if (narg != 9)
    error->all(FLERR, "Incorrect args for bond coefficients: "
                      "bond_coeff T kn kt en2 Gc kn_c kt_c en2_c mu");
  if (!allocated) allocate();

  int ilo, ihi;
  utils::bounds(FLERR, arg[0], 1, atom->nbondtypes, ilo, ihi, error);
  double v[8];
  for (int k = 0; k < 8; k++) v[k] = utils::numeric(FLERR, arg[1 + k], false, lmp);
  const char *names[8] = {"kn", "kt", "en2", "Gc", "kn_c", "kt_c", "en2_c", "mu"};
  for (int k : {0, 1, 4, 5})
    if (!(v[k] > 0.0)) error->all(FLERR, "bond_coeff bcm/griffith: {} must be > 0", names[k]);
  for (int k : {2, 6})
    if (!(v[k] >= 0.0 && v[k] <= 1.0))
      error->all(FLERR, "bond_coeff bcm/griffith: {} must be in [0, 1]", names[k]);
  for (int k : {3, 7})
    if (!(v[k] >= 0.0)) error->all(FLERR, "bond_coeff bcm/griffith: {} must be >= 0", names[k]);

  int count = 0;
  for (int i = ilo; i <= ihi; i++) {
    kn[i] = v[0];
    kt[i] = v[1];
    en2[i] = v[2];
    gc[i] = v[3];
    kn_c[i] = v[4];
    kt_c[i] = v[5];
    en2_c[i] = v[6];
    mu[i] = v[7];
    alpha[i] = damping_ratio(en2[i]);
    alpha_c[i] = damping_ratio(en2_c[i]);
    setflag[i] = 1;
    count++;
  }
  if (count == 0) error->all(FLERR, "Incorrect args for bond coefficients");
  if (domain->box_exist) FixBcmGriffith::get_or_create(lmp);
}

/* ---------------------------------------------------------------------- */

void BondBcmGriffith::init_style()
{
  if (force->newton_bond)
    error->all(FLERR, "bond_style bcm/griffith requires newton_bond off (command: newton on off): "
                      "every rank owning a cell of an interface computes it and keeps its state");
  if (atom->molecular != Atom::MOLECULAR)
    error->all(FLERR, "bond_style bcm/griffith requires a molecular atom style (not a template)");
  if (!atom->rmass || !atom->radius || !atom->omega || !atom->torque)
    error->all(FLERR, "bond_style bcm/griffith requires per-atom rmass, radius, omega and "
                      "torque (atom_style hybrid bond sphere)");
  if (!comm->ghost_velocity)
    error->all(FLERR, "bond_style bcm/griffith requires comm_modify vel yes "
                      "(damping reads the velocities and omega of ghost cells)");
  if (force->special_lj[1] != 0.0)
    error->all(FLERR, "bond_style bcm/griffith requires special_bonds lj 0 ... (bonded cells "
                      "interact only through their interface, not through the pair style)");
  int flag = -1, cols = -1, ghost = 0;
  iquat = atom->find_custom_ghost(BcmRigid::QUAT, flag, cols, ghost);
  if (iquat < 0 || flag != 1 || cols != 4 || !ghost)
    error->all(FLERR, "bond_style bcm/griffith requires the per-atom array d2_{} (4 columns, "
               "ghost yes) of fix property/atom", BcmRigid::QUAT);

  slot_size = NHEAD + NPOINT * std::max(maxpts, 1);
  store_index = BreakableUtil::peratom_array(lmp, STORE_FIX_ID, STORE_NAME,
                                             atom->bond_per_atom * slot_size);
  FixBcmGriffith::get_or_create(lmp);
  special = FixBreakableSpecial::get_or_create(lmp);

  // every bond of the topology has its interface, and the table has no extra interface
  const int nlocal = atom->nlocal;
  const tagint *tag = atom->tag;
  tagint missing[2] = {MAXTAGINT, MAXTAGINT};
  bigint nbonds = 0;
  for (int i = 0; i < nlocal; i++)
    for (int m = 0; m < atom->num_bond[i]; m++) {
      if (atom->bond_type[i][m] <= 0) continue;
      const tagint partner = atom->bond_atom[i][m];
      if (tag[i] < partner) nbonds++;
      if (find_interface(tag[i], partner) < 0 && std::min(tag[i], partner) < missing[0]) {
        missing[0] = std::min(tag[i], partner);
        missing[1] = std::max(tag[i], partner);
      }
    }
  tagint first = MAXTAGINT;
  MPI_Allreduce(&missing[0], &first, 1, MPI_LMP_TAGINT, MPI_MIN, world);
  if (first != MAXTAGINT) {
    tagint second = (missing[0] == first) ? missing[1] : MAXTAGINT, other = MAXTAGINT;
    MPI_Allreduce(&second, &other, 1, MPI_LMP_TAGINT, MPI_MIN, world);
    error->all(FLERR, "bond_style bcm/griffith: bond {}-{} has no interface in geometry file {}",
               first, other, geometry_file);
  }
  bigint total = 0;
  MPI_Allreduce(&nbonds, &total, 1, MPI_LMP_BIGINT, MPI_SUM, world);
  if (total != (bigint) interfaces.size())
    error->all(FLERR, "bond_style bcm/griffith: {} interfaces in the geometry table but {} bonds "
               "in the topology", interfaces.size(), total);

  if (!reference_taken) take_reference();
  sync_store();
  cache_valid = false;
}

/* ----------------------------------------------------------------------
   body-frame geometry from the reference state (the current one, at the
   first init): b = R^T (p - x) for each cell of each interface, normal in
   cell 1's frame. The owner of each cell fills its part; a sum over ranks
   gives the whole table to every rank. Checks that the file fits the cells:
   each point inside the cell's bounding sphere and on the cell's side of the
   face (n . (p - x1) > 0 > n . (p - x2)).
------------------------------------------------------------------------- */

void BondBcmGriffith::take_reference()
{
  const int nlocal = atom->nlocal;
  const tagint *tag = atom->tag;
  double **x = atom->x;
  double **quat = atom->darray[iquat];
  const double *radius = atom->radius;

  std::unordered_map<tagint, int> owned;
  owned.reserve(nlocal);
  for (int i = 0; i < nlocal; i++) owned[tag[i]] = i;

  std::vector<double> mine(body.size(), 0.0);
  const int nif = (int) interfaces.size();
  std::vector<int> found(2 * nif, 0);
  enum { BAD_QUAT, BAD_RADIUS, BAD_SIDE, NBAD };
  int bad[NBAD] = {nif, nif, nif};    // first offending interface per kind
  std::vector<double> centres(6 * (size_t) nif, 0.0);

  for (int ii = 0; ii < nif; ii++) {
    const Interface &itf = interfaces[ii];
    const double *n = &space[itf.soff];
    const double *pts = n + 3;
    double *out = &mine[itf.boff];
    for (int side = 0; side < 2; side++) {
      const auto it = owned.find(side ? itf.tag2 : itf.tag1);
      if (it == owned.end()) continue;
      const int i = it->second;
      found[2 * ii + side] = 1;
      for (int c = 0; c < 3; c++) centres[6 * ii + 3 * side + c] = x[i][c];
      double q[4] = {quat[i][0], quat[i][1], quat[i][2], quat[i][3]};
      const double qq = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
      if (!(qq > 0.0)) {
        bad[BAD_QUAT] = std::min(bad[BAD_QUAT], ii);
        continue;
      }
      BcmRigid::normalize_quat(q);
      double R[3][3];
      BcmRigid::quat_to_mat(q, R);
      if (side == 0) BcmRigid::rotate_back(R, n, out);
      double *b = out + 3 + 3 * itf.npts * side;
      for (int k = 0; k < itf.npts; k++) {
        double d[3];
        for (int c = 0; c < 3; c++) d[c] = pts[3 * k + c] - x[i][c];
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

  MPI_Allreduce(mine.data(), body.data(), (int) body.size(), MPI_DOUBLE, MPI_SUM, world);
  std::vector<double> both(centres.size());
  MPI_Allreduce(centres.data(), both.data(), (int) both.size(), MPI_DOUBLE, MPI_SUM, world);
  span_max = 0.0;
  for (int ii = 0; ii < nif; ii++) {
    double d[3];
    for (int c = 0; c < 3; c++) d[c] = both[6 * ii + 3 + c] - both[6 * ii + c];
    span_max = std::max(span_max, std::sqrt(dot(d, d)));
  }
  reference_taken = 1;
}

/* ----------------------------------------------------------------------
   the working copy of the bond list's interfaces, from the per-atom store:
   per entry the cells in ID order, the state slots (with newton_bond off the
   neighbor code lists a bond from an owned atom; the partner's copy is
   written too when the partner is owned here, the bond then being listed
   once), and a record with the constants, the state and the geometry
------------------------------------------------------------------------- */

void BondBcmGriffith::rebuild_cache()
{
  // the previous working copy must be in the store before it is read back; when the atoms
  // moved since, it was written at pre_exchange (fix bcm/griffith)
  if (dirty) sync_store();

  double **store = atom->darray[store_index];
  const tagint *tag = atom->tag;
  const int nlocal = atom->nlocal;
  int **bondlist = neighbor->bondlist;
  const int nbondlist = neighbor->nbondlist;

  cache.resize(nbondlist);
  cache_tags.resize(2 * (size_t) nbondlist);
  std::vector<int> iface_of(nbondlist);
  long nrec = 0, ncontact = 0;
  for (int n = 0; n < nbondlist; n++) {
    int i1 = bondlist[n][0], i2 = bondlist[n][1];
    if (i1 >= nlocal) std::swap(i1, i2);
    if (i1 >= nlocal)
      error->one(FLERR, "bond_style bcm/griffith: bond {}-{} has no owned atom", tag[i1],
                 tag[i2]);
    Entry &e = cache[n];
    const int iface = find_interface(tag[i1], tag[i2]);
    if (iface < 0)
      error->one(FLERR, "bond_style bcm/griffith: bond {}-{} has no interface (bonds created "
                 "during a run are not supported)", tag[i1], tag[i2]);
    iface_of[n] = iface;
    const int m = BreakableUtil::bond_slot(atom, i1, tag[i2]);
    if (m < 0)
      error->one(FLERR, "bond_style bcm/griffith: bond {}-{} of the bond list is not in the "
                 "atom's bond arrays", tag[i1], tag[i2]);
    e.slot = store[i1] + (long) m * slot_size;
    e.twin = nullptr;
    if (i2 < nlocal) {
      const int m2 = BreakableUtil::bond_slot(atom, i2, tag[i1]);
      if (m2 >= 0) e.twin = store[i2] + (long) m2 * slot_size;
    }
    if (tag[i1] < tag[i2]) {
      e.c1 = i1;
      e.c2 = i2;
    } else {
      e.c1 = i2;
      e.c2 = i1;
    }
    cache_tags[2 * n] = tag[e.c1];
    cache_tags[2 * n + 1] = tag[e.c2];
    e.npts = interfaces[iface].npts;
    e.roff = nrec;
    e.coff = ncontact;
    nrec += record_size(e.npts);
    ncontact += NCONTACT * e.npts;
  }

  records.resize(nrec);
  contact.resize(ncontact);
  for (int n = 0; n < nbondlist; n++) {
    const Entry &e = cache[n];
    const int np = e.npts;
    const Interface &itf = interfaces[iface_of[n]];
    double *rec = &records[e.roff];
    rec[K_AREA] = itf.area;
    cache[n].type = bondlist[n][2];
    set_constants(e, bondlist[n][2], rec);
    // state: slot header and damping forces, then the contact state apart
    std::copy(e.slot, e.slot + NHEAD + 3 * np, rec + NCONST);
    std::copy(e.slot + NHEAD + 3 * np, e.slot + NHEAD + NPOINT * np, &contact[e.coff]);
    // geometry: normal in cell 1's frame, then per point b1 and b2
    const double *g = &body[itf.boff];
    double *out = rec + NCONST + NHEAD + 3 * np;
    for (int c = 0; c < 3; c++) out[c] = g[c];
    for (int k = 0; k < np; k++)
      for (int c = 0; c < 3; c++) {
        out[3 + 6 * k + c] = g[3 + 3 * k + c];
        out[6 + 6 * k + c] = g[3 + 3 * (np + k) + c];
      }
  }
  cache_store = atom->nmax > 0 ? store[0] : nullptr;
  cache_valid = true;
  dirty = false;
}

/* ----------------------------------------------------------------------
   per-point constants of an entry's interface for bond type `type`
   (SPEC 1.2: the whole-interface stiffness and damping shared by N_p points)
------------------------------------------------------------------------- */

void BondBcmGriffith::set_constants(const Entry &e, int type, double *rec) const
{
  if (type <= 0) return;
  const int np = e.npts;
  const double m1 = atom->rmass[e.c1], m2 = atom->rmass[e.c2];
  const double mred = m1 * m2 / (m1 + m2);
  // stiffness per_area: the interface's k_n, k_t are the configured ones times S / <S> (its
  // area over the mean), so the Griffith threshold is a stress, whatever the face's size
  const double f = stiffness == PER_AREA ? rec[K_AREA] / mean_area : 1.0;
  rec[K_KP] = f * kn[type] / np;
  rec[K_KTP] = f * kt[type] / np;
  rec[K_CP] = 2.0 * alpha[type] * std::sqrt(f * kn[type] * mred) / np;
  rec[K_KC] = kn_c[type] / np;
  rec[K_KTC] = kt_c[type] / np;
  rec[K_CC] = 2.0 * alpha_c[type] * std::sqrt(kn_c[type] * mred) / np;
}

/* ----------------------------------------------------------------------
   the working copy back into the per-atom store, both copies of each
   interface. Its slots are those of the atoms when the cache was built:
   atoms must not have moved or been reordered since (fix bcm/griffith calls
   this at pre_exchange, before they do).
------------------------------------------------------------------------- */

void BondBcmGriffith::sync_store()
{
  if (!dirty) return;
  dirty = false;
  if (!cache_valid || cache.empty()) return;
  const tagint *tag = atom->tag;
  const int nall = atom->nlocal + atom->nghost;
  double **store = atom->darray[store_index];
  bool moved = (atom->nmax > 0 ? store[0] : nullptr) != cache_store;
  const int ncache = (int) cache.size();
  for (int n = 0; n < ncache && !moved; n++) {
    const Entry &e = cache[n];
    moved = e.c1 >= nall || e.c2 >= nall || tag[e.c1] != cache_tags[2 * n] ||
        tag[e.c2] != cache_tags[2 * n + 1];
  }
  if (moved)
    error->one(FLERR, "bond_style bcm/griffith: the cells moved in memory before the interface "
               "state was saved (a fix that exchanges atoms before fix {} does?)",
               FixBcmGriffith::ID);
  for (int n = 0; n < ncache; n++) {
    const Entry &e = cache[n];
    const int np = e.npts;
    const double *state = &records[e.roff + NCONST];
    const double *cstate = &contact[e.coff];
    for (double *dest : {e.slot, e.twin}) {
      if (!dest) continue;
      std::copy(state, state + NHEAD + 3 * np, dest);
      std::copy(cstate, cstate + NCONTACT * np, dest + NHEAD + 3 * np);
    }
  }
}

/* ---------------------------------------------------------------------- */

void BondBcmGriffith::compute(int eflag, int vflag)
{
  ev_init(eflag, vflag);

  if (!cache_valid || neighbor->ago == 0 || (int) cache.size() != neighbor->nbondlist)
    rebuild_cache();
  nevaluations++;
  dirty = true;

  double **x = atom->x;
  double **v = atom->v;
  double **f = atom->f;
  double **omega = atom->omega;
  double **torque = atom->torque;
  double **quat = atom->darray[iquat];
  const int nlocal = atom->nlocal;
  const int nall = nlocal + atom->nghost;
  int **bondlist = neighbor->bondlist;
  const int nbondlist = neighbor->nbondlist;

  // centre, velocity, angular velocity and orientation of every cell, once per evaluation,
  // packed per cell
  cells.resize(CELL_STRIDE * (size_t) nall);
  for (int i = 0; i < nall; i++) {
    double *cell = &cells[CELL_STRIDE * (size_t) i];
    for (int c = 0; c < 3; c++) {
      cell[c] = x[i][c];
      cell[3 + c] = v[i][c];
      cell[6 + c] = omega[i][c];
    }
    double q[4] = {quat[i][0], quat[i][1], quat[i][2], quat[i][3]};
    const double qq = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
    if (qq > 0.0) BcmRigid::normalize_quat(q);
    BcmRigid::quat_to_mat(q, reinterpret_cast<double(*)[3]>(cell + 9));
  }

  const int kind = (update->whichflag == 1) ? (update->setupflag ? EVAL_SETUP : EVAL_STEP)
                                            : EVAL_NONE;
  const double dt = update->dt;
  const bigint step = update->ntimestep;
  const double time = update->atime + (double) (step - update->atimestep) * dt;

  double r2[MAX_POINTS][3], dn[MAX_POINTS], dtan[MAX_POINTS][3], dv[MAX_POINTS][3];

  for (int nb = 0; nb < nbondlist; nb++) {
    const int type = bondlist[nb][2];
    if (type <= 0) continue;
    Entry &e = cache[nb];
    const int np = e.npts;
    const int c1 = e.c1, c2 = e.c2;
    double *rec = &records[e.roff];
    if (type != e.type) {
      set_constants(e, type, rec);
      e.type = type;
    }
    double *slot = rec + NCONST;    // working copy of the slot: header, damping forces
    if (slot[H_BROKEN] == RETIRED) continue;    // for good: the pair style's now
    double *fdamp = slot + NHEAD;
    const double *g = fdamp + 3 * np;

    // ---- kinematics of the points (SPEC 1.2: contact point kinematics)
    const double *cell1 = &cells[CELL_STRIDE * (size_t) c1];
    const double *cell2 = &cells[CELL_STRIDE * (size_t) c2];
    const double(*R1)[3] = reinterpret_cast<const double(*)[3]>(cell1 + 9);
    const double(*R2)[3] = reinterpret_cast<const double(*)[3]>(cell2 + 9);
    const double *w1 = cell1 + 6, *w2 = cell2 + 6;
    double n[3], d12[3], v12[3];
    BcmRigid::rotate(R1, g, n);
    for (int c = 0; c < 3; c++) {
      d12[c] = cell2[c] - cell1[c];
      v12[c] = cell2[3 + c] - cell1[3 + c];
    }

    const int last = (int) slot[H_LAST_KIND];
    const int nkicks =
        (last != EVAL_NONE && kind != EVAL_NONE) ? (last == EVAL_STEP) + (kind == EVAL_STEP) : 0;
    bool broken = slot[H_BROKEN] != INTACT;
    bool just_broke = false;
    double e_before = 0.0;
    const double area = rec[K_AREA];
    const double kp = rec[K_KP], ktp = rec[K_KTP], cp = rec[K_CP];

    // the damping forces of the last evaluation times the relative velocities now, for the
    // damping work settled below
    double fd_dv = 0.0;

    double ftot[3] = {0.0, 0.0, 0.0}, t2[3] = {0.0, 0.0, 0.0};
    double e_total = 0.0, pd = 0.0;

    if (!broken) {
      // ---- intact interface, one pass: kinematics, energies and the forces of the intact
      // law (SPEC 1.2 Eq. 1, 3: per point k_n / N_p, k_t / N_p, 2 alpha sqrt(k_n m) / N_p).
      // Should the Griffith criterion break the interface, the forces are recomputed below
      // by the contact law from the kinematics kept here.
      double e_tension = 0.0;
      for (int k = 0; k < np; k++) {
        const double *b = g + 3 + 6 * k;
        double r1[3], delta[3], arm1[3], wa[3], wb[3];
        BcmRigid::rotate(R1, b, r1);
        BcmRigid::rotate(R2, b + 3, r2[k]);
        for (int c = 0; c < 3; c++) {
          arm1[c] = d12[c] + r2[k][c];
          delta[c] = arm1[c] - r1[c];
        }
        const double dnk = dot(delta, n);
        dn[k] = dnk;
        for (int c = 0; c < 3; c++) dtan[k][c] = delta[c] - dnk * n[c];
        cross(w2, r2[k], wa);
        cross(w1, arm1, wb);
        for (int c = 0; c < 3; c++) dv[k][c] = v12[c] + wa[c] - wb[c];

        const double en = 0.5 * kp * dnk * dnk;
        const double et = 0.5 * ktp * dot(dtan[k], dtan[k]);
        e_total += en + et;
        e_tension += (dnk > 0.0 ? en : 0.0) + et;

        double *fd = fdamp + 3 * k;
        fd_dv += dot(fd, dv[k]);
        double F[3];
        for (int c = 0; c < 3; c++) {
          fd[c] = -cp * dv[k][c];
          F[c] = -(kp * dnk * n[c] + ktp * dtan[k][c]) + fd[c];
        }
        pd -= dot(fd, dv[k]);
        double tq[3];
        cross(r2[k], F, tq);
        for (int c = 0; c < 3; c++) {
          ftot[c] += F[c];
          t2[c] += tq[c];
        }
      }

      // ---- Griffith criterion (SPEC 1.2 Eq. 4-6) on the elastic parts, before any force.
      // Delta W_p per convention: stored energy; whole-interface k at every point (N_p
      // times); per-point forces over the whole-interface k (1/N_p times)
      double dwp = e_tension;
      if (convention == ROCKABLE)
        dwp *= np;
      else if (convention == LITERAL)
        dwp /= np;
      if (dwp / (2.0 * area) >= gc[type]) {
        broken = just_broke = true;
        e_before = e_total;
        slot[H_BROKEN] = BROKEN;
        slot[H_BREAK_STEP] = (double) step;
        slot[H_BREAK_TIME] = time;
        slot[H_E_BREAK] = e_total;
        BreakPath::interface(lmp, special, c1, c2, e_total, area);    // the event log
        // the switch (SPEC 1.2): a point in compression keeps its normal force,
        // k_c (dn - s) = k_p dn, and its tangential force, u_t = (k_tp / k_tc) dt
        double *cb = &contact[e.coff];
        for (int k = 0; k < np; k++) {
          double *pt = cb + NCONTACT * k;
          const bool closed = dn[k] < 0.0;
          pt[C_SHIFT] = closed ? dn[k] * (1.0 - kp / rec[K_KC]) : 0.0;
          pt[C_TOUCH] = closed ? 1.0 : 0.0;
          double slip[3];
          const double keep = closed ? 1.0 - ktp / rec[K_KTC] : 1.0;
          for (int c = 0; c < 3; c++) slip[c] = keep * dtan[k][c];
          BcmRigid::rotate_back(R1, slip, pt + C_SLIP);
          pt[C_FT] = 0.0;
        }
      }
    } else {
      for (int k = 0; k < np; k++) {
        const double *b = g + 3 + 6 * k;
        double r1[3], delta[3], arm1[3], wa[3], wb[3];
        BcmRigid::rotate(R1, b, r1);
        BcmRigid::rotate(R2, b + 3, r2[k]);
        for (int c = 0; c < 3; c++) {
          arm1[c] = d12[c] + r2[k][c];
          delta[c] = arm1[c] - r1[c];
        }
        dn[k] = dot(delta, n);
        for (int c = 0; c < 3; c++) dtan[k][c] = delta[c] - dn[k] * n[c];
        cross(w2, r2[k], wa);
        cross(w1, arm1, wb);
        for (int c = 0; c < 3; c++) dv[k][c] = v12[c] + wa[c] - wb[c];
        fd_dv += dot(fdamp + 3 * k, dv[k]);
      }
    }

    // ---- damping work of the previous evaluation, now that the velocity after its kicks
    // is known: nkicks (h/4) F_d . (dv_then + dv_now), the exact work of a force held over
    // half kicks in velocity Verlet (translation; second order with rotation)
    if (nkicks) slot[H_W_DAMP] += 0.25 * nkicks * slot[H_LAST_DT] * (slot[H_PD] - fd_dv);

    // ---- broken interface: cohesionless frictional contacts (SPEC 1.2 Eq. 1, 7), retired
    // once the bounding spheres part (see the top of this file)
    if (broken) {
      for (int c = 0; c < 3; c++) ftot[c] = t2[c] = 0.0;
      e_total = pd = 0.0;
      const double rsum = atom->radius[c1] + atom->radius[c2];
      const bool retire = dot(d12, d12) >= rsum * rsum;
      double fric = 0.0, unpaid = 0.0, held = 0.0;
      const double kc = rec[K_KC], ktc = rec[K_KTC], cc = rec[K_CC], muf = mu[type];
      double *cb = &contact[e.coff];
      for (int k = 0; k < np; k++) {
        double *pt = cb + NCONTACT * k;
        double *fd = fdamp + 3 * k;
        double F[3];
        const double gap = dn[k] - pt[C_SHIFT];
        if (gap < 0.0) {
          double slip[3], u[3];
          if (pt[C_TOUCH] == 0.0) {    // contact onset: the tangential spring starts unloaded
            BcmRigid::rotate_back(R1, dtan[k], pt + C_SLIP);
            pt[C_TOUCH] = 1.0;
          }
          const double fn_el = -kc * gap;
          double fn = fn_el - cc * dot(dv[k], n);
          if (fn < 0.0) fn = 0.0;    // damping may not pull
          BcmRigid::rotate(R1, pt + C_SLIP, slip);
          for (int c = 0; c < 3; c++) u[c] = dtan[k][c] - slip[c];
          const double uu = dot(u, u);
          const double limit = muf * fn;
          if (ktc * ktc * uu > limit * limit) {
            // Coulomb limit: the spring is brought back to |k_tc u| = mu f_n along u, the
            // rest of the tangential displacement becomes slip. Dissipated: the mean of the
            // force magnitudes at the last and this evaluation times the slip, which is the
            // work of the force less the change of the spring energy over the step
            const double len = std::sqrt(uu);
            const double scale = limit / (ktc * len);
            fric += 0.5 * (pt[C_FT] + limit) * len * (1.0 - scale);
            for (int c = 0; c < 3; c++) {
              u[c] *= scale;
              slip[c] = dtan[k][c] - u[c];
            }
            BcmRigid::rotate_back(R1, slip, pt + C_SLIP);
          }
          for (int c = 0; c < 3; c++) {
            fd[c] = (fn - fn_el) * n[c];
            F[c] = fn * n[c] - ktc * u[c];
          }
          pt[C_FT] = ktc * std::sqrt(dot(u, u));
          e_total += 0.5 * kc * gap * gap + 0.5 * ktc * dot(u, u);
        } else {
          if (pt[C_TOUCH] != 0.0) {    // opening: the tangential spring slips free (f_n = 0)
            double slip[3], u[3];
            BcmRigid::rotate(R1, pt + C_SLIP, slip);
            for (int c = 0; c < 3; c++) u[c] = dtan[k][c] - slip[c];
            fric += 0.5 * pt[C_FT] * std::sqrt(dot(u, u));
            pt[C_TOUCH] = 0.0;
          }
          pt[C_FT] = 0.0;
          for (int c = 0; c < 3; c++) F[c] = fd[c] = 0.0;
        }
        if (just_broke) {
          // the intact springs' force at this step was replaced before its half kick:
          // (F_contact - F_intact) . dv, elastic parts
          for (int c = 0; c < 3; c++)
            unpaid += (F[c] - fd[c] + kp * dn[k] * n[c] + ktp * dtan[k][c]) * dv[k][c];
        }
        if (retire)    // power of the elastic force that retirement takes away, below
          for (int c = 0; c < 3; c++) held += (F[c] - fd[c]) * dv[k][c];
        pd -= dot(fd, dv[k]);
        double tq[3];
        cross(r2[k], F, tq);
        for (int c = 0; c < 3; c++) {
          ftot[c] += F[c];
          t2[c] += tq[c];
        }
      }

      // SPEC 1.2 switch: stored before - stored after - 2 S G_c (a Coulomb cap at the switch
      // included). The break falls between two steps: the bodies paid the intact springs'
      // last increment only for the half kick before the break, (h/2) (F_contact -
      // F_intact) . dv short, which is taken off so that the energy balance closes to O(h^2)
      if (just_broke)
        slot[H_W_SWITCH] += e_before - e_total - 2.0 * area * gc[type] -
            (kind == EVAL_STEP ? 0.5 * dt * unpaid : 0.0);
      else
        slot[H_W_FRIC] += fric;

      if (retire) {
        // the same switch, from the contact springs to nothing: lost, what they store now
        // and the half kick of their elastic force, (h/2) F_el . dv, that the bodies will
        // not get (the damping force is dropped with its work: it never kicks)
        slot[H_W_SWITCH] += e_total + (kind == EVAL_STEP ? 0.5 * dt * held : 0.0);
        slot[H_BROKEN] = RETIRED;
        for (int c = 0; c < 3; c++) ftot[c] = t2[c] = 0.0;
        e_total = pd = 0.0;
        for (int k = 0; k < np; k++) {
          double *pt = cb + NCONTACT * k;
          pt[C_TOUCH] = pt[C_FT] = 0.0;
          for (int c = 0; c < 3; c++) fdamp[3 * k + c] = 0.0;
        }
        // hand-over: the pair style sees the pair from the next step (from the next
        // reneighboring if special_bonds leaves 1-2 pairs out of the neighbor lists)
        special->add_broken_bond(atom->tag[c1], atom->tag[c2], 0);
      }
    }

    slot[H_PD] = pd;
    slot[H_E_EL] = e_total;
    slot[H_LAST_KIND] = kind;
    slot[H_LAST_DT] = dt;

    // every force acts on cell 2 at p2 and, reversed, on cell 1 at the same point:
    // torque on cell 1 = -sum (d12 + r2) x F = -(d12 x ftot + t2)
    double t1[3];
    cross(d12, ftot, t1);
    for (int c = 0; c < 3; c++) t1[c] = -(t1[c] + t2[c]);

    // newton_bond is off: each rank adds forces and torques to its owned cells only
    if (c1 < nlocal)
      for (int c = 0; c < 3; c++) {
        f[c1][c] -= ftot[c];
        torque[c1][c] += t1[c];
      }
    if (c2 < nlocal)
      for (int c = 0; c < 3; c++) {
        f[c2][c] += ftot[c];
        torque[c2][c] += t2[c];
      }

    // rigid-body virial from the centres: (x1 - x2) (x) F on cell 1
    if (evflag)
      ev_tally_xyz(c1, c2, nlocal, 0, e_total, -ftot[0], -ftot[1], -ftot[2], -d12[0], -d12[1],
                   -d12[2]);
  }
}

/* ----------------------------------------------------------------------
   the state copy of the bond between atoms i and j in an owned atom's slot
------------------------------------------------------------------------- */

const double *BondBcmGriffith::slot_of(int i, int j) const
{
  if (store_index < 0)
    error->one(FLERR, "bond_style bcm/griffith: the interface state exists from the first run");
  double **store = atom->darray[store_index];
  const tagint *tag = atom->tag;
  const int nlocal = atom->nlocal;
  int m;
  if (i < nlocal && (m = BreakableUtil::bond_slot(atom, i, tag[j])) >= 0)
    return store[i] + (long) m * slot_size;
  if (j < nlocal && (m = BreakableUtil::bond_slot(atom, j, tag[i])) >= 0)
    return store[j] + (long) m * slot_size;
  error->one(FLERR, "bond_style bcm/griffith: atoms {} and {} share no bond on this rank",
             tag[i], tag[j]);
  return nullptr;
}

/* ----------------------------------------------------------------------
   a retired interface in bond slot m of owned atom i (fix breakable/special)
------------------------------------------------------------------------- */

bool BondBcmGriffith::released(int i, int m)
{
  if (store_index < 0 || atom->bond_type[i][m] <= 0) return false;
  sync_store();
  return atom->darray[store_index][i][(long) m * slot_size + H_BROKEN] == RETIRED;
}

/* ----------------------------------------------------------------------
   a multi-point interface has no force along the centre line: fforce = 0,
   energy = the elastic energy the interface stores now. Extra values
   (compute bond/local b1..b6): state (1 intact, 0 broken), area, stored
   energy, break step, break time (both -1 while intact), energy at break.
------------------------------------------------------------------------- */

double BondBcmGriffith::single(int type, double /*rsq*/, int i, int j, double &fforce)
{
  fforce = 0.0;
  for (int k = 0; k < single_extra; k++) svector[k] = 0.0;
  if (type <= 0) return 0.0;
  sync_store();
  const double *slot = slot_of(i, j);
  const int ii = find_interface(atom->tag[i], atom->tag[j]);
  const bool broken = slot[H_BROKEN] != INTACT;
  svector[0] = broken ? 0.0 : 1.0;
  svector[1] = ii >= 0 ? interfaces[ii].area : 0.0;
  svector[2] = slot[H_E_EL];
  svector[3] = broken ? slot[H_BREAK_STEP] : -1.0;
  svector[4] = broken ? slot[H_BREAK_TIME] : -1.0;
  svector[5] = broken ? slot[H_E_BREAK] : 0.0;
  return slot[H_E_EL];
}

/* ----------------------------------------------------------------------
   this rank's part of fix bcm/griffith's vector: interfaces whose cell with
   the smaller ID is owned here. The damping term adds the first half kick of
   the last step's damping force, (h/2) F_d . dv, not yet settled.
------------------------------------------------------------------------- */

void BondBcmGriffith::tally(double *sums)
{
  for (int k = 0; k < NVECTOR; k++) sums[k] = 0.0;
  if (store_index < 0) return;
  sync_store();
  double **store = atom->darray[store_index];
  const tagint *tag = atom->tag;
  const int nlocal = atom->nlocal;
  for (int i = 0; i < nlocal; i++)
    for (int m = 0; m < atom->num_bond[i]; m++) {
      const int type = atom->bond_type[i][m];
      const tagint partner = atom->bond_atom[i][m];
      if (type <= 0 || tag[i] > partner) continue;
      const int ii = find_interface(tag[i], partner);
      if (ii < 0) continue;
      const double *slot = store[i] + (long) m * slot_size;
      const Interface &itf = interfaces[ii];
      if (slot[H_BROKEN] != INTACT) {    // broken or retired
        sums[1] += 1.0;
        sums[2] += itf.area;
        sums[3] += 2.0 * itf.area * gc[type];
      } else {
        sums[0] += 1.0;
      }
      sums[4] += slot[H_E_EL];
      const double pending = (int) slot[H_LAST_KIND] == EVAL_STEP ? slot[H_PD] : 0.0;
      sums[5] += slot[H_W_DAMP] + 0.5 * slot[H_LAST_DT] * pending;
      sums[6] += slot[H_W_FRIC];
      sums[7] += slot[H_W_SWITCH];
    }
}

/* ----------------------------------------------------------------------
   largest distance between the centres of two bonded cells in the reference
   state: the communication cutoff must reach the partners of intact
   interfaces (broken ones may part further: see the doc, lost/bond ignore)
------------------------------------------------------------------------- */

double BondBcmGriffith::equilibrium_distance(int /*type*/)
{
  return span_max;
}

/* ---------------------------------------------------------------------- */

void BondBcmGriffith::write_restart(FILE *fp)
{
  write_restart_settings(fp);
  const int n = atom->nbondtypes;
  for (double *a : {kn, kt, en2, gc, kn_c, kt_c, en2_c, mu}) fwrite(&a[1], sizeof(double), n, fp);
}

/* ---------------------------------------------------------------------- */

void BondBcmGriffith::read_restart(FILE *fp)
{
  read_restart_settings(fp);
  allocate();
  const int n = atom->nbondtypes;
  for (double *a : {kn, kt, en2, gc, kn_c, kt_c, en2_c, mu}) {
    if (comm->me == 0) utils::sfread(FLERR, &a[1], sizeof(double), n, fp, nullptr, error);
    MPI_Bcast(&a[1], n, MPI_DOUBLE, 0, world);
  }
  for (int i = 1; i <= n; i++) {
    alpha[i] = damping_ratio(en2[i]);
    alpha_c[i] = damping_ratio(en2_c[i]);
    setflag[i] = 1;
  }
}

/* ----------------------------------------------------------------------
   the convention and the whole interface table, reference included, so a
   restarted run keeps the body-frame geometry of the original reference
------------------------------------------------------------------------- */

void BondBcmGriffith::write_restart_settings(FILE *fp)
{
  const int nif = (int) interfaces.size();
  const long nspace = (long) space.size(), nbody = (long) body.size();
  fwrite(&convention, sizeof(int), 1, fp);
  fwrite(&stiffness, sizeof(int), 1, fp);
  fwrite(&reference_taken, sizeof(int), 1, fp);
  fwrite(&span_max, sizeof(double), 1, fp);
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

void BondBcmGriffith::read_restart_settings(FILE *fp)
{
  int nif = 0, nname = 0;
  long nspace = 0, nbody = 0;
  if (comm->me == 0) {
    utils::sfread(FLERR, &convention, sizeof(int), 1, fp, nullptr, error);
    utils::sfread(FLERR, &stiffness, sizeof(int), 1, fp, nullptr, error);
    utils::sfread(FLERR, &reference_taken, sizeof(int), 1, fp, nullptr, error);
    utils::sfread(FLERR, &span_max, sizeof(double), 1, fp, nullptr, error);
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
  MPI_Bcast(&convention, 1, MPI_INT, 0, world);
  MPI_Bcast(&stiffness, 1, MPI_INT, 0, world);
  MPI_Bcast(&reference_taken, 1, MPI_INT, 0, world);
  MPI_Bcast(&span_max, 1, MPI_DOUBLE, 0, world);
  MPI_Bcast(&nbody, 1, MPI_LONG, 0, world);
  MPI_Bcast(&nname, 1, MPI_INT, 0, world);
  geometry_file.resize(nname);
  if (nname) MPI_Bcast(&geometry_file[0], nname, MPI_CHAR, 0, world);
  std::vector<double> saved_body = body;
  saved_body.resize(nbody);
  MPI_Bcast(saved_body.data(), (int) nbody, MPI_DOUBLE, 0, world);
  broadcast_geometry();    // interfaces and space; resets the offsets and the look-up
  body = saved_body;
  cache_valid = false;
}

/* ---------------------------------------------------------------------- */

void BondBcmGriffith::write_data(FILE *fp)
{
  for (int i = 1; i <= atom->nbondtypes; i++)
    fmt::print(fp, "{} {} {} {} {} {} {} {} {}\n", i, kn[i], kt[i], en2[i], gc[i], kn_c[i],
               kt_c[i], en2_c[i], mu[i]);
}

/* ---------------------------------------------------------------------- */

double BondBcmGriffith::memory_usage()
{
  double bytes = Bond::memory_usage();
  bytes += (double) cache.capacity() * sizeof(Entry);
  bytes += (double) (cells.capacity() + records.capacity() + contact.capacity()) * sizeof(double);
  bytes += (double) cache_tags.capacity() * sizeof(tagint);
  bytes += (double) (space.capacity() + body.capacity()) * sizeof(double);
  bytes += (double) interfaces.capacity() * sizeof(Interface);
  return bytes;
}
