// The graspers' jaws on the intestine, between MuJoCo and the core: which jaws
// hold which axis point (the grasps block of plugin_state, state_layout.h), the
// holds the core's step reads (vsc_grasp), and their reactions back on the jaw
// bodies, slipping past slip_force. Private to the adapter.
#ifndef VISCERA_PLUGIN_GRASPS_H
#define VISCERA_PLUGIN_GRASPS_H

#include <mujoco/mujoco.h>

#include "config.h"
#include "state_layout.h"
#include "viscera/vsc_grasp.h"
#include "viscera/vsc_rod.h"

// Per grasper state (VSC_GRASP_STATE_SIZE numbers): status (VSC_GRASP_OPEN ...,
// state_layout.h), held abscissa s, the held point in the site's frame (m, 3)
// so that taking hold moves nothing, slip count.

/// This step's holds: the core's grasps and, for each, its grasper.
typedef struct vsc_mujoco_holds {
  vsc_grasp grasps[VSC_MAX_GRASPERS];
  int owner[VSC_MAX_GRASPERS];  ///< which grasper (grasp_sites index) each hold belongs to
  int count;
} vsc_mujoco_holds;

/// Jaws take and lose their hold, from the jaw joints in `d`: a closing jaw
/// (open, now at or below closed_below) holds the axis point nearest its site
/// if within reach (else it stays closed empty); an opening jaw lets go.
/// Updates `grasp_state` (G x VSC_GRASP_STATE_SIZE) and fills `out` with this
/// step's holds, anchors at the step start (q: control points, m). Returns
/// their count.
int vsc_mujoco_holds_update(const mjModel* m, mjData* d, const vsc_grasper_config* g, vsc_rod* rod, const mjtNum* q,
                            mjtNum* grasp_state, vsc_mujoco_holds* out);

/// After the step: each hold's reaction goes to its jaw's body in `wrench`
/// (6 per body; force at the anchor); a hold that pulled harder than
/// slip_force slips out of the jaw (closed empty until it opens; its slip count
/// grows).
void vsc_mujoco_holds_release(const mjModel* m, const mjData* d, const vsc_grasper_config* g,
                              const vsc_mujoco_holds* holds, mjtNum* grasp_state, mjtNum* wrench);

#endif  // VISCERA_PLUGIN_GRASPS_H
