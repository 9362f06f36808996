/* pair_style bcm/contact: frictional contacts between BCM cells that are not bonded (never
   bonded cells, and cells of different fragments), as rounded convex polyhedra (SPEC 1.2,
   last bullets; Eq. 1, 2, 7). Geometry from a cells file (bcm_cells.h); contact points from
   bcm_find_contacts(); a fixed stiffness per contact point (bcm_contact_law.h). Restart
   files carry the settings, the coefficients and the cumulative energies; the tangential
   history is a per-atom store. See plugins/doc/pair_bcm_contact.md. */

#ifndef BRITTLE_PAIR_BCM_CONTACT_H
#define BRITTLE_PAIR_BCM_CONTACT_H

#include "bcm_cells.h"
#include "bcm_kick_work.h"
#include "bcm_motion.h"
#include "pair.h"

#include <memory>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace LAMMPS_NS {

class PairBcmContact : public Pair {
 public:
  PairBcmContact(class LAMMPS *);
  ~PairBcmContact() override;

  void compute(int, int) override;
  void settings(int, char **) override;
  void coeff(int, char **) override;
  void init_style() override;
  double init_one(int, int) override;
  void write_restart(FILE *) override;
  void read_restart(FILE *) override;
  void write_restart_settings(FILE *) override;
  void read_restart_settings(FILE *) override;
  double memory_usage() override;

 private:
  std::string cells_file;
  std::shared_ptr<const BcmCells> table;
  double rm;      // rounding radius r_m
  int nslots;     // history slots per cell

  // per type pair: frictional-contact parameters and alpha (SPEC 1.2 Eq. 2)
  double **kn, **kt, **en2, **mu, **alpha;

  int iquat;             // where the orientations live (bcm_orientation.h)
  int ihist;             // atom->darray index of the tangential history slots
  double maxrad;         // largest atom radius over all ranks
  bool warned_slots;     // a point found no free history slot (warned once)

  // compute pair extra values: [1] contact points, [2] pairs in contact, [3] points without
  // a history slot (last evaluation); cumulative, this rank's pairs: [4] energy dissipated
  // by normal damping, [5] by Coulomb slip, [6] energy of the tangential springs of points
  // dropped with their history (a point that changes its pair of features or vanishes while
  // its spring is loaded: dropped_springs()), [7] work done on the cells by all the pair's
  // forces
  static constexpr int NEXTRA = 7;
  BcmKickWork damp_work, all_work;
  double w_fric;
  double w_drop;

  // the tangential springs current at the last step (slots written then, in this rank's
  // owned and ghost cells), collected at the start of an advancing step, sorted by pair
  // (tag A, tag B) and key; a pair visited this step takes out its range, booking the springs
  // whose key no current point of the pair carries (dropped_springs)
  struct LastSpring {
    tagint ta, tb;
    double key;
    double u[3];
  };
  struct PairHash {
    size_t operator()(const std::pair<tagint, tagint> &p) const
    {
      return std::hash<long long>()(static_cast<long long>(p.first) * 1000003LL ^
                                    static_cast<long long>(p.second));
    }
  };
  std::vector<LastSpring> last_springs;
  std::unordered_map<std::pair<tagint, tagint>, std::pair<int, int>, PairHash> last_range;
  void collect_last_springs(bigint written);
  // the slots (atom index << 32 | slot) written by this rank's advancing evaluation at step
  // written_step: between two reneighborings no other slot gets that step's stamp (ghost rows
  // are sent, atoms exchanged and sorted only at reneighboring), so the next step collects
  // them from this list instead of scanning every slot of every cell; -1: not usable (a
  // setup evaluation came since, or none was recorded)
  std::vector<int64_t> written_slots, written_prev;
  bigint written_step;
  double dropped_springs(int a, int b, double ktij, double dt, int np, bool advance);

  // restart files: LAMMPS calls the pair's write_restart on rank 0 only, so the cumulative
  // [4]-[7] of all ranks are reduced to rank 0 beforehand (collectively: in init_style,
  // which write_restart calls, and at a step that writes a restart file), into saved
  bigint nevals;          // force evaluations so far
  bigint saved_at;        // nevals when saved was taken (-1: never)
  double saved[4];        // [4]-[7] summed over ranks (rank 0)
  void local_totals(double *out);
  void save_totals();

  // per force evaluation: each local cell placed in space once, on first use
  std::vector<const BcmCells::Cell *> cell_of;    // looked up for the atom of tag cell_tag
  std::vector<tagint> cell_tag;
  std::vector<int> placed;       // offset into geom, or -1
  std::vector<double> geom;      // 3 nv vertices then 4 nf planes per placed cell
  std::vector<double> scratch[2];    // the two cells of one pair (setup evaluations)
  std::vector<BcmContactPoint> points;
  BcmContactWork work;

  // separation certificates (issue 27), one per unbonded entry of the neighbour list, in the
  // list's order, for a pair whose cores bcm_cores_apart() found apart: the pair's tags, its
  // relative position and orientation then in A's body frame (P = R_A^T (x_B - x_A),
  // M = q_A^* q_B) and the margin of the separating face plane less round-off allowances.
  // The heights over that plane of the other core's points move by at most
  // |P - P1| + |R(M) - R(M1)| lever (lever: the radius of B for a plane of A, |P1| + the
  // radius of A for a plane of B), so while that bound stays below the margin the cores are
  // still apart by that plane: the pair is skipped without placing its cells, exactly as the
  // test would have skipped it. Cleared when the list is rebuilt and at a setup evaluation.
  // Each entry also keeps the square of its pair's reach (the two bounding radii and twice
  // r_m), for the entry's atoms of tags ri, rj (0: not yet), so that a pair outside reach is
  // passed over without looking up its cells.
  struct ApartCert {
    tagint ta = 0, tb = 0;    // the pair (0: no certificate)
    BcmMotion::Cert motion;   // P1, M1, margin, lever arm (bcm_motion.h)
    tagint ri = 0, rj = 0;    // the entry's (i, j) tags of reach2
    double reach2 = 0.0;
  };
  std::vector<int> unbonded;    // one atom's neighbour entries that are not bonded pairs
  std::vector<ApartCert> certs;
  NeighList *cert_list = nullptr;
  bigint cert_ncalls = -1;
  bool still_apart(const ApartCert &c, int a, int b) const;
  void certify(ApartCert &c, int a, int b, const BcmSpaceCell &sa, const BcmSpaceCell &sb,
               double margin, int side) const;

  void allocate();
  const BcmCells::Cell *cell(int i);
  int place(int i);
  const double *place_scratch(int i, int k);    // cell i placed in scratch[k]
  int find_slot(int i, tagint partner, double key, bigint step) const;
  int free_slot(int i, bigint step) const;
};

}    // namespace LAMMPS_NS

#endif
