// vsc_jacobian.c's own header: its whole API is public (viscera/vsc_jacobian.h).
#ifndef VISCERA_SRC_VSC_JACOBIAN_H
#define VISCERA_SRC_VSC_JACOBIAN_H

#include "viscera/vsc_jacobian.h"

#endif  // VISCERA_SRC_VSC_JACOBIAN_H
