// vsc_grid.c's own header: its whole API is public (viscera/vsc_grid.h).
#ifndef VISCERA_SRC_VSC_GRID_H
#define VISCERA_SRC_VSC_GRID_H

#include "viscera/vsc_grid.h"

#endif  // VISCERA_SRC_VSC_GRID_H
