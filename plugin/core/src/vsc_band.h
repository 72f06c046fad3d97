// vsc_band.c's own header: its whole API is public (viscera/vsc_band.h).
#ifndef VISCERA_SRC_VSC_BAND_H
#define VISCERA_SRC_VSC_BAND_H

#include "viscera/vsc_band.h"

#endif  // VISCERA_SRC_VSC_BAND_H
