/* bond_style bcm/griffith (SPEC 1.2; see plugins/doc/bond_bcm_griffith.md): the style, its
   working copy of the interface state and the orchestration of one force evaluation. The
   concepts it uses live apart:
     bcm_interface_table.{h,cpp}  geometry file, broadcast, look-up, reference frames, restart
     bcm_interface_state.h        the layout of an interface's state (store and working copy)
     bcm_interface_kinematics.h   the kinematics of a point (intact and broken alike)
     bcm_interface_contact.h      a point of a broken interface as a frictional contact
     bcm_griffith.h               the Griffith criterion (Eq. 4-6) and its energy conventions
     bcm_contact_law.h            the frictional contact law of a closed point (Eq. 1, 2, 7)
   An interface is intact (springs, the kernel of bcm_interface_kernel.h), breaks in break_interface(), is then a
   set of frictional contacts (contact_forces()) and is retired for good (retire()) once its
   cells part. */

#include "bond_bcm_griffith.h"

#include "atom.h"
#include "bcm_contact_law.h"
#include "bcm_griffith.h"
#include "bcm_interface_contact.h"
#include "bcm_interface_state.h"
#include "bcm_orientation.h"
#include "bcm_rigid.h"
#include "break_events.h"
#include "breakable_util.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "fix_bcm_griffith.h"
#include "force.h"
#include "memory.h"
#include "modify.h"
#include "neighbor.h"
#include "update.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <mpi.h>
#include <unordered_map>

using namespace LAMMPS_NS;
using namespace BcmInterfaceState;
using BcmInterfaceKinematics::CELL_STRIDE;
using BcmRigid::dot;

/* The intact interface's force kernel (bcm_interface_kernel.h), twice: for baseline x86-64,
   one point at a time, and for AVX, four points at a time (taken when the processor has AVX:
   BreakableUtil::avx_loops()). Both give the scalar code's results bit for bit. */
namespace {
namespace base {
using V = double;
constexpr int W = 1;
inline V load(const double *p) { return *p; }
inline void store(double *p, V v) { *p = v; }
inline void store_first(double *p, V v, int /*n >= 1*/) { *p = v; }
inline V splat(double x) { return x; }
inline V positive_or_zero(V dn, V en) { return dn > 0.0 ? en : 0.0; }
#include "bcm_interface_kernel.h"
}    // namespace base
}    // namespace

#if defined(BRITTLE_AVX_LOOPS)
#pragma GCC push_options
#pragma GCC target("avx")
namespace {
namespace avx {
#include "lanes4_avx.h"
using V = Lanes4;
constexpr int W = 4;
inline V load(const double *p)
{
  V v;
  __builtin_memcpy(&v, p, sizeof(v));
  return v;
}
inline void store(double *p, V v) { __builtin_memcpy(p, &v, sizeof(v)); }
// the first n lanes only (n < 4: the end of a row that the next row follows)
inline void store_first(double *p, V v, int n)
{
  if (n >= W) {
    store(p, v);
    return;
  }
  const Mask4 first = Mask4{0, 1, 2, 3} < Mask4{n, n, n, n};
  __builtin_ia32_maskstorepd256((Lanes4 *) p, first, v);
}
inline V splat(double x) { return V{x, x, x, x}; }
inline V positive_or_zero(V dn, V en) { return select_lt(V{}, dn, en, V{}); }    // dn > 0 ? en : 0
#include "bcm_interface_kernel.h"
}    // namespace avx
}    // namespace
#pragma GCC pop_options
#endif

static const char *const STORE_FIX_ID = "BCM_GRIFFITH_STATE";
static const char *const STORE_NAME = "bcm_griffith_state";
using BcmContactLaw::damping_ratio;

/* ---------------------------------------------------------------------- */

BondBcmGriffith::BondBcmGriffith(LAMMPS *_lmp) :
    Bond(_lmp), kn(nullptr), kt(nullptr), en2(nullptr), gc(nullptr), kn_c(nullptr),
    kt_c(nullptr), en2_c(nullptr), mu(nullptr), alpha(nullptr), alpha_c(nullptr),
    table(_lmp), convention(BcmGriffith::STORED), stiffness(PER_INTERFACE),
    broken_stiffness(CONTACT), broken_damping(CONTACT), break_shear(CARRIED), break_normal(SHIFTED),
    broken_points(POLYGON), cache_valid(false), have_state(false), atoms_moved(true),
    store_fix(nullptr), store_index(-1), iquat(-1), nevaluations(0), special(nullptr)
{
  avx_loop = BreakableUtil::avx_loops();
  writedata = 1;
  born_matrix_enable = 0;
  single_extra = 13;
  svector = new double[single_extra];
  // created now when possible so that thermo_style can name f_BCM_GRIFFITH
  if (domain->box_exist) FixBcmGriffith::get_or_create(lmp);
}

/* ---------------------------------------------------------------------- */

BondBcmGriffith::~BondBcmGriffith()
{
  // the working copy holds the only live state: a style that replaces this one takes it
  // from fix bcm/griffith (nothing is copied; at exit the fix is deleted with it)
  if (modify) {
    if (have_state) {
      auto fix = dynamic_cast<FixBcmGriffith *>(modify->get_fix_by_id(FixBcmGriffith::ID));
      if (fix) {
        fix->parked = std::make_unique<Parked>();
        fix->parked->cache.swap(cache);
        fix->parked->records.swap(records);
        fix->parked->contact.swap(contact);
        // the interfaces by their cells: the next style's table may order them otherwise
        auto &tags = fix->parked->tags;
        tags.resize(2 * fix->parked->cache.size());
        for (size_t n = 0; n < fix->parked->cache.size(); n++) {
          tags[2 * n] = table[fix->parked->cache[n].iface].tag1;
          tags[2 * n + 1] = table[fix->parked->cache[n].iface].tag2;
        }
      }
    }
    auto store = dynamic_cast<FixLazyStore *>(modify->get_fix_by_id(STORE_FIX_ID));
    if (store && store->get_owner() == this) store->set_owner(nullptr);
  }
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
                           [broken_stiffness contact|interface]
                           [broken_damping contact|interface]
                           [break_shear carried|released]
                           [break_normal shifted|unshifted]
                           [broken_points polygon|cells]
------------------------------------------------------------------------- */

// value of a two-way keyword: `first` -> 0, `second` -> 1, anything else an error
static int choice(Error *error, const char *key, const char *value, const char *first,
                  const char *second)
{
  if (strcmp(value, first) == 0) return 0;
  if (strcmp(value, second) == 0) return 1;
  error->all(FLERR, "bond_style bcm/griffith: unknown {} {} (known: {}, {})", key, value, first,
             second);
  return 0;
}

void BondBcmGriffith::settings(int narg, char **arg)
{
  std::string file;
  convention = BcmGriffith::STORED;
  stiffness = PER_INTERFACE;
  broken_stiffness = broken_damping = CONTACT;
  break_shear = CARRIED;
  break_normal = SHIFTED;
  broken_points = POLYGON;
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
      if (!BcmGriffith::parse(arg[iarg + 1], convention))
        error->all(FLERR, "bond_style bcm/griffith: unknown energy convention {} "
                   "(known: stored, rockable, literal)", arg[iarg + 1]);
    } else if (strcmp(arg[iarg], "broken_stiffness") == 0) {
      broken_stiffness = choice(error, arg[iarg], arg[iarg + 1], "contact", "interface");
    } else if (strcmp(arg[iarg], "broken_damping") == 0) {
      broken_damping = choice(error, arg[iarg], arg[iarg + 1], "contact", "interface");
    } else if (strcmp(arg[iarg], "break_shear") == 0) {
      break_shear = choice(error, arg[iarg], arg[iarg + 1], "carried", "released");
    } else if (strcmp(arg[iarg], "break_normal") == 0) {
      break_normal = choice(error, arg[iarg], arg[iarg + 1], "shifted", "unshifted");
    } else if (strcmp(arg[iarg], "broken_points") == 0) {
      broken_points = choice(error, arg[iarg], arg[iarg + 1], "polygon", "cells");
    } else {
      error->all(FLERR, "bond_style bcm/griffith: unknown keyword {} (known: geometry, energy, "
                 "stiffness, broken_stiffness, broken_damping, break_shear, break_normal, broken_points)", arg[iarg]);
    }
  }
  if (file.empty())
    error->all(FLERR, "bond_style bcm/griffith requires `geometry FILE` (the interface table)");
  table.read(file);
  cache_valid = false;
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
                      "every rank owning a cell of an interface keeps its state");
  if (atom->molecular != Atom::MOLECULAR)
    error->all(FLERR, "bond_style bcm/griffith requires a molecular atom style (not a template)");
  if (!atom->rmass || !atom->radius || !atom->omega || !atom->torque)
    error->all(FLERR, "bond_style bcm/griffith requires per-atom rmass, radius, omega and "
                      "torque (atom_style bpm/sphere)");
  if (!comm->ghost_velocity)
    error->all(FLERR, "bond_style bcm/griffith requires comm_modify vel yes "
                      "(damping reads the velocities and omega of ghost cells)");
  if (force->special_lj[1] != 0.0)
    error->all(FLERR, "bond_style bcm/griffith requires special_bonds lj 0 ... (bonded cells "
                      "interact only through their interface, not through the pair style)");
  iquat = BcmOrientation::find(atom, error, "bond_style bcm/griffith", true);

  // the records keep the last time step signed by the kind (RH_LAST): it must be > 0
  if (!(update->dt > 0.0))
    error->all(FLERR, "bond_style bcm/griffith needs a time step > 0 (timestep {})", update->dt);

  FixBcmGriffith::get_or_create(lmp);
  special = FixBreakableSpecial::get_or_create(lmp);
  // an interface across ranks evaluated by one of them (sync_copies()): its forces on the
  // other's cell travel back with the reverse communication, done only with newton on
  const char *both = std::getenv("BRITTLE_EVAL_BOTH");
  once = force->newton && force->bond == this && !(both && std::strcmp(both, "1") == 0);

  // the points' stiffness per type and N_p (point_stiffness(); per_area: per interface)
  const int nrow = BcmInterfaceTable::MAX_POINTS + 1;
  kp_of.assign((size_t) (atom->nbondtypes + 1) * nrow, 0.0);
  ktp_of.assign(kp_of.size(), 0.0);
  for (int t = 1; t <= atom->nbondtypes; t++)
    for (int np = 1; np < nrow; np++) {
      kp_of[t * nrow + np] = 1.0 * kn[t] / np;    // set_constants()'s f = 1
      ktp_of[t * nrow + np] = 1.0 * kt[t] / np;
    }

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
      if (table.find(tag[i], partner) < 0 && std::min(tag[i], partner) < missing[0]) {
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
               first, other, table.file());
  }
  bigint total = 0;
  MPI_Allreduce(&nbonds, &total, 1, MPI_LMP_BIGINT, MPI_SUM, world);
  // the store: per atom, the slots of its bonds one after the other, each as long as its
  // interface's points need (slot_offset()); as wide as the widest atom's
  long width = 1;
  for (int i = 0; i < nlocal; i++) width = std::max(width, slot_offset(i, atom->num_bond[i]));
  long store_width = 0;
  MPI_Allreduce(&width, &store_width, 1, MPI_LONG, MPI_MAX, world);
  store_index = BreakableUtil::peratom_array(lmp, STORE_FIX_ID, STORE_NAME, (int) store_width);
  store_fix = dynamic_cast<FixLazyStore *>(modify->get_fix_by_id(STORE_FIX_ID));
  if (!store_fix)
    error->all(FLERR, "bond_style bcm/griffith: fix {} is not a fix lazy/store", STORE_FIX_ID);
  store_fix->set_owner(this);
  if (total != (bigint) table.size())
    error->all(FLERR, "bond_style bcm/griffith: {} interfaces in the geometry table but {} bonds "
               "in the topology", table.size(), total);

  if (!table.has_reference()) table.take_reference(BcmOrientation::of(atom, iquat));
  adopt();
  cache_valid = false;
}

