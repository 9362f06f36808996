#include "write_bcm_interfaces.h"

#include "bcm_interface_dump.h"
#include "domain.h"
#include "error.h"
#include "group.h"
#include "update.h"
#include "utils.h"

#include <string>
#include <vector>

using namespace LAMMPS_NS;

/* ---------------------------------------------------------------------- */

void WriteBcmInterfaces::command(int narg, char **arg)
{
  if (narg < 3)
    error->all(FLERR, "Illegal write_bcm_interfaces command: write_bcm_interfaces group FILE "
                      "value ... [names name ...]");
  const int igroup = group->find(arg[0]);
  if (igroup < 0) error->all(FLERR, "write_bcm_interfaces: no group {}", arg[0]);
  if (!domain->box_exist) error->all(FLERR, "write_bcm_interfaces before the box exists");
  BcmInterfaceDump writer(lmp, std::vector<std::string>(arg + 2, arg + narg),
                          "write_bcm_interfaces");
  std::string file = arg[1];
  if (file.find('*') != std::string::npos) file = utils::star_subst(file, update->ntimestep, 0);
  writer.write(file, "w", group->bitmask[igroup]);
}
