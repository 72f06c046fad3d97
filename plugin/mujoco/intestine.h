// viscera.intestine: the spline intestine as a MuJoCo passive-force plugin.
//
// plugin_state: positions, velocities, the divergence and recovery counts, the
// reaction on every body, the friction state, the grasps (state_layout.h has
// the blocks, their order and units; Python reads them through exports.c).
// plugin_data holds only caches derived from the model (the rod's mass matrix
// factor, basis tables, scratch), one per mjData.
#ifndef VISCERA_PLUGIN_INTESTINE_H
#define VISCERA_PLUGIN_INTESTINE_H

/// Register viscera.intestine with MuJoCo.
void vsc_plugin_register_intestine(void);

#endif  // VISCERA_PLUGIN_INTESTINE_H
