/* The arithmetic of one angle of angle_style breakable/cr, on one value or on lanes: included
   by angle_breakable_cr.cpp twice, inside two namespaces, once compiled for the baseline ISA
   and once for AVX (the 4-lane loop). No include guard: each inclusion is a copy in its own
   namespace. The includer provides select_lt, vmax, vsqrt, vabs for the lane types it uses,
   and SMALL. */

// asin(x) for |x| < ASIN_XMAX = 0.3 (|dth| < 17.46 degrees): x + x z P(z), z = x^2, P of
// degree 7 interpolating (asin(x) - x) / (x z) at the Chebyshev nodes of [0, 0.09]; relative
// error below 4e-16 (rounding included). Estrin's scheme keeps the dependency chain short.
constexpr double ASIN_XMAX = 0.3;

template <class T> inline T asin_small(T x)
{
  const T z = x * x;
  const T z2 = z * z;
  const T z4 = z2 * z2;
  const T p01 = 0.1666666666666649 + 0.07500000000250932 * z;
  const T p23 = 0.04464285655916009 + 0.03038199601727747 * z;
  const T p45 = 0.02236993042003646 + 0.01740472381582807 * z;
  const T p67 = 0.01330212710356684 + 0.015818111679304542 * z;
  const T p = (p01 + p23 * z2) + (p45 + p67 * z2) * z4;
  return x + x * z * p;
}

// The arithmetic of one angle, on one value or on two lanes. Every path that decides on an
// angle (fast and exact passes, single()) goes through it, so all take the same decisions.
template <class T> struct Angle3 {
  // in: arm vectors d1 = x1 - x2, d2 = x3 - x2, references
  T d1x, d1y, d1z, d2x, d2y, d2z;
  T cos0, sin0, inv_r1_0, inv_r2_0;
  // geometry
  T r1, r2, inv_r12, c, s, l1, l2, sd, cd;

  void geometry()
  {
    // r as bond_style breakable/cr computes it: the stretch tests must agree bit for bit
    r1 = vsqrt(d1x * d1x + d1y * d1y + d1z * d1z);
    r2 = vsqrt(d2x * d2x + d2y * d2y + d2z * d2z);
    const T dot = d1x * d2x + d1y * d2y + d1z * d2z;
    const T cx = d1y * d2z - d1z * d2y;
    const T cy = d1z * d2x - d1x * d2z;
    const T cz = d1x * d2y - d1y * d2x;
    const T b = vsqrt(cx * cx + cy * cy + cz * cz);    // r1 r2 sin(theta)
    inv_r12 = 1.0 / (r1 * r2);
    c = dot * inv_r12;
    s = b * inv_r12;
    l1 = r1 * inv_r1_0;
    l2 = r2 * inv_r2_0;
    sd = s * cos0 - c * sin0;    // sin(theta - theta0)
    cd = c * cos0 + s * sin0;    // cos(theta - theta0)
  }

  // energy and force coefficients at bend dth (SPEC Eq. 3-4): f1 = a11 d1 + a12 d2,
  // f3 = a22 d2 + a12 d1, f2 = -f1 - f3
  T a11, a12, a22, energy;

  void forces(T dth, T k, T inv_thc2, T inv_ec2)
  {
    const T inv_s = 1.0 / vmax(s, T{} + SMALL);
    const T inv_r1 = r2 * inv_r12;
    const T inv_r2 = r1 * inv_r12;

    // S of the more stretched arm, and dS/dl. eps is clamped at 0 (S = 1, dS = 0), q at 0:
    // an arm past lambda_c r0 (its bond breaks in this step) gives S = dS = 0, no force.
    const T eps = vmax(vmax(l1, l2) - 1.0, T{});
    const T q = vmax(1.0 - eps * eps * inv_ec2, T{});
    const T s_fac = q * q;

    // dE/dtheta = k_A S (dth - dth^3 / theta_c^2); E = k_A S g, g = dth^2/2 - dth^4/(4 thc^2)
    const T dth2 = dth * dth;
    const T ks = k * s_fac;
    const T tau = ks * dth * (1.0 - dth2 * inv_thc2);
    const T g = dth2 * (0.5 - 0.25 * dth2 * inv_thc2);
    energy = ks * g;

    // radial term -dE/dr = -k_A g (dS/dl) / r0 along the more stretched arm (arm 1 on a
    // tie), folded into the coefficient of that arm's vector (divided by its length)
    const T fr = 4.0 * k * g * eps * q * inv_ec2;
    const T fr1 = select_lt(l1, l2, T{}, fr * inv_r1_0 * inv_r1);
    const T fr2 = select_lt(l1, l2, fr * inv_r2_0 * inv_r2, T{});

    // angular part as in angle_style harmonic
    const T aa = -tau * inv_s;
    a11 = aa * c * inv_r1 * inv_r1 + fr1;
    a12 = -aa * inv_r12;
    a22 = aa * c * inv_r2 * inv_r2 + fr2;
  }
};

