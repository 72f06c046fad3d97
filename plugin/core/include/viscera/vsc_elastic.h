// The rod's elastic energy (the model is in vsc_rod.h): stretch and bend
// springs, the global stretch term, curvature bending, clamps and the
// mesentery's tethers, evaluated on the sample points.
#ifndef VISCERA_VSC_ELASTIC_H
#define VISCERA_VSC_ELASTIC_H

#include "viscera/vsc_rod.h"

/// Elastic energy E (J) at control points q (m): springs, global stretch,
/// curvature, clamps and mesentery tethers. Writes nothing: each sample is
/// computed where it is needed (the same bits as the forces' pass).
double vsc_rod_elastic_energy(const vsc_rod* rod, const double* q);

/// Length of the axis (m), as the sum of the sample spacings. Writes nothing.
double vsc_rod_length(const vsc_rod* rod, const double* q);

#endif  // VISCERA_VSC_ELASTIC_H
