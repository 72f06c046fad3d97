// vsc_geom.c's own header: its whole API is public (viscera/vsc_geom.h).
#ifndef VISCERA_SRC_VSC_GEOM_H
#define VISCERA_SRC_VSC_GEOM_H

#include "viscera/vsc_geom.h"

#endif  // VISCERA_SRC_VSC_GEOM_H
