// vsc_base.c's own header: its whole API is public (viscera/vsc_base.h).
#ifndef VISCERA_SRC_VSC_BASE_H
#define VISCERA_SRC_VSC_BASE_H

#include "viscera/vsc_base.h"

#endif  // VISCERA_SRC_VSC_BASE_H
