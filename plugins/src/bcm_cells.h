/* Geometry of BCM cells for the contact styles (pair_style bcm/contact, fix bcm/wall):
   the table of every cell's convex core polyhedron in its body frame, read from a cells file
   (format in plugins/doc/pair_bcm_contact.md), and the detection of contact points between
   two rounded cores (SPEC 1.2, last bullets).

   A cell's material is its core polyhedron P swept by a sphere of radius r_m (Minkowski
   sum); two cells touch where their cores are closer than 2 r_m. The table is read on rank 0,
   broadcast, and replicated on every rank, indexed by atom tag (about 1.6 kB per cell of 26
   vertices and 15 faces). Styles of one LAMMPS instance that read identical files share one
   table. */

#ifndef BRITTLE_BCM_CELLS_H
#define BRITTLE_BCM_CELLS_H

#include "lmptype.h"

#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace LAMMPS_NS {

class LAMMPS;

class BcmCells {
 public:
  struct Cell {
    int nv, nf, ne;    // vertices, faces, edges
    int v0;            // first vertex: vert[3 v0 ...], adj_first[v0 ...]
    int f0;            // first face: plane[4 f0 ...], face_first[f0 ...]
    int e0;            // first edge: edge[4 e0 ...]
    double rbound;     // largest |vertex| (origin = body-frame origin = the atom position)
  };

  // a vertex or face index inside a cell (local): two bytes, as the table is replicated on
  // every rank
  using Index = uint16_t;
  static constexpr long long MAX_INDEX = 1 << 16;

  // body-frame data, flat over all cells; vertex and face indices inside a cell are local
  std::vector<double> vert;        // 3 per vertex
  std::vector<double> plane;       // 4 per face: outward unit normal, offset d (n.x = d)
  std::vector<int> face_first;     // per face + 1 sentinel: range in face_vert
  std::vector<Index> face_vert;    // face loops, counter-clockwise seen from outside
  std::vector<Index> edge;         // 4 per edge: a, b, face traversing a->b, face traversing b->a
  std::vector<int> adj_first;      // per vertex + 1 sentinel: range in adj
  std::vector<Index> adj;          // neighbour vertices of each vertex (along edges)
  std::vector<Cell> cells;
  // the cells by tag: tags ascending and each one's index into cells (8 bytes per cell, as
  // the table is replicated on every rank)
  std::vector<tagint> sorted_tag;
  std::vector<int> index_of_sorted;
  std::string source;              // file name, for messages

  // the table of a cells file, shared with the other styles of this instance that read the
  // same content; collective over all ranks (rank 0 reads, then broadcasts)
  static std::shared_ptr<const BcmCells> load(LAMMPS *lmp, const std::string &file);

  const Cell *find(tagint tag) const
  {
    const auto it = std::lower_bound(sorted_tag.begin(), sorted_tag.end(), tag);
    return (it == sorted_tag.end() || *it != tag) ? nullptr
                                                  : &cells[index_of_sorted[it - sorted_tag.begin()]];
  }
  double memory_usage() const;

 private:
  void parse(LAMMPS *lmp, const char *text, std::size_t size);
  void finish_cell(LAMMPS *lmp, tagint tag, Cell &c);
};

/* A cell's core placed in space for one force evaluation: x + R(q) b for every body-frame
   vertex b, outward normals R(q) n and offsets n'.x. */
struct BcmSpaceCell {
  const BcmCells *table;
  const BcmCells::Cell *cell;
  const double *x;        // atom position (body-frame origin)
  const double *vert;     // 3 nv
  const double *plane;    // 4 nf
};

// fills vert (3 nv) and plane (4 nf) of a cell at position x with unit quaternion q
void bcm_place_cell(const BcmCells &table, const BcmCells::Cell &c, const double *x,
                    const double *q, double *vert, double *plane);

// One contact point between cores A and B.
struct BcmContactPoint {
  double p[3];     // contact point: midpoint of the core-to-core segment
  double n[3];     // unit normal from B to A: the normal force on A is along +n
  double h;        // core-to-core distance along n (< 0 when the cores interpenetrate)
  int64_t key;     // feature pair: kind << 40 | feature of A << 20 | feature of B
};

// kinds of feature pairs (the key's top bits)
enum BcmContactKind : int64_t {
  BCM_VF = 1,    // vertex of A on face of B
  BCM_FV = 2,    // face of A under vertex of B
  BCM_EE = 3,    // edge of A across edge of B
  BCM_VE = 4,    // vertex of A against edge of B
  BCM_EV = 5,    // edge of A against vertex of B
  BCM_VV = 6     // vertex of A against vertex of B
};

// Scratch arrays reused between calls (one per style instance).
struct BcmContactWork {
  std::vector<double> ha, hb;          // heights of A's vertices over B's face planes, and B's
  std::vector<double> hmaxa, hmaxb;    // largest height of each vertex
  std::vector<int> livea, liveb;       // edges that may come within reach
};

/* Contact points between the cores of A and B closer than dcut = 2 r_m (SPEC 1.2):
   vertex-face, edge-edge, vertex-edge and vertex-vertex pairs, each a point; a face-face
   contact comes out as the corners of the overlap polygon of the two faces (>= 3 points),
   an edge-face contact as its 2 ends. Appends to out; returns the number appended. */
int bcm_find_contacts(const BcmSpaceCell &A, const BcmSpaceCell &B, double dcut,
                      BcmContactWork &work, std::vector<BcmContactPoint> &out,
                      bool apart_tested = false);

/* The early exit of bcm_find_contacts: a face plane of one core with the whole other core
   dcut or more beyond it (then it finds no point). bcm_find_contacts(..., apart_tested = true)
   leaves this test out, for a caller that made it and found the cores not apart. */
bool bcm_cores_apart(const BcmSpaceCell &A, const BcmSpaceCell &B, double dcut);

/* For cores found apart by bcm_cores_apart: the face plane of either core with the largest
   margin, the least height of the other core's vertices and centre over it less dcut (each
   of them dcut + margin or more above it: while the cores move relative to each other by
   less than the margin, bcm_cores_apart holds by that plane). side = 0: a plane of A, 1: of
   B. Returns the margin (< 0: none; the test passed by the centre test alone). */
double bcm_apart_margin(const BcmSpaceCell &A, const BcmSpaceCell &B, double dcut, int &side);

/* For cores not apart by a face plane, right after bcm_find_contacts(A, B, ..., work, ...,
   apart_tested = true) found no point, from the heights it left in work: the margin by which
   every vertex of each core lies dcut or more above some plane of the other (no vertex-face,
   vertex-edge or vertex-vertex point) and every edge of one of the cores, both its ends, dcut
   or more above one plane of the other (all its edges dead: no edge-edge point), less dcut.
   While each of these heights moves by less than the margin, bcm_find_contacts finds no
   point. < 0: none. */
double bcm_dead_margin(const BcmSpaceCell &A, const BcmSpaceCell &B, double dcut,
                       const BcmContactWork &work);

/* Index into atom->darray of a per-atom array `name` (ncols columns) kept by a hidden
   fix lazy/store of id fix_id (created if absent), so that it migrates with the atoms,
   follows sorting and goes to restart files; ghost = also communicated to ghost atoms at
   each reneighboring. */
int bcm_peratom_array(LAMMPS *lmp, const std::string &fix_id, const std::string &name,
                      int ncols, bool ghost);

}    // namespace LAMMPS_NS

#endif
