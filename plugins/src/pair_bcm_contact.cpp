/* pair_style bcm/contact (SPEC 1.2 last bullets, Eq. 1, 2, 7; see pair_bcm_contact.h).

   For a pair of cells A (smaller tag) and B with N contact points (bcm_find_contacts), at
   each point of overlap delta = h - 2 r_m < 0 (h = core distance), normal n from B to A,
   the per-point law of bcm_contact_law.h:
     f_n = k_n (-delta) + 2 alpha sqrt(k_n m / N) (-d delta/dt),   clamped at f_n >= 0
     f_t = -k_t u_t, |f_t| <= mu f_n (Coulomb; at the limit u_t = -f_t / k_t)
   with m = m_A m_B / (m_A + m_B), alpha from e_n (Eq. 2), u_t the tangential spring of the
   point: the tangential displacement of A's material point relative to B's, rotated into
   the current tangent plane (its length kept) and advanced by v_t dt each step. k_n and k_t
   are the stiffnesses of one point: a point enters and leaves at zero overlap, so a change
   of N moves no energy (an aligned face-face contact of N points is N times as stiff as a
   vertex-face point). The force acts at the point on both cells, with torques
   (p - x) x F, so that linear and angular momentum are conserved. Energy (eng_vdwl): the
   springs' energy, k_n delta^2/2 + k_t |u_t|^2/2 per point. Dissipated (compute pair extra
   values, cumulative, each pair counted once): the exact work of the normal damping over
   velocity Verlet's half kicks (bcm_kick_work.h) and Coulomb slip (mean of the last and the
   capped |f_t| times the slip); extra value [6]: the energy of tangential springs dropped
   with their history (a point that changes its pair of features or vanishes while loaded:
   dropped_springs()).

   History: u_t is kept per (pair, contact feature) in slots of a hidden per-atom array
   (fix lazy/store, ghost yes): slot = (partner tag, feature key, step, u_t[3], |f_t|),
   written into one cell of the pair owned by the computing rank (one of them is: the list's
   i; when both are, A if tag_A + tag_B is even, else B), always with the orientation
   A -> B. A slot is current when its step is this step or the previous one; a lookup
   takes the newer of the current copies in A and B. The written copy sits in an owned
   cell, migrates with it, and at reneighboring ghost cells get their owner's copies:
   whichever rank computes the pair next finds it. A copy left behind in the
   other cell is stale after one step and its slot free again. During setup (run 0, the first
   force evaluation of a run) the history is read, not advanced. */

#include "pair_bcm_contact.h"

#include "atom.h"
#include "bcm_contact_law.h"
#include "bcm_motion.h"
#include "bcm_orientation.h"
#include "bcm_rigid.h"
#include "comm.h"
#include "error.h"
#include "force.h"
#include "memory.h"
#include "neigh_list.h"
#include "neighbor.h"
#include "output.h"
#include "update.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <mpi.h>

using namespace LAMMPS_NS;
using BcmRigid::cross;
using BcmRigid::dot;

static const char *const HIST_FIX_ID = "BCM_CONTACT_HISTORY";
static const char *const HIST_NAME = "bcm_contact_history";
// slot: partner tag, feature key, step written, u_t[3], and |f_t| (the trapezoidal friction
// work)
static constexpr int SLOT = 7;
enum { S_PARTNER, S_KEY, S_STEP, S_U, S_FT = 6 };

/* ---------------------------------------------------------------------- */

PairBcmContact::PairBcmContact(LAMMPS *_lmp) :
    Pair(_lmp), rm(0.0), nslots(64), kn(nullptr), kt(nullptr), en2(nullptr), mu(nullptr),
    alpha(nullptr), iquat(-1), ihist(-1), maxrad(0.0), warned_slots(false), w_fric(0.0), w_drop(0.0),
    written_step(-1), nevals(0), saved_at(-1), saved{0.0, 0.0, 0.0, 0.0}
{
  single_enable = 0;
  // settings, coefficients and the cumulative [4]-[7] go to restart files; the tangential
  // history is the per-atom store's (a fix property/atom: restored when init_style
  // re-creates it, before LAMMPS discards the file's per-atom fix data)
  restartinfo = 1;
  finitecutflag = 1;
  born_matrix_enable = 0;
  // extra values for compute pair (see pair_bcm_contact.h)
  nextra = NEXTRA;
  pvector = new double[nextra];
  for (int k = 0; k < nextra; k++) pvector[k] = 0.0;
}

/* ---------------------------------------------------------------------- */

PairBcmContact::~PairBcmContact()
{
  delete[] pvector;
  if (allocated) {
    memory->destroy(setflag);
    memory->destroy(cutsq);
    memory->destroy(kn);
    memory->destroy(kt);
    memory->destroy(en2);
    memory->destroy(mu);
    memory->destroy(alpha);
  }
}

/* ---------------------------------------------------------------------- */

