// Placement (viscera/vsc_place.h): nothing private beyond the rod's layout.
#ifndef VISCERA_SRC_VSC_PLACE_H
#define VISCERA_SRC_VSC_PLACE_H

#include "viscera/vsc_place.h"
#include "vsc_rod.h"

#endif  // VISCERA_SRC_VSC_PLACE_H
