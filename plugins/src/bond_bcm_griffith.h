/* bond_style bcm/griffith: the cohesive interface of the bonded cell method (SPEC 1.2), one
   bond per face shared by two cells. Multi-point spring-dashpot interface, Griffith breaking
   (Eq. 4-6), then cohesionless frictional point contacts (Eq. 1, 7) until the two cells part
   (their bounding spheres separate): the interface is then retired and the pair handed to
   the pair style (pair_style bcm/contact). The geometry of every interface comes from a
   file; the per-interface state lives per atom and bond slot. See
   plugins/doc/bond_bcm_griffith.md. */

#ifndef BRITTLE_BOND_BCM_GRIFFITH_H
#define BRITTLE_BOND_BCM_GRIFFITH_H

#include "bcm_interface_kinematics.h"
#include "bcm_interface_table.h"
#include "bond.h"
#include "fix_breakable_special.h"
#include "fix_lazy_store.h"

#include <cstdint>
#include <vector>

namespace LAMMPS_NS {

class BondBcmGriffith : public Bond, public SpecialReleasedBonds, public FixLazyStore::Owner {
 public:
  static constexpr int NVECTOR = 13;       // global vector of fix bcm/griffith

  BondBcmGriffith(class LAMMPS *);
  ~BondBcmGriffith() override;

  void compute(int, int) override;
  void settings(int, char **) override;
  void coeff(int, char **) override;
  void init_style() override;
  double equilibrium_distance(int) override;
  void write_restart(FILE *) override;
  void read_restart(FILE *) override;
  void write_restart_settings(FILE *) override;
  void read_restart_settings(FILE *) override;
  void write_data(FILE *) override;
  double single(int, double, int, int, double &) override;
  double memory_usage() override;

  // this rank's share of the global vector of fix bcm/griffith (each interface counted by
  // the owner of its cell with the smaller ID)
  void tally(double *sums);
  // force evaluations so far: changes whenever the per-interface state may have
  bigint evaluations() const { return nevaluations; }
  // atoms may migrate or be sorted now (fix bcm/griffith, pre_exchange): until the working
  // copy is rebuilt, its entries' cells no longer match the atoms' indices (its state, kept
  // by interface, stays the only live copy: rows that leave are composed from it)
  void atoms_may_move() { atoms_moved = true; }
  // fix lazy/store: atom i's row of the per-slot store, from the working copy where it holds
  // the interface, else from the stored row
  size_t compose(int i, const double *stored, size_t n, double *out) override;
  // bond slot m of owned atom i is a retired interface: its cells are no longer 1-2 special
  // neighbours (fix breakable/special, at every run setup)
  bool released(int i, int m) override;
  // fix breakable/special, before the special lists are brought up to date: sync_copies()
  void before_special_update() override { sync_copies(); }
  // an interface whose cells are owned by two ranks is evaluated once (issue 27), by the
  // owner of its cell 1 (the smaller ID), which applies its forces to both cells (the ghost's
  // reach its owner with LAMMPS's reverse communication of forces and torques); the other
  // rank's entry is a copy, not evaluated. Here every copy takes its interface's state from
  // the rank that evaluates it, and a copy's interface retired since is released from the
  // special lists of this rank's cell (add_broken_bond). Collective; called at every
  // re-neighbouring and run setup (before_special_update()) and after every run (fix
  // bcm/griffith): a row that leaves with its atom (exchange, restart file) is composed from
  // an up-to-date copy.
  void sync_copies();

  // an entry of the working copy (below): 24 bytes (issue 27)
  struct Entry {
    int c1, c2;        // local indices of the cells with the smaller and the larger ID
    int iface;         // in the interface table
    int32_t coff;      // into contact: its block (BcmInterfaceState::contact_size(npts):
                       // contact constants, broken-only header, NCONTACT per point); -1
                       // while intact
    uint32_t roff;     // into records
    int16_t type;      // bond type the constants of the record were taken for
    int16_t npts;
  };
  // the working copy of a style that is replaced (bond_style given again), kept by fix
  // bcm/griffith for the next one: it holds the only live copy of the state
  struct Parked {
    std::vector<Entry> cache;
    std::vector<double> records, contact;
    std::vector<tagint> tags;
  };

