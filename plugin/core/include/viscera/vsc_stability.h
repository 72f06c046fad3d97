// How small a substep must be: the rod's highest frequencies, elastic and
// contact, and the fewest substeps of an integrator that keep omega h within
// the bound it trusts (vsc_integrate.h's table).
#ifndef VISCERA_VSC_STABILITY_H
#define VISCERA_VSC_STABILITY_H

#include "viscera/vsc_integrate.h"
#include "viscera/vsc_rod.h"

/// Most power iterations of the frequency estimate (each O(n)); it stops
/// earlier, usually after 10 to 20, once omega^2 changes by less than 1e-3 in
/// one (it then lies within about 1 % below the limit: the trusted bounds below
/// leave 5 to 10 %).
#define VSC_FREQUENCY_ITERATIONS 100

/// ... and at most this many band entries times iterations (at least 12
/// iterations): a million control points take 12, about a second.
#define VSC_FREQUENCY_WORK 4e7

/// vsc_stable_substeps never asks for more.
#define VSC_MAX_AUTO_SUBSTEPS 1024

/// Highest angular frequencies (rad/s) of the rod linearised at q (m): of its
/// elastic forces (M^-1 K, pinned points held), without the global length
/// term's rank-one part if `length_implicit` (the mode a kick that takes that
/// term implicitly meets: vsc_step_options.length_implicit), and of its contact
/// springs alone, every sphere pressed by a geom in every direction (a rod
/// lying on a plane has exactly that across it), times sqrt(2) with
/// self-collision (a pair presses two spheres). Power iteration, O(n) per
/// iteration, on a scratch allocated for the call (both 0 if memory ran out):
/// nothing an evaluation reads changes. Also sets rod->contact_damping_rate.
void vsc_rod_frequencies(vsc_rod* rod, const double* q, int length_implicit, double* elastic, double* contact);

/// Fewest substeps of `integrator` for a step dt (s) with omega h within the
/// trusted bound of its row in vsc_integrate.h, omega from the frequencies (rad/s) of
/// vsc_rod_frequencies (explicit integrators: the larger; implicit: contact,
/// whose friction and self-contacts it takes explicitly); for the integrators
/// that apply damping explicitly (leapfrog, symplectic Euler), omega^2 h^2 + 2 g h
/// within the bound's square, g the contact damping rate (1/s,
/// rod->contact_damping_rate after vsc_rod_frequencies; 0: none); 1 to
/// VSC_MAX_AUTO_SUBSTEPS.
int vsc_stable_substeps(vsc_integrator integrator, double elastic, double contact, double contact_damping_rate,
                        double dt);

/// The bound on a pile's gamma h (vsc_step_options.damping_limit) for
/// `substeps` substeps of dt (s): VSC_KICK_DAMPING_LIMIT where `integrator`
/// applies damping explicitly and the stiffest mode with the whole contact
/// damping rate passes the trusted bound at that substep (vsc_stable_substeps
/// counted on the lower limit to take so few), VSC_CONTACT_DAMPING_LIMIT
/// otherwise: a scene whose substeps hold the damping as it is keeps it whole.
double vsc_stable_damping_limit(vsc_integrator integrator, double elastic, double contact, double contact_damping_rate,
                                double dt, int substeps);

#endif  // VISCERA_VSC_STABILITY_H
