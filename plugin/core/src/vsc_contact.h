// The narrow phase: penalty contacts' forces (viscera/vsc_contact.h has the
// model and the energy).
#ifndef VISCERA_SRC_VSC_CONTACT_H
#define VISCERA_SRC_VSC_CONTACT_H

#include "viscera/vsc_contact.h"
#include "vsc_contact_lists.h"
#include "vsc_contact_load.h"
#include "vsc_context.h"
#include "vsc_touch.h"

/// The narrow phase's state, which it owns: the contacts the last pass
/// found, their load, and the touch records friction and the implicit step read.
struct vsc_contact_pass {
  vsc_touch_records touch;  ///< per sphere, the last pass's strongest contacts
  vsc_contact_load load;    ///< the pass's load on each sphere and the damping limit
  void* found;              ///< the contacts the pass found, before their forces (vsc_contact.c; own
                            ///< allocation, grown as needed)
  int found_count;          ///< contacts in `found`
  int found_capacity;       ///< contacts `found` holds
};

/// Add the contact forces to Q (N, 3n): the narrow phase over the broad
/// phase's candidates (`lists`, refreshed at the placed spheres; `listed` 0:
/// they overflowed, every pair is tested), friction from the context's stick
/// state, reactions on geoms to world->geom_wrench times the context's wrench
/// weight, the touch records rewritten; within a step (context->substep > 0)
/// the damping limited where contacts pile up past its explicit limit
/// (vsc_contact_load.h). Returns the number of contacts.
/// Where control points sleep (`sleep`, NULL: none), the pairs that cannot
/// matter are not looked for: a sphere asleep deep against a static geom, and
/// two segments whose four spheres all sleep deep (vsc_rod.h); a rod asleep
/// everywhere looks at moving bodies' geoms only.
int vsc_contact_add_forces(const vsc_step_context* context, vsc_contact_pass* pass, const vsc_contact_lists* lists,
                           int listed, const vsc_placement* placement, const vsc_sleep_flags* sleep, double* Q);

/// An evaluation that looked for no contact: none found, the touch records not current.
void vsc_contact_forget(vsc_contact_pass* pass);

/// Release the found contacts' allocation.
void vsc_contact_pass_free(vsc_contact_pass* pass);

/// Visit each contact the last pass found (vsc_rod_visit_contacts's).
void vsc_contact_visit(const vsc_contact_pass* pass,
                       void (*visit)(void* data, int rigid, int a, int b, double speed, double depth), void* data);

/// The penalty's potential at control points q (m), as vsc_rod_contact_energy:
/// through `lists`, which must cover q (vsc_contact_lists_cover, or refreshed
/// there), or with `listed` 0 (they overflowed) every pair: the same bits
/// either way. The spheres are placed where they are needed. Writes nothing
/// but `deepest` (may be NULL).
double vsc_contact_energy(const vsc_rod* rod, const vsc_world* world, const double* q, const vsc_contact_lists* lists,
                          int listed, vsc_deepest_contact* deepest);

#endif  // VISCERA_SRC_VSC_CONTACT_H
