/* The intact interface's force kernel of bond_style bcm/griffith (SPEC 1.2 Eq. 1-3, 5;
   plugins/doc/bond_bcm_griffith.md, "Kinematics" and "Intact interface"): the kinematics of
   its points (bcm_interface_kinematics.h), their spring-dashpot forces, the Griffith tension
   energy and the previous damping forces' power, W points at a time.

   No include guard on purpose: bond_bcm_griffith.cpp includes it twice, once for the baseline
   (W = 1, V = double) and once inside a `#pragma GCC target("avx")` region with lanes4_avx.h
   (W = 4, V = Lanes4), each in a namespace of its own that defines V, W and the helpers
   load(), store(), splat() and positive_or_zero(). Each lane does the operations of the
   scalar code (bcm_interface_kinematics.h, BondBcmGriffith::intact_forces() as they were)
   in the same order, and the sums over the points are taken lane by lane in point order,
   so that both copies give the scalar code's results bit for bit.

   Layout (the style's working copy, bcm_interface_state.h): the damping forces fd and the
   anchors b1, b2 are rows of np values (x row, y row, z row), not padded: W values are read at
   a time, past a row's end into what follows it (finite values of the working copy, which ends
   with spare ones); those lanes are computed and never summed, and store_first() writes only
   a row's own values. */

using BcmInterfaceKinematics::IntactSums;
using BcmInterfaceKinematics::Pair;

// the points of one intact interface; fd is read (previous damping forces) and written
inline void intact_interface(const Pair &p, double kp, double ktp, double cp, int np,
                             int P, double *fd, const double *b1, const double *b2,
                             IntactSums &s)
{
  const V R1[3][3] = {{splat(p.R1[0][0]), splat(p.R1[0][1]), splat(p.R1[0][2])},
                      {splat(p.R1[1][0]), splat(p.R1[1][1]), splat(p.R1[1][2])},
                      {splat(p.R1[2][0]), splat(p.R1[2][1]), splat(p.R1[2][2])}};
  const V R2[3][3] = {{splat(p.R2[0][0]), splat(p.R2[0][1]), splat(p.R2[0][2])},
                      {splat(p.R2[1][0]), splat(p.R2[1][1]), splat(p.R2[1][2])},
                      {splat(p.R2[2][0]), splat(p.R2[2][1]), splat(p.R2[2][2])}};
  const V n[3] = {splat(p.n[0]), splat(p.n[1]), splat(p.n[2])};
  const V d12[3] = {splat(p.d12[0]), splat(p.d12[1]), splat(p.d12[2])};
  const V v12[3] = {splat(p.v12[0]), splat(p.v12[1]), splat(p.v12[2])};
  const V w1[3] = {splat(p.w1[0]), splat(p.w1[1]), splat(p.w1[2])};
  const V w2[3] = {splat(p.w2[0]), splat(p.w2[1]), splat(p.w2[2])};
  const V kp_ = splat(kp), ktp_ = splat(ktp), mcp = splat(-cp);
  const V hkp = splat(0.5 * kp), hktp = splat(0.5 * ktp);
  // the sums in locals (registers: the stores into fd cannot alias them), from zero as the
  // scalar code's
  double fd_dv = 0.0, sum_stored = 0.0, sum_tension = 0.0, sum_pd = 0.0;
  double f0 = 0.0, f1 = 0.0, f2 = 0.0, t0 = 0.0, t1 = 0.0, t2 = 0.0;

  for (int g = 0; g < np; g += W) {
    V b[3], r1[3], r2[3], arm1[3], delta[3], dt[3], dv[3], fdo[3], fdn[3], F[3];
    for (int c = 0; c < 3; c++) b[c] = load(b1 + c * P + g);
    for (int c = 0; c < 3; c++) r1[c] = R1[c][0] * b[0] + R1[c][1] * b[1] + R1[c][2] * b[2];
    for (int c = 0; c < 3; c++) b[c] = load(b2 + c * P + g);
    for (int c = 0; c < 3; c++) r2[c] = R2[c][0] * b[0] + R2[c][1] * b[1] + R2[c][2] * b[2];
    for (int c = 0; c < 3; c++) {
      arm1[c] = d12[c] + r2[c];    // p2 - x1
      delta[c] = arm1[c] - r1[c];
    }
    const V dn = delta[0] * n[0] + delta[1] * n[1] + delta[2] * n[2];
    for (int c = 0; c < 3; c++) dt[c] = delta[c] - dn * n[c];
    // w2 x r2 and w1 x arm1
    const V wa[3] = {w2[1] * r2[2] - w2[2] * r2[1], w2[2] * r2[0] - w2[0] * r2[2],
                     w2[0] * r2[1] - w2[1] * r2[0]};
    const V wb[3] = {w1[1] * arm1[2] - w1[2] * arm1[1], w1[2] * arm1[0] - w1[0] * arm1[2],
                     w1[0] * arm1[1] - w1[1] * arm1[0]};
    for (int c = 0; c < 3; c++) dv[c] = v12[c] + wa[c] - wb[c];

    for (int c = 0; c < 3; c++) fdo[c] = load(fd + c * P + g);
    const V fdv_old = fdo[0] * dv[0] + fdo[1] * dv[1] + fdo[2] * dv[2];

    const V en = hkp * dn * dn;
    const V et = hktp * (dt[0] * dt[0] + dt[1] * dt[1] + dt[2] * dt[2]);
    const V stored = en + et;
    const V tension = positive_or_zero(dn, en) + et;
    const V kdn = kp_ * dn;
    for (int c = 0; c < 3; c++) {
      fdn[c] = mcp * dv[c];
      F[c] = -(kdn * n[c] + ktp_ * dt[c]) + fdn[c];
      store_first(fd + c * P + g, fdn[c], np - g);
    }
    const V pd = fdn[0] * dv[0] + fdn[1] * dv[1] + fdn[2] * dv[2];
    const V tq[3] = {r2[1] * F[2] - r2[2] * F[1], r2[2] * F[0] - r2[0] * F[2],
                     r2[0] * F[1] - r2[1] * F[0]};

    // the sums, point by point in order
    double l_fdv[W], l_stored[W], l_tension[W], l_pd[W], l_F[3][W], l_tq[3][W];
    store(l_fdv, fdv_old);
    store(l_stored, stored);
    store(l_tension, tension);
    store(l_pd, pd);
    for (int c = 0; c < 3; c++) {
      store(l_F[c], F[c]);
      store(l_tq[c], tq[c]);
    }
    const int nl = np - g < W ? np - g : W;
    for (int l = 0; l < nl; l++) {
      fd_dv += l_fdv[l];
      sum_stored += l_stored[l];
      sum_tension += l_tension[l];
      sum_pd -= l_pd[l];
      f0 += l_F[0][l];
      f1 += l_F[1][l];
      f2 += l_F[2][l];
      t0 += l_tq[0][l];
      t1 += l_tq[1][l];
      t2 += l_tq[2][l];
    }
  }
  s.fd_dv = fd_dv;
  s.stored = sum_stored;
  s.tension = sum_tension;
  s.pd = sum_pd;
  s.f[0] = f0;
  s.f[1] = f1;
  s.f[2] = f2;
  s.t2[0] = t0;
  s.t2[1] = t1;
  s.t2[2] = t2;
}

