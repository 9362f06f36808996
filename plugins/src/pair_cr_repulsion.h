/* pair_style cr/repulsion: the non-bonded interactions of the Clemmer-Robbins bonded particle
   model in one loop (SPEC 2.2): the repulsion of Eq. 1 and the non-bonded damping of Eq. 5,
   both cut at abar, no random force. Bonded pairs are left out through special_bonds lj 0.
   See plugins/doc/pair_cr_repulsion.md. */

#ifndef BRITTLE_PAIR_CR_REPULSION_H
#define BRITTLE_PAIR_CR_REPULSION_H

#include "pair.h"

namespace LAMMPS_NS {

class PairCRRepulsion : public Pair {
 public:
  PairCRRepulsion(class LAMMPS *);
  ~PairCRRepulsion() override;

  void compute(int, int) override;
  void settings(int, char **) override;
  void coeff(int, char **) override;
  void init_style() override;
  double init_one(int, int) override;
  void write_restart(FILE *) override;
  void read_restart(FILE *) override;
  void write_restart_settings(FILE *) override {}
  void read_restart_settings(FILE *) override {}
  void write_data(FILE *) override;
  void write_data_all(FILE *) override;
  double single(int, int, int, int, double, double, double, double &) override;

 private:
  // per type pair: coefficients (abar is also the cutoff)
  double **u, **abar, **gamma;
  // per type pair, derived in init_one(): 12 u, abar^2, 1 / abar
  double **u12, **abar_sq, **inv_abar;

  void allocate();
  template <bool EVFLAG, bool EFLAG, bool NEWTON_PAIR> void eval();
};

}    // namespace LAMMPS_NS

#endif
