/* fix bcm/wall: a rigid plane against the rounded BCM cells (SPEC 1.2 last bullet): each
   vertex of a cell's core closer than r_m to the plane is a contact point, with the
   frictional-contact law of pair_style bcm/contact (Eq. 1, 2, 7; bcm_contact_law.h): a
   fixed stiffness per touching vertex. The plane may move along its normal at a prescribed
   velocity (a platen, SPEC 4.1): the law then takes the vertices' velocities relative to it.
   See plugins/doc/fix_bcm_wall.md.

   How the work is counted (per plane; J, cumulative; plugins/doc/fix_bcm_wall.md): the work
   done on the cells by the plane's forces, [8] = W, is
       W = -(E_now - E_start) - D + W_p
   with E the springs' stored energy [4], D the energy dissipated at the plane [3] (damping
   [5], Coulomb slip [6], [7]), and W_p = int F . V_p dt [11] the work the moving plane does
   on the cells (F the plane's force on them, V_p its velocity): the springs store and the
   damping and slip dissipate on the vertices' displacement relative to the plane, the cells
   take the work on their own displacement, and the difference is what the plane's motion
   puts in. W, W_p and the damping's share of both are trapezoids on the displacements,
   settled over the half kicks of velocity Verlet (bcm_kick_work.h; the plane's on its stored
   position), and a linear spring stores exactly its trapezoid: read during a run, the
   identity holds to round-off for translating cells whose contacts start and end at steps,
   otherwise to velocity Verlet's O(h^2) (rotation, the clamp, a contact starting within a
   step). Once every half kick is settled (`run 0`), W is the change of kinetic energy it
   causes (exactly, in translation), and
       W = -(E_now - E_start) - D + W_p + sum over cells (h^2 / 8 m) [F_w . F]_start^now
   (F_w this plane's force on the cell, F the net force on it): velocity Verlet's full-step
   kinetic energy against the trapezoid, a term that does not accumulate. At rest W_p = 0
   and the numbers are those of the plane before it could move, to the bit. */

#ifndef BRITTLE_FIX_BCM_WALL_H
#define BRITTLE_FIX_BCM_WALL_H

#include "bcm_cells.h"
#include "bcm_kick_work.h"
#include "fix.h"

#include <memory>
#include <string>
#include <vector>

namespace LAMMPS_NS {

class FixBcmWall : public Fix {
 public:
  FixBcmWall(class LAMMPS *, int, char **);
  ~FixBcmWall() override;

  int setmask() override;
  void post_constructor() override;
  void init() override;
  void setup(int) override;
  void post_force(int) override;
  double compute_scalar() override;
  double compute_vector(int) override;
  int modify_param(int, char **) override;
  void write_restart(FILE *) override;
  void restart(char *) override;
  double memory_usage() override;

 private:
  std::string cells_file;
  std::shared_ptr<const BcmCells> table;
  double rm;                 // rounding radius r_m
  int axis;                  // 0, 1, 2: the plane is x[axis] = coord
  double side;               // +1 (xlo, ...: cells above) or -1 (xhi, ...: cells below)
  double coord;              // the plane's current position (moves by vel dt each step)
  double vel;                // its velocity along +e_axis (m/s): constant, or the variable's
  std::string vel_var;       // equal-style variable giving vel at each evaluation (or empty)
  int ivar;
  double kn, kt, en2, mu, alpha;
  int nslots;
  bool per_cell;    // stiffness per_cell: k_n, k_t of the cell shared by its touching vertices

  std::string hist_id, hist_name;
  int iquat, ihist;

  // this rank's part of the last evaluation: cells touching, sum of f_n, stored energy
  double local_now[3];
  // this rank's energy accounting since the fix began: work of the damping forces and of
  // all the wall's forces on the cells, energy dissipated by friction
  BcmKickWork damp_work, all_work;
  // the same forces' work on the moving plane, F . V_p: of the damping part, and of all (W_p)
  BcmPrescribedWork damp_plane, all_plane;
  double w_fric;
  double w_npoints;    // energy of changes of N (stiffness per_cell), [7]
  // the global vector: [1] cells touching, [2] sum of f_n, [3] dissipated ([5] + [6] + [7]),
  // [4] stored, [5] damping, [6] friction, [7] change of N (identically zero under the
  // per-point law: kept for the positions), [8] work of the wall's forces, [9] the plane's
  // position, [10] its velocity, [11] W_p, the work of its motion on the cells
  static constexpr int NVECTOR = 11;
  static constexpr int NSUMMED = 8;    // [1]-[8], [11] are sums over ranks; [9], [10] are not
  double totals[NVECTOR];
  bool totals_valid;

  bool warned_slots;        // a cell touched with more vertices than slots (warned once)
  int nmax_touch;
  double *touch;             // per atom: touching vertices (vector_atom)
  std::vector<int> touching;
  // per owned cell, checked by its tag (atoms change indices where neighbor lists are built):
  // its geometry; and the cells that did not touch at the last evaluation (their tag; 0 for
  // one that touched): only the others can hold a slot written at the previous step
  std::vector<const BcmCells::Cell *> cell_of;
  std::vector<double> cell_rbound;    // cell_of[i]->rbound, read in order each step
  std::vector<tagint> cell_tag, touched_last;

  void set_velocity(const char *arg);
  void wall_forces(bool advance);
  void sum_totals();
};

}    // namespace LAMMPS_NS

#endif
