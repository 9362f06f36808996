/* fix bcm/wall (see fix_bcm_wall.h).

   Plane x[axis] = coord with unit normal n_w = side e_axis pointing to the cells' side.
   A cell with N vertices at heights h_k < r_m over the plane has N contact points, each
   with overlap delta_k = h_k - r_m < 0, at the midpoint between the plane and the bottom
   of the vertex's sphere, under the per-point law of bcm_contact_law.h (SPEC 1.2 Eq. 1, 2,
   7; m = the cell's mass, wall at rest):
     f_n = k_n (-delta) + 2 alpha sqrt(k_n m / N) (-d delta/dt),   clamped at f_n >= 0
     f_t = -k_t u_t,  |f_t| <= mu f_n  (at the limit u_t = -f_t / k_t)
   u_t = tangential displacement of the vertex's material point along the plane since the
   contact began, kept per (cell, vertex) in slots of a hidden per-atom array
   (vertex + 1, step, u_t[3], |f_t|); a slot is current when written at this step or the
   previous one. The setup force evaluation reads the history without advancing it.
   Energy accounting (the same as pair_style bcm/contact and bond_style bcm/griffith):
   stored = k_n delta^2/2 + k_t |u_t|^2/2 per vertex; damping: the exact work of the damping
   force (f_n - k_n (-delta)) n_w (the energy a clamped f_n lets go included) over the half
   kicks of velocity Verlet (bcm_kick_work.h); friction: per Coulomb cap, the mean of the
   previous and the capped |f_t| times the slip, and when a vertex stops touching, its
   spring's energy (it slips free). A vertex starts and stops touching at zero overlap, so
   a change of N moves no energy: vector value [7] is identically zero.

   Option `stiffness per_cell` (not the SPEC 1.2 law: a diagnostic of what the plane's law
   does to an impact): the cell's contact is one spring k_n, k_t shared by its N touching
   vertices, k_n / N and k_t / N each, damping 2 alpha sqrt(k_n m) / N each. When N changes
   the same deformation stores another energy: the jump, (1/N - 1/N_before) times the mean
   of the whole-stiffness energies E_w = sum k_n delta^2/2 + k_t |u_t|^2/2 at the two steps
   (velocity Verlet's trapezoid puts the switch at mid-step), is booked in [7] (negative
   when the re-split creates energy). */

#include "fix_bcm_wall.h"

#include "atom.h"
#include "bcm_contact_law.h"
#include "bcm_rigid.h"
#include "comm.h"
#include "error.h"
#include "memory.h"
#include "update.h"

#include <cmath>
#include <cstring>
#include <mpi.h>

using namespace LAMMPS_NS;
using namespace FixConst;
using BcmRigid::cross;
using BcmRigid::dot;

// slot: vertex + 1, step written, u_t[3], |f_t| (the trapezoidal friction work), and for
// stiffness per_cell the cell's N and whole-stiffness energy E_w at that step
static constexpr int SLOT = 8;
enum { S_VERTEX, S_STEP, S_U, S_FT = 5, S_NP, S_EWHOLE };

/* ----------------------------------------------------------------------
   fix ID group bcm/wall cells FILE rm R plane FACE VALUE kn kt en2 mu [slots N]
                         [stiffness per_point|per_cell]
------------------------------------------------------------------------- */

