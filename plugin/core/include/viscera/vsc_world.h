// What surrounds one rod during a step: the host's inputs (gravity, rigid geoms,
// held points) and where the step writes its reactions. Host-owned; the core
// never keeps a pointer past the call it was given in. What a step mutates on
// its own account (friction state, each evaluation's weight) lives in the
// core's step context (src/vsc_context.h), not here.
#ifndef VISCERA_VSC_WORLD_H
#define VISCERA_VSC_WORLD_H

#include "viscera/vsc_geom.h"

struct vsc_grasp;  // viscera/vsc_grasp.h

/// Rigid surroundings of one rod (host-owned).
typedef struct vsc_world {
  double gravity[3];        ///< gravitational acceleration (m/s^2)
  const vsc_geom* geoms;    ///< rigid geoms the rod collides with
  int geom_count;
  double* geom_wrench;      ///< optional output: reaction on each geom, 6 per geom (force N, torque N m
                            ///< about the geom position, world frame)
  struct vsc_grasp* grasps; ///< optional held points (see vsc_grasp.h); their reactions are written
  int grasp_count;
  const double* control_load;  ///< optional: forces on the control points, constant over the step
                               ///< (generalized, N, 3 per point; e.g. another rod's contacts, which
                               ///< that rod computed and the host handed over); NULL: none
} vsc_world;

#endif  // VISCERA_VSC_WORLD_H
