// One force evaluation of the rod: gravity, elastic forces, grasps and
// contacts gathered onto the control points, and the accelerations the
// integrators read (the model is in vsc_rod.h).
#ifndef VISCERA_VSC_FORCES_H
#define VISCERA_VSC_FORCES_H

#include "viscera/vsc_rod.h"
#include "viscera/vsc_world.h"

/// Generalised forces on control points, Q = Q_gravity + Q_contact + Q_grasp - grad E
/// (N, 3n interleaved, overwritten) at positions q (m) and velocities v (m/s).
/// Damping is not included (see vsc_rod_acceleration). The reactions on the
/// geoms and the anchors are added to `reactions` (NULL: not wanted). No
/// friction state: contacts slide with their damping alone (vsc_rod_step
/// carries the friction state).
void vsc_rod_forces(vsc_rod* rod, const vsc_world* world, const vsc_reactions* reactions, const double* q,
                    const double* v, double* generalized_force);

/// Accelerations a (m/s^2, 3n, overwritten) from positions q and velocities v:
/// a = M^{-1} Q - damping v, and a = 0 at pinned points. O(n).
void vsc_rod_acceleration(vsc_rod* rod, const vsc_world* world, const vsc_reactions* reactions, const double* q,
                          const double* v, double* acceleration);

#endif  // VISCERA_VSC_FORCES_H
