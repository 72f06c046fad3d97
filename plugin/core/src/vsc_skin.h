// vsc_skin.c's own header: its whole API is public (viscera/vsc_skin.h).
#ifndef VISCERA_SRC_VSC_SKIN_H
#define VISCERA_SRC_VSC_SKIN_H

#include "viscera/vsc_skin.h"

#endif  // VISCERA_SRC_VSC_SKIN_H
