// Explicit time integration of the rod (France et al. 2002, 3.1.4: RK4).
#ifndef VISCERA_VSC_INTEGRATE_H
#define VISCERA_VSC_INTEGRATE_H

#include "viscera/vsc_rod.h"

/// Integrators selectable by name.
typedef enum vsc_integrator {
  VSC_INTEGRATOR_RK4 = 0,  ///< classical 4th-order Runge-Kutta, 4 force evaluations a step
} vsc_integrator;

/// Largest speed (m/s) a finite state may reach before it counts as diverged.
#define VSC_DIVERGED_SPEED 1.0e4

/// Advance q (m), v (m/s) and the friction state `stick` (VSC_STICK_SIZE per
/// sphere, may be NULL) in place by `substeps` RK4 steps of dt / substeps
/// (dt in s). The world (geom poses) is frozen over dt. If world->geom_wrench
/// is set, the reaction on each geom averaged over dt is added to it (RK4's
/// stage weights), so the impulse the geoms receive is exactly the one the rod
/// gave. If the state becomes non-finite or faster than VSC_DIVERGED_SPEED, q
/// is restored to its value at the start of the failing substep, v, the
/// friction state and the geom reactions are cleared and VSC_ERROR_DIVERGED is
/// returned: the state always stays finite.
vsc_status vsc_rod_step(vsc_rod* rod, const vsc_world* world, double* q, double* v, double* stick, double dt,
                        int substeps);

#endif  // VISCERA_VSC_INTEGRATE_H
