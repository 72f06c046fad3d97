// Placement (viscera/vsc_place.h), and its inverse the contact stage inlines:
// a force at a sphere spread onto the control points.
#ifndef VISCERA_SRC_VSC_PLACE_H
#define VISCERA_SRC_VSC_PLACE_H

#include "viscera/vsc_place.h"
#include "vsc_rod.h"

/// The placement stage's state, which it owns: the collision spheres where
/// the last evaluation placed them. The broad and narrow phases, the kick's
/// reactions and the public reads take it const.
struct vsc_placement {
  double* sphere_xyz;       ///< collision sphere centres (3 x spheres) (m)
  double* sphere_velocity;  ///< collision sphere velocities (3 x spheres) (m/s)
};

/// Place the collision spheres and their velocities from q (m) and v (m/s; may
/// be NULL: velocities are then left as they were).
void vsc_place_spheres(const vsc_rod* rod, const double* q, const double* v, vsc_placement* placement);

/// Place the spring sample points from q (m) into x, y, z (N each, caller's):
/// the elastic pass and the Jacobian each place their own.
void vsc_place_samples(const vsc_rod* rod, const double* q, double* x, double* y, double* z);

/// Q += the force f (N) at collision sphere `sphere`, by the spline's weights
/// there (vsc_rod_add_sphere_force, inlined for the contact pass).
static inline __attribute__((always_inline)) void vsc_place_add_at_sphere(const vsc_rod* rod, int sphere,
                                                                          const double f[3], double* Q) {
  // weights and force in locals: the stores to Q then force no reloads
  const vsc_basis* b = &rod->sphere_basis[sphere];
  double* out = Q + 3 * b->first;
  const double f0 = f[0], f1 = f[1], f2 = f[2];
  const double w[VSC_SPLINE_SUPPORT] = {b->weight[0], b->weight[1], b->weight[2], b->weight[3]};
  for (int j = 0; j < VSC_SPLINE_SUPPORT; ++j) {
    out[3 * j] += w[j] * f0;
    out[3 * j + 1] += w[j] * f1;
    out[3 * j + 2] += w[j] * f2;
  }
}

#endif  // VISCERA_SRC_VSC_PLACE_H
