// The rod's mechanical energies (viscera/vsc_energy.h): nothing private beyond the rod's layout.
#ifndef VISCERA_SRC_VSC_ENERGY_H
#define VISCERA_SRC_VSC_ENERGY_H

#include "viscera/vsc_energy.h"
#include "vsc_rod.h"

#endif  // VISCERA_SRC_VSC_ENERGY_H
