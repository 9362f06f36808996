#include "fix_bcm_interfaces_dump.h"

#include "error.h"
#include "update.h"
#include "utils.h"

using namespace LAMMPS_NS;

/* ---------------------------------------------------------------------- */

FixBcmInterfacesDump::FixBcmInterfacesDump(LAMMPS *_lmp, int narg, char **arg) :
    Fix(_lmp, narg, arg)
{
  if (narg < 6)
    error->all(FLERR, "Illegal fix bcm/interfaces/dump command: fix ID group "
                      "bcm/interfaces/dump N FILE value ... [names name ...]");
  nevery = utils::inumeric(FLERR, arg[3], false, lmp);
  if (nevery <= 0) error->all(FLERR, "fix bcm/interfaces/dump: N must be > 0, not {}", arg[3]);
  file = arg[4];
  writer = std::make_unique<BcmInterfaceDump>(
      lmp, std::vector<std::string>(arg + 5, arg + narg), "fix bcm/interfaces/dump");
}

/* ---------------------------------------------------------------------- */

int FixBcmInterfacesDump::setmask()
{
  return FixConst::END_OF_STEP;
}

/* ---------------------------------------------------------------------- */

void FixBcmInterfacesDump::init()
{
  writer->check();
}

/* ----------------------------------------------------------------------
   after the forces of a run's setup, as LAMMPS's output writes a dump there
   (a `run N pre no` sets up no fix, and LAMMPS then writes no dump either:
   the previous run's last step, if a multiple of N, was written already)
------------------------------------------------------------------------- */

void FixBcmInterfacesDump::setup(int /*vflag*/)
{
  write_frame();
}

/* ----------------------------------------------------------------------
   every N steps (nevery): the state of the step's forces, as the output
   after the end-of-step fixes sees it (no end-of-step fix changes it)
------------------------------------------------------------------------- */

void FixBcmInterfacesDump::end_of_step()
{
  write_frame();
}

/* ---------------------------------------------------------------------- */

void FixBcmInterfacesDump::write_frame()
{
  const bigint step = update->ntimestep;
  if (step % nevery != 0 || step == last_step) return;
  if (file.find('*') != std::string::npos) {
    writer->write(utils::star_subst(file, step, 0), "w", groupbit);
  } else {
    writer->write(file, started ? "a" : "w", groupbit);
    started = true;
  }
  last_step = step;
}
