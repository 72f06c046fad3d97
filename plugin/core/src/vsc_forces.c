// One force evaluation of the rod, top to bottom: place, gravity, elastic
// forces, grasps, contacts; and the accelerations the integrators read.
#include "vsc_forces.h"

#include <stddef.h>
#include <string.h>

#include "viscera/vsc_band.h"
#include "vsc_contact.h"
#include "vsc_elastic.h"
#include "vsc_grasp.h"
#include "vsc_place.h"
#include "vsc_sleep.h"

void vsc_forces_evaluate(const vsc_step_context* context, const double* q, const double* v, double* Q) {
  const vsc_rod* rod = context->rod;
  const vsc_rod_stages* stage = &rod->stages;
  const vsc_world* world = context->world;
  int n = rod->n;
  // place: the contact stages read the spheres (the elastic pass and the Jacobian place their own samples)
  int contacts = world->geom_count > 0 || rod->def.self_collision;
  if (contacts) vsc_place_spheres(rod, q, v, stage->placement);
  for (int k = 0; k < n; ++k) {  // gravity, distributed exactly: Q_k = g sum_j M_kj
    double m = rod->mass_row_sum[k];
    Q[3 * k] = m * world->gravity[0];
    Q[3 * k + 1] = m * world->gravity[1];
    Q[3 * k + 2] = m * world->gravity[2];
  }
  if (world->control_load)
    for (int i = 0; i < 3 * n; ++i) Q[i] += world->control_load[i];
  vsc_elastic_add_forces(rod, stage->elastic, vsc_sleep_points(stage->sleep), q, Q);
  if (world->grasp_count > 0) vsc_rod_add_grasp_forces(context, q, v, Q);
  if (!contacts) {  // no contact looked for: none for friction or sleeping to read
    vsc_contact_forget(stage->contact);
    return;
  }
  // the broad phase, then the narrow phase over its candidates
  int listed = vsc_contact_lists_refresh(rod, stage->broad_phase, stage->placement->sphere_xyz, world);
  vsc_contact_add_forces(context, stage->contact, stage->broad_phase, listed, stage->placement, stage->sleep, Q);
}

void vsc_forces_at_rest(vsc_step_context* context, const double* q, double* Q) {
  const vsc_rod* rod = context->rod;
  const vsc_rod_stages* stage = &rod->stages;
  const vsc_world* world = context->world;
  memset(Q, 0, sizeof(double) * 3 * (size_t)rod->n);
  context->wrench_weight = 1.0;
  context->substep = 0.0;
  if (!(world->geom_count > 0)) {  // sleeping spheres never touch each other
    vsc_contact_forget(stage->contact);
    return;
  }
  vsc_place_spheres(rod, q, NULL, stage->placement);  // held: the spheres' velocities are zero
  memset(stage->placement->sphere_velocity, 0, sizeof(double) * 3 * (size_t)rod->def.collision_sphere_count);
  int listed = vsc_contact_lists_refresh(rod, stage->broad_phase, stage->placement->sphere_xyz, world);
  vsc_contact_add_forces(context, stage->contact, stage->broad_phase, listed, stage->placement, stage->sleep, Q);
}

void vsc_forces_acceleration(const vsc_step_context* context, const double* q, const double* v, double* a) {
  const vsc_rod* rod = context->rod;
  int n = rod->n;
  vsc_forces_evaluate(context, q, v, a);
  for (int k = 0; k < n; ++k)
    if (rod->is_pinned[k]) a[3 * k] = a[3 * k + 1] = a[3 * k + 2] = 0.0;
  if (rod->def.lumped_mass) {  // a diagonal factor: the band solve's off-diagonal terms are all zero
    for (int k = 0; k < n; ++k) {
      double inverse = rod->mass_factor[4 * k + 3];
      a[3 * k] *= inverse;
      a[3 * k + 1] *= inverse;
      a[3 * k + 2] *= inverse;
    }
  } else {
    vsc_band_solve3(rod->mass_factor, n, a);
  }
  // damping force -c M v gives acceleration -c v without a solve
  double c = rod->def.damping;
  for (int i = 0; i < 3 * n; ++i) a[i] -= c * v[i];
  for (int k = 0; k < n; ++k)
    if (rod->is_pinned[k]) a[3 * k] = a[3 * k + 1] = a[3 * k + 2] = 0.0;
  // sleeping points are held like pinned ones, and an edge point's changed load wakes it (vsc_sleep.h)
  if (context->rest) vsc_sleep_hold(rod, rod->stages.sleep, context->rest, a);
}

const vsc_reactions vsc_no_reactions = {NULL, NULL};

// A lone evaluation: no friction state, reactions at full weight.
static vsc_step_context lone(vsc_rod* rod, const vsc_world* world, const vsc_reactions* reactions) {
  vsc_step_context context = {rod, world, reactions ? reactions : &vsc_no_reactions, NULL, 1.0, 1.0, NULL, 0.0,
                               VSC_CONTACT_DAMPING_LIMIT, 0, NULL};
  return context;
}

void vsc_rod_forces(vsc_rod* rod, const vsc_world* world, const vsc_reactions* reactions, const double* q,
                    const double* v, double* Q) {
  vsc_step_context context = lone(rod, world, reactions);
  vsc_forces_evaluate(&context, q, v, Q);
}

void vsc_rod_acceleration(vsc_rod* rod, const vsc_world* world, const vsc_reactions* reactions, const double* q,
                          const double* v, double* a) {
  vsc_step_context context = lone(rod, world, reactions);
  vsc_forces_acceleration(&context, q, v, a);
}
