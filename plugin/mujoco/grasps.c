// The graspers' jaws on the intestine (see grasps.h).
#include "grasps.h"

#include <math.h>

#include "viscera/vsc_geom.h"
#include "viscera/vsc_spline.h"

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
    hold->stiffness = g->stiffness;
    hold->damping = g->damping;
    hold->reaction[0] = hold->reaction[1] = hold->reaction[2] = 0.0;
  }
  out->count = holds;
  return holds;
}

// After the step: each hold's reaction goes to its jaw's body (force at the
// anchor); a hold that pulled harder than slip_force slips out of the jaw
// (the jaw stays closed empty until it opens).
void vsc_mujoco_holds_release(const mjModel* m, const mjData* d, const vsc_grasper_config* g,
                              const vsc_mujoco_holds* holds, mjtNum* grasp_state, mjtNum* wrench) {
  for (int h = 0; h < holds->count; ++h) {
    const vsc_grasp* hold = &holds->grasps[h];
    int i = holds->owner[h], body = m->site_bodyid[g->site[i]];
    const double* f = hold->reaction;
    if (!(isfinite(f[0]) && isfinite(f[1]) && isfinite(f[2]))) continue;  // never hand MuJoCo a NaN
    const mjtNum* com = d->xipos + 3 * body;
    double arm[3] = {hold->anchor[0] - com[0], hold->anchor[1] - com[1], hold->anchor[2] - com[2]};
    vsc_wrench_add(wrench + 6 * body, 1.0, f, NULL, arm);
    if (f[0] * f[0] + f[1] * f[1] + f[2] * f[2] > g->slip_force * g->slip_force) {
      mjtNum* st = grasp_state + VSC_GRASP_STATE_SIZE * i;
      st[0] = VSC_GRASP_CLOSED_EMPTY;
      st[5] += 1.0;
    }
  }
}
