// The resolution a tolerance chooses: its shape length, counts and substeps'
// accuracy follow the rule vsc_resolution.h states, and what cannot be met
// says why.
#include <math.h>

#include "viscera/vsc_resolution.h"
#include "vsc_test.h"
#include "vsc_tolerance_table.h"

#define ROWS(table) ((int)(sizeof(table) / sizeof(table[0])))

// A 0.5 m beam of 12.5 mm radius, 0.1 kg/m, EI = 1 N m^2, under gravity, alone: its bending
// length (EI / (mu g))^(1/3) = 1.006 m is longer than it.
static vsc_resolution_request beam(double tolerance) {
  return (vsc_resolution_request){.tolerance = tolerance, .length = 0.5, .radius = 0.0125, .mass_per_length = 0.1,
                                  .bending_rigidity = 1.0, .axial_stiffness = 1e4, .gravity = 9.81,
                                  .contacts = 0, .integrator = VSC_INTEGRATOR_LEAPFROG};
}

// At the chosen resolution the group's envelope is within the tolerance, and
// one segment fewer over the shape length would not be.
static void counts_meet_the_tolerance(void) {
  double lowest = vsc_tolerance_envelope_bending[ROWS(vsc_tolerance_envelope_bending) - 1][1] / VSC_TOLERANCE_MARGIN;
  for (double tolerance = 0.05; tolerance > lowest; tolerance *= 0.7) {
    vsc_resolution r;
    vsc_resolution_request q = beam(tolerance);
    ENSURE(vsc_resolution_choose(&q, &r) == VSC_RESOLUTION_OK);
    ENSURE(r.error_bound <= VSC_TOLERANCE_MARGIN * tolerance * (1 + 1e-9));
    ENSURE_NEAR(r.shape_length, 0.5, 0.0);
    ENSURE(r.control_points >= 4 && r.samples_per_segment == 1);
    ENSURE(r.control_points - 1 >= (int)floor(r.segments_per_shape));
  }
}

// The shape length: the whole length for a rod that touches nothing (its
// loads and supports shape it); where it may touch something, the length it
// folds over: its bending length under gravity, or for springs alone (no
// bending rigidity) a loop of its circumference 2 pi r.
static void shape_length(void) {
  vsc_resolution r;
  vsc_resolution_request q = beam(1e-2);
  q.length = 5.0;  // longer than its bending length
  ENSURE(vsc_resolution_choose(&q, &r) == VSC_RESOLUTION_OK);
  ENSURE_NEAR(r.shape_length, 5.0, 0.0);
  q.contacts = 1;
  ENSURE(vsc_resolution_choose(&q, &r) == VSC_RESOLUTION_OK);
  ENSURE_NEAR(r.shape_length, cbrt(1.0 / (0.1 * 9.81)), 1e-12);
  q.gravity = 0.0;  // weightless: nothing bends it over less than its length
  ENSURE(vsc_resolution_choose(&q, &r) == VSC_RESOLUTION_OK);
  ENSURE_NEAR(r.shape_length, 5.0, 0.0);
  q.bending_rigidity = 0.0;  // springs alone, that can fold onto themselves
  ENSURE(vsc_resolution_choose(&q, &r) == VSC_RESOLUTION_OK);
  ENSURE_NEAR(r.shape_length, 2.0 * VSC_PI * 0.0125, 1e-15);
  int folding_points = r.control_points;
  q.contacts = 0;  // ... or cannot: a catenary's length
  ENSURE(vsc_resolution_choose(&q, &r) == VSC_RESOLUTION_OK);
  ENSURE_NEAR(r.shape_length, 5.0, 0.0);
  ENSURE(folding_points - 1 > 50 * (r.control_points - 1));
}

