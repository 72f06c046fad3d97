// The rod's elastic forces (viscera/vsc_elastic.h has the energy).
#ifndef VISCERA_SRC_VSC_ELASTIC_H
#define VISCERA_SRC_VSC_ELASTIC_H

#include "viscera/vsc_elastic.h"
#include "vsc_rod.h"

/// Add the elastic forces -dE/dq at control points q (m) to Q (N, 3n):
/// springs, curvature and clamps from the placed samples (vsc_place.h, which
/// must be current for q), then the mesentery's tethers.
void vsc_rod_add_elastic_forces(vsc_rod* rod, const double* q, double* Q);

/// The gradient g = dl/dq (dimensionless, 3n) of the axis length l at the
/// placed samples (vsc_place.h, current for the q it is wanted at): the
/// direction the global length term K_g (l - length) g pushes along, and its
/// stiffness's rank-one part K_g g g'. Overwrites the rod's spring edges and
/// sample forces (0 where a control point sleeps deep).
void vsc_rod_length_gradient(vsc_rod* rod, double* gradient);

#endif  // VISCERA_SRC_VSC_ELASTIC_H
