// Penalty contacts' forces (viscera/vsc_contact.h has the model and the energy).
#ifndef VISCERA_SRC_VSC_CONTACT_H
#define VISCERA_SRC_VSC_CONTACT_H

#include "viscera/vsc_contact.h"
#include "vsc_context.h"

/// Add the contact forces to Q (N, 3n): every candidate pair's narrow phase,
/// friction from the context's stick state, reactions on geoms to
/// world->geom_wrench times the context's wrench weight, the touch records
/// (vsc_touch.h) rewritten; within a step (context->substep > 0) the damping
/// limited where contacts pile up past its explicit limit (vsc_contact_load.h).
/// The spheres and their velocities must be placed (vsc_place.h). Returns the
/// number of contacts.
/// Where control points sleep (rod->work.asleep_count > 0), the pairs that cannot
/// matter are not looked for: a sphere asleep deep against a static geom, and
/// two segments whose four spheres all sleep deep (vsc_rod.h); a rod asleep
/// everywhere looks at moving bodies' geoms only.
int vsc_rod_add_contact_forces(const vsc_step_context* context, double* Q);

#endif  // VISCERA_SRC_VSC_CONTACT_H
