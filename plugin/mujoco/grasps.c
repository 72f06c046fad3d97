// The graspers' jaws on the intestine (see grasps.h).
#include "grasps.h"

#include <math.h>

#include "viscera/vsc_geom.h"
#include "viscera/vsc_spline.h"

// A hinge axis closer to the site than this gives no lever (m): a 1 mm floor.
#define VSC_MIN_LEVER_M 1e-3

// The jaws rest on the tissue they hold at closed_below: the actuators' force is
// evaluated there, at rest, from their input (the clamped control, or the
// activation), gain and affine bias, clamped to their force range.
double vsc_mujoco_grasp_pinch(const mjModel* m, const mjData* d, const vsc_grasper_config* g, int i) {
  if (g->actuator_count[i] == 0) return -1.0;
  int joint = g->joint[i];
  double squeeze = 0.0;  // generalized force towards lower positions (N m or N)
  for (int k = 0; k < g->actuator_count[i]; ++k) {
    int a = g->actuator[i][k];
    double gear = m->actuator_gear[6 * a];
    double input = d->ctrl[a];
    if (m->actuator_dyntype[a] != mjDYN_NONE) {
      input = d->act[m->actuator_actadr[a] + m->actuator_actnum[a] - 1];
    } else if (m->actuator_ctrllimited[a]) {
      double low = m->actuator_ctrlrange[2 * a], high = m->actuator_ctrlrange[2 * a + 1];
      input = input < low ? low : (input > high ? high : input);
    }
    const mjtNum* bias = m->actuator_biasprm + mjNBIAS * a;
    double force = m->actuator_gainprm[mjNGAIN * a] * input;
    if (m->actuator_biastype[a] == mjBIAS_AFFINE) force += bias[0] + bias[1] * gear * g->closed_below;
    if (m->actuator_forcelimited[a]) {
      double low = m->actuator_forcerange[2 * a], high = m->actuator_forcerange[2 * a + 1];
      force = force < low ? low : (force > high ? high : force);
    }
    squeeze -= gear * force;
  }
  if (squeeze <= 0.0) return 0.0;
  if (m->jnt_type[joint] != mjJNT_HINGE) return squeeze;
  double lever = g->lever;
  if (lever <= 0.0) {  // the hinge axis's distance to the site: both move with the tool, so each step
    const mjtNum* anchor = d->xanchor + 3 * joint;
    const mjtNum* axis = d->xaxis + 3 * joint;
    const mjtNum* site = d->site_xpos + 3 * g->site[i];
    double r[3] = {site[0] - anchor[0], site[1] - anchor[1], site[2] - anchor[2]};
    double along = r[0] * axis[0] + r[1] * axis[1] + r[2] * axis[2];
    double across[3] = {r[0] - along * axis[0], r[1] - along * axis[1], r[2] - along * axis[2]};
    lever = sqrt(across[0] * across[0] + across[1] * across[1] + across[2] * across[2]);
    if (lever < VSC_MIN_LEVER_M) lever = VSC_MIN_LEVER_M;
  }
  return squeeze / lever;
}

double vsc_mujoco_grasp_slip_pull(const vsc_grasper_config* g, double pinch) {
  if (pinch < 0.0) return g->slip_force;
  double friction_limit = 2.0 * g->friction * pinch;  // two jaw faces
  return friction_limit < g->slip_force ? friction_limit : g->slip_force;
}

