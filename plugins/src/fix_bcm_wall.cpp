/* fix bcm/wall (see fix_bcm_wall.h).

   Plane x[axis] = coord with unit normal n_w = side e_axis pointing to the cells' side,
   moving along e_axis at the velocity V (0 unless `velocity` is given; SPEC 4.1: a platen):
   coord += V h at each step, V being the plane's velocity seen at that step's force
   evaluation, as a cell's x += h v with the v seen at that evaluation (velocity Verlet).
   A cell with N vertices at heights h_k < r_m over the plane has N contact points, each
   with overlap delta_k = h_k - r_m < 0, at the midpoint between the plane and the bottom
   of the vertex's sphere, under the per-point law of bcm_contact_law.h (SPEC 1.2 Eq. 1, 2,
   7; m = the cell's mass), with the velocity of the vertex's material point relative to
   the plane, v_r = v + omega x r - V e_axis (SPEC 4.1):
     f_n = k_n (-delta) + 2 alpha sqrt(k_n m / N) (-d delta/dt),   d delta/dt = v_r . n_w,
           clamped at f_n >= 0
     f_t = -k_t u_t,  |f_t| <= mu f_n  (at the limit u_t = -f_t / k_t)
   u_t = tangential displacement of the vertex's material point along the plane since the
   contact began (v_r's tangential part: the vertex's own, the plane moving along its
   normal), kept per (cell, vertex) in slots of a hidden per-atom array
   (vertex + 1, step, u_t[3], |f_t|); a slot is current when written at this step or the
   previous one. The setup force evaluation reads the history without advancing it.
   Energy accounting (the same as pair_style bcm/contact and bond_style bcm/griffith):
   stored = k_n delta^2/2 + k_t |u_t|^2/2 per vertex; damping: the exact work of the damping
   force (f_n - k_n (-delta)) n_w (the energy a clamped f_n lets go included) over the half
   kicks of velocity Verlet (bcm_kick_work.h); friction: per Coulomb cap, the mean of the
   previous and the capped |f_t| times the slip, and when a vertex stops touching, its
   spring's energy (it slips free). A vertex starts and stops touching at zero overlap, so
   a change of N moves no energy: vector value [7] is identically zero. A moving plane
   (fix_bcm_wall.h): the damping dissipates -(its work on the cells) + (its work on the
   plane), both over the half kicks; W_p = the work of all the forces on the plane.

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
#include "bcm_orientation.h"
#include "bcm_rigid.h"
#include "comm.h"
#include "error.h"
#include "input.h"
#include "memory.h"
#include "modify.h"
#include "update.h"
#include "variable.h"

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

// restart layout tag: the layout before the moving plane held 4 values, the first the
// energy dissipated by damping (>= 0 J up to round-off), which cannot be this
static constexpr double RESTART_PLANE = -1.0e300;

/* ----------------------------------------------------------------------
   fix ID group bcm/wall cells FILE rm R plane FACE VALUE kn kt en2 mu [slots N]
                         [stiffness per_point|per_cell] [velocity V|v_name]
------------------------------------------------------------------------- */

FixBcmWall::FixBcmWall(LAMMPS *_lmp, int narg, char **arg) :
    Fix(_lmp, narg, arg), rm(0.0), axis(2), side(1.0), coord(0.0), vel(0.0), ivar(-1), kn(0.0),
    kt(0.0), en2(0.0), mu(0.0), alpha(1.0), nslots(16), per_cell(false), iquat(-1), ihist(-1),
    local_now{0.0, 0.0, 0.0}, w_fric(0.0), w_npoints(0.0), totals{}, totals_valid(false),
    warned_slots(false),
    nmax_touch(0), touch(nullptr)
{
  const char *usage =
      "fix ID group bcm/wall cells FILE rm R plane FACE VALUE kn kt en2 mu [slots N] "
      "[stiffness per_point|per_cell] [velocity V|v_name]";
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
    } else if (strcmp(arg[iarg], "velocity") == 0) {
      set_velocity(arg[iarg + 1]);
    } else {
      error->all(FLERR, "fix bcm/wall: unknown keyword {} (known: slots, stiffness, velocity)",
                 arg[iarg]);
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
  // the plane's position and velocity are intensive, the rest extensive
  extvector = -1;
  extlist = new int[NVECTOR];
  for (int k = 0; k < NVECTOR; k++) extlist[k] = 1;
  extlist[8] = extlist[9] = 0;
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
  delete[] extlist;
}

