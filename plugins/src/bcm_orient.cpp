#include "bcm_orient.h"

#include "atom.h"
#include "bcm_rigid.h"
#include "domain.h"
#include "error.h"

#include <algorithm>
#include <cmath>
#include <mpi.h>
#include <string>

using namespace LAMMPS_NS;

/* ---------------------------------------------------------------------- */

void BcmOrient::command(int narg, char **arg)
{
  if (narg != 1) error->all(FLERR, "Illegal bcm_orient command: bcm_orient d2_NAME");
  if (!domain->box_exist) error->all(FLERR, "bcm_orient before the box exists");
  if (!atom->quat_flag)
    error->all(FLERR, "bcm_orient needs an atom style with a quaternion (atom_style "
                      "bpm/sphere); atom_style {} has none", atom->get_style());
  const std::string name = arg[0];
  if (name.rfind("d2_", 0) != 0)
    error->all(FLERR, "bcm_orient: {} is not a per-atom array (d2_NAME)", name);
  int flag = -1, cols = -1;
  const int index = atom->find_custom(name.substr(3).c_str(), flag, cols);
  if (index < 0 || flag != 1 || cols != 4)
    error->all(FLERR, "bcm_orient: no per-atom array {} with 4 columns (fix property/atom {} 4 "
                      "before read_data)", name, name);

  double **from = atom->darray[index];
  double **quat = atom->quat;
  const tagint *tag = atom->tag;
  tagint bad = MAXTAGINT;    // the smallest atom ID without an orientation, over all ranks
  for (int i = 0; i < atom->nlocal; i++) {
    const double qq = BcmRigid::quat_norm2(from[i]);
    if (!(qq > 0.0) || !std::isfinite(qq)) bad = std::min(bad, tag[i]);
    for (int k = 0; k < 4; k++) quat[i][k] = from[i][k];
  }
  tagint first = MAXTAGINT;
  MPI_Allreduce(&bad, &first, 1, MPI_LMP_TAGINT, MPI_MIN, world);
  if (first != MAXTAGINT)
    error->all(FLERR, "bcm_orient: atom {} has no orientation (zero quaternion in {})", first,
               name);
}
