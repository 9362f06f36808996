/* Kinematics of the points of a bond_style bcm/griffith interface (SPEC 1.2, contact point
   kinematics; plugins/doc/bond_bcm_griffith.md, "Kinematics"), written once for the intact
   springs and the contacts of a broken interface.

   Cell 1 / cell 2 = the cell with the smaller / larger atom ID; n points from 1 to 2.
   Per point k of an interface with N_p points (body-frame anchors b1, b2 in cells 1 and 2):
     r2 = R2 b2, p2 = x2 + r2, p1 = x1 + R1 b1, delta = p2 - p1, n = R1 n_body,
     dn = delta . n (> 0 gap), dt = delta - dn n,
     dv = v2 + w2 x r2 - v1 - w1 x (p2 - x1): the velocity of p2 relative to the point of
          cell 1 at p2, i.e. the rate of delta seen from cell 1's rotating frame
          (dv . n = d(dn)/dt exactly).
   Every force of a point acts on cell 2 at p2 and, reversed, on cell 1 at the same point p2.
   For an energy E(delta, vectors carried by cell 1) this gives exactly -grad E (the torque of
   -F at p2 on cell 1 is the arm p1 - x1 plus the turn of n: (k_p - k_tp) dn (delta x n) for the
   intact spring), and forces that share their point of action conserve angular momentum
   (BcmInterfaceKinematics::Load). */

#ifndef BRITTLE_BCM_INTERFACE_KINEMATICS_H
#define BRITTLE_BCM_INTERFACE_KINEMATICS_H

#include "bcm_rigid.h"

namespace BcmInterfaceKinematics {

// one cell, packed once per evaluation: centre (3), velocity (3), angular velocity (3), R (9)
constexpr int CELL_STRIDE = 18;

inline void pack_cell(const double *x, const double *v, const double *omega, const double *quat,
                      double *cell)
{
  for (int c = 0; c < 3; c++) {
    cell[c] = x[c];
    cell[3 + c] = v[c];
    cell[6 + c] = omega[c];
  }
  BcmRigid::rotation(quat, reinterpret_cast<double(*)[3]>(cell + 9));
}

// the two cells of an interface (packed by pack_cell) and its current normal
struct Pair {
  const double (*R1)[3], (*R2)[3];
  const double *w1, *w2;
  double n[3];      // R1 n_body
  double d12[3];    // x2 - x1
  double v12[3];    // v2 - v1

  Pair(const double *cell1, const double *cell2, const double *n_body) :
      R1(reinterpret_cast<const double(*)[3]>(cell1 + 9)),
      R2(reinterpret_cast<const double(*)[3]>(cell2 + 9)), w1(cell1 + 6), w2(cell2 + 6)
  {
    BcmRigid::rotate(R1, n_body, n);
    for (int c = 0; c < 3; c++) {
      d12[c] = cell2[c] - cell1[c];
      v12[c] = cell2[3 + c] - cell1[3 + c];
    }
  }
};

// one point of the interface
struct Point {
  double r2[3];    // p2 - x2
  double dn;       // delta . n, > 0 open
  double dt[3];    // delta - dn n
  double dv[3];    // velocity of p2 relative to cell 1's point at p2
};

// the point with body-frame anchors b1 (cell 1) and b2 (cell 2)
inline void point(const Pair &p, const double *b1, const double *b2, Point &out)
{
  double r1[3], delta[3], arm1[3], wa[3], wb[3];
  BcmRigid::rotate(p.R1, b1, r1);
  BcmRigid::rotate(p.R2, b2, out.r2);
  for (int c = 0; c < 3; c++) {
    arm1[c] = p.d12[c] + out.r2[c];    // p2 - x1
    delta[c] = arm1[c] - r1[c];
  }
  out.dn = BcmRigid::dot(delta, p.n);
  for (int c = 0; c < 3; c++) out.dt[c] = delta[c] - out.dn * p.n[c];
  BcmRigid::cross(p.w2, out.r2, wa);
  BcmRigid::cross(p.w1, arm1, wb);
  for (int c = 0; c < 3; c++) out.dv[c] = p.v12[c] + wa[c] - wb[c];
}

/* The forces of an interface's points on cell 2, summed: total force and torque about x2.
   Each acts on cell 2 at p2 and, reversed, on cell 1 at the same point, so the torque on
   cell 1 is -sum (d12 + r2) x F = -(d12 x f + t2). */
struct Load {
  double f[3] = {0.0, 0.0, 0.0};
  double t2[3] = {0.0, 0.0, 0.0};

  void add(const Point &q, const double *F)
  {
    double tq[3];
    BcmRigid::cross(q.r2, F, tq);
    for (int c = 0; c < 3; c++) {
      f[c] += F[c];
      t2[c] += tq[c];
    }
  }
  void torque1(const Pair &p, double *t1) const
  {
    BcmRigid::cross(p.d12, f, t1);
    for (int c = 0; c < 3; c++) t1[c] = -(t1[c] + t2[c]);
  }
};

// what the intact interface's force kernel (bcm_interface_kernel.h) gives: the sums over the
// points of one evaluation
struct IntactSums {
  double stored = 0.0;     // energy of the springs
  double tension = 0.0;    // Griffith's share of it (Eq. 5: normal springs in tension only)
  double pd = 0.0;         // -sum F_d . dv of the new damping forces
  double fd_dv = 0.0;      // sum F_d . dv of the previous damping forces at the new dv
  double f[3] = {0.0, 0.0, 0.0};     // total force on cell 2
  double t2[3] = {0.0, 0.0, 0.0};    // torque on cell 2 about x2
};

}    // namespace BcmInterfaceKinematics

#endif
