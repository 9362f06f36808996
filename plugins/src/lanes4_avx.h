/* Four-lane arithmetic helpers (AVX) of the breakable styles' force loops, the counterparts of
   the Lanes2 helpers of breakable_util.h. No include guard on purpose: include it inside a
   `#pragma GCC target("avx")` region and a namespace of that translation unit (each includer
   gets its own internal copy, compiled for AVX; nothing of it may reach baseline code). */

using Lanes4 = double __attribute__((vector_size(32)));
using Mask4 = long long __attribute__((vector_size(32)));

// x < y ? a : b, per lane, without a branch (one of a, b bit for bit)
inline Lanes4 select_lt(Lanes4 x, Lanes4 y, Lanes4 a, Lanes4 b)
{
  const Mask4 m = x < y;
  return (Lanes4) (((Mask4) a & m) | ((Mask4) b & ~m));
}
inline Lanes4 vmax(Lanes4 a, Lanes4 b) { return select_lt(a, b, b, a); }
inline Lanes4 vsqrt(Lanes4 a) { return __builtin_ia32_sqrtpd256(a); }
inline Lanes4 vabs(Lanes4 a)
{
  const long long mag = 0x7fffffffffffffffLL;
  return (Lanes4) ((Mask4) a & Mask4{mag, mag, mag, mag});
}
