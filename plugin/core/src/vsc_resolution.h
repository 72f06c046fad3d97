// The resolution a tolerance chooses (viscera/vsc_resolution.h): nothing private
// beyond the integrators' table it reads their error orders from.
#ifndef VISCERA_SRC_VSC_RESOLUTION_H
#define VISCERA_SRC_VSC_RESOLUTION_H

#include "viscera/vsc_resolution.h"

#endif  // VISCERA_SRC_VSC_RESOLUTION_H