FixBcmWall::FixBcmWall(LAMMPS *_lmp, int narg, char **arg) :
    Fix(_lmp, narg, arg), rm(0.0), axis(2), side(1.0), coord(0.0), kn(0.0), kt(0.0), en2(0.0),
    mu(0.0), alpha(1.0), nslots(16), per_cell(false), iquat(-1), ihist(-1),
    local_now{0.0, 0.0, 0.0}, w_fric(0.0), w_npoints(0.0), totals{}, totals_valid(false),
    warned_slots(false),
    nmax_touch(0), touch(nullptr)
{
  const char *usage =
      "fix ID group bcm/wall cells FILE rm R plane FACE VALUE kn kt en2 mu [slots N] "
      "[stiffness per_point|per_cell]";
  if (narg < 14) error->all(FLERR, "Illegal fix bcm/wall command: {}", usage);
  if (strcmp(arg[3], "cells") != 0 || strcmp(arg[5], "rm") != 0 || strcmp(arg[7], "plane") != 0)
    error->all(FLERR, "Illegal fix bcm/wall command: {}", usage);
  cells_file = arg[4];
  rm = utils::numeric(FLERR, arg[6], false, lmp);
  const std::string face = arg[8];
  if (face.size() != 3 || face[0] < 'x' || face[0] > 'z' ||
      (face.substr(1) != "lo" && face.substr(1) != "hi"))
    error->all(FLERR, "fix bcm/wall: plane must be xlo, xhi, ylo, yhi, zlo or zhi, not {}", face);
  axis = face[0] - 'x';
  side = face.substr(1) == "lo" ? 1.0 : -1.0;
  coord = utils::numeric(FLERR, arg[9], false, lmp);
  kn = utils::numeric(FLERR, arg[10], false, lmp);
  kt = utils::numeric(FLERR, arg[11], false, lmp);
  en2 = utils::numeric(FLERR, arg[12], false, lmp);
  mu = utils::numeric(FLERR, arg[13], false, lmp);
  for (int iarg = 14; iarg < narg; iarg += 2) {
    if (iarg + 1 >= narg) error->all(FLERR, "fix bcm/wall: keyword {} needs a value", arg[iarg]);
    if (strcmp(arg[iarg], "slots") == 0) {
      nslots = utils::inumeric(FLERR, arg[iarg + 1], false, lmp);
    } else if (strcmp(arg[iarg], "stiffness") == 0) {
      if (strcmp(arg[iarg + 1], "per_point") == 0)
        per_cell = false;
      else if (strcmp(arg[iarg + 1], "per_cell") == 0)
        per_cell = true;
      else
        error->all(FLERR, "fix bcm/wall: unknown stiffness {} (known: per_point, per_cell)",
                   arg[iarg + 1]);
    } else {
      error->all(FLERR, "fix bcm/wall: unknown keyword {} (known: slots, stiffness)", arg[iarg]);
    }
  }
  if (!(rm >= 0.0)) error->all(FLERR, "fix bcm/wall: rm must be >= 0");
  if (!(kn > 0.0)) error->all(FLERR, "fix bcm/wall: kn must be > 0");
  if (!(kt >= 0.0)) error->all(FLERR, "fix bcm/wall: kt must be >= 0");
  if (!(en2 >= 0.0 && en2 <= 1.0)) error->all(FLERR, "fix bcm/wall: en2 must be in [0, 1]");
  if (!(mu >= 0.0)) error->all(FLERR, "fix bcm/wall: mu must be >= 0");
  if (nslots < 1) error->all(FLERR, "fix bcm/wall: slots must be >= 1");
  alpha = BcmContactLaw::damping_ratio(en2);

  table = BcmCells::load(lmp, cells_file);

  scalar_flag = 1;
  vector_flag = 1;
  size_vector = NVECTOR;
  global_freq = 1;
  extscalar = 1;
  extvector = 1;
  energy_global_flag = 1;
  peratom_flag = 1;
  size_peratom_cols = 0;
  peratom_freq = 1;
  restart_global = 1;

  hist_id = std::string("BCM_WALL_") + id;
  hist_name = std::string("bcm_wall_") + id;
}

/* ---------------------------------------------------------------------- */

FixBcmWall::~FixBcmWall()
{
  memory->destroy(touch);
}

/* ----------------------------------------------------------------------
   the history store is a fix of its own: created here, once this fix is in
   place (creating a fix from a constructor would disturb the fix list)
------------------------------------------------------------------------- */

void FixBcmWall::post_constructor()
{
  ihist = bcm_peratom_array(lmp, hist_id, hist_name, SLOT * nslots, false);
}

/* ---------------------------------------------------------------------- */

int FixBcmWall::setmask()
{
  return POST_FORCE;
}

/* ---------------------------------------------------------------------- */