 private:
  enum Stiffness { PER_INTERFACE, PER_AREA };
  // the law of a broken interface's closed points (plugins/doc/bond_bcm_griffith.md,
  // "Broken interface"): stiffness and damping those of the contact (bond_coeff kn_c, kt_c,
  // en2_c, split over N_p) or those of the intact interface; at the break, the tangential
  // spring of a closed point carried into the contact (force kept, Coulomb cap) or released
  enum BrokenLaw { CONTACT, INTERFACE };
  enum BreakShear { CARRIED, RELEASED };
  // at the break, the normal spring of a closed point: its reference shifted so that the
  // normal force is kept (SPEC 1.2), or not shifted (the contact law from the overlap itself,
  // as the reference code Rockable switches: a diagnostic; it creates energy, booked as a
  // negative switch term)
  enum BreakNormal { SHIFTED, UNSHIFTED };
  // the points of a broken interface: the glued face polygon's vertices (SPEC 1.2, until the
  // cells part: retire()), or none: handed to pair_style bcm/contact (the rounded cells' own
  // contact geometry) at the break itself (a diagnostic of issue 23; a hand-over in compression
  // makes the pair's overlap energy from nothing, which no counter books)
  enum BrokenPoints { POLYGON, CELLS };

  // per type: bond_coeff values and derived damping ratios (SPEC Eq. 2)
  double *kn, *kt, *en2, *gc, *kn_c, *kt_c, *en2_c, *mu;
  double *alpha, *alpha_c;

  BcmInterfaceTable table;    // the geometry of every interface, identical on every rank
  int convention;             // BcmGriffith::Convention
  int stiffness;              // PER_INTERFACE (the published model) or PER_AREA (k times S / <S>)
  int broken_stiffness;       // BrokenLaw of the closed points' springs
  int broken_damping;         // BrokenLaw of the closed points' damping
  int break_shear;            // BreakShear
  int break_normal;           // BreakNormal
  int broken_points;          // BrokenPoints

  // Working copy of the interfaces of the bond list, rebuilt with it (at each
  // reneighbouring): per entry one contiguous record in bondlist order holding the per-point
  // constants, the state read and written at every evaluation (slot header and damping
  // forces) and the body-frame geometry, so that the force loop streams through memory and
  // does no look-up; the contact state of broken interfaces apart. It is the only live copy
  // of the state (issue 27): at a rebuild each interface's state comes from the previous
  // working copy, or from the per-atom store's row of a cell that arrived with it (exchange,
  // restart file), which is then emptied; the store holds between rebuilds only what arrived
  // and the interfaces of owned cells that the bond list lacks (a partner lost), and a row
  // that leaves is composed from the working copy (compose()).
  std::vector<Entry> cache;
  std::vector<double> records;
  std::vector<double> contact;
  bool cache_valid;                  // entries match the bond list (else rebuilt)
  bool have_state;                   // the records hold the state of their interfaces
  bool atoms_moved;                  // atoms may have moved since the working copy was built
  // per interface of the table: its entry (an evaluated one before a copy), or -1 (valid
  // while have_state)
  std::vector<int> entry_of_iface;
  // per entry, by the owners of its cells: both owned here (a ghost may be the periodic
  // image of a cell owned here: both of that interface's entries are evaluated, each adding
  // to its owned cell, as before issue 27), cell 2 owned by another rank (evaluated here for
  // both cells), or cell 1 owned by another rank (a copy: evaluated here only when `once` is
  // off); set with the working copy
  enum Side : uint8_t { OWNED = 0, CROSSING = 1, COPY = 2 };
  std::vector<uint8_t> side;
  long ncrossing_entries = 0;    // entries not OWNED
  // each interface evaluated by one rank (sync_copies()): on with a reverse communication of
  // forces (newton on: newton_pair on) and this style not a hybrid's sub-style, unless the
  // environment sets BRITTLE_EVAL_BOTH=1 (every rank evaluates its entries, copies included,
  // as before issue 27's change: a check of the once path)
  bool once = false;
  int32_t new_contact_block(int npts);
  void load_copy(Entry &e, const double *slot);
  // per owned atom and bond slot: the entry of the interface when the atom is its cell with
  // the smaller ID, or -1 (tally() reads the working copy in the store's order)
  std::vector<int> entry_of_slot;
  FixLazyStore *store_fix;           // the per-slot store (rows that arrived or were handed back)
  // the state of an entry as a slot of the store (header, damping forces by point, contact)
  void slot_from_entry(const Entry &e, double *dest) const;
  // its inverse: the entry's record (and contact block, if it has one) from a slot
  void entry_from_slot(const Entry &e, const double *slot);
  // the header of the interface in bond slot m of owned atom i (working copy, else the
  // atom's row, else zeros: scratch holds the copy)
  const double *header_of(int i, int m, double *scratch) const;
  // the stored row's slot at off, size values, zero-filled past the row's length
  void row_slot(int i, long off, long size, double *out) const;
  // per owned and ghost cell, this evaluation: BcmInterfaceKinematics::pack_cell(), of the
  // cells in used_cells only (the others' values are left as they were: nothing reads them)
  std::vector<double> cells;
  // the local indices the working copy's entries name (c1, c2), ascending, set with it: a
  // ghost that is no interface's partner is neither packed nor followed (cell_moves()); on 2
  // ranks of the 1728-cell impact 350 ghosts per rank, about half of them partners
  std::vector<int> used_cells;
  // quiet certificates (issue 27): a broken interface found quiet at a step keeps what is
  // left of its least gap (dn - s over its points, less round-off allowances), less at each
  // later step a bound on how far its gaps can have moved over that step (quiet_now()); while
  // some is left, and the interface was quiet at each evaluation since (nothing wrote its
  // state), quiet() would find it quiet again and is not run. Per entry: what is left (<= 0:
  // none) and the lever arm (its farthest anchor of cell 2). Per owned and ghost cell: its
  // position and orientation at the last step, and its move over this one (|R - R_prev| and
  // x - x_prev). Cleared with the cache (atoms change index) and at any evaluation that is
  // not a step; 8 bytes per interface, 88 per cell.
  struct QuietCert {
    float left = -1.0f, arm2 = 0.0f;
  };
  std::vector<QuietCert> quiet_cert;
  std::vector<double> cell_prev;    // 7 per cell: x, q at the last step
  std::vector<double> cell_move;    // 4 per cell: x - x_prev, |R - R_prev| (HUGE_VAL: unknown)
  bool moves_known = false;         // cell_prev holds the last step's cells, same indices
  long nbroken_last = 0;            // broken interfaces at the last evaluation (0: none kept)
  void cell_moves(bool step);

