/* The Griffith criterion of bond_style bcm/griffith (SPEC 1.2 Eq. 4-6; plugins/doc/
   bond_bcm_griffith.md, "Griffith criterion"), checked at every force evaluation of an intact
   interface, before any force, on the elastic parts of its springs only. */

#ifndef BRITTLE_BCM_GRIFFITH_H
#define BRITTLE_BCM_GRIFFITH_H

#include <cstring>

namespace BcmGriffith {

// the `energy` keyword: what Delta W_p of Eq. 5 is, from the energy the springs store
enum Convention {
  STORED,      // the energy the per-point springs (k / N_p) store
  ROCKABLE,    // the whole-interface k at every point, as Rockable: N_p times stored
  LITERAL      // per-point forces over the whole-interface k (Eq. 5 read literally): 1/N_p times
};

// the convention named `name`; false if there is none
inline bool parse(const char *name, int &convention)
{
  if (strcmp(name, "stored") == 0)
    convention = STORED;
  else if (strcmp(name, "rockable") == 0)
    convention = ROCKABLE;
  else if (strcmp(name, "literal") == 0)
    convention = LITERAL;
  else
    return false;
  return true;
}

// SPEC 1.2 Eq. 5, one point's share of the stored energy: its normal spring's energy en
// counts in tension only (H(dn), compression left out), its tangential spring's et always
inline double tension_energy(double en, double et, double dn)
{
  return (dn > 0.0 ? en : 0.0) + et;
}

// SPEC 1.2 Eq. 4-6: an interface of area S and np points whose springs store `tension`
// (the sum of tension_energy()) breaks when G = Delta W_p / (2 S) >= G_c
inline bool breaks(double tension, int np, int convention, double area, double gc)
{
  double dwp = tension;
  if (convention == ROCKABLE)
    dwp *= np;
  else if (convention == LITERAL)
    dwp /= np;
  return dwp / (2.0 * area) >= gc;
}

}    // namespace BcmGriffith

#endif
