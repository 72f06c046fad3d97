// viscera.intestine: the spline intestine as a MuJoCo passive-force plugin.
//
// plugin_state layout per instance (n control points, S collision spheres,
// B = m->nbody; mjtNums):
//   [0, 3n)        control point positions, x y z per point (m, world frame)
//   [3n, 6n)       control point velocities (m/s)
//   [6n]           divergence count: steps that diverged (non-finite, faster than
//                  100 m/s, or an energy jump; see vsc_integrate.h) at every
//                  retry, whose positions were restored and velocities zeroed
//   [6n + 1]       recovery count: steps that diverged but held when retried
//                  with more substeps (both counts: reset writes 0)
//   6B numbers     per body, the reaction of the intestine over the last step:
//                  force (N), torque about the body's centre of mass (N m), world
//   8S numbers     per sphere, friction state (see vsc_contact.h)
//   6G numbers     per grasper (grasp_sites), its hold: status (0 open, 1 holding,
//                  2 closed without a hold: missed or slipped), held abscissa
//                  s in [0, 1], held point in the site frame (m, 3), slip count
// plugin_data holds only caches derived from the model (the rod's mass matrix
// factor, basis tables, scratch), one per mjData.
#ifndef VISCERA_PLUGIN_INTESTINE_H
#define VISCERA_PLUGIN_INTESTINE_H

/// Register viscera.intestine with MuJoCo.
void vsc_plugin_register_intestine(void);

#endif  // VISCERA_PLUGIN_INTESTINE_H
