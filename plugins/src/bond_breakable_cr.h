/* bond_style breakable/cr: the breakable two-body bond of Clemmer & Robbins (SPEC 2.2 Eq. 2,
   bonded damping of Eq. 5). Per-bond reference length r0 from the input (fix
   breakable/references); the bond breaks for good when r > lambda_c r0, through the single
   break path (break_events.h). See plugins/doc/bond_breakable_cr.md. */

#ifndef BRITTLE_BOND_BREAKABLE_CR_H
#define BRITTLE_BOND_BREAKABLE_CR_H

#include "bond.h"

#include <vector>

namespace LAMMPS_NS {

struct BreakEvent;

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

  // fix breakable/special, end of step: a break decided on some rank, applied here if this
  // rank still holds the bond intact
  void break_if_intact(const BreakEvent &ev);

 private:
  // per type: coefficients, then constants derived from them (derive())
  double *lambda_c, *gamma, *a, *u;

  struct TypeParams {
    double lambda_c, gamma;
    double c1;        // C1 = 36 2^(2/3) u / a^2
    double c3r2;      // C3 r0^2 = -C1 / (lambda_c - 1)^2
    double krep;      // K / r0^2 with K = 6 2^(2/3) u r0^2 / a^2, prefactor of the r < r0 branch
    double inv_lc;    // 1 / lambda_c
  };
  std::vector<TypeParams> params;

  // one record per intact bondlist entry, rebuilt whenever the bondlist is: the entry (type
  // set to 0 when the bond breaks), its row n in the bondlist and its reference length
  struct Ref {
    int i1, i2, type, n;
    double r0, inv_r0;
  };
  std::vector<Ref> cache;
  std::vector<int> deferred;    // cache entries the two-lane pass leaves to the exact one
  int cached_nbondlist;         // size of the bondlist the cache was built from, -1 = none

  int store_index;                // atom->darray index of r0 per atom and bond slot
  double r0_max;                  // largest r0 (estimate) over all ranks, for the comm cutoff
  class FixBreakableSpecial *special;

  void allocate();
  void derive(int type);
  void rebuild_cache();
  double reference_length(int i, int j);
  void break_bond(Ref &R, double energy);
  template <bool EVFLAG>
  void apply(const Ref &R, double fbond, double ebond, double delx, double dely, double delz,
             double *const *f, int nlocal);
  template <bool EVFLAG> void exact(Ref &R, const double *const *x, const double *const *v,
                                    double *const *f, int nlocal);
  template <bool EVFLAG> void loop();
  template <bool EVFLAG> void loop4();    // AVX: four entries at a time
  bool avx_loop;                          // compute() takes loop4()
};

}    // namespace LAMMPS_NS

#endif