/* ----------------------------------------------------------------------
   the working copy of the style this one replaced (bond_style given again),
   kept by fix bcm/griffith: its entries' interfaces looked up again by their
   cells in this style's table
------------------------------------------------------------------------- */

void BondBcmGriffith::adopt()
{
  auto fix = FixBcmGriffith::get_or_create(lmp);
  if (!fix->parked) return;
  std::unique_ptr<Parked> p = std::move(fix->parked);
  if (have_state) return;    // this style has its own (the parked one is older)
  cache.swap(p->cache);
  records.swap(p->records);
  contact.swap(p->contact);
  const std::vector<tagint> &tags = p->tags;
  entry_of_iface.assign(table.size(), -1);
  for (int n = 0; n < (int) cache.size(); n++) {
    Entry &e = cache[n];
    e.iface = table.find(tags[2 * n], tags[2 * n + 1]);
    if (e.iface < 0 || table[e.iface].npts != e.npts)
      error->one(FLERR, "bond_style bcm/griffith: interface {}-{} of the former style is not in "
                 "geometry file {} with {} points", tags[2 * n], tags[2 * n + 1],
                 table.file(), e.npts);
    if (entry_of_iface[e.iface] < 0) entry_of_iface[e.iface] = n;
  }
  have_state = true;
  cache_valid = false;
  atoms_moved = true;
}

/* ----------------------------------------------------------------------
   the working copy of the bond list's interfaces: per entry the cells in ID
   order (with newton_bond off the neighbor code lists a bond from an owned
   atom, once when both are owned here) and a record with the constants, the
   state and the geometry. Each interface's state comes from the working
   copy before (the only live copy), else from the row of an owned cell that
   arrived with it (exchange, restart file), else it is new (zeros: intact,
   never evaluated). Rows taken are emptied; an interface of the working copy
   before that the bond list lacks now (its partner lost) while a cell of it
   is owned is handed back to that cell's row.
------------------------------------------------------------------------- */

