// viscera.intestine: the spline intestine as a MuJoCo passive-force plugin.
//
// plugin_state: positions, velocities, the divergence and recovery counts, the
// reaction on every body, the friction state, the grasps (state_layout.h has
// the blocks, their order and units; Python reads them through exports.c).
// plugin_data holds only caches derived from the model (the rod's mass matrix
// factor, basis tables, scratch), one per mjData.
#ifndef VISCERA_PLUGIN_INTESTINE_H
#define VISCERA_PLUGIN_INTESTINE_H

#include <mujoco/mujoco.h>

#include "config.h"

/// Register viscera.intestine with MuJoCo.
void vsc_plugin_register_intestine(void);

/// The skin definition and control point count of intestine `instance` as
/// data `d`'s caches read them for model `m`, copied under the registry's lock
/// (so another thread freeing the caches cannot pull them away). Returns 1, or
/// 0 if d has no caches for m (nothing written).
int vsc_intestine_skin_def(const mjModel* m, const mjData* d, int instance, vsc_skin_def* skin, int* control_count);

#endif  // VISCERA_PLUGIN_INTESTINE_H
