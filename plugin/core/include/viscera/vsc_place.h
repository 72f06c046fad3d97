// Placement: where the rod's sample points and collision spheres are, from its
// control points. Every later stage of an evaluation (forces, contacts, grasps)
// reads what placement wrote; placement reads nothing but q and v.
#ifndef VISCERA_VSC_PLACE_H
#define VISCERA_VSC_PLACE_H

#include "viscera/vsc_rod.h"

/// Place the sample points from control points q (m); read them with vsc_rod_sample_point.
void vsc_rod_update_samples(vsc_rod* rod, const double* q);

/// Place the collision spheres and their velocities from q (m) and v (m/s; may
/// be NULL: velocities are then left untouched); read them with vsc_rod_sphere_centres.
void vsc_rod_update_spheres(vsc_rod* rod, const double* q, const double* v);

/// The collision spheres' centres (m) and velocities (m/s) at q and v into
/// `centres` and `velocities` (3 per sphere, caller-owned), leaving the rod
/// untouched: what another rod's host reads of this one (the same bits as
/// vsc_rod_update_spheres).
void vsc_rod_sphere_points(const vsc_rod* rod, const double* q, const double* v, double* centres, double* velocities);

/// Q += the force f (N) acting at collision sphere `sphere`, as generalized
/// forces on the control points (3 per point, N): the spline's weights at the
/// sphere's abscissa, as the contact pass spreads its forces.
void vsc_rod_add_sphere_force(const vsc_rod* rod, int sphere, const double f[3], double* Q);

#endif  // VISCERA_VSC_PLACE_H
