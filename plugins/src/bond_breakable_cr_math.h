/* The force law of one bond of bond_style breakable/cr, on one value or on lanes: included by
   bond_breakable_cr.cpp twice, inside two namespaces, once compiled for the baseline ISA and
   once for AVX (the 4-lane loop). No include guard: each inclusion is a copy in its own
   namespace. The includer provides select_lt for the lane types it uses. */

/* ----------------------------------------------------------------------
   force / r of one intact bond (SPEC 2.2 Eq. 2 and the bonded damping of
   Eq. 5), F > 0 repulsive, and its energy, on one value or on two lanes:
   every path (the two-lane loop, the exact pass, single()) computes a bond
   with this arithmetic. Both branches of Eq. 2 are evaluated and one is
   selected: r < r0 holds for about half of the bonds of a solid, at random.
   l = r / r0 (as r * (1/r0)), dot = (x_i - x_j) . (v_i - v_j).
------------------------------------------------------------------------- */

template <class T>
inline T bond_force(T r, T inv_rsq, T l, T dot, T r0, T inv_r0, T c1, T c3r2, T krep,
                    T gamma, T inv_lc, T &ebond)
{
  const T r0sq = r0 * r0;
  const T k = krep * r0sq;
  const T x2 = r0sq * inv_rsq;    // (r0/r)^2
  const T x6 = x2 * x2 * x2;
  const T x12 = x6 * x6;
  const T d = r - r0;
  const T d2 = d * d;
  const T c3 = c3r2 * inv_r0 * inv_r0;
  ebond = select_lt(r, r0, (k / 12.0) * (x12 - 2.0 * x6 + 1.0), d2 * (0.5 * c1 + 0.25 * c3 * d2));
  const T fr_rep = k * (x12 - x6) * inv_rsq;
  const T fr_att = -d * (c1 + c3 * d2) * r * inv_rsq;
  // SPEC 2.2 Eq. 5, bonded: r_max = lambda_c r0; not part of the energy
  const T w = 1.0 - l * inv_lc;
  return select_lt(r, r0, fr_rep, fr_att) - gamma * w * w * dot * inv_rsq;
}