void FixBcmWall::init()
{
  if (!atom->rmass_flag || !atom->omega_flag || !atom->torque_flag)
    error->all(FLERR, "fix bcm/wall requires per-atom rmass, omega and torque "
                      "(atom_style hybrid bond sphere)");
  int flag = -1, cols = -1;
  iquat = atom->find_custom(BcmRigid::QUAT, flag, cols);
  if (iquat < 0 || flag != 1 || cols != 4)
    error->all(FLERR, "fix bcm/wall requires the per-atom array d2_{} with 4 columns",
               BcmRigid::QUAT);
  ihist = bcm_peratom_array(lmp, hist_id, hist_name, SLOT * nslots, false);
  if (atom->map_style == Atom::MAP_NONE)
    error->all(FLERR, "fix bcm/wall requires an atom map (atom_modify map array): the "
                      "damping work of a step is settled at the next one by atom ID");

  const int nlocal = atom->nlocal;
  tagint missing = 0, any = 0;
  for (int i = 0; i < nlocal; i++)
    if ((atom->mask[i] & groupbit) && !table->find(atom->tag[i]) && !missing)
      missing = atom->tag[i];
  MPI_Allreduce(&missing, &any, 1, MPI_LMP_TAGINT, MPI_MAX, world);
  if (any) error->all(FLERR, "fix bcm/wall: cell {} has no geometry in {}", any, cells_file);
}

/* ---------------------------------------------------------------------- */

void FixBcmWall::setup(int /*vflag*/)
{
  wall_forces(false);
}

void FixBcmWall::post_force(int /*vflag*/)
{
  wall_forces(true);
}

/* ---------------------------------------------------------------------- */

