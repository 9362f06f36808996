/* Work done on BCM cells by forces held over the half kicks of velocity Verlet (fix
   bcm/rigid), settled exactly: the damping work of pair_style bcm/contact and fix bcm/wall,
   and the work of all their forces (a check of their energy accounting).

   A force F computed at one evaluation (at velocities v_k) acts in up to two half kicks:
   the one closing its step and the one opening the next. A half kick of length h/2 changes
   the kinetic energy of a cell by (h/2) (F . v + tau . w) with v, w the means over the kick,
   whatever other forces kick at the same time (the change is linear in the impulse). Both
   kicks use the same F, so the velocity between them is the mean of those before and after:
   the work of F is
       W = n_kicks (h/4) (P_k + P_k+1),   P = F . v_a + tau_a . w_a - F . v_b + tau_b . w_b,
   with P_k+1 the same force at the velocities of the next evaluation and n_kicks =
   [evaluation k was a step] + [evaluation k+1 is a step] (a run's setup evaluation is not).
   Exact for translation; with rotation the space-frame w of the next evaluation has also
   turned with the cell (second order), as in bond_style bcm/griffith.

   The forces of one evaluation are kept per rank with the atom IDs of their cells; the next
   evaluation finds the cells through the atom map (owned or ghost: a cell touching at one
   step is within the ghost cutoff of the same rank at the next, and ghost v and omega are
   current with comm_modify vel yes).

   BcmPrescribedWork settles the same way the work of forces on a body whose motion is
   prescribed rather than kicked (the moving plane of fix bcm/wall). The force F_k of
   evaluation k is held over the half kick closing step k, over which the body moved by
   dX_k, and the half kick opening step k+1, over which it moves by dX_k+1:
       W = F_k dX_k / 2 [closing] + F_k dX_k+1 / 2 [opening]
   (a run's setup evaluation closes and opens no step). Over a run of steps this is
   sum_k (F_k + F_k+1)/2 dX_k+1, the trapezoid on the body's displacement, as the work of
   BcmKickWork is on the cells' (x_k+1 - x_k = h v seen at evaluation k+1): a linear spring
   between a translating cell and the body stores the work done on both. dX is the body's
   displacement as stored (position after less position before), not V h: a position of
   1e-4 m moved by a constant 1e-11 m a step rounds the same way at every step, a
   systematic 1e-9 of the displacement that the springs see and V h would not. */

#ifndef BRITTLE_BCM_KICK_WORK_H
#define BRITTLE_BCM_KICK_WORK_H

#include "lmptype.h"

#include <vector>

namespace LAMMPS_NS {

class LAMMPS;

class BcmKickWork {
 public:
  enum Kind { NONE = 0, SETUP = 1, STEP = 2 };

  // what the current force evaluation is (a step of a run, a run's setup, neither)
  static int evaluation_kind(LAMMPS *lmp);

  // settle the forces of the previous evaluation with the current velocities and start
  // a new list; call once per force evaluation, before add()
  void begin(LAMMPS *lmp, const char *style);

  // F on cell i (local index) with torque ti about its centre, and -F on cell j with
  // torque tj (j < 0: a single cell against an immobile wall)
  void add(LAMMPS *lmp, int i, int j, const double *F, const double *ti, const double *tj);

  // work done on the cells since the start, with the pending first half kick of the
  // last step's forces estimated as (h/2) P_k (settled exactly at the next evaluation)
  double work() const;

  // work done on the cells since the start with the last step's forces settled over the
  // half kick that closed that step, at the current velocities: once the step is complete
  // (between runs, at write_restart), what begin() settles at the setup of the next run;
  // right after a force evaluation (velocities unchanged since), equal to work()
  double work_closed(LAMMPS *lmp, const char *style) const;

  // start again from a work w (read from a restart file), nothing pending
  void restore(double w);

 private:
  struct Entry {
    tagint a, b;    // atom IDs (b = 0: no second cell)
    double f[3], ta[3], tb[3];
    double p;    // P at the evaluation that computed the force
  };
  std::vector<Entry> entries;
  int last_kind = NONE;
  double last_dt = 0.0;
  double settled = 0.0;
  double pending_power = 0.0;    // sum of P over the entries

  static double power(LAMMPS *lmp, const Entry &e, int ia, int ib);
  // work of the listed forces over nkicks half kicks at the current velocities
  double kicks(LAMMPS *lmp, const char *style, int nkicks) const;
};

class BcmPrescribedWork {
 public:
  // settle the previous evaluation's force over the half kicks between it and this one,
  // with the body's displacement dx over the step that ends at this evaluation (0 at a
  // run's setup), and start again from zero force; call once per force evaluation, before
  // add()
  void begin(LAMMPS *lmp, double dx);

  // a force on the body: its component along the body's motion (this rank's part)
  void add(double f) { force += f; }

  // work done on the body since the start, the closing half kick of the last step's force
  // included (F_k dX_k / 2: exact, the body's displacement over that step being known)
  double work() const;

  void restore(double w);

 private:
  double force = 0.0;      // this rank's sum of the forces of the last evaluation
  double dx_last = 0.0;    // the body's displacement over the step of the last evaluation
  int last_kind = BcmKickWork::NONE;
  double settled = 0.0;
};

}    // namespace LAMMPS_NS

#endif
