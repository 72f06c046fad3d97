// vsc_spline.c's own header: its whole API is public (viscera/vsc_spline.h).
#ifndef VISCERA_SRC_VSC_SPLINE_H
#define VISCERA_SRC_VSC_SPLINE_H

#include "viscera/vsc_spline.h"

#endif  // VISCERA_SRC_VSC_SPLINE_H
