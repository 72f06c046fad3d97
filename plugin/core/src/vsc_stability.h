// Stability estimates (viscera/vsc_stability.h): nothing private beyond the rod's layout.
#ifndef VISCERA_SRC_VSC_STABILITY_H
#define VISCERA_SRC_VSC_STABILITY_H

#include "viscera/vsc_stability.h"
#include "vsc_rod.h"

#endif  // VISCERA_SRC_VSC_STABILITY_H
