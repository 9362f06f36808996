/* Registration of every style of the brittle-fracture plugin library, and nothing else. */

#include "lammpsplugin.h"

#include "angle_breakable_cr.h"
#include "bond_breakable_cr.h"
#include "fix_breakable_special.h"

using namespace LAMMPS_NS;

static Bond *bond_breakable_cr_creator(LAMMPS *lmp)
{
  return new BondBreakableCR(lmp);
}

static Angle *angle_breakable_cr_creator(LAMMPS *lmp)
{
  return new AngleBreakableCR(lmp);
}

static Fix *fix_breakable_special_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new FixBreakableSpecial(lmp, argc, argv);
}

extern "C" void lammpsplugin_init(void *lmp, void *handle, void *vregfunc)
{
  auto regfunc = (lammpsplugin_regfunc) vregfunc;
  lammpsplugin_t plugin;
  plugin.version = BRITTLE_LAMMPS_VERSION;
  plugin.author = "brittle-driver developers";
  plugin.handle = handle;

  plugin.style = "bond";
  plugin.name = "breakable/cr";
  plugin.info = "Clemmer-Robbins breakable two-body bond (SPEC 2.2 Eq. 2, 5)";
  plugin.creator.v1 = (lammpsplugin_factory1 *) &bond_breakable_cr_creator;
  (*regfunc)(&plugin, lmp);

  plugin.style = "angle";
  plugin.name = "breakable/cr";
  plugin.info = "Clemmer-Robbins breakable three-body angle (SPEC 2.2 Eq. 3-4)";
  plugin.creator.v1 = (lammpsplugin_factory1 *) &angle_breakable_cr_creator;
  (*regfunc)(&plugin, lmp);

  plugin.style = "fix";
  plugin.name = "breakable/special";
  plugin.info = "special-list and neighbor-list updates for broken bonds, break counters";
  plugin.creator.v2 = (lammpsplugin_factory2 *) &fix_breakable_special_creator;
  (*regfunc)(&plugin, lmp);
}
