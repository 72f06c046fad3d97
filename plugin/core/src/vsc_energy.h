// The rod's mechanical energies (viscera/vsc_energy.h), on a caller's scratch.
#ifndef VISCERA_SRC_VSC_ENERGY_H
#define VISCERA_SRC_VSC_ENERGY_H

#include "viscera/vsc_energy.h"
#include "vsc_elastic.h"

/// Kinetic energy 1/2 v' M v (J); `mass_times_v` (3n, caller's) is scratch
/// for a consistent mass matrix.
double vsc_energy_kinetic(const vsc_rod* rod, const double* v, double* mass_times_v);

/// Kinetic + elastic energy at (q, v) (J), on the caller's scratch.
double vsc_energy_active(const vsc_rod* rod, vsc_elastic_scratch* elastic, double* mass_times_v, const double* q,
                         const double* v);

#endif  // VISCERA_SRC_VSC_ENERGY_H
