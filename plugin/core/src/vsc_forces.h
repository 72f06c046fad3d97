// One force evaluation inside a step (viscera/vsc_forces.h has the lone one).
#ifndef VISCERA_SRC_VSC_FORCES_H
#define VISCERA_SRC_VSC_FORCES_H

#include "viscera/vsc_forces.h"
#include "vsc_context.h"

/// Generalised forces Q (N, 3n, overwritten) at q (m), v (m/s), in the
/// stages' order: place (samples, and spheres when contacts are looked for),
/// gravity, elastic forces and tethers, grasps, contacts. Reactions are added
/// times the context's wrench weight; contacts read the context's friction state.
void vsc_forces_evaluate(const vsc_step_context* context, const double* q, const double* v, double* Q);

/// Accelerations a (m/s^2, 3n, overwritten): a = M^{-1} Q - damping v, 0 at
/// pinned points, Q from vsc_forces_evaluate.
void vsc_forces_acceleration(const vsc_step_context* context, const double* q, const double* v, double* a);

#endif  // VISCERA_SRC_VSC_FORCES_H
