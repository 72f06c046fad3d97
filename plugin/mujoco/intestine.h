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

/// The config of intestine `instance` as read once when data `d`'s caches were
/// built for model `m` (owned by those caches: valid while d lives and is not
/// stepped with another model), or NULL if d has none for m.
const vsc_plugin_config* vsc_intestine_config(const mjModel* m, const mjData* d, int instance);

#endif  // VISCERA_PLUGIN_INTESTINE_H
