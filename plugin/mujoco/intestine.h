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
/// data `d`'s caches read them for model `m`, copied under the caches' mutex
/// (so another thread freeing the caches cannot pull them away). Returns 1, or
/// 0 if d has no caches for m (nothing written).
int vsc_intestine_skin_def(const mjModel* m, const mjData* d, int instance, vsc_skin_def* skin, int* control_count);

/// The graspers' config of intestine `instance` as data `d`'s caches read it
/// for model `m`, copied under the caches' mutex (no config text parsed).
/// Returns 1, or 0 if d has no caches for m (nothing written).
int vsc_intestine_grasper_config(const mjModel* m, const mjData* d, int instance, vsc_grasper_config* grasp);

/// Rebuild data `d`'s caches of intestine `instance` from model `m`'s config as
/// it is now: for a model whose config values were rewritten in place (same
/// lengths; plugin_attr) to start another episode without compiling. d's
/// plugin_state is left as it is; mj_resetData then writes the new config's
/// initial state. The old caches are freed. Returns 0, or -1 with a message in
/// `error` (`error_size` bytes) if the config is invalid or the instance is not
/// an intestine (the old caches are then kept).
int vsc_intestine_reconfigure(const mjModel* m, mjData* d, int instance, char* error, int error_size);

/// A drawn capsule's dataid where the wall under it is damaged: fully bruised or
/// torn (vsc_damage.h); -1 elsewhere. Segmentation renders label it apart.
#define VSC_DRAWN_DAMAGED 1

/// The skin's colour (rgba) over wall bruised `bruise` (0 to 1) or `torn`,
/// from its `healthy` colour.
void vsc_damage_colour(const float healthy[4], double bruise, int torn, float out[4]);

/// The colours damage is drawn in: out = bruise rgb (fully bruised), torn rgb.
void vsc_damage_colours(double out[6]);

#endif  // VISCERA_PLUGIN_INTESTINE_H
