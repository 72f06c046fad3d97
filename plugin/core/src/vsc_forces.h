// One force evaluation inside a step (viscera/vsc_forces.h has the lone one).
#ifndef VISCERA_SRC_VSC_FORCES_H
#define VISCERA_SRC_VSC_FORCES_H

#include "viscera/vsc_forces.h"
#include "vsc_context.h"

/// Generalised forces Q (N, 3n, overwritten) at q (m), v (m/s), in the
/// stages' order: place the spheres (when contacts are looked for), gravity,
/// the elastic pass and tethers, grasps, the broad phase, the narrow phase.
/// Each stage gets its own state from the rod's (vsc_rod_stages) and reads
/// the earlier ones' const. Reactions are added
/// times the context's wrench weight; contacts read the context's friction state.
void vsc_forces_evaluate(const vsc_step_context* context, const double* q, const double* v, double* Q);

/// Accelerations a (m/s^2, 3n, overwritten): a = M^{-1} Q - damping v, 0 at
/// pinned points and, in a step where points sleep, at those (vsc_sleep_hold),
/// Q from vsc_forces_evaluate.
void vsc_forces_acceleration(const vsc_step_context* context, const double* q, const double* v, double* a);

/// A rod asleep everywhere, at q (m): its contacts with moving bodies' geoms
/// alone, pushed at full weight (their reactions written to the world) into
/// Q (N, 3n, scratch: the rod is held still), the spheres placed at rest.
void vsc_forces_at_rest(vsc_step_context* context, const double* q, double* Q);

#endif  // VISCERA_SRC_VSC_FORCES_H
