// Placement: where the rod's sample points and collision spheres are, from its
// control points. Every later stage of an evaluation (forces, contacts, grasps)
// reads what placement wrote; placement reads nothing but q and v.
#ifndef VISCERA_VSC_PLACE_H
#define VISCERA_VSC_PLACE_H

#include "viscera/vsc_rod.h"

/// Sample point `a` (m, 3) at control points q (m), leaving the rod untouched
/// (the same bits as the elastic pass places).
void vsc_rod_sample_point(const vsc_rod* rod, const double* q, int a, double out[3]);

/// The collision spheres' centres (m) and velocities (m/s) at q and v into
/// `centres` and `velocities` (3 per sphere, caller-owned; v may be NULL: no
/// velocities), leaving the rod untouched: what another rod's host reads of
/// this one (the same bits as an evaluation places).
void vsc_rod_sphere_points(const vsc_rod* rod, const double* q, const double* v, double* centres, double* velocities);

/// Q += the force f (N) acting at collision sphere `sphere`, as generalized
/// forces on the control points (3 per point, N): the spline's weights at the
/// sphere's abscissa, as the contact pass spreads its forces.
void vsc_rod_add_sphere_force(const vsc_rod* rod, int sphere, const double f[3], double* Q);

#endif  // VISCERA_VSC_PLACE_H
