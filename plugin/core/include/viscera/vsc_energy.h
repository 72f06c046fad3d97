// The rod's mechanical energies, as the step's divergence guard weighs them.
#ifndef VISCERA_VSC_ENERGY_H
#define VISCERA_VSC_ENERGY_H

#include "viscera/vsc_rod.h"

/// Kinetic + elastic energy (J). Writes nothing.
double vsc_rod_active_energy(const vsc_rod* rod, const double* q, const double* v);

/// Gravitational potential energy (J) under `gravity` (m/s^2), zero at the origin.
double vsc_rod_gravity_energy(const vsc_rod* rod, const double gravity[3], const double* q);

/// Kinetic energy 1/2 v^T M v (J). Writes nothing.
double vsc_rod_kinetic_energy(const vsc_rod* rod, const double* v);

#endif  // VISCERA_VSC_ENERGY_H
