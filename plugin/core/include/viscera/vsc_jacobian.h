// Force Jacobians of the rod, in band form, for implicit integration.
//
// The generalised force Q(q, v) of vsc_rod_forces is local along the spline:
// each spring, bending angle, tether, grasp and contact involves at most three
// neighbouring samples, each sample four consecutive control points. So
// K = -dQ/dq (N/m) and D = -dQ/dv (N s/m) are banded over the 3n unknowns,
// except for the global stretch term, whose Hessian K_g g g^T (g = dl/dq, l
// the axis length) is dense but of rank one: it is returned apart, as g, for a
// Sherman-Morrison update of the solve (vsc_integrate.c).
//
// Linearised (in K and D), each kept positive semi-definite so that
// M + h D + h^2 K is positive definite for every step h:
//   stretch and bend springs  k e e^T + max(T, 0) / l (I - e e^T), e the unit spring
//                             vector, T its tension (stretch springs include the global
//                             term's tension): the exact Hessian, without the negative
//                             geometric stiffness of a compressed spring
//   curvature and clamps      the Gauss-Newton Hessian of (EI / l0)(1 - cos theta) =
//                             (EI / 2 l0) |w/|w| - u/|u||^2: exact on a straight axis
//   mesentery tethers         like springs, while taut
//   grasps                    k I and c I at the held point
//   rigid contacts            k n n^T and c n n^T of each sphere's strongest rigid contact
//                             (its touch record from the last force evaluation)
// Explicit (in Q only): gravity, friction and the contacts' tangential damping,
// and self-contacts, whose pairs change from one evaluation to the next.
#ifndef VISCERA_VSC_JACOBIAN_H
#define VISCERA_VSC_JACOBIAN_H

#include "viscera/vsc_rod.h"

/// Add `mass_weight` M (kg, band 7 of vsc_rod) to `band`, a wide band (vsc_band.h)
/// of size 3n and half-width vsc_rod_jacobian_half_width(rod).
void vsc_rod_add_mass(const vsc_rod* rod, double mass_weight, double* band);

/// Add stiffness_weight K + damping_weight D at positions q (m) to `band` (same
/// layout as above). Rigid contacts come from the touch records, so call
/// vsc_rod_forces at q first. If global_gradient is not NULL, g = dl/dq
/// (dimensionless, 3n) is written there; K_g g g^T is never added to `band`.
/// Overwrites the implicit scheme's scratch.
void vsc_rod_add_jacobian(vsc_rod* rod, const vsc_world* world, const double* q, double stiffness_weight,
                          double damping_weight, double* band, double* global_gradient);

/// Replace the rows and columns of the pinned control points by identity.
void vsc_rod_pin_band(const vsc_rod* rod, double* band);

#endif  // VISCERA_VSC_JACOBIAN_H