void PairBcmContact::allocate()
{
  allocated = 1;
  const int n = atom->ntypes + 1;
  memory->create(setflag, n, n, "pair:setflag");
  memory->create(cutsq, n, n, "pair:cutsq");
  memory->create(kn, n, n, "pair:kn");
  memory->create(kt, n, n, "pair:kt");
  memory->create(en2, n, n, "pair:en2");
  memory->create(mu, n, n, "pair:mu");
  memory->create(alpha, n, n, "pair:alpha");
  for (int i = 0; i < n; i++)
    for (int j = 0; j < n; j++) setflag[i][j] = 0;
}

/* ----------------------------------------------------------------------
   pair_style bcm/contact cells FILE rm R [slots N]
------------------------------------------------------------------------- */

void PairBcmContact::settings(int narg, char **arg)
{
  const char *usage = "pair_style bcm/contact cells FILE rm R [slots N]";
  std::string file;
  bool have_rm = false;
  for (int iarg = 0; iarg < narg; iarg += 2) {
    if (iarg + 1 >= narg) error->all(FLERR, "{}: keyword {} needs a value", usage, arg[iarg]);
    if (strcmp(arg[iarg], "cells") == 0) {
      file = arg[iarg + 1];
    } else if (strcmp(arg[iarg], "rm") == 0) {
      rm = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
      have_rm = true;
    } else if (strcmp(arg[iarg], "slots") == 0) {
      nslots = utils::inumeric(FLERR, arg[iarg + 1], false, lmp);
    } else {
      error->all(FLERR, "{}: unknown keyword {} (known: cells, rm, slots)", usage, arg[iarg]);
    }
  }
  if (file.empty() || !have_rm) error->all(FLERR, "{}: cells and rm are required", usage);
  if (!(rm >= 0.0)) error->all(FLERR, "pair_style bcm/contact: rm must be >= 0");
  if (nslots < 1) error->all(FLERR, "pair_style bcm/contact: slots must be >= 1");
  cells_file = file;
  table = BcmCells::load(lmp, cells_file);
}

/* ----------------------------------------------------------------------
   pair_coeff I J kn kt en2 mu
------------------------------------------------------------------------- */

void PairBcmContact::coeff(int narg, char **arg)
{
  if (narg != 6) error->all(FLERR, "Incorrect args for pair coefficients: pair_coeff I J kn kt en2 mu");
  if (!allocated) allocate();
  int ilo, ihi, jlo, jhi;
  utils::bounds(FLERR, arg[0], 1, atom->ntypes, ilo, ihi, error);
  utils::bounds(FLERR, arg[1], 1, atom->ntypes, jlo, jhi, error);
  const double kn_one = utils::numeric(FLERR, arg[2], false, lmp);
  const double kt_one = utils::numeric(FLERR, arg[3], false, lmp);
  const double en2_one = utils::numeric(FLERR, arg[4], false, lmp);
  const double mu_one = utils::numeric(FLERR, arg[5], false, lmp);
  if (!(kn_one > 0.0)) error->all(FLERR, "pair_coeff bcm/contact: kn must be > 0");
  if (!(kt_one >= 0.0)) error->all(FLERR, "pair_coeff bcm/contact: kt must be >= 0");
  if (!(en2_one >= 0.0 && en2_one <= 1.0))
    error->all(FLERR, "pair_coeff bcm/contact: en2 (e_n squared) must be in [0, 1]");
  if (!(mu_one >= 0.0)) error->all(FLERR, "pair_coeff bcm/contact: mu must be >= 0");

  int count = 0;
  for (int i = ilo; i <= ihi; i++)
    for (int j = std::max(jlo, i); j <= jhi; j++) {
      kn[i][j] = kn_one;
      kt[i][j] = kt_one;
      en2[i][j] = en2_one;
      mu[i][j] = mu_one;
      alpha[i][j] = BcmContactLaw::damping_ratio(en2_one);
      setflag[i][j] = 1;
      count++;
    }
  if (count == 0) error->all(FLERR, "Incorrect args for pair coefficients");
}

/* ---------------------------------------------------------------------- */

