// One force evaluation of the rod, top to bottom: place, gravity, elastic
// forces, grasps, contacts; and the accelerations the integrators read.
#include "vsc_forces.h"

#include <stddef.h>

#include "viscera/vsc_band.h"
#include "viscera/vsc_sleep.h"
#include "vsc_contact.h"
#include "vsc_elastic.h"
#include "vsc_contact_load.h"
#include "vsc_grasp.h"
#include "vsc_place.h"

void vsc_forces_evaluate(const vsc_step_context* context, const double* q, const double* v, double* Q) {
  vsc_rod* rod = context->rod;
  const vsc_world* world = context->world;
  int n = rod->n;
  // place: every later stage reads the samples or the spheres
  rod->work.touched = world->geom_count > 0 || rod->def.self_collision;
  if (!rod->work.touched) rod->work.found_count = 0;  // no contact found: none for sleeping to read
  vsc_rod_update_samples(rod, q);
  if (rod->work.touched) vsc_rod_update_spheres(rod, q, v);
  for (int k = 0; k < n; ++k) {  // gravity, distributed exactly: Q_k = g sum_j M_kj
    double m = rod->mass_row_sum[k];
    Q[3 * k] = m * world->gravity[0];
    Q[3 * k + 1] = m * world->gravity[1];
    Q[3 * k + 2] = m * world->gravity[2];
  }
  if (world->control_load)
    for (int i = 0; i < 3 * n; ++i) Q[i] += world->control_load[i];
  vsc_rod_add_elastic_forces(rod, q, Q);
  if (world->grasp_count > 0) vsc_rod_add_grasp_forces(context, q, v, Q);
  if (rod->work.touched) vsc_rod_add_contact_forces(context, Q);
}

void vsc_forces_acceleration(const vsc_step_context* context, const double* q, const double* v, double* a) {
  vsc_rod* rod = context->rod;
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
  if (rod->work.asleep_count > 0) {  // sleeping points are held like pinned ones (vsc_sleep.h) ...
    const double limit2 = VSC_SLEEP_WAKE_ACCELERATION * VSC_SLEEP_WAKE_ACCELERATION;
    for (int k = 0; k < n; ++k) {
      if (!rod->work.asleep[k]) continue;
      double* ak = a + 3 * k;
      if (rod->work.asleep[k] == VSC_ASLEEP_EDGE) {  // ... and one next to awake points wakes when its forces change
        double* record = rod->work.rest + VSC_REST_SIZE * k;
        double* load = record + VSC_REST_LOAD;
        if (record[VSC_REST_WATCHED] == 0.0) {
          load[0] = ak[0];
          load[1] = ak[1];
          load[2] = ak[2];
          record[VSC_REST_WATCHED] = 1.0;
        }
        double d0 = ak[0] - load[0], d1 = ak[1] - load[1], d2 = ak[2] - load[2];
        if (d0 * d0 + d1 * d1 + d2 * d2 > limit2) rod->work.unbalanced[k] = 1;
      }
      ak[0] = ak[1] = ak[2] = 0.0;
    }
  }
}

const vsc_reactions vsc_no_reactions = {NULL, NULL};

// A lone evaluation: no friction state, reactions at full weight.
static vsc_step_context lone(vsc_rod* rod, const vsc_world* world, const vsc_reactions* reactions) {
  vsc_step_context context = {rod, world, reactions ? reactions : &vsc_no_reactions, NULL, 1.0, 1.0, NULL, 0.0,
                               VSC_CONTACT_DAMPING_LIMIT, 0};
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