void BondBcmGriffith::rebuild_cache()
{
  const tagint *tag = atom->tag;
  const int nlocal = atom->nlocal;
  int **bondlist = neighbor->bondlist;
  const int nbondlist = neighbor->nbondlist;
  const int ntable = table.size();

  // the entries of the new bond list: cells and interface; the slot of the listed atom
  std::vector<Entry> fresh(nbondlist);
  std::vector<int> slot1(nbondlist);
  for (int n = 0; n < nbondlist; n++) {
    int i1 = bondlist[n][0], i2 = bondlist[n][1];
    if (i1 >= nlocal) std::swap(i1, i2);
    if (i1 >= nlocal)
      error->one(FLERR, "bond_style bcm/griffith: bond {}-{} has no owned atom", tag[i1],
                 tag[i2]);
    Entry &e = fresh[n];
    e.iface = table.find(tag[i1], tag[i2]);
    if (e.iface < 0)
      error->one(FLERR, "bond_style bcm/griffith: bond {}-{} has no interface (bonds created "
                 "during a run are not supported)", tag[i1], tag[i2]);
    slot1[n] = BreakableUtil::bond_slot(atom, i1, tag[i2]);
    if (slot1[n] < 0)
      error->one(FLERR, "bond_style bcm/griffith: bond {}-{} of the bond list is not in the "
                 "atom's bond arrays", tag[i1], tag[i2]);
    if (tag[i1] < tag[i2]) {
      e.c1 = i1;
      e.c2 = i2;
    } else {
      e.c1 = i2;
      e.c2 = i1;
    }
    e.npts = table[e.iface].npts;
    e.type = bondlist[n][2];
  }

  // the bond list as before (atoms neither sorted nor migrated since): the records stay
  bool same = have_state && cache.size() == (size_t) nbondlist;
  for (int n = 0; same && n < nbondlist; n++) same = fresh[n].iface == cache[n].iface;

  // rows of owned atoms that hold something (arrived, or handed back before)
  const bool rows_held = [&] {
    for (int i = 0; i < nlocal; i++)
      if (store_fix->length(i)) return true;
    return false;
  }();

  if (same) {
    for (int n = 0; n < nbondlist; n++) {
      Entry &e = cache[n];
      e.c1 = fresh[n].c1;
      e.c2 = fresh[n].c2;
      e.type = fresh[n].type;
      set_constants(e, e.type, &records[e.roff]);
    }
  } else {
    // the state of the entries before, as their records hold it (the record's header, then
    // the damping forces' rows: SAVED(np) values), and their contact blocks: all that is read
    // back below (the records are then written over). The smallest copy (issue 27: the peak
    // of a run is at such a rebuild)
    const auto SAVED = [](int np) { return (long) NRHEAD + 3L * row_stride(np); };
    std::vector<int> old_of(ntable, -1);
    std::vector<long> soff;
    std::vector<double> saved;
    std::vector<double> old_contact;
    std::vector<Entry> old;
    std::vector<uint8_t> old_side;
    if (have_state) {
      old.swap(cache);
      old_side.swap(side);
      old_side.resize(old.size(), OWNED);    // a parked working copy (adopt()) has none
      old_contact.swap(contact);
      soff.resize(old.size());
      long ns = 0;
      for (size_t o = 0; o < old.size(); o++) {
        soff[o] = ns;
        ns += SAVED(old[o].npts);
      }
      saved.resize(ns);
      for (size_t o = 0; o < old.size(); o++) {
        const Entry &e = old[o];
        const double *rec = &records[e.roff];
        std::copy(rec + R_HEAD, rec + R_HEAD + SAVED(e.npts), &saved[soff[o]]);
        // an evaluated entry before a copy (the same state after sync_copies())
        if (old_of[e.iface] < 0 || (old_side[old_of[e.iface]] == COPY && old_side[o] != COPY))
          old_of[e.iface] = (int) o;
      }
    }
    // an old entry's state as a slot of the store (header, damping forces by point)
    const auto saved_slot = [&](size_t o, double *slot) {
      const Entry &e = old[o];
      const int np = e.npts, P = row_stride(np);
      const double *sv = &saved[soff[o]];
      const double *cb = e.coff >= 0 ? &old_contact[e.coff] : nullptr;
      compose_head_from(sv, cb, slot);
      for (int k = 0; k < np; k++)
        for (int c = 0; c < 3; c++) slot[NHEAD + 3 * k + c] = sv[NRHEAD + c * P + k];
    };
    std::vector<char> used(old.size(), 0);

    // where each new entry's state is: an entry before (>= 0), a row (-2: the atom row_from[n]
    // at row_off[n]), none (-1)
    cache.swap(fresh);
    std::vector<int> source(nbondlist, -1), row_from(nbondlist, -1);
    std::vector<long> row_off(nbondlist, 0);
    std::vector<double> slotbuf(NHEAD + NPOINT * BcmInterfaceTable::MAX_POINTS);
    long nrec = 0, ncontact = 0;
    for (int n = 0; n < nbondlist; n++) {
      Entry &e = cache[n];
      e.roff = (uint32_t) nrec;    // checked below
      nrec += record_size(e.npts);
      const int o = old_of[e.iface];
      bool broken = false;
      if (o >= 0) {
        source[n] = o;
        used[o] = 1;
        broken = saved[soff[o] + RH_BROKEN] != INTACT;
      } else if (rows_held) {
        // the row of cell 1 (the smaller ID: the rank that evaluates the interface composes
        // it) when owned, else cell 2's
        const int listed = (bondlist[n][0] < nlocal) ? bondlist[n][0] : bondlist[n][1];
        const int i1 = e.c1 < nlocal ? e.c1 : listed;
        const int i2 = i1 == e.c1 ? e.c2 : e.c1;
        const int m1 = i1 == listed ? slot1[n] : BreakableUtil::bond_slot(atom, i1, tag[i2]);
        long off = m1 >= 0 ? slot_offset(i1, m1) : (long) store_fix->length(i1);
        int from = i1;
        if ((size_t) off >= store_fix->length(i1) && i2 < nlocal) {
          const int m2 = BreakableUtil::bond_slot(atom, i2, tag[i1]);
          if (m2 >= 0 && (size_t) slot_offset(i2, m2) < store_fix->length(i2)) {
            from = i2;
            off = slot_offset(i2, m2);
          }
        }
        if ((size_t) off < store_fix->length(from)) {
          source[n] = -2;
          row_from[n] = from;
          row_off[n] = off;
          row_slot(from, off, NHEAD, slotbuf.data());
          broken = slotbuf[H_BROKEN] != INTACT;
        }
      }
      // contact state only for an interface that is broken already (one that breaks during
      // the run gets its block then: break_interface())
      e.coff = broken ? (int32_t) ncontact : -1;    // checked below
      if (broken) ncontact += contact_size(e.npts);
    }

    if (nrec + RECORD_TAIL > (long) UINT32_MAX || ncontact > (long) INT32_MAX)
      error->one(FLERR, "bond_style bcm/griffith: the {} interfaces of this rank need {} values "
                 "of state; at most {} are supported on a rank: use more ranks", nbondlist,
                 nrec + ncontact, (long) INT32_MAX);
    records.assign(nrec + RECORD_TAIL, 0.0);    // what the kernel reads past the last row
    contact.assign(ncontact, 0.0);
    double g[BcmInterfaceTable::BODY_MAX];
    for (int n = 0; n < nbondlist; n++) {
      const Entry &e = cache[n];
      const int np = e.npts, P = row_stride(np);
      const BcmInterfaceTable::Interface &itf = table[e.iface];
      double *rec = &records[e.roff];
      rec[K_AREA] = itf.area;
      set_constants(e, e.type, rec);
      // state: slot header, damping forces (per point in a slot, rows here), then the
      // contact state apart
      if (source[n] >= 0) {
        // as the record before held it: the header and the rows, then the broken-only
        // header and the points' contact state from its contact block
        const double *sv = &saved[soff[source[n]]];
        std::copy(sv, sv + SAVED(np), rec + R_HEAD);
        const long oc = old[source[n]].coff;
        if (e.coff >= 0) {
          for (int h = 0; h < NBROKEN_HEAD; h++)
            contact[e.coff + B_HEAD + h] = oc >= 0 ? old_contact[oc + B_HEAD + h] : 0.0;
          if (oc >= 0)
            std::copy(&old_contact[oc + NBHEAD], &old_contact[oc + NBHEAD] + NCONTACT * np,
                      &contact[e.coff + NBHEAD]);
        }
      } else if (source[n] == -2) {
        row_slot(row_from[n], row_off[n], NHEAD + NPOINT * np, slotbuf.data());
        entry_from_slot(e, slotbuf.data());
      }
      // geometry: normal in cell 1's frame, then the rows of b1 and of b2 (computed by the
      // table from the reference state)
      table.body_of(e.iface, g);
      double *out = rec + record_geometry(np);
      for (int c = 0; c < 3; c++) out[c] = g[c];
      for (int k = 0; k < np; k++)
        for (int c = 0; c < 3; c++) {
          out[3 + c * P + k] = g[3 + 3 * k + c];
          out[3 + 3 * P + c * P + k] = g[3 + 3 * (np + k) + c];
        }
    }

    // interfaces before that the bond list lacks now, a cell of them owned here: back to
    // that cell's row
    for (size_t o = 0; o < old.size(); o++) {
      if (used[o] || old_of[old[o].iface] != (int) o) continue;
      const tagint t1 = table[old[o].iface].tag1, t2 = table[old[o].iface].tag2;
      const Entry &e = old[o];
      const int np = e.npts;
      for (int side = 0; side < 2; side++) {
        const tagint self = side ? t2 : t1, other = side ? t1 : t2;
        const int j = atom->map(self);
        if (j < 0 || j >= nlocal) continue;
        const int m = BreakableUtil::bond_slot(atom, j, other);
        if (m < 0) continue;
        const long off = slot_offset(j, m);
        const long size = NHEAD + NPOINT * np;
        std::vector<double> row(std::max<long>(off + size, (long) store_fix->length(j)), 0.0);
        std::copy(store_fix->row(j), store_fix->row(j) + store_fix->length(j), row.begin());
        saved_slot(o, &row[off]);
        if (e.coff >= 0)
          std::copy(&old_contact[e.coff + NBHEAD], &old_contact[e.coff + NBHEAD] + NCONTACT * np,
                    row.begin() + off + NHEAD + 3 * np);
        size_t len = row.size();
        while (len > 0 && row[len - 1] == 0.0 && !std::signbit(row[len - 1])) len--;
        store_fix->set(j, row.data(), len);
      }
    }
  }

  // each entry's side, by the owner of each cell (a ghost may be the image of a cell owned
  // here too: periodic)
  side.resize(nbondlist);
  const auto owned = [&](int i) {
    const int j = i < nlocal ? i : atom->map(tag[i]);
    return j >= 0 && j < nlocal;
  };
  ncrossing_entries = 0;
  for (int n = 0; n < nbondlist; n++) {
    const bool own1 = owned(cache[n].c1), own2 = owned(cache[n].c2);
    side[n] = own1 && own2 ? OWNED : own1 ? CROSSING : COPY;
    ncrossing_entries += side[n] != OWNED;
  }
  entry_of_iface.assign(ntable, -1);
  for (int n = 0; n < nbondlist; n++) {
    int &k = entry_of_iface[cache[n].iface];
    if (k < 0 || (side[k] == COPY && side[n] != COPY)) k = n;
  }
  // rows that arrived: the slots of interfaces now in the working copy are emptied (the
  // working copy is current for them), the others kept
  if (rows_held) {
    std::vector<double> row;
    for (int i = 0; i < nlocal; i++) {
      const size_t len = store_fix->length(i);
      if (!len) continue;
      row.assign(store_fix->row(i), store_fix->row(i) + len);
      long off = 0;
      for (int m = 0; m < atom->num_bond[i] && (size_t) off < len; m++) {
        const int k = table.find(tag[i], atom->bond_atom[i][m]);
        const long size = NHEAD + NPOINT * (k >= 0 ? table[k].npts : 0);
        if (k >= 0 && entry_of_iface[k] >= 0)
          for (long v = off; v < std::min<long>(off + size, (long) len); v++) row[v] = 0.0;
        off += size;
      }
      size_t n = len;
      while (n > 0 && row[n - 1] == 0.0 && !std::signbit(row[n - 1])) n--;
      store_fix->set(i, row.data(), n);
    }
  }

  entry_of_slot.assign((size_t) nlocal * atom->bond_per_atom, -1);
  for (int n = 0; n < nbondlist; n++) {
    const Entry &e = cache[n];
    // tally() counts the interface from the owned cell with the smaller ID
    if (e.c1 < nlocal) {
      const int m1 = BreakableUtil::bond_slot(atom, e.c1, tag[e.c2]);
      if (m1 >= 0) entry_of_slot[(size_t) e.c1 * atom->bond_per_atom + m1] = n;
    }
  }
  used_cells.clear();
  for (int n = 0; n < nbondlist; n++) {
    if (once && side[n] == COPY) continue;    // not evaluated here
    used_cells.push_back(cache[n].c1);
    used_cells.push_back(cache[n].c2);
  }
  std::sort(used_cells.begin(), used_cells.end());
  used_cells.erase(std::unique(used_cells.begin(), used_cells.end()), used_cells.end());
  quiet_cert.assign(nbondlist, QuietCert());
  moves_known = false;
  cache_valid = true;
  have_state = true;
  atoms_moved = false;
}