void PairBcmContact::init_style()
{
  if (!atom->radius_flag || !atom->rmass_flag || !atom->omega_flag || !atom->torque_flag)
    error->all(FLERR, "pair_style bcm/contact requires per-atom radius, rmass, omega and torque "
                      "(atom_style bpm/sphere)");
  if (!comm->ghost_velocity)
    error->all(FLERR, "pair_style bcm/contact requires comm_modify vel yes "
                      "(the contact damping reads ghost velocities and angular velocities)");
  if (atom->molecular != Atom::ATOMIC && atom->nbonds > 0 && force->special_lj[1] != 0.0)
    error->all(FLERR, "pair_style bcm/contact requires special_bonds lj 0 1 1: bonded cells "
                      "(interfaces) must not touch through contacts");

  iquat = BcmOrientation::find(atom, error, "pair_style bcm/contact", true);
  ihist = bcm_peratom_array(lmp, HIST_FIX_ID, HIST_NAME, SLOT * nslots, true);
  if (atom->map_style == Atom::MAP_NONE)
    error->all(FLERR, "pair_style bcm/contact requires an atom map (atom_modify map array): "
                      "the damping work of a step is settled at the next one by atom ID");

  neighbor->add_request(this, NeighConst::REQ_SIZE);

  // every owned cell has a geometry and a radius that covers its rounded core
  const int nlocal = atom->nlocal;
  const tagint *tag = atom->tag;
  const double *radius = atom->radius;
  tagint missing = 0, small = 0;
  double rad = 0.0;
  for (int i = 0; i < nlocal; i++) {
    rad = std::max(rad, radius[i]);
    const BcmCells::Cell *c = table->find(tag[i]);
    if (!c) {
      if (!missing) missing = tag[i];
    } else if (radius[i] < (c->rbound + rm) * (1.0 - 1.0e-12)) {
      if (!small) small = tag[i];
    }
  }
  tagint any[2] = {missing, small}, all_[2];
  MPI_Allreduce(any, all_, 2, MPI_LMP_TAGINT, MPI_MAX, world);
  if (all_[0])
    error->all(FLERR, "pair_style bcm/contact: cell {} has no geometry in {}", all_[0],
               cells_file);
  if (all_[1])
    error->all(FLERR,
               "pair_style bcm/contact: cell {} has a radius smaller than its bounding radius "
               "plus rm (the neighbour lists would miss contacts)",
               all_[1]);
  MPI_Allreduce(&rad, &maxrad, 1, MPI_DOUBLE, MPI_MAX, world);

  // write_restart initialises LAMMPS right before writing the file
  save_totals();
}

/* ---------------------------------------------------------------------- */

double PairBcmContact::init_one(int i, int j)
{
  if (!setflag[i][j])
    error->all(FLERR, "pair_style bcm/contact: no pair_coeff for types {} {} (no mixing)", i, j);
  kn[j][i] = kn[i][j];
  kt[j][i] = kt[i][j];
  en2[j][i] = en2[i][j];
  mu[j][i] = mu[i][j];
  alpha[j][i] = alpha[i][j];
  // pairs enter the (size) neighbour list by their radii; this only sizes bins and ghosts
  return 2.0 * maxrad;
}

/* ---------------------------------------------------------------------- */

const BcmCells::Cell *PairBcmContact::cell(int i)
{
  if (!cell_of[i] || cell_tag[i] != atom->tag[i]) {
    cell_tag[i] = atom->tag[i];
    cell_of[i] = table->find(atom->tag[i]);
    if (!cell_of[i])
      error->one(FLERR, "pair_style bcm/contact: cell {} has no geometry in {}", atom->tag[i],
                 cells_file);
  }
  return cell_of[i];
}

int PairBcmContact::place(int i)
{
  if (placed[i] < 0) {
    const BcmCells::Cell *c = cell(i);
    placed[i] = static_cast<int>(geom.size());
    geom.resize(geom.size() + 3 * c->nv + 4 * c->nf);
    bcm_place_cell(*table, *c, atom->x[i], BcmOrientation::of(atom, iquat)[i],
                   &geom[placed[i]], &geom[placed[i] + 3 * c->nv]);
  }
  return placed[i];
}

const double *PairBcmContact::place_scratch(int i, int k)
{
  const BcmCells::Cell *c = cell(i);
  std::vector<double> &g = scratch[k];
  g.resize(3 * c->nv + 4 * c->nf);
  bcm_place_cell(*table, *c, atom->x[i], BcmOrientation::of(atom, iquat)[i], g.data(),
                 g.data() + 3 * c->nv);
  return g.data();
}

/* ----------------------------------------------------------------------
   separation certificates (see pair_bcm_contact.h and bcm_motion.h)
------------------------------------------------------------------------- */

bool PairBcmContact::still_apart(const ApartCert &c, int a, int b) const
{
  if (c.ta != atom->tag[a] || c.tb != atom->tag[b]) return false;
  double **quat = BcmOrientation::of(atom, iquat);
  return BcmMotion::holds(c.motion, atom->x[a], atom->x[b], quat[a], quat[b]);
}

void PairBcmContact::certify(ApartCert &c, int a, int b, const BcmSpaceCell &sa,
                             const BcmSpaceCell &sb, double m, int side) const
{
  c.ta = 0;
  double **quat = BcmOrientation::of(atom, iquat);
  // side 0: B's points over a plane of A; 1: A's over a plane of B; 2: both ways round
  const double ra = sa.cell->rbound, rb = sb.cell->rbound;
  if (!BcmMotion::certify(c.motion, atom->x[a], atom->x[b], quat[a], quat[b], m,
                          side != 1 ? rb : -1.0, side != 0 ? ra : -1.0, ra + rb))
    return;
  c.ta = atom->tag[a];
  c.tb = atom->tag[b];
}

/* ---------------------------------------------------------------------- */

