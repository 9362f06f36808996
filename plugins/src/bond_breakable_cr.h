/* bond_style breakable/cr: the breakable two-body bond of Clemmer & Robbins (SPEC 2.2 Eq. 2,
   bonded damping of Eq. 5). Per-bond reference length r0 = the bond's length when the style
   first computes it; the bond breaks for good when r > lambda_c r0. See
   plugins/doc/bond_breakable_cr.md. */

#ifndef BRITTLE_BOND_BREAKABLE_CR_H
#define BRITTLE_BOND_BREAKABLE_CR_H

#include "bond.h"

#include <vector>

namespace LAMMPS_NS {

class BondBreakableCR : public Bond {
 public:
  BondBreakableCR(class LAMMPS *);
  ~BondBreakableCR() override;

  void compute(int, int) override;
  void coeff(int, char **) override;
  void init_style() override;
  double equilibrium_distance(int) override;
  void write_restart(FILE *) override;
  void read_restart(FILE *) override;
  void write_data(FILE *) override;
  double single(int, double, int, int, double &) override;
  double memory_usage() override;

 private:
  // per type: coefficients, then constants derived from them (derive())
  double *lambda_c, *gamma, *a, *u;
  double *c1;        // C1 = 36 2^(2/3) u / a^2
  double *c3r2;      // C3 r0^2 = -C1 / (lambda_c - 1)^2
  double *krep;      // K / r0^2 with K = 6 2^(2/3) u r0^2 / a^2, prefactor of the r < r0 branch
  double *inv_lc;    // 1 / lambda_c

  // per bondlist entry, rebuilt whenever the bondlist is
  struct Ref {
    double r0, inv_r0;
  };
  std::vector<Ref> cache;
  bool cache_valid;

  int store_index;                // atom->darray index of r0 per atom and bond slot
  double r0_max;                  // largest r0 (estimate) over all ranks, for the comm cutoff
  class FixBreakableSpecial *special;

  void allocate();
  void derive(int type);
  void rebuild_cache();
  double reference_length(int i, int j);
  void break_bond(int n, int i1, int i2);
  double bond_fbond(int type, double r, double inv_rsq, double r0, double inv_r0,
                    double &ebond, int eflag) const;
};

}    // namespace LAMMPS_NS

#endif
