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

// record of a bondlist entry in the working copy: these constants, the slot's header, the
// damping forces and the geometry (normal in cell 1's frame, then the anchors b1, b2), the
// per-point values as rows over the points padded to a multiple of LANES (x row, y row, z row:
// the layout of the 4-lane force kernel, bcm_interface_kernel.h; padding is never summed):
//   NCONST | NHEAD | fd: 3 P | normal: 3 | b1: 3 P | b2: 3 P
enum {
  K_AREA,    // S
  K_KP,      // k_n / N_p
  K_KTP,     // k_t / N_p
  K_CP,      // 2 alpha sqrt(k_n m) / N_p
  K_KC,      // contact k_n / N_p
  K_KTC,     // contact k_t / N_p
  K_CC,      // contact 2 alpha_c sqrt(k_n,c m) / N_p
  NCONST
};
constexpr int LANES = 4;
inline int padded(int npts) { return (npts + LANES - 1) / LANES * LANES; }
constexpr int R_SLOT = NCONST;            // the slot header
constexpr int R_FD = NCONST + NHEAD;      // damping forces, 3 rows of P
inline long record_geometry(int npts) { return R_FD + 3L * padded(npts); }    // normal, b1, b2
inline long record_size(int npts) { return record_geometry(npts) + 3 + 6L * padded(npts); }

// what the last force evaluation was: it decides which half kicks used its damping force
enum EvalKind { EVAL_NONE = 0, EVAL_SETUP = 1, EVAL_STEP = 2 };

}    // namespace BcmInterfaceState

#endif
