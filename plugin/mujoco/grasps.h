// The graspers' jaws on the intestine, between MuJoCo and the core: which jaws
// hold which axis point (the grasps block of plugin_state, state_layout.h), the
// holds the core's step reads (vsc_grasp), and their reactions back on the jaw
// bodies, slipping past what the jaws' friction at their pinch holds (or
// slip_force). Private to the adapter.
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
  double pinch[VSC_MAX_GRASPERS];    ///< each hold's pinch this step (N; negative: no actuator drives the jaw)
  double slip_at[VSC_MAX_GRASPERS];  ///< the pull past which each hold slips this step (N)
  double reaction[3 * VSC_MAX_GRASPERS];  ///< each hold's force on its anchor, the step's average (N; the
                                          ///< core's output, vsc_reactions.grasp_force)
  int count;
} vsc_mujoco_holds;

/// Grasper i's pinch (N): the squeeze of the actuators on its jaw joint,
/// evaluated where the jaws meet the tissue (the joint at `closed_below`, at
/// rest), in the closing direction (towards lower positions); a hinge's torque
/// over the lever (`lever`, or the hinge axis's distance to the site in `d`).
/// At least 0. Negative (-1) when no actuator drives the jaw.
double vsc_mujoco_grasp_pinch(const mjModel* m, const mjData* d, const vsc_grasper_config* g, int i);

/// The pull (N) past which a hold slips at `pinch` (N; negative: no actuator
/// drives the jaw): 2 friction x pinch (two jaw faces), at most slip_force.
double vsc_mujoco_grasp_slip_pull(const vsc_grasper_config* g, double pinch);

/// Jaws take and lose their hold, from the jaw joints in `d`: a closing jaw
/// (open, now at or below closed_below) holds the axis point nearest its site
/// if within reach (else it stays closed empty); an opening jaw lets go.
/// Updates `grasp_state` (G x VSC_GRASP_STATE_SIZE) and fills `out` with this
/// step's holds, anchors at the step start (q: control points, m). Returns
/// their count.
int vsc_mujoco_holds_update(const mjModel* m, mjData* d, const vsc_grasper_config* g, vsc_rod* rod, const mjtNum* q,
                            mjtNum* grasp_state, vsc_mujoco_holds* out);

/// After the step: each hold's reaction goes to its jaw's body in `wrench`
/// (6 per body; force at the anchor). A hold that pulled harder than its
/// slip_at: past `slip_force`, it tears out of the jaw at once (closed empty
/// until it opens; its slip count grows); past the jaws' friction alone, the
/// tissue slides in the jaws, its held point moved in the site's frame so that
/// the spring pulls with the friction limit, and it slips out once that point
/// is further than `reach` from the site. `q`: the n control points after the
/// step (m).
void vsc_mujoco_holds_release(const mjModel* m, const mjData* d, const vsc_grasper_config* g,
                              const vsc_mujoco_holds* holds, int n, const mjtNum* q, mjtNum* grasp_state,
                              mjtNum* wrench);

#endif  // VISCERA_PLUGIN_GRASPS_H