void FixBcmWall::wall_forces(bool advance)
{
  double **x = atom->x, **v = atom->v, **f = atom->f;
  double **omega = atom->omega, **torque = atom->torque;
  double **quat = atom->darray[iquat];
  double **hist = atom->darray[ihist];
  const double *rmass = atom->rmass;
  const int *mask = atom->mask;
  const tagint *tag = atom->tag;
  const int nlocal = atom->nlocal;
  const double dt = update->dt;
  const bigint step = update->ntimestep;
  const double now = static_cast<double>(step), before = static_cast<double>(step - 1);

  if (atom->nmax > nmax_touch) {
    nmax_touch = atom->nmax;
    memory->destroy(touch);
    memory->create(touch, nmax_touch, "bcm/wall:touch");
  }
  vector_atom = touch;
  // each cell's geometry kept from step to step, checked by its tag (atoms change indices
  // where lists are rebuilt)
  cell_of.resize(nlocal, nullptr);
  cell_tag.resize(nlocal, 0);
  // energy accounting: the previous evaluation's forces settled now (bcm_kick_work.h)
  damp_work.begin(lmp, "fix bcm/wall");
  all_work.begin(lmp, "fix bcm/wall");

  double ncells = 0.0, fnsum = 0.0, stored = 0.0, fric = 0.0, npoints = 0.0;
  double nw[3] = {0.0, 0.0, 0.0};
  nw[axis] = side;

  for (int i = 0; i < nlocal; i++) {
    touch[i] = 0.0;
    if (!(mask[i] & groupbit)) continue;
    if (cell_tag[i] != tag[i] || !cell_of[i]) {
      cell_tag[i] = tag[i];
      cell_of[i] = table->find(tag[i]);
    }
    const BcmCells::Cell *c = cell_of[i];
    if (!c) error->one(FLERR, "fix bcm/wall: cell {} has no geometry in {}", tag[i], cells_file);
    const double hc = side * (x[i][axis] - coord);
    if (hc - c->rbound >= rm) continue;

    double R[3][3];
    BcmRigid::rotation(quat[i], R);
    const double *bv = &table->vert[3 * c->v0];
    touching.clear();
    for (int k = 0; k < c->nv; k++) {
      const double *b = bv + 3 * k;
      const double off = R[axis][0] * b[0] + R[axis][1] * b[1] + R[axis][2] * b[2];
      if (hc + side * off < rm) touching.push_back(k);
    }
    const int np = static_cast<int>(touching.size());
    if (np == 0) continue;
    touch[i] = np;
    ncells += 1.0;

    // per vertex: k_n, k_t (SPEC 1.2), or the cell's k_n, k_t shared by its N vertices
    const double knp = per_cell ? kn / np : kn, ktp = per_cell ? kt / np : kt;
    // SPEC 1.2 Eq. 1, 2: the cell's mass shared by its touching vertices (bcm_contact_law.h)
    const double gamma = BcmContactLaw::damping(alpha, knp, rmass[i], np);
    double fcell[3] = {0.0, 0.0, 0.0}, tcell[3] = {0.0, 0.0, 0.0};
    double fdamp[3] = {0.0, 0.0, 0.0}, tdamp[3] = {0.0, 0.0, 0.0};
    // per_cell: N and E_w at the cell's last step (from any slot written then), E_w now
    double np_before = 0.0, ew_before = 0.0, ewhole = 0.0;

    for (const int k : touching) {
      double r[3];
      BcmRigid::rotate(R, bv + 3 * k, r);
      const double height = hc + side * r[axis];
      const double overlap = rm - height;
      r[axis] -= side * 0.5 * (height + rm);    // contact point p = x + r
      double w[3], vp[3];
      cross(omega[i], r, w);
      for (int d = 0; d < 3; d++) vp[d] = v[i][d] + w[d];
      const double vn = dot(vp, nw);

      // the vertex's tangential spring: from its slot, advanced along the plane
      double u[3] = {0.0, 0.0, 0.0}, ft_before = 0.0;
      int slot = -1, freeslot = -1;
      double *h = hist[i];
      if (kt > 0.0) {
        for (int m = 0; m < nslots; m++) {
          const double *s = h + SLOT * m;
          const bool current = s[S_VERTEX] != 0.0 && (s[S_STEP] == now || s[S_STEP] == before);
          if (current && s[S_VERTEX] == k + 1) {
            slot = m;
            break;
          }
          if (!current && freeslot < 0) freeslot = m;
        }
        if (slot >= 0) {
          const double *s = h + SLOT * slot;
          for (int d = 0; d < 3; d++) u[d] = s[S_U + d];
          ft_before = s[S_FT];
          if (s[S_STEP] == before) {
            np_before = s[S_NP];
            ew_before = s[S_EWHOLE];
          }
        }
        u[axis] = 0.0;    // the plane does not turn: u_t stays in it
        if (advance)
          for (int d = 0; d < 3; d++)
            if (d != axis) u[d] += vp[d] * dt;
      }

      const BcmContactLaw::Point pt =
          BcmContactLaw::point(knp, ktp, gamma, mu, overlap, vn, u, ft_before);
      if (per_cell) ewhole += np * pt.stored;

      if (kt > 0.0 && advance) {
        fric += pt.slip;
        if (slot < 0) slot = freeslot;
        if (slot >= 0) {
          double *s = h + SLOT * slot;
          s[S_VERTEX] = k + 1;
          s[S_STEP] = now;
          for (int d = 0; d < 3; d++) s[S_U + d] = u[d];
          s[S_FT] = pt.ftm;
          s[S_NP] = np;
        } else if (!warned_slots) {
          warned_slots = true;
          error->warning(FLERR, "fix bcm/wall: cell {} touches with more than {} vertices: "
                                "raise slots", tag[i], nslots);
        }
      }

      double F[3], tq[3];
      for (int d = 0; d < 3; d++) F[d] = pt.fn * nw[d] + pt.ft[d];
      cross(r, F, tq);
      for (int d = 0; d < 3; d++) {
        fcell[d] += F[d];
        tcell[d] += tq[d];
      }
      // the damping part of the normal force (with the clamp: what it lets go)
      double Fd[3];
      for (int d = 0; d < 3; d++) Fd[d] = (pt.fn - pt.fel) * nw[d];
      cross(r, Fd, tq);
      for (int d = 0; d < 3; d++) {
        fdamp[d] += Fd[d];
        tdamp[d] += tq[d];
      }
      fnsum += pt.fn;
      stored += pt.stored;
    }
    for (int d = 0; d < 3; d++) {
      f[i][d] += fcell[d];
      torque[i][d] += tcell[d];
    }
    damp_work.add(lmp, i, -1, fdamp, tdamp, nullptr);
    all_work.add(lmp, i, -1, fcell, tcell, nullptr);
    if (per_cell && advance && kt > 0.0) {
      if (np_before > 0.0 && np_before != np)
        npoints -= (1.0 / np - 1.0 / np_before) * 0.5 * (ewhole + ew_before);
      for (const int k : touching) {    // E_w into the slots written at this step
        double *h = hist[i];
        for (int m = 0; m < nslots; m++)
          if (h[SLOT * m + S_VERTEX] == k + 1 && h[SLOT * m + S_STEP] == now)
            h[SLOT * m + S_EWHOLE] = ewhole;
      }
    }
  }

  // vertices that touched at the last step and no longer do: the spring slips free, its
  // energy is dissipated (f_n reached 0 first, so it is small unless the vertex left by
  // turning away)
  if (advance && kt > 0.0) {
    for (int i = 0; i < nlocal; i++) {
      if (!(mask[i] & groupbit)) continue;
      // a cell that did not touch at the last evaluation holds no slot of the previous step
      if (i < (int) touched_last.size() && touched_last[i] == tag[i]) continue;
      double *h = hist[i];
      for (int m = 0; m < nslots; m++) {
        double *s = h + SLOT * m;
        if (s[S_VERTEX] != 0.0 && s[S_STEP] == before) {
          fric += BcmFriction::release(s[S_FT], s + S_U);
          s[S_VERTEX] = 0.0;
        }
      }
    }
  }

  touched_last.resize(nlocal);
  for (int i = 0; i < nlocal; i++) touched_last[i] = touch[i] > 0.0 ? 0 : tag[i];
  local_now[0] = ncells;
  local_now[1] = fnsum;
  local_now[2] = stored;
  w_fric += fric;
  w_npoints += npoints;
  totals_valid = false;
}

