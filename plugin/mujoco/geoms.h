// The MuJoCo geoms the intestine may touch, as the core sees them (vsc_geom):
// which geoms (MuJoCo's contype/conaffinity rule against the intestine's 1/1,
// every geom type the core can collide), their mesh hulls and height fields
// built once per model, their poses and velocities refreshed from an mjData.
// Private to the adapter.
#ifndef VISCERA_PLUGIN_GEOMS_H
#define VISCERA_PLUGIN_GEOMS_H

#include <mujoco/mujoco.h>

#include "viscera/vsc_geom.h"

/// The candidate geoms of one model. Owns every array (vsc_mujoco_geoms_free).
typedef struct vsc_mujoco_geoms {
  int count;                     ///< geoms that may touch the intestine
  int* ids;                      ///< their MuJoCo geom ids (count)
  vsc_geom* geoms;               ///< their world description, refreshed by vsc_mujoco_geoms_update (count)
  vsc_convex* convex;            ///< hulls of mesh geoms (count; face_count 0 elsewhere)
  vsc_heightfield* heightfield;  ///< height fields (count; reading the model's data; their vertex records owned here)
} vsc_mujoco_geoms;

/// Find the candidate geoms of `m` and build their hulls and height fields.
/// Returns 0, or -1 if memory ran out (then *out is freed and zeroed).
int vsc_mujoco_geoms_create(const mjModel* m, vsc_mujoco_geoms* out);

/// 1 if the model has a geom of a type the intestine collides with, whatever
/// its contype and conaffinity (a user may change those after load; what
/// depends on this, the resolution a tolerance chooses, must not), else 0.
int vsc_mujoco_geoms_possible(const mjModel* m);

/// Release what vsc_mujoco_geoms_create built (a zeroed struct is fine).
void vsc_mujoco_geoms_free(vsc_mujoco_geoms* geoms);

/// Poses (m), rotations, velocities (m/s, rad/s), boxes and friction of the
/// geoms from `d`; `friction` >= 0 overrides every geom's (the 'friction' key).
void vsc_mujoco_geoms_update(const mjModel* m, const mjData* d, double friction, vsc_mujoco_geoms* geoms);

#endif  // VISCERA_PLUGIN_GEOMS_H