// Jaws take and lose their hold: a closing jaw (open, now at or below
// closed_below) holds the axis point nearest its site if within reach, else it
// stays closed empty; an opening jaw lets go (see grasps.h).
int vsc_mujoco_holds_update(const mjModel* m, mjData* d, const vsc_grasper_config* g, vsc_rod* rod, const mjtNum* q,
                            mjtNum* grasp_state, vsc_mujoco_holds* out) {
  int holds = 0;
  for (int i = 0; i < g->count; ++i) {
    mjtNum* st = grasp_state + VSC_GRASP_STATE_SIZE * i;
    int site = g->site[i];
    const mjtNum* origin = d->site_xpos + 3 * site;
    const mjtNum* rotation = d->site_xmat + 9 * site;  // site to world, row major
    int closed = d->qpos[m->jnt_qposadr[g->joint[i]]] <= g->closed_below;
    if (!closed) {
      st[0] = VSC_GRASP_OPEN;
      continue;
    }
    if (st[0] == VSC_GRASP_OPEN) {  // closing now: take the nearest axis point within reach
      double s, point[3];
      double distance = vsc_rod_nearest_abscissa(rod, q, origin, &s);
      st[0] = VSC_GRASP_CLOSED_EMPTY;
      if (distance <= g->reach) {
        vsc_basis basis = vsc_spline_basis(vsc_rod_control_count(rod), s);
        vsc_basis_point(&basis, q, point);
        double offset[3] = {point[0] - origin[0], point[1] - origin[1], point[2] - origin[2]};
        st[0] = VSC_GRASP_HOLDING;
        st[1] = s;
        for (int a = 0; a < 3; ++a)  // world offset into the site frame: R^T offset
          st[2 + a] = rotation[a] * offset[0] + rotation[3 + a] * offset[1] + rotation[6 + a] * offset[2];
      }
    }
    if (st[0] != VSC_GRASP_HOLDING) continue;
    vsc_grasp* hold = &out->grasps[holds];
    out->owner[holds++] = i;
    hold->abscissa = st[1] < 0.0 ? 0.0 : (st[1] > 1.0 ? 1.0 : st[1]);
    mjtNum arm[3], velocity[6];
    mju_mulMatVec3(arm, rotation, st + 2);
    mj_objectVelocity(m, d, mjOBJ_SITE, site, velocity, 0);  // rotation, translation; world frame
    for (int a = 0; a < 3; ++a) hold->anchor[a] = origin[a] + arm[a];
    hold->anchor_velocity[0] = velocity[3] + velocity[1] * arm[2] - velocity[2] * arm[1];
    hold->anchor_velocity[1] = velocity[4] + velocity[2] * arm[0] - velocity[0] * arm[2];
    hold->anchor_velocity[2] = velocity[5] + velocity[0] * arm[1] - velocity[1] * arm[0];
    out->pinch[holds - 1] = vsc_mujoco_grasp_pinch(m, d, g, i);
    out->slip_at[holds - 1] = vsc_mujoco_grasp_slip_pull(g, out->pinch[holds - 1]);
    hold->stiffness = g->stiffness;
    hold->damping = g->damping;
  }
  out->count = holds;
  return holds;
}

// After the step: reactions to the jaws; tearing out past slip_force, sliding
// past the jaws' friction (see grasps.h).
void vsc_mujoco_holds_release(const mjModel* m, const mjData* d, const vsc_grasper_config* g,
                              const vsc_mujoco_holds* holds, int n, const mjtNum* q, mjtNum* grasp_state,
                              mjtNum* wrench) {
  for (int h = 0; h < holds->count; ++h) {
    const vsc_grasp* hold = &holds->grasps[h];
    int i = holds->owner[h], body = m->site_bodyid[g->site[i]];
    const double* f = holds->reaction + 3 * h;
    if (!(isfinite(f[0]) && isfinite(f[1]) && isfinite(f[2]))) continue;  // never hand MuJoCo a NaN
    const mjtNum* com = d->xipos + 3 * body;
    double arm[3] = {hold->anchor[0] - com[0], hold->anchor[1] - com[1], hold->anchor[2] - com[2]};
    vsc_wrench_add(wrench + 6 * body, 1.0, f, NULL, arm);
    double limit = holds->slip_at[h];
    if (f[0] * f[0] + f[1] * f[1] + f[2] * f[2] <= limit * limit) continue;
    mjtNum* st = grasp_state + VSC_GRASP_STATE_SIZE * i;
    if (limit >= g->slip_force) {  // past the cap: torn out of the jaw
      st[0] = VSC_GRASP_CLOSED_EMPTY;
      st[5] += 1.0;
      continue;
    }
    // past the friction: the spring's stretch delta = anchor - P(s) is cut back to the friction
    // limit, k |delta| = limit, by moving the held point in the site's frame (the tissue slides)
    double point[3], delta[3];
    vsc_basis basis = vsc_spline_basis(n, hold->abscissa);
    vsc_basis_point(&basis, q, point);
    for (int a = 0; a < 3; ++a) delta[a] = hold->anchor[a] - point[a];
    double stretch = sqrt(delta[0] * delta[0] + delta[1] * delta[1] + delta[2] * delta[2]);
    double allowed = hold->stiffness > 0.0 ? limit / hold->stiffness : 0.0;
    if (stretch > allowed) {
      const mjtNum* origin = d->site_xpos + 3 * g->site[i];
      const mjtNum* rotation = d->site_xmat + 9 * g->site[i];
      double scale = allowed / stretch, offset[3];
      for (int a = 0; a < 3; ++a) offset[a] = point[a] + scale * delta[a] - origin[a];
      for (int a = 0; a < 3; ++a)  // world offset into the site frame: R^T offset
        st[2 + a] = rotation[a] * offset[0] + rotation[3 + a] * offset[1] + rotation[6 + a] * offset[2];
    }
    if (st[2] * st[2] + st[3] * st[3] + st[4] * st[4] > g->reach * g->reach) {  // slid out of the jaws
      st[0] = VSC_GRASP_CLOSED_EMPTY;
      st[5] += 1.0;
    }
  }
}