  int store_index;     // atom->darray index of the per-slot state
  int iquat;           // where the orientations live (bcm_orientation.h)
  bigint nevaluations;
  bool avx_loop;       // the 4-lane AVX kernel (BreakableUtil::avx_loops())
  FixBreakableSpecial *special;    // takes retired interfaces out of the special lists

  // what a force evaluation is: it decides which half kicks use its damping force
  struct Clock {
    int kind;    // EvalKind
    double dt, time;
    bigint step;
  };
  using Pair = BcmInterfaceKinematics::Pair;
  using Point = BcmInterfaceKinematics::Point;
  // one evaluation of one interface: its forces on cell 2, the energy its springs store and
  // the power -sum F_d . dv of its damping forces
  struct Result {
    BcmInterfaceKinematics::Load load;
    double stored = 0.0, pd = 0.0;
  };

  void allocate();
  void adopt();
  void rebuild_cache();
  double stiffness_factor(const double *rec) const;    // per_area: S / <S>, else 1
  void set_constants(const Entry &e, int type, double *rec);
  // k_n / N_p and k_t / N_p of an entry's points (per type and N_p, or per_area from S)
  std::vector<double> kp_of, ktp_of;    // per_interface: [type * (MAX_POINTS + 1) + N_p]
  void point_stiffness(int type, int npts, const double *rec, double &kp, double &ktp) const;
  void set_contact_constants(const Entry &e, int type, const double *rec, double *cb) const;
  const double *slot_of(int i, int j, double *scratch) const;
  long slot_offset(int i, int m) const;
  void interface_points(const Pair &p, const double *g, int np, Point *pts);
  bool quiet(const Entry &e, const double *rec, const Pair &p, const double *g,
             double *least = nullptr);
  bool quiet_now(const Entry &e, int nb, const double *rec, const Pair &p, const double *g,
                 bool step);
  void break_interface(Entry &e, double *rec, const Pair &p, const Point *pts,
                       double stored, const Clock &now);
  void contact_forces(const Entry &e, int type, double *rec, const Pair &p, const Point *pts,
                      bool just_broke, double e_before, const Clock &now, Result &r);
  void retire(const Entry &e, double *rec, double held, const Clock &now, Result &r);
  void apply(const Entry &e, const Pair &p, const Result &r, bool both);
};

}    // namespace LAMMPS_NS

#endif