/* ----------------------------------------------------------------------
   the stored row of owned atom i from off, size values, zeros past its length
------------------------------------------------------------------------- */

void BondBcmGriffith::row_slot(int i, long off, long size, double *out) const
{
  const long len = (long) store_fix->length(i);
  const double *row = store_fix->row(i);
  for (long v = 0; v < size; v++) out[v] = off + v < len ? row[off + v] : 0.0;
}

/* ----------------------------------------------------------------------
   the state of an entry as a slot of the store: header, damping forces by
   point, the contact state (zeros while intact)
------------------------------------------------------------------------- */

void BondBcmGriffith::slot_from_entry(const Entry &e, double *dest) const
{
  const int np = e.npts, P = row_stride(np);
  const double *rec = &records[e.roff];
  compose_head(rec, e.coff >= 0 ? &contact[e.coff] : nullptr, dest);
  for (int k = 0; k < np; k++)
    for (int c = 0; c < 3; c++) dest[NHEAD + 3 * k + c] = rec[R_FD + c * P + k];
  if (e.coff >= 0)
    std::copy(&contact[e.coff + NBHEAD], &contact[e.coff + NBHEAD] + NCONTACT * np,
              dest + NHEAD + 3 * np);
  else
    std::fill(dest + NHEAD + 3 * np, dest + NHEAD + NPOINT * np, 0.0);
}

/* ----------------------------------------------------------------------
   the inverse: an entry's state from a slot of the store (its contact block,
   if it has one, takes the broken-only header and the points' contact state)
------------------------------------------------------------------------- */

void BondBcmGriffith::entry_from_slot(const Entry &e, const double *slot)
{
  const int np = e.npts, P = row_stride(np);
  double *rec = &records[e.roff];
  split_head(slot, rec, e.coff >= 0 ? &contact[e.coff] : nullptr);
  for (int k = 0; k < np; k++)
    for (int c = 0; c < 3; c++) rec[R_FD + c * P + k] = slot[NHEAD + 3 * k + c];
  if (e.coff >= 0)
    std::copy(slot + NHEAD + 3 * np, slot + NHEAD + NPOINT * np, &contact[e.coff + NBHEAD]);
}

/* ----------------------------------------------------------------------
   fix lazy/store: atom i's row leaves (exchange, restart file). Each slot
   from the working copy where it holds the interface, else from the stored
   row; its length up to its last value that is not +0.0
------------------------------------------------------------------------- */

size_t BondBcmGriffith::compose(int i, const double *stored, size_t n, double *out)
{
  const tagint self = atom->tag[i];
  long off = 0;
  for (int m = 0; m < atom->num_bond[i]; m++) {
    const int k = table.find(self, atom->bond_atom[i][m]);
    const int np = k >= 0 ? table[k].npts : 0;
    const long size = NHEAD + NPOINT * np;
    const int e = (have_state && k >= 0) ? entry_of_iface[k] : -1;
    if (e >= 0)
      slot_from_entry(cache[e], out + off);
    else
      for (long v = 0; v < size; v++) out[off + v] = (size_t) (off + v) < n ? stored[off + v] : 0.0;
    off += size;
  }
  size_t len = (size_t) off;
  while (len > 0 && out[len - 1] == 0.0 && !std::signbit(out[len - 1])) len--;
  return len;
}

/* ----------------------------------------------------------------------
   stiffness per_area: the interface's k_n, k_t are the configured ones times S / <S> (its
   area over the mean), so the Griffith threshold is a stress, whatever the face's size;
   per_interface: 1
------------------------------------------------------------------------- */

inline double BondBcmGriffith::stiffness_factor(const double *rec) const
{
  return stiffness == PER_AREA ? rec[K_AREA] / table.mean_area() : 1.0;
}

/* ----------------------------------------------------------------------
   per-point constants of an entry's interface for bond type `type`
   (SPEC 1.2: the whole-interface stiffness and damping shared by N_p points)
------------------------------------------------------------------------- */

void BondBcmGriffith::set_constants(const Entry &e, int type, double *rec)
{
  if (type <= 0) return;
  const int np = e.npts;
  const double m1 = atom->rmass[e.c1], m2 = atom->rmass[e.c2];
  const double mred = m1 * m2 / (m1 + m2);
  const double f = stiffness_factor(rec);
  rec[K_CP] = 2.0 * alpha[type] * std::sqrt(f * kn[type] * mred) / np;
  if (e.coff >= 0) set_contact_constants(e, type, rec, &contact[e.coff]);
}

/* ----------------------------------------------------------------------
   SPEC 1.2 Eq. 1: k_n / N_p and k_t / N_p of an entry's points, the configured stiffness of
   its type split over its points; per_area: times S / <S>. Looked up, not kept per record
   (16 bytes per interface, issue 27)
------------------------------------------------------------------------- */

inline void BondBcmGriffith::point_stiffness(int type, int npts, const double *rec, double &kp,
                                             double &ktp) const
{
  if (stiffness == PER_AREA) {
    const double f = stiffness_factor(rec);
    kp = f * kn[type] / npts;
    ktp = f * kt[type] / npts;
  } else {
    const size_t k = (size_t) type * (BcmInterfaceTable::MAX_POINTS + 1) + npts;
    kp = kp_of[k];
    ktp = ktp_of[k];
  }
}

/* ----------------------------------------------------------------------
   the contact law's per-point constants of a broken interface's entry, into
   its contact block cb (rec: its record, constants set)
------------------------------------------------------------------------- */

void BondBcmGriffith::set_contact_constants(const Entry &e, int type, const double *rec,
                                            double *cb) const
{
  if (type <= 0) return;
  const int np = e.npts;
  const double m1 = atom->rmass[e.c1], m2 = atom->rmass[e.c2];
  const double mred = m1 * m2 / (m1 + m2);
  // broken interface, closed points: the contact's k_n,c / N_p, k_t,c / N_p (SPEC 1.2, the
  // frictional-contact parameters), or the intact interface's own k_p, k_tp (a closed crack
  // as stiff as the material it cut: the switch then keeps forces and energy)
  const bool own = broken_stiffness == INTERFACE;
  double kp, ktp;
  point_stiffness(type, np, rec, kp, ktp);
  cb[B_KC] = own ? kp : kn_c[type] / np;
  cb[B_KTC] = own ? ktp : kt_c[type] / np;
  // their damping (SPEC 1.2 Eq. 1): the point's stiffness and the pair's reduced mass shared
  // by the N_p points, with the contact's e_n or the interface's (with broken_stiffness
  // interface and broken_damping interface the closed point's dashpot is the intact one, c_p)
  const double a = broken_damping == INTERFACE ? alpha[type] : alpha_c[type];
  cb[B_CC] = BcmContactLaw::damping(a, cb[B_KC], mred, np);
}

/* ----------------------------------------------------------------------
   one force evaluation: per interface of the bond list, the kinematics of
   its points, then its intact springs (and the Griffith check) or its
   contacts, the damping work of the last evaluation settled in between
------------------------------------------------------------------------- */

