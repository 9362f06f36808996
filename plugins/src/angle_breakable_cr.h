/* angle_style breakable/cr: the breakable three-body angle of Clemmer & Robbins
   (SPEC 2.2 Eq. 3-4). Per-angle references theta0 and arm lengths r1_0, r2_0 = the values
   when the style first computes the angle; the angle breaks for good when
   |theta - theta0| >= theta_c or when an arm is stretched past lambda_c times its reference.
   See plugins/doc/angle_breakable_cr.md. */

#ifndef BRITTLE_ANGLE_BREAKABLE_CR_H
#define BRITTLE_ANGLE_BREAKABLE_CR_H

#include "angle.h"

#include <vector>

namespace LAMMPS_NS {

class AngleBreakableCR : public Angle {
 public:
  AngleBreakableCR(class LAMMPS *);
  ~AngleBreakableCR() override;

  void compute(int, int) override;
  void coeff(int, char **) override;
  void init_style() override;
  double equilibrium_angle(int) override;
  void write_restart(FILE *) override;
  void read_restart(FILE *) override;
  void write_data(FILE *) override;
  double single(int, int, int, int) override;
  double memory_usage() override;

 private:
  // per type: coefficients (theta_c in radians), then constants derived from them
  double *k, *theta_c, *lambda_c;
  double *inv_thc2;    // 1 / theta_c^2
  double *inv_ec2;     // 1 / (lambda_c - 1)^2

  // per anglelist entry, rebuilt whenever the anglelist is
  struct Ref {
    double theta0;
    double inv_r1_0, inv_r2_0;    // 1 / reference arm lengths (atom1-atom2, atom3-atom2)
  };
  std::vector<Ref> cache;
  bool cache_valid;

  int store_index;    // atom->darray index: theta0, r1_0, r2_0 per atom and angle slot
  class FixBreakableSpecial *special;

  void allocate();
  void derive(int type);
  void rebuild_cache();
  void capture(int a1, int a2, int a3, double *dest);
  void break_angle(int n, int i1, int i2, int i3);
};

}    // namespace LAMMPS_NS

#endif
