/* angle_style breakable/cr: the breakable three-body angle of Clemmer & Robbins
   (SPEC 2.2 Eq. 3-4). Per-angle references theta0 and arm lengths r1_0, r2_0 from the input
   (fix breakable/references); the angle breaks for good when |theta - theta0| >= theta_c,
   or with either of its arm bonds (break_with_bond), through the single break path
   (break_events.h). See plugins/doc/angle_breakable_cr.md. */

#ifndef BRITTLE_ANGLE_BREAKABLE_CR_H
#define BRITTLE_ANGLE_BREAKABLE_CR_H

#include "angle.h"

#include <vector>

namespace LAMMPS_NS {

struct BreakEvent;

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

  // fix breakable/special, end of step: the bond of ev broke on some rank in this step;
  // the angles having it as an arm break with it
  void break_with_bond(const BreakEvent &ev);

 private:
  // per type: coefficients (theta_c in radians; lambda_c only shapes S of Eq. 4)
  double *k, *theta_c, *lambda_c;

  // per type, packed for the force loop (derive())
  struct TypeParams {
    double k, theta_c, lambda_c;
    double inv_thc2;    // 1 / theta_c^2
    double inv_ec2;     // 1 / (lambda_c - 1)^2
  };
  std::vector<TypeParams> params;

  // one record per intact anglelist entry, rebuilt whenever the anglelist is: the entry
  // (type set to 0 when the angle breaks), its row n in the anglelist and its references,
  // read front to back by the force loop
  struct Ref {
    int i1, i2, i3, type, n;
    double cos0, sin0;            // cos and sin of theta0
    double inv_r1_0, inv_r2_0;    // 1 / reference arm lengths (atom1-atom2, atom3-atom2)
  };
  std::vector<Ref> cache;
  std::vector<int> deferred;    // cache entries the fast pass leaves to the exact one
  int cached_nanglelist;        // size of the anglelist the cache was built from, -1 = none
  std::vector<int> vertex_head;    // per local atom: first cache entry with it as vertex, or -1
  std::vector<int> vertex_next;    // per cache entry: next entry with the same vertex, or -1

  int store_index;    // atom->darray index: theta0, r1_0, r2_0 per atom and angle slot
  class FixBreakableSpecial *special;

  void allocate();
  void derive(int type);
  void rebuild_cache();
  void break_angle(Ref &R, double energy);
  void break_angle(Ref &R, double energy, bigint step, double time);
  double energy_now(const Ref &R) const;
  template <bool EVFLAG>
  void apply(const Ref &R, double a11, double a12, double a22, const double *d, double eangle,
             double *const *f, int nlocal);
  template <bool EVFLAG>
  void scatter(const Ref &R, const double *f1, const double *f3, const double *f13,
               const double *d, double eangle, double *const *f, int nlocal);
  template <bool EVFLAG> void exact(Ref &R, const double *const *x, double *const *f, int nlocal);
  template <bool EVFLAG> void loop();
  template <bool EVFLAG> void loop4();    // AVX: four entries at a time
  bool avx_loop;                          // compute() takes loop4()
};

}    // namespace LAMMPS_NS

#endif