void BondBcmGriffith::compute(int eflag, int vflag)
{
  ev_init(eflag, vflag);

  if (!cache_valid || neighbor->ago == 0 || (int) cache.size() != neighbor->nbondlist)
    rebuild_cache();
  nevaluations++;

  // centre, velocity, angular velocity and orientation of every cell, once per evaluation
  const int nall = atom->nlocal + atom->nghost;
  double **quat = BcmOrientation::of(atom, iquat);
  cells.resize(CELL_STRIDE * (size_t) nall);
  const auto pack = [&](int i) {
    BcmInterfaceKinematics::pack_cell(atom->x[i], atom->v[i], atom->omega[i], quat[i],
                                      &cells[CELL_STRIDE * (size_t) i]);
  };
  if (used_cells.size() == (size_t) nall)    // one rank: every cell (the plain loop is faster)
    for (int i = 0; i < nall; i++) pack(i);
  else
    for (const int i : used_cells) pack(i);

  Clock now;
  now.kind = (update->whichflag == 1) ? (update->setupflag ? EVAL_SETUP : EVAL_STEP) : EVAL_NONE;
  now.dt = update->dt;
  now.step = update->ntimestep;
  now.time = update->atime + (double) (now.step - update->atimestep) * now.dt;

  int **bondlist = neighbor->bondlist;
  const int nbondlist = neighbor->nbondlist;
  Point pts[BcmInterfaceTable::MAX_POINTS];
  // quiet certificates: made and used at steps only
  const bool step = now.kind == EVAL_STEP;
  cell_moves(step);
  long nbroken = 0;
  // entries across ranks here (none on one rank): the loop reads their side only then
  const bool across = once && ncrossing_entries > 0;

  for (int nb = 0; nb < nbondlist; nb++) {
    const int type = bondlist[nb][2];
    if (type <= 0) {
      quiet_cert[nb].left = -1.0f;    // not evaluated: its certificate would miss this step
      continue;
    }
    if (across && side[nb] == COPY) {    // evaluated by the owner of its cell 1
      quiet_cert[nb].left = -1.0f;
      continue;
    }
    Entry &e = cache[nb];
    double *rec = &records[e.roff];
    if (type != e.type) {
      set_constants(e, type, rec);
      e.type = type;
    }
    double *head = rec + R_HEAD;    // the record's header (every interface's fields)
    if (head[RH_BROKEN] == RETIRED) {    // for good: the pair style's now
      quiet_cert[nb].left = -1.0f;
      continue;
    }
    const int np = e.npts, P = row_stride(np);
    double *fd = rec + R_FD;    // damping forces of the last evaluation, rows of np
    const double *g = rec + record_geometry(np);    // normal in cell 1's frame, b1 rows, b2 rows

    const Pair p(&cells[CELL_STRIDE * (size_t) e.c1], &cells[CELL_STRIDE * (size_t) e.c2], g);
    // fd_dv: the damping forces of the last evaluation times the relative velocities now,
    // for the damping work settled below
    double fd_dv = 0.0;
    Result r;
    bool just_broke = false, quiet_broken = false;
    double e_before = 0.0;
    if (head[RH_BROKEN] == INTACT) {
      // SPEC 1.2 Eq. 1, 3: per point k_n / N_p, k_t / N_p and the dashpot 2 alpha sqrt(k_n m)
      // / N_p on the relative velocity; the energy of the springs in tension that the
      // Griffith criterion reads (Eq. 5)
      BcmInterfaceKinematics::IntactSums s;
      double kp, ktp;
      point_stiffness(type, np, rec, kp, ktp);
#if defined(BRITTLE_AVX_LOOPS)
      if (avx_loop)
        avx::intact_interface(p, kp, ktp, rec[K_CP], np, P, fd, g + 3, g + 3 + 3 * P, s);
      else
#endif
        base::intact_interface(p, kp, ktp, rec[K_CP], np, P, fd, g + 3, g + 3 + 3 * P, s);
      fd_dv = s.fd_dv;
      r.stored = s.stored;
      r.pd = s.pd;
      for (int c = 0; c < 3; c++) {
        r.load.f[c] = s.f[c];
        r.load.t2[c] = s.t2[c];
      }
      // SPEC 1.2 Eq. 4-6, on the elastic parts, before any force is applied; should the
      // interface break, contact_forces() replaces these forces from the same kinematics
      if (BcmGriffith::breaks(s.tension, np, convention, rec[K_AREA], gc[type])) {
        just_broke = true;
        e_before = r.stored;
        interface_points(p, g, np, pts);
        break_interface(e, rec, p, pts, r.stored, now);
      }
    } else if (quiet_now(e, nb, rec, p, g, step)) {
      // every point open, none closed at the last evaluation, no damping force left: the
      // contact law would add zeros only (forces, energies, friction, slip, damping power)
      // and write what the state holds already; the damping work of the last evaluation is
      // still settled below (fd_dv = 0)
      quiet_broken = true;
    } else {
      interface_points(p, g, np, pts);
      for (int k = 0; k < np; k++)
        fd_dv += fd[k] * pts[k].dv[0] + fd[P + k] * pts[k].dv[1] + fd[2 * P + k] * pts[k].dv[2];
    }

    // damping work of the previous evaluation, now that the velocity after its kicks is
    // known: nkicks (h/4) F_d . (dv_then + dv_now), the exact work of a force held over half
    // kicks in velocity Verlet (translation; second order with rotation)
    const int last = last_kind(head[RH_LAST]);
    const int nkicks = (last != EVAL_NONE && now.kind != EVAL_NONE)
        ? (last == EVAL_STEP) + (now.kind == EVAL_STEP)
        : 0;
    if (nkicks) head[RH_W_DAMP] += 0.25 * nkicks * last_dt(head[RH_LAST]) * (head[RH_PD] - fd_dv);
    if (just_broke) contact[e.coff + B_W_DAMP_BREAK] = head[RH_W_DAMP];

    if (quiet_broken)
      contact[e.coff + B_NCLOSED] = contact[e.coff + B_FN] = 0.0;
    else if (head[RH_BROKEN] != INTACT)
      contact_forces(e, type, rec, p, pts, just_broke, e_before, now, r);

    if (head[RH_BROKEN] != INTACT) nbroken++;
    head[RH_PD] = r.pd;
    head[RH_E_EL] = r.stored;
    head[RH_LAST] = last_of(now.kind, now.dt);
    // a quiet interface's load is zero: adding it changes no force, torque, energy or virial
    if (!quiet_broken) apply(e, p, r, across && side[nb] == CROSSING);
  }
  nbroken_last = nbroken;
}

/* ----------------------------------------------------------------------
   a broken interface whose contact law has nothing to do at this evaluation:
   its cells' bounding spheres still overlap (no retirement), and every point
   is open now (dn - s >= 0), was open at the last evaluation (not touching)
   and holds no damping force from it. Its points' forces, stored energy,
   friction, slip and damping power are then zeros, and its contact state is
   left as it is, exactly what contact_forces() would give (the sums of
   zeros it would take are zeros)
------------------------------------------------------------------------- */

bool BondBcmGriffith::quiet(const Entry &e, const double *rec, const Pair &p, const double *g,
                            double *least)
{
  const double rsum = atom->radius[e.c1] + atom->radius[e.c2];
  if (dot(p.d12, p.d12) >= rsum * rsum) return false;    // retiring: contact_forces()
  const int np = e.npts, P = row_stride(np);
  const double *fd = rec + R_FD;
  const double *cb = &contact[e.coff + NBHEAD];    // the points' contact state
  for (int k = 0; k < np; k++)
    if (cb[NCONTACT * k + C_TOUCH] != 0.0 || fd[k] != 0.0 || fd[P + k] != 0.0 ||
        fd[2 * P + k] != 0.0)
      return false;
  double dn[BcmInterfaceTable::MAX_POINTS];
#if defined(BRITTLE_AVX_LOOPS)
  if (avx_loop)
    avx::interface_gaps(p, np, P, g + 3, g + 3 + 3 * P, dn);
  else
#endif
    base::interface_gaps(p, np, P, g + 3, g + 3 + 3 * P, dn);
  for (int k = 0; k < np; k++)
    if (dn[k] - cb[NCONTACT * k + C_SHIFT] < 0.0) return false;    // closed (contact law)
  if (least) {
    *least = HUGE_VAL;
    for (int k = 0; k < np; k++) *least = std::min(*least, dn[k] - cb[NCONTACT * k + C_SHIFT]);
  }
  return true;
}

/* ----------------------------------------------------------------------
   each cell's move since the last step, for the quiet certificates: x - x_prev and
   |R(q) - R(q_prev)| = 2 |Im(q_prev^* q)| (unit quaternions; HUGE_VAL when one is more than
   1e-12 from unit length, or the last step's cells are not known: after the cache was
   rebuilt, or a setup evaluation, whose certificates are dropped). Not at a step: the
   certificates are dropped and the cells forgotten.
------------------------------------------------------------------------- */

void BondBcmGriffith::cell_moves(bool step)
{
  const int nall = atom->nlocal + atom->nghost;
  // not at a step, or no broken interface at the last evaluation (none can hold a
  // certificate at the next step): nothing kept
  if (!step || nbroken_last == 0) {
    if (moves_known) quiet_cert.assign(quiet_cert.size(), QuietCert());
    moves_known = false;
    return;
  }
  double **x = atom->x, **quat = BcmOrientation::of(atom, iquat);
  const bool known = moves_known && cell_prev.size() == 7 * (size_t) nall;
  if (!known) quiet_cert.assign(quiet_cert.size(), QuietCert());
  cell_prev.resize(7 * (size_t) nall);
  cell_move.resize(4 * (size_t) nall);
  const bool every = used_cells.size() == (size_t) nall;
  for (size_t u = 0; u < (every ? (size_t) nall : used_cells.size()); u++) {
    const int i = every ? (int) u : used_cells[u];
    double *prev = &cell_prev[7 * (size_t) i], *mv = &cell_move[4 * (size_t) i];
    const double *q = quat[i];
    if (known) {
      for (int c = 0; c < 3; c++) mv[c] = x[i][c] - prev[c];
      const double *q0 = prev + 3;
      if (std::fabs(BcmRigid::quat_norm2(q) - 1.0) > 1.0e-12 ||
          std::fabs(BcmRigid::quat_norm2(q0) - 1.0) > 1.0e-12) {
        mv[3] = HUGE_VAL;
      } else {
        // Im(q0^* q) = w0 u - w u0 - u0 x u
        double cr[3], im[3];
        BcmRigid::cross(q0 + 1, q + 1, cr);
        for (int c = 0; c < 3; c++) im[c] = q0[0] * q[1 + c] - q[0] * q0[1 + c] - cr[c];
        mv[3] = 2.0 * std::sqrt(dot(im, im));
      }
    }
    for (int c = 0; c < 3; c++) prev[c] = x[i][c];
    for (int c = 0; c < 4; c++) prev[3 + c] = q[c];
  }
  moves_known = true;
}

