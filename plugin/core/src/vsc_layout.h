// vsc_layout.c's own header: its whole API is public (viscera/vsc_layout.h).
#ifndef VISCERA_SRC_VSC_LAYOUT_H
#define VISCERA_SRC_VSC_LAYOUT_H

#include "viscera/vsc_layout.h"

#endif  // VISCERA_SRC_VSC_LAYOUT_H
