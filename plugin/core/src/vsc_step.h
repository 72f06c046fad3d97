// The step (viscera/vsc_integrate.h's vsc_rod_step): nothing private beyond
// the step context (vsc_context.h) and the scheme table (vsc_schemes.h).
#ifndef VISCERA_SRC_VSC_STEP_H
#define VISCERA_SRC_VSC_STEP_H

#include "viscera/vsc_integrate.h"
#include "vsc_context.h"

#endif  // VISCERA_SRC_VSC_STEP_H