/* ----------------------------------------------------------------------
   quiet() of a broken interface, or what it would answer. In cell 1's frame a gap is
   dn = n_body . (R_1^T (x_2 - x_1) + R_1^T R_2 b2 - b1): over one step it moves by at most
   |D' - D| + |R_1' - R_1| (|D'| + |b2|) + |R_2' - R_2| |b2| (D = x_2 - x_1). An interface
   quiet at its last evaluation (its state unwritten since) whose certificate has some of its
   least gap left after this step's bound, and whose cells still overlap by their bounding
   spheres, is quiet again; otherwise quiet() decides, and a quiet interface gets a
   certificate (its least gap dn - s less allowances for round-off: 1e-9 of the lever arm
   and |D|, 1e-13 of the coordinates), one that is not loses it.
------------------------------------------------------------------------- */

bool BondBcmGriffith::quiet_now(const Entry &e, int nb, const double *rec, const Pair &p,
                                const double *g, bool step)
{
  QuietCert &qc = quiet_cert[nb];
  const double d2 = dot(p.d12, p.d12);
  if (step && qc.left > 0.0f) {
    const double *m1 = &cell_move[4 * (size_t) e.c1], *m2 = &cell_move[4 * (size_t) e.c2];
    const double dd[3] = {m2[0] - m1[0], m2[1] - m1[1], m2[2] - m1[2]};
    const double arm2 = qc.arm2;
    // the bound, 1e-9 over its own round-off
    const double moved =
        (std::sqrt(dot(dd, dd)) + m1[3] * (std::sqrt(d2) + arm2) + m2[3] * arm2) * (1.0 + 1.0e-9);
    const double left = static_cast<double>(qc.left) - moved;
    const double rsum = atom->radius[e.c1] + atom->radius[e.c2];
    if (left > 0.0 && d2 < rsum * rsum) {
      // rounded down to single precision: float(y) <= y (1 + 2^-24)
      const float lf = static_cast<float>(left * (1.0 - 0x1p-22));
      qc.left = lf;
      if (lf > 0.0f) return true;
    }
  }
  double least = 0.0;
  const bool q = quiet(e, rec, p, g, step ? &least : nullptr);
  qc.left = -1.0f;
  if (!q || !step) return q;
  // the lever arm: the farthest anchor of cell 2 from its centre
  const int np = e.npts, P = row_stride(np);
  const double *b2 = g + 3 + 3 * P;
  double arm2 = 0.0;
  for (int k = 0; k < np; k++)
    arm2 = std::max(arm2, b2[k] * b2[k] + b2[P + k] * b2[P + k] + b2[2 * P + k] * b2[2 * P + k]);
  arm2 = std::sqrt(arm2);
  const double *x1 = atom->x[e.c1], *x2 = atom->x[e.c2];
  const double left = least - 1.0e-9 * (arm2 + std::sqrt(d2)) -
      1.0e-13 * (std::fabs(x1[0]) + std::fabs(x1[1]) + std::fabs(x1[2]) + std::fabs(x2[0]) +
                 std::fabs(x2[1]) + std::fabs(x2[2]));
  if (!(left > 0.0)) return true;
  // rounded down and up to single precision
  qc.left = static_cast<float>(left * (1.0 - 0x1p-22));
  qc.arm2 = static_cast<float>(arm2 * (1.0 + 0x1p-22));
  return true;
}

/* ----------------------------------------------------------------------
   the points of an interface from its record's geometry (rows of np anchors)
------------------------------------------------------------------------- */

void BondBcmGriffith::interface_points(const Pair &p, const double *g, int np, Point *pts)
{
  const int P = row_stride(np);
  for (int k = 0; k < np; k++) {
    const double b1[3] = {g[3 + k], g[3 + P + k], g[3 + 2 * P + k]};
    const double b2[3] = {g[3 + 3 * P + k], g[3 + 4 * P + k], g[3 + 5 * P + k]};
    BcmInterfaceKinematics::point(p, b1, b2, pts[k]);
  }
}

/* ----------------------------------------------------------------------
   THE BREAK: the one place where an interface switches from INTACT to
   BROKEN (the Griffith criterion met at this evaluation). Records step,
   time and the energy stored just before (`stored`), and sets the contact
   state of the switch (SPEC 1.2): a point in compression keeps its normal
   force, k_c (dn - s) = k_p dn (break_normal unshifted: s = 0, the force
   jumps to k_c dn), and (break_shear carried) its tangential
   force, u_t = (k_tp / k_tc) dt, or (break_shear released) starts with an
   unloaded tangential spring, u_t = 0; a point in tension opens. What the
   springs held and no longer do is booked at the switch (contact_forces()).
------------------------------------------------------------------------- */

int32_t BondBcmGriffith::new_contact_block(int npts)
{
  if (contact.size() + (size_t) contact_size(npts) > (size_t) INT32_MAX)
    error->one(FLERR, "bond_style bcm/griffith: more broken interfaces on this rank than its "
               "contact state can hold ({} values): use more ranks", (long) INT32_MAX);
  const auto coff = (int32_t) contact.size();
  // grown by an eighth, not doubled: in a fracture the blocks arrive by thousands, and a
  // doubling holds the old array and twice it at once (issue 27: a run's peak)
  const size_t need = contact.size() + (size_t) contact_size(npts);
  if (need > contact.capacity())
    contact.reserve(std::max(need, contact.size() + contact.size() / 8 + 4096));
  contact.resize(need, 0.0);    // zeros, as in the store
  return coff;
}

/* ---------------------------------------------------------------------- */

void BondBcmGriffith::break_interface(Entry &e, double *rec, const Pair &p,
                                      const Point *pts, double stored, const Clock &now)
{
  if (e.coff < 0) e.coff = new_contact_block(e.npts);    // its contact block from now on
  double *cb = &contact[e.coff];
  set_contact_constants(e, e.type, rec, cb);
  rec[R_HEAD + RH_BROKEN] = BROKEN;
  cb[B_BREAK_STEP] = (double) now.step;
  cb[B_BREAK_TIME] = now.time;
  cb[B_E_BREAK] = stored;
  BreakPath::interface(lmp, special, e.c1, e.c2, stored, rec[K_AREA]);    // the event log

  double kp, ktp;
  point_stiffness(e.type, e.npts, rec, kp, ktp);
  for (int k = 0; k < e.npts; k++) {
    const Point &q = pts[k];
    double *pt = cb + NBHEAD + NCONTACT * k;
    const bool closed = q.dn < 0.0;
    pt[C_SHIFT] = closed && break_normal == SHIFTED ? q.dn * (1.0 - kp / cb[B_KC]) : 0.0;
    pt[C_TOUCH] = closed ? 1.0 : 0.0;
    double slip[3];
    // slip offset sigma = (1 - kept) dt, so that u_t = dt - sigma = kept dt
    const double kept = closed && break_shear == CARRIED ? ktp / cb[B_KTC] : 0.0;
    const double keep = 1.0 - kept;
    for (int c = 0; c < 3; c++) slip[c] = keep * q.dt[c];
    BcmRigid::rotate_back(p.R1, slip, pt + C_SLIP);
    pt[C_FT] = 0.0;
  }
}

/* ----------------------------------------------------------------------
   broken interface: cohesionless frictional contacts at its points (SPEC
   1.2 Eq. 1, 7), replacing whatever r held; retired once the bounding
   spheres part (retire()). At the break step (just_broke) the energy
   balance of the switch is booked, e_before being what the intact springs
   stored.
------------------------------------------------------------------------- */

