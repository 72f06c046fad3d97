// Penalty contact between the rod's collision spheres and rigid geoms
// (France et al. 2002, 3.3). Spheres of radius def.radius sit uniformly in
// abscissa; a sphere that penetrates a geom by depth d > 0 with normal approach
// speed v_n receives f = max(0, k d - c v_n) along the outward normal, applied at
// its abscissa through the spline basis (virtual work). The geom receives the
// opposite force at the contact point on its surface.
#ifndef VISCERA_VSC_CONTACT_H
#define VISCERA_VSC_CONTACT_H

#include "viscera/vsc_rod.h"

/// Add contact forces to Q (N, 3n) and, if geom_wrench is not NULL, the
/// reaction on each geom (6 per geom: force N, torque N m about its position).
/// rod->sphere_xyz and rod->sphere_velocity must be current
/// (vsc_rod_update_spheres). Returns the number of sphere-geom contacts.
int vsc_rod_contact_forces(vsc_rod* rod, const vsc_world* world, double* Q, double* geom_wrench);

#endif  // VISCERA_VSC_CONTACT_H
