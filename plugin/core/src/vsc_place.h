// Placement (viscera/vsc_place.h), and its inverse the contact stage inlines:
// a force at a sphere spread onto the control points.
#ifndef VISCERA_SRC_VSC_PLACE_H
#define VISCERA_SRC_VSC_PLACE_H

#include "viscera/vsc_place.h"
#include "vsc_rod.h"

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