int PairBcmContact::find_slot(int i, tagint partner, double key, bigint step) const
{
  const double *h = atom->darray[ihist][i];
  const double now = static_cast<double>(step), before = static_cast<double>(step - 1);
  const double ptag = static_cast<double>(partner);
  for (int m = 0; m < nslots; m++, h += SLOT)
    if (h[S_PARTNER] == ptag && h[S_KEY] == key && (h[S_STEP] == now || h[S_STEP] == before))
      return m;
  return -1;
}

int PairBcmContact::free_slot(int i, bigint step) const
{
  const double *h = atom->darray[ihist][i];
  const double now = static_cast<double>(step), before = static_cast<double>(step - 1);
  for (int m = 0; m < nslots; m++, h += SLOT)
    if (h[S_PARTNER] == 0.0 || (h[S_STEP] != now && h[S_STEP] != before)) return m;
  return -1;
}

/* ----------------------------------------------------------------------
   the springs written at step `written` (the last step; at a setup evaluation, this one),
   in this rank's owned and ghost cells (a copy seen twice, in both cells or as two images,
   once), sorted by pair and key
------------------------------------------------------------------------- */

void PairBcmContact::collect_last_springs(bigint written)
{
  last_springs.clear();
  last_range.clear();
  const double before = static_cast<double>(written);
  const tagint *tag = atom->tag;
  const int nall = atom->nlocal + atom->nghost;
  double **hist = atom->darray[ihist];
  auto take = [&](int i, const double *h) {
    const tagint partner = static_cast<tagint>(h[S_PARTNER]);
    LastSpring e{std::min(tag[i], partner), std::max(tag[i], partner), h[S_KEY],
                 {h[S_U], h[S_U + 1], h[S_U + 2]}};
    last_springs.push_back(e);
  };
  // the slots that this rank wrote at that step, in the order of the full scan below (atom,
  // then slot): the same springs in the same order, so the same sort. Usable when that was
  // the last step, no reneighboring came since (neighbor->ago >= 1: the rows of this step's
  // ghosts and atoms are those of the last step) and no setup evaluation (written_step reset)
  if (written_step >= 0 && written_step == written && neighbor->ago >= 1 &&
      update->setupflag == 0) {
    std::sort(written_prev.begin(), written_prev.end());
    written_prev.erase(std::unique(written_prev.begin(), written_prev.end()), written_prev.end());
    for (const int64_t w : written_prev) {
      const int i = static_cast<int>(w >> 32), m = static_cast<int>(w & 0xffffffff);
      const double *h = hist[i] + SLOT * m;
      if (i < nall && h[S_PARTNER] != 0.0 && h[S_STEP] == before) take(i, h);
    }
  } else {
    for (int i = 0; i < nall; i++) {
      const double *h = hist[i];
      for (int m = 0; m < nslots; m++, h += SLOT)
        if (h[S_PARTNER] != 0.0 && h[S_STEP] == before) take(i, h);
    }
  }
  if (last_springs.empty()) return;
  auto less = [](const LastSpring &x, const LastSpring &y) {
    if (x.ta != y.ta) return x.ta < y.ta;
    if (x.tb != y.tb) return x.tb < y.tb;
    return x.key < y.key;
  };
  std::sort(last_springs.begin(), last_springs.end(), less);
  last_springs.erase(std::unique(last_springs.begin(), last_springs.end(),
                                 [](const LastSpring &x, const LastSpring &y) {
                                   return x.ta == y.ta && x.tb == y.tb && x.key == y.key;
                                 }),
                     last_springs.end());
  const int n = static_cast<int>(last_springs.size());
  for (int k = 0; k < n;) {
    int e = k + 1;
    while (e < n && last_springs[e].ta == last_springs[k].ta &&
           last_springs[e].tb == last_springs[k].tb)
      e++;
    last_range[{last_springs[k].ta, last_springs[k].tb}] = {k, e};
    k = e;
  }
}

/* ----------------------------------------------------------------------
   pair (a, b) (a = smaller tag) visited with its np current points in `points`: the energy
   of its springs of the last step whose key no current point carries (a point that changed
   its pair of features, or vanished, with its spring loaded), each k_t |u|^2 / 2, plus, at
   an advancing step, the work k_t u . Delta / 2 that the cells did against the spring's last
   force over the half kick opening this step (velocity Verlet's quadrature, as [7] counts
   it), Delta the relative displacement of the material points over the step, taken at the
   mean of the pair's new points (those of no key of the last step; else all its points; no
   point: none). At a setup evaluation (the cells moved between two runs) the springs that
   the setup force no longer carries are booked without that work, and their slots freed, so
   that the next step does not book them again. The pair's range is taken out: booked once.
------------------------------------------------------------------------- */