/* ----------------------------------------------------------------------
   velocity V (m/s along +e_axis: a zhi platen moving down has V < 0) or v_name (an
   equal-style variable, evaluated at every force evaluation)
------------------------------------------------------------------------- */

void FixBcmWall::set_velocity(const char *arg)
{
  if (strncmp(arg, "v_", 2) == 0) {
    vel_var = arg + 2;
    if (vel_var.empty()) error->all(FLERR, "fix bcm/wall: velocity v_ needs a variable name");
  } else {
    vel_var.clear();
    vel = utils::numeric(FLERR, arg, false, lmp);
    if (!std::isfinite(vel)) error->all(FLERR, "fix bcm/wall: velocity must be finite");
  }
}

int FixBcmWall::modify_param(int narg, char **arg)
{
  if (strcmp(arg[0], "velocity") != 0) return 0;
  if (narg < 2) error->all(FLERR, "fix_modify {} velocity needs a value (V or v_name)", id);
  set_velocity(arg[1]);
  return 2;
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
                      "(atom_style bpm/sphere)");
  iquat = BcmOrientation::find(atom, error, "fix bcm/wall", false);
  ihist = bcm_peratom_array(lmp, hist_id, hist_name, SLOT * nslots, false);
  if (atom->map_style == Atom::MAP_NONE)
    error->all(FLERR, "fix bcm/wall requires an atom map (atom_modify map array): the "
                      "damping work of a step is settled at the next one by atom ID");
  if (!vel_var.empty()) {
    ivar = input->variable->find(vel_var.c_str());
    if (ivar < 0) error->all(FLERR, "fix bcm/wall: velocity variable {} does not exist", vel_var);
    if (!input->variable->equalstyle(ivar))
      error->all(FLERR, "fix bcm/wall: velocity variable {} is not equal-style", vel_var);
  }

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
  double **quat = BcmOrientation::of(atom, iquat);
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
  cell_rbound.resize(nlocal, 0.0);
  // the plane's velocity at this evaluation, and its position at the end of the step
  if (!vel_var.empty()) {
    modify->clearstep_compute();
    vel = input->variable->compute_equal(ivar);
    modify->addstep_compute(update->ntimestep + 1);
  }
  const double coord_before = coord;
  if (advance) coord += vel * dt;
  // energy accounting: the previous evaluation's forces settled now (bcm_kick_work.h), on
  // the plane with its displacement as stored (exactly 0 at rest)
  damp_work.begin(lmp, "fix bcm/wall");
  all_work.begin(lmp, "fix bcm/wall");
  damp_plane.begin(lmp, coord - coord_before);
  all_plane.begin(lmp, coord - coord_before);

  double ncells = 0.0, fnsum = 0.0, stored = 0.0, fric = 0.0, npoints = 0.0;
  double nw[3] = {0.0, 0.0, 0.0}, vw[3] = {0.0, 0.0, 0.0};
  nw[axis] = side;
  vw[axis] = vel;

  for (int i = 0; i < nlocal; i++) {
    touch[i] = 0.0;
    if (!(mask[i] & groupbit)) continue;
    if (cell_tag[i] != tag[i] || !cell_of[i]) {
      cell_tag[i] = tag[i];
      cell_of[i] = table->find(tag[i]);
      if (!cell_of[i])
        error->one(FLERR, "fix bcm/wall: cell {} has no geometry in {}", tag[i], cells_file);
      cell_rbound[i] = cell_of[i]->rbound;
    }
    const double hc = side * (x[i][axis] - coord);
    if (hc - cell_rbound[i] >= rm) continue;
    const BcmCells::Cell *c = cell_of[i];

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
      // velocity of the vertex's material point relative to the plane (SPEC 4.1)
      double w[3], vr[3];
      cross(omega[i], r, w);
      for (int d = 0; d < 3; d++) vr[d] = (v[i][d] + w[d]) - vw[d];
      const double vn = dot(vr, nw);

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
            if (d != axis) u[d] += vr[d] * dt;
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
    // on the plane, moving along e_axis: F . dX_p = F[axis] dX
    damp_plane.add(fdamp[axis]);
    all_plane.add(fcell[axis]);
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
  // damping dissipates on the displacement relative to the plane: -(its work on the cells)
  // + (its work on the plane); the latter is exactly +0 for a plane at rest, so this is
  // -damp_work.work() to the bit
  const double damp = -(damp_work.work() - damp_plane.work());
  // [7], the energy of changes of N under a shared stiffness, is identically zero under the
  // per-point law (SPEC 1.2); stiffness per_cell books it
  constexpr int NSUM = 9;
  const double mine[NSUM] = {local_now[0], local_now[1], damp + w_fric + w_npoints,
                             local_now[2], damp,         w_fric,
                             w_npoints,    all_work.work(), all_plane.work()};
  double sums[NSUM];
  MPI_Allreduce(mine, sums, NSUM, MPI_DOUBLE, MPI_SUM, world);
  for (int k = 0; k < 8; k++) totals[k] = sums[k];
  totals[8] = coord;    // the same on every rank
  totals[9] = vel;
  totals[10] = sums[8];
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
   stiffness per_cell), work, and the moving plane's position and works (its velocity is a
   setting: the command's). The kick works are closed as the
   next run's setup would close them (BcmKickWork::work_closed), so a resumed run carries
   on with the very numbers of an uninterrupted one. Called on every rank (the sums need
   them all); only rank 0 has a file. Layout: RESTART_PLANE, damping (cells' part, negated),
   friction, [7], work on the cells, the plane's position, damping's work on the plane, W_p.
------------------------------------------------------------------------- */

void FixBcmWall::write_restart(FILE *fp)
{
  const double mine[6] = {-damp_work.work_closed(lmp, "fix bcm/wall"), w_fric, w_npoints,
                          all_work.work_closed(lmp, "fix bcm/wall"), damp_plane.work(),
                          all_plane.work()};
  double total[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  MPI_Reduce(mine, total, 6, MPI_DOUBLE, MPI_SUM, 0, world);
  if (comm->me == 0) {
    const double out[8] = {RESTART_PLANE, total[0], total[1], total[2],
                           total[3],      coord,    total[4], total[5]};
    const int size = sizeof(out);
    fwrite(&size, sizeof(int), 1, fp);
    fwrite(out, sizeof(double), 8, fp);
  }
}

void FixBcmWall::restart(char *buf)
{
  // a file written before the moving plane holds the first 4 values, without the tag: the
  // plane stays where the command puts it, and its works start from zero
  double first;
  std::memcpy(&first, buf, sizeof(double));
  const bool tagged = first == RESTART_PLANE;
  double total[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  if (tagged) {
    double in[8];
    std::memcpy(in, buf, sizeof(in));
    for (int k = 0; k < 4; k++) total[k] = in[k + 1];
    coord = in[5];
    total[4] = in[6];
    total[5] = in[7];
  } else {
    std::memcpy(total, buf, 4 * sizeof(double));
  }
  const bool root = comm->me == 0;
  damp_work.restore(root ? -total[0] : 0.0);
  w_fric = root ? total[1] : 0.0;
  w_npoints = root ? total[2] : 0.0;
  all_work.restore(root ? total[3] : 0.0);
  damp_plane.restore(root ? total[4] : 0.0);
  all_plane.restore(root ? total[5] : 0.0);
}

/* ---------------------------------------------------------------------- */

double FixBcmWall::memory_usage()
{
  double bytes = sizeof(double) * nmax_touch;
  if (table) bytes += table->memory_usage();
  return bytes;
}
