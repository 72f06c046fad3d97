// Contacts between the intestine instances of one model (private to the
// adapter). Of each pair, the lower instance computes them: it collides
// against the higher one's tube as a chain of capsule geoms, between its
// collision spheres as placed at the step start and moving with their
// velocities, exactly as it collides against a tool. The reaction on those
// capsules, averaged over the step, goes to the higher instance as loads on
// its control points, which it feels over its own step: the two impulses are
// equal and opposite, and each instance still integrates only itself.
#ifndef VISCERA_PLUGIN_PARTNERS_H
#define VISCERA_PLUGIN_PARTNERS_H

#include "viscera/vsc_geom.h"
#include "viscera/vsc_rod.h"

/// The capsules along another rod's spheres, at `centres` (m) moving at
/// `velocities` (m/s; 3 per sphere each, vsc_rod_sphere_points) with `rod`'s
/// radii: spheres - 1 capsules into `out`, each of the
/// mean radius of its two spheres (m) and Coulomb coefficient `friction`, each moving rigidly with its two
/// spheres (the velocity of its middle, the spin of its axis). Each sphere is
/// placed `ahead` seconds along its velocity: the core holds a geom still over
/// a step, and a partner held where it will be at mid-step (ahead = dt / 2)
/// meets the rod where it moves to, not where it was (a tube falling at 2 m/s
/// moves 4 mm, a third of its radius, in a 2 ms step).
void vsc_partner_capsules(const vsc_rod* rod, const double* centres, const double* velocities, int spheres,
                          double friction, double ahead, vsc_geom* out);

/// Add the reactions on those capsules (`wrench`: 6 per capsule, force N and
/// torque N m about its middle, averaged over a step; vsc_world.geom_wrench)
/// to `load` (3 per control point of `rod`, of `spheres` collision spheres;
/// generalized forces, N): each
/// capsule's force and torque across its axis become forces at its two
/// spheres, spread onto the control points as the rod's contacts spread theirs
/// (vsc_rod_add_sphere_force).
void vsc_partner_add_load(const vsc_rod* rod, int spheres, const vsc_geom* capsules, const double* wrench,
                          double* load);

#endif  // VISCERA_PLUGIN_PARTNERS_H