double PairBcmContact::dropped_springs(int a, int b, double ktij, double dt, int np,
                                       bool advance)
{
  const tagint *tag = atom->tag;
  auto it = last_range.find({tag[a], tag[b]});
  if (it == last_range.end()) return 0.0;
  const int k0 = it->second.first, k1 = it->second.second;
  last_range.erase(it);
  auto carried = [&](double key) {
    for (int k = 0; k < np; k++)
      if (static_cast<double>(points[k].key) == key) return true;
    return false;
  };
  auto in_last = [&](double key) {
    for (int k = k0; k < k1; k++)
      if (last_springs[k].key == key) return true;
    return false;
  };
  double lost = 0.0, delta[3] = {0.0, 0.0, 0.0};
  bool have_delta = false;
  for (int k = k0; k < k1; k++) {
    const LastSpring &e = last_springs[k];
    if (carried(e.key)) continue;
    if (!advance) {
      // setup: no step, no work; the slots (either cell, owned or ghost) are freed
      for (int c : {a, b}) {
        double *h = atom->darray[ihist][c];
        const double ptag = static_cast<double>(c == a ? tag[b] : tag[a]);
        for (int m = 0; m < nslots; m++, h += SLOT)
          if (h[S_PARTNER] == ptag && h[S_KEY] == e.key &&
              h[S_STEP] == static_cast<double>(update->ntimestep))
            h[S_PARTNER] = 0.0;
      }
      lost += 0.5 * ktij * dot(e.u, e.u);
      continue;
    }
    if (!have_delta && np > 0) {
      // the relative displacement over the step at the mean of the new points (else all)
      double p[3] = {0.0, 0.0, 0.0};
      int cnt = 0;
      for (int pass = 0; pass < 2 && cnt == 0; pass++)
        for (int q = 0; q < np; q++)
          if (pass == 1 || !in_last(static_cast<double>(points[q].key))) {
            for (int d = 0; d < 3; d++) p[d] += points[q].p[d];
            cnt++;
          }
      double **x = atom->x, **v = atom->v, **omega = atom->omega;
      double ra[3], rb[3], wa[3], wb[3];
      for (int d = 0; d < 3; d++) {
        p[d] /= cnt;
        ra[d] = p[d] - x[a][d];
        rb[d] = p[d] - x[b][d];
      }
      cross(omega[a], ra, wa);
      cross(omega[b], rb, wb);
      for (int d = 0; d < 3; d++) delta[d] = (v[a][d] + wa[d] - v[b][d] - wb[d]) * dt;
      have_delta = true;
    }
    lost += 0.5 * ktij * (dot(e.u, e.u) + dot(e.u, delta));
  }
  return lost;
}

/* ---------------------------------------------------------------------- */