void BondBcmGriffith::contact_forces(const Entry &e, int type, double *rec, const Pair &p,
                                     const Point *pts, bool just_broke, double e_before,
                                     const Clock &now, Result &r)
{
  r = Result();
  double *cb = &contact[e.coff];    // contact block: constants, broken-only header, points
  double *fdamp = rec + R_FD;    // rows of np
  const int P = row_stride(e.npts);
  const double rsum = atom->radius[e.c1] + atom->radius[e.c2];
  // broken_points cells: handed to the pair style at the break (its points never act)
  const bool retiring = (broken_points == CELLS && just_broke) || dot(p.d12, p.d12) >= rsum * rsum;
  double kp, ktp;
  point_stiffness(e.type, e.npts, rec, kp, ktp);
  const BcmInterfaceContact::Constants law{cb[B_KC], cb[B_KTC], cb[B_CC], mu[type]};
  double fric = 0.0, unpaid = 0.0, held = 0.0, slip = 0.0, fn = 0.0;
  int nclosed = 0;
  for (int k = 0; k < e.npts; k++) {
    const Point &q = pts[k];
    double fd[3], F[3];
    const BcmInterfaceContact::Energy ce =
        BcmInterfaceContact::point(law, p, q, cb + NBHEAD + NCONTACT * k, fd, F);
    for (int c = 0; c < 3; c++) fdamp[c * P + k] = fd[c];
    fric += ce.fric;
    slip += ce.slip;
    fn += ce.fn;
    nclosed += ce.closed;
    r.stored += ce.stored;
    if (just_broke) {
      // the intact springs' force at this step was replaced before its half kick:
      // (F_contact - F_intact) . dv, elastic parts
      for (int c = 0; c < 3; c++)
        unpaid += (F[c] - fd[c] + kp * q.dn * p.n[c] + ktp * q.dt[c]) * q.dv[c];
    }
    if (retiring)    // power of the elastic force that retirement takes away
      for (int c = 0; c < 3; c++) held += (F[c] - fd[c]) * q.dv[c];
    r.pd -= dot(fd, q.dv);
    r.load.add(q, F);
  }

  // SPEC 1.2 switch: stored before - stored after - 2 S G_c (a Coulomb cap at the switch
  // included). The break falls between two steps: the bodies paid the intact springs'
  // last increment only for the half kick before the break, (h/2) (F_contact -
  // F_intact) . dv short, which is taken off so that the energy balance closes to O(h^2)
  if (just_broke)
    cb[B_W_SWITCH] += e_before - r.stored - 2.0 * rec[K_AREA] * gc[type] -
        (now.kind == EVAL_STEP ? 0.5 * now.dt * unpaid : 0.0);
  else {
    cb[B_W_FRIC] += fric;
    cb[B_SLIP] += slip;
  }
  cb[B_NCLOSED] = nclosed;
  cb[B_FN] = fn;

  if (retiring) retire(e, rec, held, now, r);
}

/* ----------------------------------------------------------------------
   Retirement. The points of a broken interface are anchored to the two
   faces that were glued: they stand for the contact of those faces only
   while the cells are near each other. Far apart, the face plane of a
   turning cell 1 can sweep past a partner's anchors millimetres away and
   close a point there, with the whole separation as lever arm (a force
   from nothing, and a damping that turns unstable at that effective mass).
   So once the cells' bounding spheres part, |x2 - x1| >= r1 + r2
   (atom->radius holds the rounded cell: pair bcm/contact checks it), the
   interface is retired for good: its points open and are never evaluated
   again, what they store is counted as lost at this switch (W_switch, as
   at the break), and the pair leaves the 1-2 special lists (fix
   breakable/special), so that if the cells meet again they touch through
   pair_style bcm/contact, the polyhedral contact of SPEC 1.2. The bond
   keeps its type, its area stays in the broken area and W_f, its counters
   in the sums. Every rank holding the bond (newton_bond off: the owners of
   both cells) decides alike, from the same positions and radii of both
   cells; the partner is still a ghost when the spheres part, the
   communication cutoff reaching beyond r1 + r2 (pair bcm/contact's cutoff
   is twice the largest radius). The retired state lives in the per-slot
   header (restart files keep it), and fix breakable/special reads it at
   every run setup (released()). `held` is the power of the contacts'
   elastic forces at this evaluation.
------------------------------------------------------------------------- */

void BondBcmGriffith::retire(const Entry &e, double *rec, double held, const Clock &now,
                             Result &r)
{
  double *cb = &contact[e.coff];
  // the same switch, from the contact springs to nothing: lost, what they store now and the
  // half kick of their elastic force, (h/2) F_el . dv, that the bodies will not get (the
  // damping force is dropped with its work: it never kicks)
  cb[B_W_SWITCH] += r.stored + (now.kind == EVAL_STEP ? 0.5 * now.dt * held : 0.0);
  rec[R_HEAD + RH_BROKEN] = RETIRED;
  cb[B_NCLOSED] = cb[B_FN] = 0.0;
  r = Result();
  double *fdamp = rec + R_FD;
  const int P = row_stride(e.npts);
  for (int k = 0; k < e.npts; k++) {
    double *pt = cb + NBHEAD + NCONTACT * k;
    pt[C_TOUCH] = pt[C_FT] = 0.0;
    for (int c = 0; c < 3; c++) fdamp[c * P + k] = 0.0;
  }
  // hand-over: the pair style sees the pair from the next step (from the next reneighboring
  // if special_bonds leaves 1-2 pairs out of the neighbor lists)
  special->add_broken_bond(atom->tag[e.c1], atom->tag[e.c2], 0);
}

/* ----------------------------------------------------------------------
   the forces of an interface on its cells, and the rigid-body virial from
   the centres, (x1 - x2) (x) F on cell 1. newton_bond is off: a rank adds to
   its owned cells only, except for an interface across ranks evaluated once
   (both): its rank adds to both cells (the ghost's forces travel back to its
   owner) and tallies all of its energy and virial
------------------------------------------------------------------------- */

void BondBcmGriffith::apply(const Entry &e, const Pair &p, const Result &r, bool both)
{
  double **f = atom->f;
  double **torque = atom->torque;
  const int nlocal = atom->nlocal;
  const double *ftot = r.load.f, *t2 = r.load.t2;
  double t1[3];
  r.load.torque1(p, t1);
  if (e.c1 < nlocal)
    for (int c = 0; c < 3; c++) {
      f[e.c1][c] -= ftot[c];
      torque[e.c1][c] += t1[c];
    }
  if (e.c2 < nlocal || both)
    for (int c = 0; c < 3; c++) {
      f[e.c2][c] += ftot[c];
      torque[e.c2][c] += t2[c];
    }
  if (evflag)
    ev_tally_xyz(e.c1, e.c2, nlocal, both ? 1 : 0, r.stored, -ftot[0], -ftot[1], -ftot[2],
                 -p.d12[0], -p.d12[1], -p.d12[2]);
}

/* ----------------------------------------------------------------------
   where bond slot m of owned atom i starts in its store row: after the slots
   before it, each NHEAD + NPOINT N_p long for its interface's N_p points (the
   bonds of an atom keep their slots for good: bonds are never deleted)
------------------------------------------------------------------------- */

long BondBcmGriffith::slot_offset(int i, int m) const
{
  const tagint *batom = atom->bond_atom[i];
  const tagint self = atom->tag[i];
  long off = 0;
  for (int k = 0; k < m; k++) {
    const int ii = table.find(self, batom[k]);
    off += NHEAD + NPOINT * (ii >= 0 ? table[ii].npts : 0);
  }
  return off;
}

/* ----------------------------------------------------------------------
   the header of the interface in bond slot m of owned atom i: the working
   copy's when it holds the interface, else the atom's stored row (zeros past
   its length: an interface never evaluated), copied into scratch (NHEAD)
------------------------------------------------------------------------- */

const double *BondBcmGriffith::header_of(int i, int m, double *scratch) const
{
  const int k = table.find(atom->tag[i], atom->bond_atom[i][m]);
  const int n = (have_state && k >= 0) ? entry_of_iface[k] : -1;
  if (n >= 0) {
    const Entry &e = cache[n];
    compose_head(&records[e.roff], e.coff >= 0 ? &contact[e.coff] : nullptr, scratch);
    return scratch;
  }
  if (store_fix)
    row_slot(i, slot_offset(i, m), NHEAD, scratch);
  else
    std::fill(scratch, scratch + NHEAD, 0.0);
  return scratch;
}

/* ----------------------------------------------------------------------
   the header of the bond between atoms i and j, from an owned atom's side
------------------------------------------------------------------------- */

const double *BondBcmGriffith::slot_of(int i, int j, double *scratch) const
{
  if (store_index < 0)
    error->one(FLERR, "bond_style bcm/griffith: the interface state exists from the first run");
  const tagint *tag = atom->tag;
  const int nlocal = atom->nlocal;
  int m;
  if (i < nlocal && (m = BreakableUtil::bond_slot(atom, i, tag[j])) >= 0)
    return header_of(i, m, scratch);
  if (j < nlocal && (m = BreakableUtil::bond_slot(atom, j, tag[i])) >= 0)
    return header_of(j, m, scratch);
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
  double scratch[NHEAD];
  return header_of(i, m, scratch)[H_BROKEN] == RETIRED;
}

/* ----------------------------------------------------------------------
   the copies of interfaces evaluated on another rank take their state from
   the rank evaluating them: each rank sends its evaluated entries whose
   cell 2 is a ghost (interface, then its state as a slot of the store) to
   all ranks. Collective; see the
   header. A retired interface is released from the special lists of the
   copy's owned cell here, as the evaluating rank released its own.
------------------------------------------------------------------------- */

