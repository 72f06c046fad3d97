// Grasp springs (viscera/vsc_grasp.h has the held point and the nearest axis point).
#ifndef VISCERA_SRC_VSC_GRASP_H
#define VISCERA_SRC_VSC_GRASP_H

#include "viscera/vsc_grasp.h"
#include "vsc_context.h"

/// Add the grasp springs' forces at q (m), v (m/s) to Q (N, 3n), and their
/// reactions to each grasp's `reaction` times the context's wrench weight.
void vsc_rod_add_grasp_forces(const vsc_step_context* context, const double* q, const double* v, double* Q);

#endif  // VISCERA_SRC_VSC_GRASP_H