void PairBcmContact::compute(int eflag, int vflag)
{
  ev_init(eflag, vflag);

  double **x = atom->x, **v = atom->v, **f = atom->f;
  double **omega = atom->omega, **torque = atom->torque;
  const double *rmass = atom->rmass;
  const tagint *tag = atom->tag;
  const int *type = atom->type;
  double **hist = atom->darray[ihist];
  const int nlocal = atom->nlocal;
  const int nall = nlocal + atom->nghost;
  const int newton_pair = force->newton_pair;
  const double *weight = force->special_lj;
  const bigint step = update->ntimestep;
  const bool advance = !update->setupflag;
  const double dt = update->dt;
  const double dcut = 2.0 * rm;

  // the geometry of each local cell is kept from step to step, checked by its tag (atoms
  // change indices where lists are rebuilt)
  cell_of.resize(nall, nullptr);
  cell_tag.resize(nall, 0);
  placed.assign(nall, -1);
  geom.clear();
  bigint npoints = 0, npairs = 0, nlost = 0;
  // energy accounting: the previous evaluation's forces settled now (bcm_kick_work.h)
  damp_work.begin(lmp, "pair_style bcm/contact");
  all_work.begin(lmp, "pair_style bcm/contact");
  // the springs of the last step, to book those that no point carries on (dropped_springs)
  written_prev.swap(written_slots);
  collect_last_springs(advance ? step - 1 : step);
  written_slots.clear();
  written_step = -1;

  const int inum = list->inum;
  const int *ilist = list->ilist;
  const int *numneigh = list->numneigh;
  int **firstneigh = list->firstneigh;
  // separation certificates: one per unbonded entry of this list, in its order
  if (list != cert_list || neighbor->ncalls != cert_ncalls || !advance) {
    certs.clear();
    cert_list = list;
    cert_ncalls = neighbor->ncalls;
  }
  std::size_t nentry = 0;
  // the special bits of a bonded pair (an interface, not a contact: weight 0)
  bool keep[4];
  for (int s = 0; s < 4; s++) keep[s] = weight[s] != 0.0;

  for (int ii = 0; ii < inum; ii++) {
    const int i = ilist[ii];
    const int *jlist = firstneigh[i];
    const int jnum = numneigh[i];
    // the entries that are not bonded pairs, in the list's order (without a branch each)
    if (static_cast<int>(unbonded.size()) < jnum) unbonded.resize(jnum);
    int *jpair = unbonded.data();
    int npair = 0;
    for (int jj = 0; jj < jnum; jj++) {
      const int j = jlist[jj];
      jpair[npair] = j;
      npair += keep[sbmask(j)];
    }
    for (int jp = 0; jp < npair; jp++) {
      const int j = jpair[jp] & NEIGHMASK;
      if (nentry == certs.size()) certs.emplace_back();
      ApartCert &cert = certs[nentry++];

      // A = the smaller tag: both cells' history copies and every rank agree on the order
      const tagint ti = tag[i], tj = tag[j];
      const int a = ti < tj ? i : j;
      const int b = a == i ? j : i;
      double dx[3] = {x[a][0] - x[b][0], x[a][1] - x[b][1], x[a][2] - x[b][2]};
      if (cert.ri != ti || cert.rj != tj) {
        const double reach = cell(a)->rbound + cell(b)->rbound + dcut;
        cert.reach2 = reach * reach;
        cert.ri = ti;
        cert.rj = tj;
      }
      // with newton_pair off a pair across ranks is computed on both: its energy
      // accounting is kept by the rank owning A
      const bool counted = newton_pair || a < nlocal;
      const int itype = type[i], jtype = type[j];
      // outside the bounding spheres, or still apart by the face plane of its certificate:
      // no point, the cells not placed
      if (dot(dx, dx) >= cert.reach2 || still_apart(cert, a, b)) {
        if (!last_range.empty()) {
          const double lost = dropped_springs(a, b, kt[itype][jtype], dt, 0, advance);
          if (counted) w_drop += lost;
        }
        continue;
      }

      const BcmCells::Cell *ca = cell(a), *cb = cell(b);
      const double kn_ = kn[itype][jtype], kt_ = kt[itype][jtype], mu_ = mu[itype][jtype];
      // placed once per evaluation (geom) at a step; at a setup evaluation, where every pair
      // in reach is tested (no certificate yet) and none is held for later, each pair places
      // its two cells in scratch instead: geom then holds only what steps need (issue 27)
      const double *ga, *gb;
      if (advance) {
        const int oa = place(a), ob = place(b);
        ga = &geom[oa];
        gb = &geom[ob];
      } else {
        ga = place_scratch(a, 0);
        gb = place_scratch(b, 1);
      }
      const BcmSpaceCell sa{table.get(), ca, x[a], ga, ga + 3 * ca->nv};
      const BcmSpaceCell sb{table.get(), cb, x[b], gb, gb + 3 * cb->nv};
      points.clear();
      int np = 0;
      if (bcm_cores_apart(sa, sb, dcut)) {
        int side = 0;
        const double m = bcm_apart_margin(sa, sb, dcut, side);
        certify(cert, a, b, sa, sb, m, side);
      } else {
        np = bcm_find_contacts(sa, sb, dcut, work, points, true);
        cert.ta = 0;
        if (np == 0) certify(cert, a, b, sa, sb, bcm_dead_margin(sa, sb, dcut, work), 2);
      }
      // springs of the last step that no current point carries on: their energy is lost
      if (!last_range.empty()) {
        const double lost = dropped_springs(a, b, kt_, dt, np, advance);
        if (counted) w_drop += lost;
      }
      if (np == 0) continue;
      npairs++;
      npoints += np;
      const double meff = rmass[a] * rmass[b] / (rmass[a] + rmass[b]);
      // SPEC 1.2 Eq. 1, 2: the reduced mass shared by the contact's points (bcm_contact_law.h)
      const double gamma = BcmContactLaw::damping(alpha[itype][jtype], kn_, meff, np);

      double fa[3] = {0.0, 0.0, 0.0}, ta[3] = {0.0, 0.0, 0.0}, tb[3] = {0.0, 0.0, 0.0};
      double fda[3] = {0.0, 0.0, 0.0}, tda[3] = {0.0, 0.0, 0.0}, tdb[3] = {0.0, 0.0, 0.0};
      double epair = 0.0, fric = 0.0;
      for (const BcmContactPoint &c : points) {
        const double *n = c.n;
        const double overlap = dcut - c.h;    // -delta > 0
        double ra[3], rb[3], wa[3], wb[3], vrel[3];
        for (int d = 0; d < 3; d++) {
          ra[d] = c.p[d] - x[a][d];
          rb[d] = c.p[d] - x[b][d];
        }
        cross(omega[a], ra, wa);
        cross(omega[b], rb, wb);
        for (int d = 0; d < 3; d++) vrel[d] = v[a][d] + wa[d] - v[b][d] - wb[d];
        const double vn = dot(vrel, n);

        // the point's tangential spring: from the newer current copy of its history,
        // carried into the current tangent plane (length kept) and advanced over the step
        double u[3] = {0.0, 0.0, 0.0}, ft_before = 0.0;
        const double key = static_cast<double>(c.key);
        if (kt_ > 0.0) {
          const int sa_ = find_slot(a, tag[b], key, step);
          const int sb_ = find_slot(b, tag[a], key, step);
          const double *src = nullptr;
          if (sa_ >= 0) src = &hist[a][SLOT * sa_];
          if (sb_ >= 0 && (!src || hist[b][SLOT * sb_ + S_STEP] > src[S_STEP]))
            src = &hist[b][SLOT * sb_];
          if (src) {
            for (int d = 0; d < 3; d++) u[d] = src[S_U + d];
            const double len0 = std::sqrt(dot(u, u));
            const double un = dot(u, n);
            for (int d = 0; d < 3; d++) u[d] -= un * n[d];
            const double len1 = std::sqrt(dot(u, u));
            if (len1 > 0.0)
              for (double &ud : u) ud *= len0 / len1;
            ft_before = src[S_FT];
          }
          if (advance)
            for (int d = 0; d < 3; d++) u[d] += (vrel[d] - vn * n[d]) * dt;
        }

        // SPEC 1.2 Eq. 1, 7 at one point, the per-point law
        const BcmContactLaw::Point pt =
            BcmContactLaw::point(kn_, kt_, gamma, mu_, overlap, vn, u, ft_before);

        if (kt_ > 0.0 && advance) {
          fric += pt.slip;
          // one copy, in an owned cell of the pair (i always is); when both are owned,
          // the parity of the tag sum picks one, so that cells share the load evenly
          const bool in_a = b >= nlocal || (a < nlocal && ((tag[a] + tag[b]) & 1) == 0);
          const int o = in_a ? a : b;
          const tagint partner = o == a ? tag[b] : tag[a];
          int m = find_slot(o, partner, key, step);
          if (m < 0) m = free_slot(o, step);
          if (m >= 0) {
            written_slots.push_back(static_cast<int64_t>(o) << 32 | m);
            double *dst = &hist[o][SLOT * m];
            dst[S_PARTNER] = static_cast<double>(partner);
            dst[S_KEY] = key;
            dst[S_STEP] = static_cast<double>(step);
            for (int d = 0; d < 3; d++) dst[S_U + d] = u[d];
            dst[S_FT] = pt.ftm;
          } else {
            nlost++;
          }
        }

        double F[3], tqa[3], tqb[3];
        for (int d = 0; d < 3; d++) F[d] = pt.fn * n[d] + pt.ft[d];
        cross(ra, F, tqa);
        cross(rb, F, tqb);
        for (int d = 0; d < 3; d++) {
          fa[d] += F[d];
          ta[d] += tqa[d];
          tb[d] -= tqb[d];
        }
        // the damping part of the normal force (with the clamp: what it lets go)
        double Fd[3];
        for (int d = 0; d < 3; d++) Fd[d] = (pt.fn - pt.fel) * n[d];
        cross(ra, Fd, tqa);
        cross(rb, Fd, tqb);
        for (int d = 0; d < 3; d++) {
          fda[d] += Fd[d];
          tda[d] += tqa[d];
          tdb[d] -= tqb[d];
        }
        epair += pt.stored;
      }

      if (counted) {
        damp_work.add(lmp, a, b, fda, tda, tdb);
        all_work.add(lmp, a, b, fa, ta, tb);
        if (advance) w_fric += fric;
      }

      if (a < nlocal || newton_pair) {
        for (int d = 0; d < 3; d++) {
          f[a][d] += fa[d];
          torque[a][d] += ta[d];
        }
      }
      if (b < nlocal || newton_pair) {
        for (int d = 0; d < 3; d++) {
          f[b][d] -= fa[d];
          torque[b][d] += tb[d];
        }
      }
      if (evflag) {
        // force on i, separation x_i - x_j
        const double sgn = a == i ? 1.0 : -1.0;
        ev_tally_xyz(i, j, nlocal, newton_pair, epair, 0.0, sgn * fa[0], sgn * fa[1],
                     sgn * fa[2], sgn * dx[0], sgn * dx[1], sgn * dx[2]);
      }
    }
  }

  // this advancing evaluation's writes are all of the slots stamped with its step
  if (advance) written_step = step;
  pvector[0] = static_cast<double>(npoints);
  pvector[1] = static_cast<double>(npairs);
  pvector[2] = static_cast<double>(nlost);
  pvector[3] = -damp_work.work();
  pvector[4] = w_fric;
  pvector[5] = w_drop;    // springs dropped with their history (dropped_springs)
  pvector[6] = all_work.work();
  nevals++;
  // a restart file is written at the end of this step (restart command): the totals as of
  // this evaluation, with the last step's pending half kick estimated
  if (comm->nprocs > 1 && output->restart_flag && output->next_restart == step) save_totals();
  if (nlost && !warned_slots) {
    warned_slots = true;
    error->warning(FLERR,
                   "pair_style bcm/contact: {} contact points found no free history slot "
                   "(slots {}): their friction restarts from zero; raise slots",
                   nlost, nslots);
  }
}