// Finer tolerances cost more: points, spheres and the substeps' accuracy.
static void finer_costs_more(void) {
  vsc_resolution coarse, fine;
  vsc_resolution_request q = beam(1e-2);
  q.contacts = 1;
  ENSURE(vsc_resolution_choose(&q, &coarse) == VSC_RESOLUTION_OK);
  q.tolerance = 1e-3;
  ENSURE(vsc_resolution_choose(&q, &fine) == VSC_RESOLUTION_OK);
  ENSURE(fine.control_points > coarse.control_points);
  ENSURE(fine.collision_spheres > coarse.collision_spheres);
  ENSURE(vsc_resolution_substeps(&fine, 1e-3) > vsc_resolution_substeps(&coarse, 1e-3));
  // spheres: sagitta d^2 / (8 r) = tolerance r
  double spacing = 0.0125 * sqrt(8e-3);
  ENSURE(fine.collision_spheres == (int)ceil(0.5 / spacing - 1e-9) + 1);
  q.tolerance = 0.5;  // coarse: never wider apart than one radius
  ENSURE(vsc_resolution_choose(&q, &coarse) == VSC_RESOLUTION_OK);
  ENSURE(coarse.collision_spheres == 41);
  q.tolerance = 1e-3;  // nothing to touch: one radius apart
  q.contacts = 0;
  ENSURE(vsc_resolution_choose(&q, &fine) == VSC_RESOLUTION_OK);
  ENSURE(fine.collision_spheres == 41);
}

// The substeps' bound: leapfrog (omega h)^2 / 24, RK4 (omega h)^4 / 120,
// implicit Euler pi omega h, each equal to the tolerance.
static void substep_accuracy(void) {
  vsc_resolution r;
  vsc_resolution_request q = beam(1e-3);
  ENSURE(vsc_resolution_choose(&q, &r) == VSC_RESOLUTION_OK);
  ENSURE_NEAR(r.accuracy_omega_h, sqrt(24e-3), 1e-12);
  double k = 2 * VSC_PI / 0.5;
  ENSURE_NEAR(r.accuracy_frequency, fmax(k * k * sqrt(10.0), k * sqrt(1e5)), 1e-9);
  ENSURE(vsc_resolution_substeps(&r, 1e-3) == ceil(1e-3 * r.accuracy_frequency / r.accuracy_omega_h));
  q.integrator = VSC_INTEGRATOR_RK4;
  ENSURE(vsc_resolution_choose(&q, &r) == VSC_RESOLUTION_OK);
  ENSURE_NEAR(r.accuracy_omega_h, pow(120e-3, 0.25), 1e-12);
  q.integrator = VSC_INTEGRATOR_IMPLICIT;
  ENSURE(vsc_resolution_choose(&q, &r) == VSC_RESOLUTION_OK);
  ENSURE_NEAR(r.accuracy_omega_h, 1e-3 / VSC_PI, 1e-15);
}

// What cannot be met says why, and with the number it would need.
static void limits(void) {
  vsc_resolution r;
  vsc_resolution_request q = beam(1e-6);
  ENSURE(vsc_resolution_choose(&q, &r) == VSC_RESOLUTION_BELOW_FLOOR);
  ENSURE(r.floor == vsc_tolerance_envelope_bending[ROWS(vsc_tolerance_envelope_bending) - 1][1] / VSC_TOLERANCE_MARGIN);
  q = beam(1e-2);
  q.length = 1e5;  // 100 km of bowel
  q.contacts = 1;
  ENSURE(vsc_resolution_choose(&q, &r) == VSC_RESOLUTION_CONTROL_POINTS);
  ENSURE(r.needed_control_points > 1e6 && r.control_points == VSC_MAX_CONTROL_POINTS);
  ENSURE(r.collision_spheres > 0 && r.accuracy_omega_h > 0.0);  // the rest still chosen
  q = beam(1e-2);
  q.radius = 1e-9;  // spheres a nanometre wide on a 0.5 m rod
  ENSURE(vsc_resolution_choose(&q, &r) == VSC_RESOLUTION_COLLISION_SPHERES);
  ENSURE(r.needed_spheres > 1e7 && r.collision_spheres == VSC_MAX_COLLISION_SPHERES);
  q = beam(0.0);
  ENSURE(vsc_resolution_choose(&q, &r) == VSC_RESOLUTION_INVALID);
  q = beam(1e-2);
  q.mass_per_length = NAN;
  ENSURE(vsc_resolution_choose(&q, &r) == VSC_RESOLUTION_INVALID);
}

int main(void) {
  RUN(counts_meet_the_tolerance);
  RUN(shape_length);
  RUN(finer_costs_more);
  RUN(substep_accuracy);
  RUN(limits);
  TEST_MAIN_END();
}
