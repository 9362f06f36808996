/* Small helpers shared by the breakable Clemmer-Robbins styles: per-atom storage of
   reference geometry in a hidden fix lazy/store, and slot look-ups in atom topology. */

#ifndef BRITTLE_BREAKABLE_UTIL_H
#define BRITTLE_BREAKABLE_UTIL_H

#include "atom.h"
#include "error.h"
#include "fix.h"
#include "lammps.h"
#include "modify.h"

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <string>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace LAMMPS_NS {
namespace BreakableUtil {

  // The per-atom reference stores of bond_style and angle_style breakable/cr, filled by fix
  // breakable/references: r0 per bond slot; theta0, r1_0, r2_0 per angle slot.
  constexpr const char *BOND_REF_FIX_ID = "BREAKABLE_CR_BOND_R0";
  constexpr const char *BOND_REF_NAME = "breakable_cr_bond_r0";
  constexpr const char *ANGLE_REF_FIX_ID = "BREAKABLE_CR_ANGLE_REF";
  constexpr const char *ANGLE_REF_NAME = "breakable_cr_angle_ref";

  // Index into atom->darray of a per-atom array "name" with ncols columns, created as a
  // hidden fix lazy/store (id fix_id) so that it migrates with its atoms, follows atom
  // sorting and is written to restart files; unlike fix property/atom, its rows cost memory
  // only once an atom uses them (fix_lazy_store.h). A fix of the same id re-created after
  // read_restart gets its stored values back.
  inline int peratom_array(LAMMPS *lmp, const std::string &fix_id, const std::string &name,
                           int ncols)
  {
    if (ncols < 1)
      lmp->error->all(FLERR, "Per-atom store {} needs at least one column", name);
    if (!lmp->modify->get_fix_by_id(fix_id))
      lmp->modify->add_fix(fmt::format("{} all lazy/store {} {} ghost no", fix_id, name, ncols));
    int flag = -1, cols = -1;
    const int index = lmp->atom->find_custom(name.c_str(), flag, cols);
    if (index < 0 || flag != 1 || cols != ncols)
      lmp->error->all(FLERR,
                      "Per-atom store {} (fix {}) has {} columns, {} needed: the topology per "
                      "atom changed after the reference geometry was stored",
                      name, fix_id, cols, ncols);
    return index;
  }

  // Arithmetic on one value (double) or on two lanes at once (Lanes2), written once as
  // templates: add, multiply, divide and sqrt round each lane exactly as the scalar
  // instruction does, so a lane and the scalar path give the same bits and take the same
  // decisions. No fused multiply-add is involved (the plugin is built for baseline x86-64).
  using Lanes2 = double __attribute__((vector_size(16)));
  using Mask2 = long long __attribute__((vector_size(16)));

  // x < y ? a : b, without a branch: in the force loops the outcome (which arm of an angle
  // is longer, whether a bond is compressed) is random from one entry to the next, so a
  // branch would be mispredicted about half of the time. Exact: one of a, b bit for bit.
  inline double select_lt(double x, double y, double a, double b)
  {
#if defined(__SSE2__)
    const __m128d m = _mm_cmplt_sd(_mm_set_sd(x), _mm_set_sd(y));
    return _mm_cvtsd_f64(_mm_or_pd(_mm_and_pd(m, _mm_set_sd(a)), _mm_andnot_pd(m, _mm_set_sd(b))));
#else
    return x < y ? a : b;
#endif
  }

  inline Lanes2 select_lt(Lanes2 x, Lanes2 y, Lanes2 a, Lanes2 b)
  {
    const Mask2 m = x < y;
    return (Lanes2) (((Mask2) a & m) | ((Mask2) b & ~m));
  }

  // std::max(a, b) = (a < b) ? b : a
  inline double vmax(double a, double b) { return (a < b) ? b : a; }
  inline Lanes2 vmax(Lanes2 a, Lanes2 b) { return select_lt(a, b, b, a); }

  inline double vsqrt(double a) { return sqrt(a); }
  inline Lanes2 vsqrt(Lanes2 a)
  {
#if defined(__SSE2__)
    return (Lanes2) _mm_sqrt_pd((__m128d) a);
#else
    return Lanes2{sqrt(a[0]), sqrt(a[1])};
#endif
  }

  inline double vabs(double a) { return fabs(a); }
  inline Lanes2 vabs(Lanes2 a)
  {
    return (Lanes2) ((Mask2) a & Mask2{0x7fffffffffffffffLL, 0x7fffffffffffffffLL});
  }

  // Whether the force loops take their 4-lane AVX versions (compiled alongside the baseline
  // x86-64 ones with `#pragma GCC target("avx")`, lanes4_avx.h): the processor has AVX and the
  // environment does not ask for the baseline loops (BRITTLE_NO_AVX=1, to test both paths).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define BRITTLE_AVX_LOOPS 1
#endif
  inline bool avx_loops()
  {
#if defined(BRITTLE_AVX_LOOPS)
    __builtin_cpu_init();
    const char *off = getenv("BRITTLE_NO_AVX");
    return __builtin_cpu_supports("avx") && !(off && *off && strcmp(off, "0") != 0);
#else
    return false;
#endif
  }

  // Slot m of the bond of owned atom i with atom tag partner, or -1.
  inline int bond_slot(const Atom *atom, int i, tagint partner)
  {
    const tagint *batom = atom->bond_atom[i];
    for (int m = 0; m < atom->num_bond[i]; m++)
      if (batom[m] == partner) return m;
    return -1;
  }

  // Slot m of the angle (t1, t2, t3) of owned atom i, or -1. Every atom of an angle
  // stores it with the same atom order (newton_bond off), so the order must match.
  inline int angle_slot(const Atom *atom, int i, tagint t1, tagint t2, tagint t3)
  {
    for (int m = 0; m < atom->num_angle[i]; m++)
      if (atom->angle_atom2[i][m] == t2 && atom->angle_atom1[i][m] == t1 &&
          atom->angle_atom3[i][m] == t3)
        return m;
    return -1;
  }

}    // namespace BreakableUtil
}    // namespace LAMMPS_NS

#endif
