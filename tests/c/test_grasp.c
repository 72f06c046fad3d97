// Grasps: the nearest axis point, and a rod held by one grasp carries its weight.
#include <stdlib.h>
#include <string.h>

#include "viscera/vsc_grasp.h"
#include "viscera/vsc_integrate.h"
#include "viscera/vsc_layout.h"
#include "vsc_contact_lists.h"
#include "vsc_touch.h"
#include "viscera/viscera.h"
#include "vsc_test.h"

static vsc_rod* straight_rod(int n, double length, double damping, double* q) {
  vsc_rod_def def = vsc_default_rod_def();
  def.control_count = n;
  def.length = length;
  def.damping = damping;
  def.self_collision = 0;
  vsc_rod* rod = NULL;
  ENSURE(vsc_rod_create(&def, &rod) == VSC_OK);
  double start[3] = {0, 0, 0}, direction[3] = {1, 0, 0};
  ENSURE(vsc_layout_line(n, length, start, direction, q) == VSC_OK);
  return rod;
}

// A point beside a straight axis projects onto it exactly.
static void nearest_abscissa_on_a_line(void) {
  double q[3 * 40];
  vsc_rod* rod = straight_rod(40, 2.0, 1.0, q);
  double point[3] = {0.6, 0.05, 0.0}, s = -1;
  double distance = vsc_rod_nearest_abscissa(rod, q, point, &s);
  ENSURE_NEAR(s, 0.3, 1e-12);
  ENSURE_NEAR(distance, 0.05, 1e-12);
  double beyond[3] = {-0.1, 0.0, 0.0};  // past the first end: the end itself
  distance = vsc_rod_nearest_abscissa(rod, q, beyond, &s);
  ENSURE_NEAR(s, 0.0, 1e-12);
  ENSURE_NEAR(distance, 0.1, 1e-12);
  vsc_rod_destroy(rod);
}

// Held at its middle by one grasp, a rod comes to rest hanging from it: the
// anchor then carries the whole weight m g (momentum balance), and the held
// point sits m g / k below the anchor (the spring's static stretch).
// With every integrator: the implicit one's reaction is its linearised force
// at the step end, which must balance the weight as well.
static void a_held_rod_hangs_from_its_grasp(void) {
  for (int t = 0; t < VSC_INTEGRATOR_COUNT; ++t) {  // every integrator, the leapfrog default included
    int n = 40;
    double q[3 * 40], v[3 * 40] = {0};
    vsc_rod* rod = straight_rod(n, 1.0, 4.0, q);
    double weight = rod->def.mass * 9.81;
    vsc_grasp grasp = {0.5, {0.5, 0.0, 0.0}, {0, 0, 0}, 1000.0, 2.0};
    vsc_world world = {{0, 0, -9.81}, NULL, 0};
    world.grasps = &grasp;
    world.grasp_count = 1;
    double reaction[3] = {0, 0, 0};
    vsc_reactions reactions = {NULL, reaction};
    vsc_step_options options = vsc_default_step_options();
    options.integrator = (vsc_integrator)t;
    options.substeps = t == VSC_INTEGRATOR_IMPLICIT ? 1 : 2;
    vsc_status status = VSC_OK;
    for (int step = 0; step < 3000 && status == VSC_OK; ++step)
      status = vsc_rod_step(rod, &world, &reactions, q, v, NULL, NULL, 0.002, &options, NULL);
    printf("  integrator %d: reaction %.5g N, weight %.5g N\n", t, reaction[2], weight);
    ENSURE(status == VSC_OK);
    ENSURE_NEAR(reaction[2], -weight, 0.005 * weight);
    ENSURE_NEAR(reaction[0], 0.0, 0.005 * weight);
    vsc_basis basis = vsc_spline_basis(n, 0.5);
    double held[3];
    vsc_basis_point(&basis, q, held);
    ENSURE_NEAR(grasp.anchor[2] - held[2], weight / grasp.stiffness, 0.01 * weight / grasp.stiffness);
    vsc_rod_destroy(rod);
  }
}

// A grasp whose anchor moves drags the held point along at the anchor's speed.
static void a_moving_anchor_drags_the_point(void) {
  int n = 40;
  double q[3 * 40], v[3 * 40] = {0};
  vsc_rod* rod = straight_rod(n, 1.0, 1.0, q);
  vsc_grasp grasp = {1.0, {1.0, 0.0, 0.0}, {0.0, 0.1, 0.0}, 1000.0, 2.0};
  vsc_world world = {{0, 0, 0}, NULL, 0};
  world.grasps = &grasp;
  world.grasp_count = 1;
  double dt = 0.002;
  for (int step = 0; step < 1000; ++step) {  // 2 s at 0.1 m/s: the end follows 0.2 m sideways
    vsc_step_options options = vsc_default_step_options();
    options.substeps = 2;
    ENSURE(vsc_rod_step(rod, &world, NULL, q, v, NULL, NULL, dt, &options, NULL) == VSC_OK);
    for (int c = 0; c < 3; ++c) grasp.anchor[c] += dt * grasp.anchor_velocity[c];
  }
  double end[3];
  vsc_basis basis = vsc_spline_basis(n, 1.0);
  vsc_basis_point(&basis, q, end);
  ENSURE_NEAR(end[1], grasp.anchor[1], 0.005);  // within the spring's lag
  vsc_basis_point(&basis, v, end);
  ENSURE_NEAR(end[1], 0.1, 0.01);
  vsc_rod_destroy(rod);
}

int main(void) {
  RUN(nearest_abscissa_on_a_line);
  RUN(a_held_rod_hangs_from_its_grasp);
  RUN(a_moving_anchor_drags_the_point);
  TEST_MAIN_END();
}
