// The contact load: the explicit damping of the last contact pass against the
// substep it must stay stable over.
//
// A penalty contact's damping (contact_damping, N s/m) is explicit in every
// integrator but the implicit one's rigid contacts: it holds while the
// damping rate gamma a point feels, times the substep h, stays below 2. The
// substeps come from one contact per sphere (vsc_stability.c), but a tool
// pressing the bowel's loops into a pile piles many on a sphere: a crossing of
// two tubes alone is found by up to 16 segment pairs, and a sphere squeezed
// under a retractor was measured with 14. Their damping then adds up past the
// limit and pumps energy into the pile each substep (random tool actions on
// randomised cavity episodes: a storm of divergence recoveries). So each
// contact pass bounds gamma h at every control point (Gershgorin's bound of
// the damping matrix c J' J, over the lumped mass) after finding its contacts
// and before pushing them; where the bound exceeds VSC_CONTACT_DAMPING_LIMIT
// the damping of the contacts there is scaled down to the limit. Contacts below
// it (a tube on a plane, any pile below the bound) are untouched, bit for bit.
//
// The kick schemes (leapfrog, symplectic Euler) need no such limit: each
// control point takes its contacts' damping explicitly up to gamma h =
// VSC_CONTACT_DAMPING_EXPLICIT and the rest implicitly, dv_k <- dv_k / (1 +
// gamma h - VSC_CONTACT_DAMPING_EXPLICIT) with gamma h the same bound. The
// damping keeps its full strength (a pile settles), no kick reverses a
// velocity, and the explicit share enters the stability estimate
// (vsc_stable_substeps): at a 1 ms step the anatomical small bowel's contacts
// (1122 rad/s, gamma h 1.26) then take one substep, not two.
#ifndef VISCERA_SRC_VSC_CONTACT_LOAD_H
#define VISCERA_SRC_VSC_CONTACT_LOAD_H

#include "vsc_rod.h"

/// The bound on gamma h (dimensionless) a contact pass keeps to: the explicit
/// limit itself, as the bound is an upper one (no margin needed).
#define VSC_CONTACT_DAMPING_LIMIT 2.0

/// The share of gamma h (dimensionless) a kick takes explicitly; past it, implicitly.
/// Below 1, so that the explicit share never reverses a velocity, and low enough
/// that a pile's damping settles it within a step or two (measured: after the
/// anatomical sweep 76-90 % of the small bowel sleeps within 5 s at 0.5, 73-84 %
/// with the damping limited to 0.9 instead).
#define VSC_CONTACT_DAMPING_EXPLICIT 0.5

/// Set rod->contact_load_unit: the largest Gershgorin row of B' B over the
/// lumped mass (1/kg, B the spheres' basis rows), the bound one unit of
/// stiffness at every sphere gives. At creation, after the mass matrix.
void vsc_contact_load_prepare(vsc_rod* rod);

/// Add a contact's stiffness (N/m) to `sphere`'s load, weighted by the
/// sphere's share of the contact times the contact's total share (1 against a
/// geom; 2 between two segments, each side summing to 1): its row in the
/// Gershgorin sum of the contact's matrix k J' n n' J.
static inline void vsc_contact_load_add(vsc_rod* rod, int sphere, double stiffness) {
  rod->work.contact_load[sphere] += stiffness;
}

/// After a contact pass at substep h (s): 1 if its damping bound exceeds
/// VSC_CONTACT_DAMPING_LIMIT somewhere; then rod->work.damping_scale holds, per
/// sphere, the factor (<= 1) on its contacts' damping. 0 otherwise. Clears the
/// load either way. O(spheres): below the limit, one pass for the most loaded sphere.
int vsc_contact_load_limit_damping(vsc_rod* rod, double h);

/// After a contact pass at substep h (s) of a kick scheme: 1 if its damping bound
/// exceeds VSC_CONTACT_DAMPING_EXPLICIT somewhere; then rod->work.contact_kick
/// holds, per control point, the factor (<= 1) on its velocity change in the
/// kick (vsc_schemes.c). 0 otherwise. Clears the load either way.
int vsc_contact_load_kick_damping(vsc_rod* rod, double h);

/// The last pass's largest bound on gamma h (for tests and tools).
double vsc_contact_load_last_bound(const vsc_rod* rod);

#endif  // VISCERA_SRC_VSC_CONTACT_LOAD_H
