/* The state of a bond_style bcm/griffith interface: its layout in the per-slot store and in
   the style's working copy (plugins/doc/bond_bcm_griffith.md, "Storage"). */

#ifndef BRITTLE_BCM_INTERFACE_STATE_H
#define BRITTLE_BCM_INTERFACE_STATE_H

namespace BcmInterfaceState {

/* Per-slot state (per atom and bond slot, in a hidden fix lazy/store): header, then the
   damping force of each point at the last evaluation (damping-work quadrature), then per point
   the contact reference shift s, the slip offset sigma (cell 1's body frame), the in-contact
   flag and the last tangential contact force (friction work). The force loop works on a copy
   of the state in bondlist order (rebuilt at reneighboring, written back by sync_store()). */

// slot header
enum {
  H_BROKEN,        // INTACT, BROKEN or RETIRED
  H_BREAK_STEP,    // step of the break
  H_BREAK_TIME,    // simulation time of the break
  H_E_BREAK,       // elastic energy stored by the interface just before the switch
  H_E_EL,          // elastic energy stored now (intact springs or contact springs)
  H_W_DAMP,        // cumulative energy dissipated by damping
  H_W_FRIC,        // cumulative energy dissipated by friction
  H_W_SWITCH,      // energy dissipated at the switch (see contact_forces())
  H_LAST_KIND,     // kind of the last evaluation (EvalKind)
  H_LAST_DT,       // time step of the last evaluation
  H_PD,            // power dissipated by damping at the last evaluation, -sum F_d . dv
  H_W_DAMP_BREAK,  // H_W_DAMP when the interface broke: what its damping took after the
                   // break is H_W_DAMP - H_W_DAMP_BREAK (diagnostics of the broken law)
  H_SLIP,          // cumulative Coulomb slip of its points, m (summed over the points)
  H_NCLOSED,       // closed points of the broken interface at the last evaluation
  H_FN,            // normal force of its closed points at the last evaluation, N
  NHEAD
};

// After the header, the damping forces of the last evaluation, 3 per point (F_d on cell 2:
// the only per-point state an intact interface reads and writes, kept together), then the
// contact state of the points of a broken interface, NCONTACT per point:
enum {
  C_SHIFT,        // s: contact overlap reference
  C_SLIP,         // sigma (3): slip offset in cell 1's body frame, u_t = dt - R1 sigma
  C_TOUCH = 4,    // 1 while the point is a closed contact
  C_FT,           // magnitude of the tangential contact force at the last evaluation
  NCONTACT
};
constexpr int NPOINT = 3 + NCONTACT;    // doubles per point in a slot

// H_BROKEN: the points are the intact interface's springs; frictional contacts; nothing (the
// pair is the pair style's)
constexpr double INTACT = 0.0, BROKEN = 1.0, RETIRED = 2.0;

// record of a bondlist entry in the working copy: these constants, the fields of the slot's
// header that every interface reads and writes (below), the damping forces and the geometry
// (normal in cell 1's frame, then the anchors b1, b2), the per-point values as rows of N_p
// values (x row, y row, z row: the layout of the 4-lane force kernel, bcm_interface_kernel.h,
// which reads 4 at a time past a row's end into what follows it, never sums those lanes and
// writes only the row's own: the working copy ends with RECORD_TAIL spare values):
//   NCONST | NRHEAD | fd: 3 N_p | normal: 3 | b1: 3 N_p | b2: 3 N_p
enum {
  K_AREA,    // S
  K_CP,      // 2 alpha sqrt(k_n m) / N_p (k_n / N_p and k_t / N_p: BondBcmGriffith::point_stiffness())
  NCONST
};
// what the last force evaluation was: it decides which half kicks used its damping force
enum EvalKind { EVAL_NONE = 0, EVAL_SETUP = 1, EVAL_STEP = 2 };
// the record's header: the slot header's fields of every interface, the last evaluation's
// kind and time step in one value (RH_LAST: +dt after a step, -dt after a setup, 0 before
// any; exact both ways, dt > 0)
enum { RH_BROKEN, RH_E_EL, RH_W_DAMP, RH_LAST, RH_PD, NRHEAD };
constexpr int RECORD_HEAD[NRHEAD] = {H_BROKEN, H_E_EL, H_W_DAMP, -1, H_PD};    // -1: RH_LAST
inline double last_of(int kind, double dt)
{
  return kind == EVAL_STEP ? dt : kind == EVAL_SETUP ? -dt : 0.0;
}
inline int last_kind(double last) { return last > 0.0 ? EVAL_STEP : last < 0.0 ? EVAL_SETUP : EVAL_NONE; }
inline double last_dt(double last) { return last < 0.0 ? -last : last; }
// the contact block of a broken (or retired) interface, apart from the records: the contact
// law's constants, the slot header's fields that only a broken interface writes (zeros while
// intact), then NCONTACT per point:
//   NBHEAD | contact state: NCONTACT N_p
enum {
  B_KC,      // contact k_n / N_p
  B_KTC,     // contact k_t / N_p
  B_CC,      // contact 2 alpha_c sqrt(k_n,c m) / N_p
  B_HEAD,    // the broken-only header fields, BROKEN_HEAD's order
  NBHEAD = B_HEAD + 9
};
constexpr int NBROKEN_HEAD = NBHEAD - B_HEAD;
constexpr int BROKEN_HEAD[NBROKEN_HEAD] = {H_BREAK_STEP, H_BREAK_TIME, H_E_BREAK, H_W_FRIC,
                                           H_W_SWITCH, H_W_DAMP_BREAK, H_SLIP, H_NCLOSED,
                                           H_FN};
// a broken-only field's place in the contact block
constexpr int B_BREAK_STEP = B_HEAD, B_BREAK_TIME = B_HEAD + 1, B_E_BREAK = B_HEAD + 2,
              B_W_FRIC = B_HEAD + 3, B_W_SWITCH = B_HEAD + 4, B_W_DAMP_BREAK = B_HEAD + 5,
              B_SLIP = B_HEAD + 6, B_NCLOSED = B_HEAD + 7, B_FN = B_HEAD + 8;
inline long contact_size(int npts) { return NBHEAD + (long) NCONTACT * npts; }
constexpr int LANES = 4;
// the values of a row of the record: N_p, not padded (issue 27: 0.9 kB per cell)
inline int row_stride(int npts) { return npts; }
constexpr long RECORD_TAIL = LANES - 1;    // what a 4-lane read of the last row goes past
constexpr int R_HEAD = NCONST;            // the record's header
constexpr int R_FD = NCONST + NRHEAD;     // damping forces, 3 rows of N_p
inline long record_geometry(int npts) { return R_FD + 3L * row_stride(npts); }    // normal, b1, b2
inline long record_size(int npts) { return record_geometry(npts) + 3 + 6L * row_stride(npts); }

// the slot header (NHEAD) from a record's header rh (rec + R_HEAD, or a copy of it) and its
// contact block cb (nullptr while intact: zeros)
inline void compose_head_from(const double *rh, const double *cb, double *head)
{
  for (int h = 0; h < NRHEAD; h++)
    if (h != RH_LAST) head[RECORD_HEAD[h]] = rh[h];
  head[H_LAST_KIND] = last_kind(rh[RH_LAST]);
  head[H_LAST_DT] = last_dt(rh[RH_LAST]);
  for (int h = 0; h < NBROKEN_HEAD; h++) head[BROKEN_HEAD[h]] = cb ? cb[B_HEAD + h] : 0.0;
}
inline void compose_head(const double *rec, const double *cb, double *head)
{
  compose_head_from(rec + R_HEAD, cb, head);
}
// a slot header into a record and its contact block (nullptr while intact: not kept)
inline void split_head(const double *head, double *rec, double *cb)
{
  for (int h = 0; h < NRHEAD; h++)
    if (h != RH_LAST) rec[R_HEAD + h] = head[RECORD_HEAD[h]];
  rec[R_HEAD + RH_LAST] = last_of((int) head[H_LAST_KIND], head[H_LAST_DT]);
  if (cb)
    for (int h = 0; h < NBROKEN_HEAD; h++) cb[B_HEAD + h] = head[BROKEN_HEAD[h]];
}

}    // namespace BcmInterfaceState

#endif
