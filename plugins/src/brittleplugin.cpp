/* Registration of every style of the brittle-fracture plugin library, and nothing else. */

#include "lammpsplugin.h"

#include "angle_breakable_cr.h"
#include "bond_breakable_cr.h"
#include "fix_breakable_log.h"
#include "fix_breakable_references.h"
#include "fix_breakable_special.h"
#include "fix_lazy_store.h"
#include "pair_cr_repulsion.h"
#include "bond_bcm_griffith.h"
#include "fix_bcm_griffith.h"
#include "fix_bcm_interfaces_dump.h"
#include "fix_bcm_rigid.h"
#include "fix_bcm_wall.h"
#include "pair_bcm_contact.h"
#include "write_bcm_interfaces.h"
#include "bcm_orient.h"

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

static Fix *fix_breakable_references_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new FixBreakableReferences(lmp, argc, argv);
}

static Fix *fix_breakable_log_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new FixBreakableLog(lmp, argc, argv);
}

static Fix *fix_lazy_store_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new FixLazyStore(lmp, argc, argv);
}

static Pair *pair_cr_repulsion_creator(LAMMPS *lmp)
{
  return new PairCRRepulsion(lmp);
}

static Fix *fix_bcm_rigid_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new FixBcmRigid(lmp, argc, argv);
}

static Bond *bond_bcm_griffith_creator(LAMMPS *lmp)
{
  return new BondBcmGriffith(lmp);
}

static Fix *fix_bcm_griffith_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new FixBcmGriffith(lmp, argc, argv);
}

static Pair *pair_bcm_contact_creator(LAMMPS *lmp)
{
  return new PairBcmContact(lmp);
}

static Fix *fix_bcm_wall_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new FixBcmWall(lmp, argc, argv);
}

static Fix *fix_bcm_interfaces_dump_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new FixBcmInterfacesDump(lmp, argc, argv);
}

static Command *bcm_orient_creator(LAMMPS *lmp)
{
  return new BcmOrient(lmp);
}

static Command *write_bcm_interfaces_creator(LAMMPS *lmp)
{
  return new WriteBcmInterfaces(lmp);
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

  plugin.style = "fix";
  plugin.name = "breakable/references";
  plugin.info = "reference r0, theta0 of the breakable/cr bonds and angles, read from a file";
  plugin.creator.v2 = (lammpsplugin_factory2 *) &fix_breakable_references_creator;
  (*regfunc)(&plugin, lmp);

  plugin.style = "fix";
  plugin.name = "breakable/log";
  plugin.info = "break-event log of the breakable styles (one line per break)";
  plugin.creator.v2 = (lammpsplugin_factory2 *) &fix_breakable_log_creator;
  (*regfunc)(&plugin, lmp);

  plugin.style = "fix";
  plugin.name = "lazy/store";
  plugin.info = "hidden per-atom store whose rows cost memory only once used";
  plugin.creator.v2 = (lammpsplugin_factory2 *) &fix_lazy_store_creator;
  (*regfunc)(&plugin, lmp);

  plugin.style = "fix";
  plugin.name = "bcm/rigid";
  plugin.info = "BCM cells: velocity Verlet + NO_SQUISH rigid rotation, full inertia";
  plugin.creator.v2 = (lammpsplugin_factory2 *) &fix_bcm_rigid_creator;
  (*regfunc)(&plugin, lmp);

  plugin.style = "bond";
  plugin.name = "bcm/griffith";
  plugin.info = "BCM cohesive interface with Griffith breaking, then contacts (SPEC 1.2)";
  plugin.creator.v1 = (lammpsplugin_factory1 *) &bond_bcm_griffith_creator;
  (*regfunc)(&plugin, lmp);

  plugin.style = "fix";
  plugin.name = "bcm/griffith";
  plugin.info = "interface counters of bond_style bcm/griffith (created by it)";
  plugin.creator.v2 = (lammpsplugin_factory2 *) &fix_bcm_griffith_creator;
  (*regfunc)(&plugin, lmp);

  plugin.style = "pair";
  plugin.name = "bcm/contact";
  plugin.info = "BCM frictional contacts between rounded convex cells (SPEC 1.2)";
  plugin.creator.v1 = (lammpsplugin_factory1 *) &pair_bcm_contact_creator;
  (*regfunc)(&plugin, lmp);

  plugin.style = "fix";
  plugin.name = "bcm/wall";
  plugin.info = "BCM rigid plane against rounded cells, frictional contact (SPEC 1.2)";
  plugin.creator.v2 = (lammpsplugin_factory2 *) &fix_bcm_wall_creator;
  (*regfunc)(&plugin, lmp);

  plugin.style = "fix";
  plugin.name = "bcm/interfaces/dump";
  plugin.info = "BCM interface dump every N steps, streamed from the bond style";
  plugin.creator.v2 = (lammpsplugin_factory2 *) &fix_bcm_interfaces_dump_creator;
  (*regfunc)(&plugin, lmp);

  plugin.style = "command";
  plugin.name = "write_bcm_interfaces";
  plugin.info = "BCM interface dump of the current state, streamed from the bond style";
  plugin.creator.v1 = (lammpsplugin_factory1 *) &write_bcm_interfaces_creator;
  (*regfunc)(&plugin, lmp);

  plugin.style = "command";
  plugin.name = "bcm_orient";
  plugin.info = "BCM cells' orientations (atom_style bpm/sphere's quaternion) from a per-atom array";
  plugin.creator.v1 = (lammpsplugin_factory1 *) &bcm_orient_creator;
  (*regfunc)(&plugin, lmp);

  plugin.style = "pair";
  plugin.name = "cr/repulsion";
  plugin.info = "Clemmer-Robbins non-bonded repulsion and damping, one loop (SPEC 2.2 Eq. 1, 5)";
  plugin.creator.v1 = (lammpsplugin_factory1 *) &pair_cr_repulsion_creator;
  (*regfunc)(&plugin, lmp);
}
