// Band force Jacobians against central differences of the forces, and their
// positive semi-definiteness where the exact Hessian is indefinite.
#include <stdlib.h>
#include <string.h>

#include "viscera/vsc_band.h"
#include "viscera/vsc_grasp.h"
#include "viscera/vsc_jacobian.h"
#include "vsc_contact_lists.h"
#include "vsc_touch.h"
#include "viscera/viscera.h"
#include "vsc_test.h"

enum { N_POINTS = 8, SIZE = 3 * N_POINTS };

static vsc_rod* small_rod(double rigidity, int clamped, double radius_end) {
  vsc_rod_def def = vsc_default_rod_def();
  def.radius_end = radius_end;  // 0: untapered
  def.wall_thickness = 0.002;
  def.control_count = N_POINTS;
  def.length = 0.5;
  def.mass = 0.05;
  def.stretch_stiffness = 40.0;
  def.bend_stiffness = 4.0;
  def.global_stretch_stiffness = 100.0;
  def.bending_rigidity = rigidity;
  def.self_collision = 0;
  def.collision_sphere_count = 20;
  def.mesentery_points = 2;
  def.mesentery_stiffness = 30.0;
  def.mesentery_length = 0.05;
  double root[6] = {0.0, 0.0, 0.2, 0.5, 0.0, 0.2};  // 0.2 m above: both tethers taut
  memcpy(def.mesentery_root, root, sizeof(root));
  if (clamped) {
    def.clamp_start = def.clamp_end = 1;
    def.clamp_direction_start[0] = def.clamp_direction_end[0] = 1.0;
  }
  vsc_rod* rod = NULL;
  ENSURE(vsc_rod_create(&def, &rod) == VSC_OK);
  return rod;
}

// Dense K (or D) from the band plus the global term's rank one part.
static void dense_jacobian(vsc_rod* rod, const vsc_world* world, const double* q, double stiffness, double damping,
                           double* dense) {
  int w = rod->jacobian_half_width;
  double* band = calloc((size_t)SIZE * (w + 1), sizeof(double));
  double gradient[SIZE];
  double* forces = malloc(sizeof(double) * SIZE);
  vsc_rod_forces(rod, world, NULL, q, q, forces);  // touch records (none here)
  vsc_rod_add_jacobian(rod, world, q, stiffness, damping, band, gradient);
  for (int i = 0; i < SIZE; ++i)
    for (int j = 0; j < SIZE; ++j) {
      int r = i > j ? i : j, c = i > j ? j : i;
      dense[SIZE * i + j] = r - c <= w ? band[(w + 1) * r + w + c - r] : 0.0;
      dense[SIZE * i + j] += stiffness * rod->def.global_stretch_stiffness * gradient[i] * gradient[j];
    }
  free(band);
  free(forces);
}

// -dQ/dq (or -dQ/dv) by central differences, column by column.
static void differenced(vsc_rod* rod, const vsc_world* world, const double* q, const double* v, int by_velocity,
                        double* dense) {
  double plus[SIZE], minus[SIZE], x[SIZE], y[SIZE], eps = 1e-6;
  for (int j = 0; j < SIZE; ++j) {
    memcpy(x, q, sizeof(x));
    memcpy(y, v, sizeof(y));
    double* moved = by_velocity ? y : x;
    moved[j] += eps;
    vsc_rod_forces(rod, world, NULL, x, y, plus);
    moved[j] -= 2.0 * eps;
    vsc_rod_forces(rod, world, NULL, x, y, minus);
    for (int i = 0; i < SIZE; ++i) dense[SIZE * i + j] = -(plus[i] - minus[i]) / (2.0 * eps);
  }
}

static double largest(const double* a) {
  double m = 0.0;
  for (int i = 0; i < SIZE * SIZE; ++i) m = fabs(a[i]) > m ? fabs(a[i]) : m;
  return m;
}

static void compare(const double* analytic, const double* numeric, double relative) {
  double scale = largest(numeric), worst = 0.0;
  for (int i = 0; i < SIZE * SIZE; ++i) worst = fabs(analytic[i] - numeric[i]) > worst ? fabs(analytic[i] - numeric[i]) : worst;
  printf("  largest entry %.4g, largest difference %.3g\n", scale, worst);
  ENSURE(scale > 0.0);
  ENSURE(worst <= relative * scale);
}

// A 2 % stretched straight axis with a small transverse bow: every spring is in
// tension, so the spring Hessians are exact; the Gauss-Newton curvature term is
// exact on the straight axis and off by the bow's angle squared here.
static void stiffness_matches_differences(void) {
  double rigidities[3] = {0.0, 1e-3, 1e-3}, radius_end[3] = {0.0, 0.0, 0.006};  // the third tapers
  for (int t = 0; t < 3; ++t) {
    vsc_rod* rod = small_rod(rigidities[t], t >= 1, radius_end[t]);
    double q[SIZE], v[SIZE] = {0};
    for (int k = 0; k < N_POINTS; ++k) {
      double s = (double)k / (N_POINTS - 1);
      q[3 * k] = 1.02 * 0.5 * s;
      q[3 * k + 1] = t == 0 ? 0.03 * sin(3.14159 * s) : 0.0;
      q[3 * k + 2] = 0.0;
    }
    vsc_grasp grasp = {0.37, {0.2, 0.01, 0.02}, {0, 0, 0}, 500.0, 3.0};
    vsc_world world = {{0, 0, -9.81}, NULL, 0};
    world.grasps = &grasp;
    world.grasp_count = 1;
    double *analytic = malloc(sizeof(double) * SIZE * SIZE), *numeric = malloc(sizeof(double) * SIZE * SIZE);
    dense_jacobian(rod, &world, q, 1.0, 0.0, analytic);
    differenced(rod, &world, q, v, 0, numeric);
    compare(analytic, numeric, 1e-6);
    dense_jacobian(rod, &world, q, 0.0, 1.0, analytic);
    differenced(rod, &world, q, v, 1, numeric);
    compare(analytic, numeric, 1e-6);
    free(analytic);
    free(numeric);
    vsc_rod_destroy(rod);
  }
}

// On a crumpled axis (compressed springs, sharp angles) the exact Hessian is
// indefinite; the band Jacobian must still make M + K positive definite, for
// every weight, or the implicit step could not be solved.
static void stiffness_is_semidefinite(void) {
  vsc_rod* rod = small_rod(1e-2, 0, 0.0);
  unsigned seed = 3;
  double q[SIZE];
  for (int trial = 0; trial < 20; ++trial) {
    for (int k = 0; k < N_POINTS; ++k)
      for (int c = 0; c < 3; ++c) q[3 * k + c] = 0.05 * vsc_test_random(&seed) + (c == 0 ? 0.03 * k : 0.0);
    vsc_world world = {{0, 0, 0}, NULL, 0};
    int w = rod->jacobian_half_width;
    double* band = calloc((size_t)SIZE * (w + 1), sizeof(double));
    double row[64];
    double forces[SIZE];
    vsc_rod_forces(rod, &world, NULL, q, q, forces);
    vsc_rod_add_mass(rod, 1e-9, band);  // K alone, nudged off singular (rigid motions)
    vsc_rod_add_jacobian(rod, &world, q, 1e6, 0.0, band, NULL);
    ENSURE(vsc_band_wide_factor(band, SIZE, w, row) == VSC_OK);
    free(band);
  }
  vsc_rod_destroy(rod);
}

int main(void) {
  RUN(stiffness_matches_differences);
  RUN(stiffness_is_semidefinite);
  TEST_MAIN_END();
}
