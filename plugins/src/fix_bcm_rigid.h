/* fix bcm/rigid: time integration of BCM cells as rigid bodies with a full (diagonal in the
   body frame) inertia tensor. Velocity Verlet for translation; for rotation the symplectic,
   time-reversible NO_SQUISH splitting of the free rotor (Miller et al., J. Chem. Phys. 116,
   8649, 2002) between two half kicks of the space-frame angular momentum. Orientation,
   principal moments and angular momentum live in the per-atom arrays of bcm_rigid.h
   (the orientation in atom_style bpm/sphere's quaternion: bcm_orientation.h).
   See plugins/doc/fix_bcm_rigid.md. */

#ifndef BRITTLE_FIX_BCM_RIGID_H
#define BRITTLE_FIX_BCM_RIGID_H

#include "fix.h"

namespace LAMMPS_NS {

class FixBcmRigid : public Fix {
 public:
  FixBcmRigid(class LAMMPS *, int, char **);

  int setmask() override;
  void init() override;
  void setup_pre_force(int) override;
  void initial_integrate(int) override;
  void pre_force(int) override;
  void final_integrate() override;
  void reset_dt() override;
  double compute_scalar() override;
  int pack_forward_comm(int, int *, double *, int, int *) override;
  void unpack_forward_comm(int, int, double *) override;

 private:
  double dtv, dtf;
  int iquat;                       // where the orientations live (bcm_orientation.h)
  int iinertia, iangmom;           // atom->darray indices of the bcm_rigid.h arrays
  int comm_with_omega;             // the current forward communication carries omega too
  bool send_quat;                  // every step's pre_force sends the ghosts' orientations
  bool avx_loop;                   // full batches of 4 cells in AVX lanes (free_rotors4)

  int find_array(const char *name, int ncols);
  void set_omega(int i);
  void free_rotors(const int *batch, int n);
};

}    // namespace LAMMPS_NS

#endif
