// RK4 on the first-order system (q, v)' = (v, a(q, v)).
#include "viscera/vsc_integrate.h"

#include "viscera/vsc_contact.h"
#include "viscera/vsc_grasp.h"

#include <math.h>
#include <string.h>

static int state_is_sane(const double* q, const double* v, int size) {
  double limit = VSC_DIVERGED_SPEED;
  for (int i = 0; i < size; ++i)
    if (!isfinite(q[i]) || !(fabs(v[i]) < limit)) return 0;
  return 1;
}

// `world` is this evaluation's copy; its wrench weight is set per stage so the
// stages' reactions add up to their average over the whole step dt.
static vsc_status rk4_substep(vsc_rod* rod, vsc_world* world, double* q, double* v, double h, double dt) {
  double weight = h / (6.0 * dt);
  int size = 3 * rod->n;
  double* q0 = rod->stage;
  double* v0 = q0 + size;
  double* qs = v0 + size;     // stage position
  double* vs = qs + size;     // stage velocity
  double* a = vs + size;      // stage acceleration
  double* dq = a + size;      // weighted sum of position slopes
  double* dv = dq + size;     // weighted sum of velocity slopes
  memcpy(q0, q, sizeof(double) * size);
  memcpy(v0, v, sizeof(double) * size);
  // stage 1 at (q0, v0)
  world->wrench_weight = weight;
  vsc_rod_acceleration(rod, world, q0, v0, a);
  for (int i = 0; i < size; ++i) {
    dq[i] = v0[i];
    dv[i] = a[i];
    qs[i] = q0[i] + 0.5 * h * v0[i];
    vs[i] = v0[i] + 0.5 * h * a[i];
  }
  // stages 2 and 3 at half steps
  static const double next_fraction[2] = {0.5, 1.0};
  world->wrench_weight = 2.0 * weight;
  for (int stage = 0; stage < 2; ++stage) {
    vsc_rod_acceleration(rod, world, qs, vs, a);
    double f = next_fraction[stage] * h;
    for (int i = 0; i < size; ++i) {
      double vi = vs[i];
      dq[i] += 2.0 * vi;
      dv[i] += 2.0 * a[i];
      qs[i] = q0[i] + f * vi;
      vs[i] = v0[i] + f * a[i];
    }
  }
  // stage 4 at the full step
  world->wrench_weight = weight;
  vsc_rod_acceleration(rod, world, qs, vs, a);
  double sixth = h / 6.0;
  for (int i = 0; i < size; ++i) {
    q[i] = q0[i] + sixth * (dq[i] + vs[i]);
    v[i] = v0[i] + sixth * (dv[i] + a[i]);
  }
  if (state_is_sane(q, v, size)) return VSC_OK;
  memcpy(q, q0, sizeof(double) * size);
  memset(v, 0, sizeof(double) * size);
  if (!state_is_sane(q, v, size)) memset(q, 0, sizeof(double) * size);
  return VSC_ERROR_DIVERGED;
}

vsc_status vsc_rod_step(vsc_rod* rod, const vsc_world* world, double* q, double* v, double* stick, double dt,
                        int substeps) {
  if (substeps < 1 || !(dt > 0.0)) return VSC_ERROR_INVALID_ARGUMENT;
  vsc_world stage_world = *world;
  stage_world.stick = stick;
  double h = dt / (double)substeps;
  vsc_status status = VSC_OK;
  for (int i = 0; i < rod->def.pinned_count; ++i) {  // pinned means fixed, whatever the state said
    double* pinned_velocity = v + 3 * rod->pinned[i];
    pinned_velocity[0] = pinned_velocity[1] = pinned_velocity[2] = 0.0;
  }
  for (int s = 0; s < substeps; ++s) {
    vsc_status r = rk4_substep(rod, &stage_world, q, v, h, dt);
    if (r != VSC_OK) {
      status = r;
      if (stick) vsc_stick_clear(stick, rod->def.collision_sphere_count);
      if (world->geom_wrench)  // the failed substeps' forces must not reach the bodies
        memset(world->geom_wrench, 0, sizeof(double) * 6 * (size_t)world->geom_count);
      for (int g = 0; g < world->grasp_count; ++g)
        world->grasps[g].reaction[0] = world->grasps[g].reaction[1] = world->grasps[g].reaction[2] = 0.0;
    } else if (stick) {
      vsc_rod_update_stick(rod, stick, h);  // from the last stage's contacts
    }
  }
  return status;
}