/* ----------------------------------------------------------------------
   cumulative [4]-[7] of this rank, the last step's forces settled over the half kick that
   closed it (exact once the step is complete: what the next run's setup settles)
------------------------------------------------------------------------- */

void PairBcmContact::local_totals(double *out)
{
  out[0] = -damp_work.work_closed(lmp, "pair_style bcm/contact");
  out[1] = w_fric;
  out[2] = w_drop;
  out[3] = all_work.work_closed(lmp, "pair_style bcm/contact");
}

void PairBcmContact::save_totals()
{
  double mine[4];
  local_totals(mine);
  MPI_Reduce(mine, saved, 4, MPI_DOUBLE, MPI_SUM, 0, world);
  saved_at = nevals;
}

/* ----------------------------------------------------------------------
   per type pair coefficients (rank 0 writes; all ranks read)
------------------------------------------------------------------------- */

void PairBcmContact::write_restart(FILE *fp)
{
  write_restart_settings(fp);
  for (int i = 1; i <= atom->ntypes; i++)
    for (int j = i; j <= atom->ntypes; j++) {
      fwrite(&setflag[i][j], sizeof(int), 1, fp);
      if (setflag[i][j])
        for (double **a : {kn, kt, en2, mu}) fwrite(&a[i][j], sizeof(double), 1, fp);
    }
}