// the normal gap dn of every point of an interface (as BcmInterfaceKinematics::point() computes
// it), into dn[0 .. np rounded up to W): the screening of a broken interface's points (all open?)
inline void interface_gaps(const Pair &p, int np, int P, const double *b1, const double *b2,
                           double *dn)
{
  const V R1[3][3] = {{splat(p.R1[0][0]), splat(p.R1[0][1]), splat(p.R1[0][2])},
                      {splat(p.R1[1][0]), splat(p.R1[1][1]), splat(p.R1[1][2])},
                      {splat(p.R1[2][0]), splat(p.R1[2][1]), splat(p.R1[2][2])}};
  const V R2[3][3] = {{splat(p.R2[0][0]), splat(p.R2[0][1]), splat(p.R2[0][2])},
                      {splat(p.R2[1][0]), splat(p.R2[1][1]), splat(p.R2[1][2])},
                      {splat(p.R2[2][0]), splat(p.R2[2][1]), splat(p.R2[2][2])}};
  const V n[3] = {splat(p.n[0]), splat(p.n[1]), splat(p.n[2])};
  const V d12[3] = {splat(p.d12[0]), splat(p.d12[1]), splat(p.d12[2])};
  for (int g = 0; g < np; g += W) {
    V b[3], r1[3], r2[3], delta[3];
    for (int c = 0; c < 3; c++) b[c] = load(b1 + c * P + g);
    for (int c = 0; c < 3; c++) r1[c] = R1[c][0] * b[0] + R1[c][1] * b[1] + R1[c][2] * b[2];
    for (int c = 0; c < 3; c++) b[c] = load(b2 + c * P + g);
    for (int c = 0; c < 3; c++) r2[c] = R2[c][0] * b[0] + R2[c][1] * b[1] + R2[c][2] * b[2];
    for (int c = 0; c < 3; c++) delta[c] = (d12[c] + r2[c]) - r1[c];
    store(dn + g, delta[0] * n[0] + delta[1] * n[1] + delta[2] * n[2]);
  }
}