void BondBcmGriffith::sync_copies()
{
  if (!once) return;
  const bool ready = have_state && side.size() == cache.size();
  std::vector<double> mine;
  if (ready)
    for (size_t n = 0; n < cache.size(); n++) {
      if (side[n] != CROSSING) continue;
      const Entry &e = cache[n];
      const size_t at = mine.size();
      mine.resize(at + 1 + NHEAD + NPOINT * e.npts);
      mine[at] = (double) e.iface;
      slot_from_entry(e, &mine[at + 1]);
    }
  const int nprocs = comm->nprocs;
  const int nmine = (int) mine.size();
  std::vector<int> counts(nprocs), displs(nprocs, 0);
  MPI_Allgather(&nmine, 1, MPI_INT, counts.data(), 1, MPI_INT, world);
  long total = 0;
  for (int p = 0; p < nprocs; p++) {
    displs[p] = (int) total;
    total += counts[p];
  }
  if (total > (long) INT32_MAX)
    error->all(FLERR, "bond_style bcm/griffith: the interfaces across ranks hold more state than "
               "one exchange carries ({} values)", total);
  if (total == 0) return;
  std::vector<double> all(total);
  MPI_Allgatherv(mine.data(), nmine, MPI_DOUBLE, all.data(), counts.data(), displs.data(),
                 MPI_DOUBLE, world);
  if (!ready) return;
  std::unordered_map<int, long> slot_at;
  for (long at = 0; at < total;) {
    const int k = (int) all[at];
    slot_at.emplace(k, at + 1);
    at += 1 + NHEAD + NPOINT * table[k].npts;
  }
  for (size_t n = 0; n < cache.size(); n++) {
    if (side[n] != COPY) continue;
    const auto it = slot_at.find(cache[n].iface);
    if (it != slot_at.end()) load_copy(cache[n], &all[it->second]);
  }
}

/* ----------------------------------------------------------------------
   a copy's state from the evaluating rank's slot (sync_copies()). A contact
   block is made when the slot is broken; its constants are set at the
   rebuild of the working copy that follows every sync (the re-neighbouring,
   the next run's setup) before any evaluation
------------------------------------------------------------------------- */

void BondBcmGriffith::load_copy(Entry &e, const double *slot)
{
  const double *rec = &records[e.roff];
  const bool was_retired = rec[R_HEAD + RH_BROKEN] == RETIRED;
  if (slot[H_BROKEN] != INTACT && e.coff < 0) e.coff = new_contact_block(e.npts);
  entry_from_slot(e, slot);
  if (!was_retired && rec[R_HEAD + RH_BROKEN] == RETIRED)
    special->add_broken_bond(table[e.iface].tag1, table[e.iface].tag2, 0);
}

/* ----------------------------------------------------------------------
   a multi-point interface has no force along the centre line: fforce = 0,
   energy = the elastic energy the interface stores now. Extra values
   (compute bond/local b1..b13): state (1 intact, 0 broken), area, stored
   energy, break step, break time (both -1 while intact), energy at break;
   its cumulative damping work, the part of it after the break, friction
   work, switch loss, Coulomb slip; its closed points and their normal force
   at the last evaluation (0 while intact or retired).
------------------------------------------------------------------------- */

double BondBcmGriffith::single(int type, double /*rsq*/, int i, int j, double &fforce)
{
  fforce = 0.0;
  for (int k = 0; k < single_extra; k++) svector[k] = 0.0;
  if (type <= 0) return 0.0;
  double scratch[NHEAD];
  const double *slot = slot_of(i, j, scratch);
  const int ii = table.find(atom->tag[i], atom->tag[j]);
  const bool broken = slot[H_BROKEN] != INTACT;
  svector[0] = broken ? 0.0 : 1.0;
  svector[1] = ii >= 0 ? table[ii].area : 0.0;
  svector[2] = slot[H_E_EL];
  svector[3] = broken ? slot[H_BREAK_STEP] : -1.0;
  svector[4] = broken ? slot[H_BREAK_TIME] : -1.0;
  svector[5] = broken ? slot[H_E_BREAK] : 0.0;
  svector[6] = slot[H_W_DAMP];
  svector[7] = broken ? slot[H_W_DAMP] - slot[H_W_DAMP_BREAK] : 0.0;
  svector[8] = slot[H_W_FRIC];
  svector[9] = slot[H_W_SWITCH];
  svector[10] = slot[H_SLIP];
  svector[11] = slot[H_NCLOSED];
  svector[12] = slot[H_FN];
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
  // an interface of the bond list is read from the working copy, one that is not (its
  // partner out of reach) from the store, which holds it then; either way in the order of the
  // owned atoms and their bond slots, so that the sums do not depend on where an interface's
  // state lives
  const bool cached = cache_valid && !atoms_moved &&
      entry_of_slot.size() == (size_t) atom->nlocal * atom->bond_per_atom;
  double scratch[NHEAD];
  const tagint *tag = atom->tag;
  const int nlocal = atom->nlocal;
  const int bpa = atom->bond_per_atom;
  // one interface's fields (a record's header and contact block, or a composed slot) into
  // the sums, in the same order for both
  const auto add = [&](double broken, double area, int type, double e_el, double w_damp,
                       double last_kind_, double last_dt_, double pd, const double *bh) {
    if (broken != INTACT) {    // broken or retired
      sums[1] += 1.0;
      sums[2] += area;
      sums[3] += 2.0 * area * gc[type];
    } else {
      sums[0] += 1.0;
    }
    sums[4] += e_el;
    const double pending = (int) last_kind_ == EVAL_STEP ? pd : 0.0;
    const double damp = w_damp + 0.5 * last_dt_ * pending;
    sums[5] += damp;
    // bh: the broken-only fields in BROKEN_HEAD's order (nullptr while intact: zeros)
    sums[6] += bh ? bh[B_W_FRIC - B_HEAD] : 0.0;
    sums[7] += bh ? bh[B_W_SWITCH - B_HEAD] : 0.0;
    if (broken != INTACT) {
      const double nclosed = bh ? bh[B_NCLOSED - B_HEAD] : 0.0;
      sums[8] += nclosed > 0.0;
      sums[9] += nclosed;
      sums[10] += bh ? bh[B_FN - B_HEAD] : 0.0;
      sums[11] += bh ? bh[B_SLIP - B_HEAD] : 0.0;
      sums[12] += damp - (bh ? bh[B_W_DAMP_BREAK - B_HEAD] : 0.0);
    }
  };
  for (int i = 0; i < nlocal; i++)
    for (int m = 0; m < atom->num_bond[i]; m++) {
      const int type = atom->bond_type[i][m];
      const tagint partner = atom->bond_atom[i][m];
      if (type <= 0 || tag[i] > partner) continue;
      const int n = cached ? entry_of_slot[(size_t) i * bpa + m] : -1;
      if (n >= 0) {    // the working copy's fields as they are (compose_head()'s values)
        const Entry &e = cache[n];
        const double *rh = &records[e.roff] + R_HEAD;
        add(rh[RH_BROKEN], records[e.roff + K_AREA], type, rh[RH_E_EL], rh[RH_W_DAMP],
            last_kind(rh[RH_LAST]), last_dt(rh[RH_LAST]), rh[RH_PD],
            e.coff >= 0 ? &contact[e.coff + B_HEAD] : nullptr);
      } else {
        const int ii = table.find(tag[i], partner);
        if (ii < 0) continue;
        const double *slot = header_of(i, m, scratch);
        double bh[NBROKEN_HEAD];
        for (int h = 0; h < NBROKEN_HEAD; h++) bh[h] = slot[BROKEN_HEAD[h]];
        add(slot[H_BROKEN], table[ii].area, type, slot[H_E_EL], slot[H_W_DAMP],
            slot[H_LAST_KIND], slot[H_LAST_DT], slot[H_PD], bh);
      }
    }
}

/* ----------------------------------------------------------------------
   largest distance between the centres of two bonded cells in the reference
   state: the communication cutoff must reach the partners of intact
   interfaces (broken ones may part further: see the doc, lost/bond ignore)
------------------------------------------------------------------------- */

double BondBcmGriffith::equilibrium_distance(int /*type*/)
{
  return table.span_max();
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
   the convention, the stiffness mode and the whole interface table, the
   reference state of its cells and box included, so a restarted run keeps
   the body frames of the original reference
------------------------------------------------------------------------- */

void BondBcmGriffith::write_restart_settings(FILE *fp)
{
  for (const int *v :
       {&convention, &stiffness, &broken_stiffness, &broken_damping, &break_shear, &break_normal,
        &broken_points})
    fwrite(v, sizeof(int), 1, fp);
  table.write_restart(fp);
}

/* ---------------------------------------------------------------------- */

void BondBcmGriffith::read_restart_settings(FILE *fp)
{
  int *settings[] = {&convention,     &stiffness,   &broken_stiffness,
                     &broken_damping, &break_shear, &break_normal, &broken_points};
  if (comm->me == 0)
    for (int *v : settings) utils::sfread(FLERR, v, sizeof(int), 1, fp, nullptr, error);
  table.read_restart(fp);
  for (int *v : settings) MPI_Bcast(v, 1, MPI_INT, 0, world);
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
  bytes += (double) (entry_of_iface.capacity() + entry_of_slot.capacity()) * sizeof(int);
  bytes += table.memory_usage();
  return bytes;
}