void PairBcmContact::read_restart(FILE *fp)
{
  read_restart_settings(fp);
  allocate();
  const bool root = comm->me == 0;
  for (int i = 1; i <= atom->ntypes; i++)
    for (int j = i; j <= atom->ntypes; j++) {
      if (root) utils::sfread(FLERR, &setflag[i][j], sizeof(int), 1, fp, nullptr, error);
      MPI_Bcast(&setflag[i][j], 1, MPI_INT, 0, world);
      if (!setflag[i][j]) continue;
      for (double **a : {kn, kt, en2, mu}) {
        if (root) utils::sfread(FLERR, &a[i][j], sizeof(double), 1, fp, nullptr, error);
        MPI_Bcast(&a[i][j], 1, MPI_DOUBLE, 0, world);
      }
      alpha[i][j] = BcmContactLaw::damping_ratio(en2[i][j]);
    }
}

/* ----------------------------------------------------------------------
   the cells file name (re-read when the restart file is read, relative to the working
   directory then), rm, slots, and the cumulative [4]-[7] summed over ranks
------------------------------------------------------------------------- */

void PairBcmContact::write_restart_settings(FILE *fp)
{
  // rank 0 only: with one rank the totals are this rank's, current at any time
  if (comm->nprocs == 1) {
    local_totals(saved);
    saved_at = nevals;
  } else if (saved_at != nevals) {
    error->warning(FLERR, "pair_style bcm/contact: restart file written at a step without a "
                          "sum of the cumulative energies [4]-[7] over the ranks: they are "
                          "saved as of {} force evaluations earlier (use write_restart or the "
                          "restart command)",
                   nevals - std::max<bigint>(saved_at, 0));
  }
  const int n = static_cast<int>(cells_file.size());
  fwrite(&n, sizeof(int), 1, fp);
  fwrite(cells_file.data(), sizeof(char), n, fp);
  fwrite(&rm, sizeof(double), 1, fp);
  fwrite(&nslots, sizeof(int), 1, fp);
  fwrite(saved, sizeof(double), 4, fp);
}

void PairBcmContact::read_restart_settings(FILE *fp)
{
  const bool root = comm->me == 0;
  int n = 0;
  double totals[4] = {0.0, 0.0, 0.0, 0.0};
  if (root) {
    utils::sfread(FLERR, &n, sizeof(int), 1, fp, nullptr, error);
    cells_file.resize(n);
    if (n) utils::sfread(FLERR, &cells_file[0], sizeof(char), n, fp, nullptr, error);
    utils::sfread(FLERR, &rm, sizeof(double), 1, fp, nullptr, error);
    utils::sfread(FLERR, &nslots, sizeof(int), 1, fp, nullptr, error);
    utils::sfread(FLERR, totals, sizeof(double), 4, fp, nullptr, error);
  }
  MPI_Bcast(&n, 1, MPI_INT, 0, world);
  cells_file.resize(n);
  if (n) MPI_Bcast(&cells_file[0], n, MPI_CHAR, 0, world);
  MPI_Bcast(&rm, 1, MPI_DOUBLE, 0, world);
  MPI_Bcast(&nslots, 1, MPI_INT, 0, world);
  table = BcmCells::load(lmp, cells_file);

  // the totals carry on from rank 0 (compute pair sums the ranks); nothing pending: the
  // last step's forces were settled when the file was written
  damp_work.restore(-totals[0]);
  w_fric = totals[1];
  w_drop = totals[2];
  all_work.restore(totals[3]);
  for (int k = 0; k < nextra; k++) pvector[k] = 0.0;
  for (int k = 0; k < 4; k++) pvector[3 + k] = totals[k];
}

/* ---------------------------------------------------------------------- */

double PairBcmContact::memory_usage()
{
  double bytes = Pair::memory_usage();
  bytes += sizeof(double) * geom.capacity() + sizeof(int) * placed.capacity() +
      sizeof(void *) * cell_of.capacity() + sizeof(BcmContactPoint) * points.capacity() +
      sizeof(ApartCert) * certs.capacity();
  if (table) bytes += table->memory_usage();
  return bytes;
}
