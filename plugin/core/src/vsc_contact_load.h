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
// and before pushing them; where the bound exceeds the scheme's limit the
// damping of the contacts there is scaled down to the limit. Contacts below
// it (a tube on a plane, any pile below the bound) are untouched, bit for bit.
//
// The schemes that apply damping explicitly (leapfrog, symplectic Euler) keep
// to the step's damping_limit: 2, or VSC_KICK_DAMPING_LIMIT where the stability
// estimate counted on it (vsc_stable_damping_limit): below 1, an explicit kick
// never reverses a velocity by its damping, and at a 1 ms step the anatomical
// small bowel's contacts (1122 rad/s, gamma h 1.26 for one contact per sphere)
// then take one substep, where they took two. Tried instead: the damping past
// gamma h 0.5 taken implicitly in the kick, point by point (dv_k / (1 + gamma h
// - 0.5)). That keeps a pile's damping whole, but it scales the point's whole
// response, its contacts' push too, and as contacts come and go each step it
// pumped a swept pile into a lasting churn at metres a second (the anatomical
// sweep's 8 s, then 5 s of rest: nothing slept; with the limit, all of it
// within 4 s).
#ifndef VISCERA_SRC_VSC_CONTACT_LOAD_H
#define VISCERA_SRC_VSC_CONTACT_LOAD_H

#include "viscera/vsc_integrate.h"
#include "vsc_rod.h"

/// The contact pass's load (vsc_contact.h's pass holds it).
typedef struct vsc_contact_load {
  double* stiffness;      ///< per sphere, the pass's stiffness (N/m), zero between passes, then per
                          ///< control point its Gershgorin row (n), then the inverse lumped masses
                          ///< (n, 1/kg; 0 where pinned; set at creation)
  double* damping_scale;  ///< per sphere, the factor (<= 1) on its contacts' damping in a limited pass
  double bound;           ///< the last pass's largest bound on gamma h
} vsc_contact_load;

/// Set the inverse lumped masses in `load` and rod->contact_load_unit: the
/// largest Gershgorin row of B' B over the lumped mass (1/kg, B the spheres'
/// basis rows), the bound one unit of stiffness at every sphere gives. At
/// creation, after the mass matrix.
void vsc_contact_load_prepare(vsc_rod* rod, vsc_contact_load* load);

/// Add a contact's stiffness (N/m) to `sphere`'s load, weighted by the
/// sphere's share of the contact times the contact's total share (1 against a
/// geom; 2 between two segments, each side summing to 1): its row in the
/// Gershgorin sum of the contact's matrix k J' n n' J.
static inline void vsc_contact_load_add(vsc_contact_load* load, int sphere, double stiffness) {
  load->stiffness[sphere] += stiffness;
}

/// After a contact pass at substep h (s): 1 if its damping bound exceeds
/// `limit` (gamma h, the scheme's: VSC_CONTACT_DAMPING_LIMIT or
/// VSC_KICK_DAMPING_LIMIT) somewhere; then load->damping_scale holds, per
/// sphere, the factor (<= 1) on its contacts' damping. 0 otherwise. Clears the
/// load either way. O(spheres): below the limit, one pass for the most loaded sphere.
int vsc_contact_load_limit_damping(const vsc_rod* rod, vsc_contact_load* load, double h, double limit);

#endif  // VISCERA_SRC_VSC_CONTACT_LOAD_H