/* ---------------------------------------------------------------------- */

void FixBcmWall::sum_totals()
{
  if (totals_valid) return;
  const double damp = -damp_work.work();
  // [7], the energy of changes of N under a shared stiffness, is identically zero under the
  // per-point law (SPEC 1.2); stiffness per_cell books it
  const double mine[NVECTOR] = {local_now[0], local_now[1], damp + w_fric + w_npoints,
                                local_now[2], damp, w_fric, w_npoints, all_work.work()};
  MPI_Allreduce(mine, totals, NVECTOR, MPI_DOUBLE, MPI_SUM, world);
  totals_valid = true;
}

double FixBcmWall::compute_scalar()
{
  sum_totals();
  return totals[3];
}

double FixBcmWall::compute_vector(int n)
{
  sum_totals();
  return totals[n];
}

/* ----------------------------------------------------------------------
   the dissipated energies and the work of the wall's forces carry on across restarts
   (kept on rank 0): damping, friction, the energy of changes of N ([7]: zero but for
   stiffness per_cell), work. The kick works are closed as the
   next run's setup would close them (BcmKickWork::work_closed), so a resumed run carries
   on with the very numbers of an uninterrupted one. Called on every rank (the sums need
   them all); only rank 0 has a file.
------------------------------------------------------------------------- */

void FixBcmWall::write_restart(FILE *fp)
{
  const double mine[4] = {-damp_work.work_closed(lmp, "fix bcm/wall"), w_fric, w_npoints,
                          all_work.work_closed(lmp, "fix bcm/wall")};
  double total[4] = {0.0, 0.0, 0.0, 0.0};
  MPI_Reduce(mine, total, 4, MPI_DOUBLE, MPI_SUM, 0, world);
  if (comm->me == 0) {
    const int size = 4 * sizeof(double);
    fwrite(&size, sizeof(int), 1, fp);
    fwrite(total, sizeof(double), 4, fp);
  }
}

void FixBcmWall::restart(char *buf)
{
  double total[4];
  std::memcpy(total, buf, sizeof(total));
  const bool root = comm->me == 0;
  damp_work.restore(root ? -total[0] : 0.0);
  w_fric = root ? total[1] : 0.0;
  w_npoints = root ? total[2] : 0.0;
  all_work.restore(root ? total[3] : 0.0);
}

/* ---------------------------------------------------------------------- */

double FixBcmWall::memory_usage()
{
  double bytes = sizeof(double) * nmax_touch;
  if (table) bytes += table->memory_usage();
  return bytes;
}
