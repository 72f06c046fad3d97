// The contact machinery's internals (see viscera/vsc_contact.h for the model):
// the touch records, the deep-contact and margin constants, the candidate lists,
// the contact forces and the friction state's advance. Private to the core (and
// its tests): the adapter sees only the friction state's format and the energy.
#ifndef VISCERA_VSC_CONTACT_INTERNAL_H
#define VISCERA_VSC_CONTACT_INTERNAL_H

#include "viscera/vsc_contact.h"
#include "vsc_rod_internal.h"

/// Per sphere record of the last evaluation's strongest contacts (rigid, then
/// self): partner, normal force (N), mu, normal (3), tangential velocity (m/s, 3),
/// closest points on the two segments (self; 0 for rigid).
#define VSC_TOUCH_SIZE 22

/// Candidate lists are built with this margin, as a multiple of the radius:
/// they stay valid until a sphere or a geom moves by half of it.
#define VSC_CONTACT_MARGIN 1.0

/// Candidate contact lists of one rod (owned by the rod).
vsc_contact_lists* vsc_contact_lists_create(int sphere_count);
void vsc_contact_lists_destroy(vsc_contact_lists* lists);

/// Heap bytes vsc_contact_lists_create(sphere_count) allocates.
double vsc_contact_lists_memory_bytes(int sphere_count);

/// Add contact forces to Q (N, 3n); reactions on geoms go to world->geom_wrench
/// times world->wrench_weight. rod->sphere_xyz and rod->sphere_velocity must be
/// current (vsc_rod_update_spheres). Returns the number of contacts.
int vsc_rod_contact_forces(vsc_rod* rod, const vsc_world* world, double* Q);

/// The strongest rigid contact of `sphere` in the last evaluation: returns its
/// geom index (-1: none) and writes its unit normal, from the geom to the sphere.
int vsc_rod_rigid_touch(const vsc_rod* rod, int sphere, double normal[3]);

/// Advance the friction state by a substep of h (s), from the contacts of the
/// last evaluation. `velocity_change` (m/s per control point coordinate, 3n,
/// may be NULL) is what the substep added to v after that evaluation read it:
/// a stick spring then stretches with the substep's end velocity (symplectic
/// Euler on the spring), not with its start velocity (explicit Euler, which
/// pumps energy into a stuck contact every substep). Under leapfrog, positions
/// move by the mean of the two velocities: the spring's elongation and the
/// contact's displacement then differ by h/2 (v_end - v_start), which does not
/// accumulate (the sum telescopes).
void vsc_rod_update_stick(const vsc_rod* rod, double* stick, double h, const double* velocity_change);

#endif  // VISCERA_VSC_CONTACT_INTERNAL_H
