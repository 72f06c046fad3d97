// What surrounds one rod during a step: the host's inputs (gravity, rigid geoms,
// held points, loads), which the core only reads, and apart from them where the
// step writes its reactions on the host's bodies (vsc_reactions). Host-owned;
// the core never keeps a pointer past the call it was given in. What a step
// mutates on its own account (friction state, each evaluation's weight) lives
// in the core's step context (src/vsc_context.h).
#ifndef VISCERA_VSC_WORLD_H
#define VISCERA_VSC_WORLD_H

#include "viscera/vsc_geom.h"

struct vsc_grasp;  // viscera/vsc_grasp.h

/// Rigid surroundings of one rod (host-owned, read only).
typedef struct vsc_world {
  double gravity[3];        ///< gravitational acceleration (m/s^2)
  const vsc_geom* geoms;    ///< rigid geoms the rod collides with
  int geom_count;
  const struct vsc_grasp* grasps;  ///< optional held points (see vsc_grasp.h)
  int grasp_count;
  const double* control_load;  ///< optional: forces on the control points, constant over the step
                               ///< (generalized, N, 3 per point; e.g. another rod's contacts, which
                               ///< that rod computed and the host handed over); NULL: none
  int wake_all;                ///< 1: every control point wakes as the step begins (the host's gravity
                               ///< changed; vsc_sleep.h)
  const unsigned char* wake_capsules;  ///< optional, per capsule c (spheres c and c + 1): 1 where another
                                       ///< rod's moving spheres pressed it, so the points either sphere
                                       ///< depends on wake as the step begins; NULL: none
} vsc_world;

/// Where a step or a lone force evaluation writes the reactions on the host's
/// bodies (host-owned outputs; a NULL member is not written). A step
/// overwrites them with their average over it; a lone evaluation adds its own.
typedef struct vsc_reactions {
  double* geom_wrench;  ///< per world geom, 6: the force (N) and torque (N m, about the geom's position,
                        ///< world frame) the rod's contacts put on it
  double* grasp_force;  ///< per world grasp, 3: the force (N) its spring puts on the anchor
} vsc_reactions;

#endif  // VISCERA_VSC_WORLD_H
