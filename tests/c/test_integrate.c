// RK4: energy conservation, fourth-order convergence, and the divergence guard.
#include <stdlib.h>
#include <string.h>

#include "viscera/vsc_integrate.h"
#include "viscera/vsc_layout.h"
#include "vsc_test.h"

// A stretched and bent intestine, released without gravity or damping.
static vsc_rod* released(double* q, double* v) {
  vsc_rod_def def = vsc_default_rod_def();
  def.damping = 0.0;
  def.self_collision = 0;  // the loop overlaps itself: test the rod alone
  vsc_rod* rod = NULL;
  ENSURE(vsc_rod_create(&def, &rod) == VSC_OK);
  int n = def.control_count;
  for (int k = 0; k < n; ++k) {
    double t = 1.02 * def.length * k / (n - 1);  // arc length: 2 % stretched
    q[3 * k] = 0.5 * cos(t / 0.5);                // bent on a 0.5 m circle
    q[3 * k + 1] = 0.5 * sin(t / 0.5);
    q[3 * k + 2] = 0.0;
  }
  memset(v, 0, sizeof(double) * 3 * n);
  return rod;
}

static double total_energy(vsc_rod* rod, const double* q, const double* v) {
  return vsc_rod_elastic_energy(rod, q) + vsc_rod_kinetic_energy(rod, v);
}

// Relative energy change over 1 s of 2 ms steps split into `substeps`.
static double drift_over_one_second(int substeps) {
  double q[750], v[750];
  vsc_rod* rod = released(q, v);
  vsc_world world = {{0, 0, 0}, NULL, 0};
  double e0 = total_energy(rod, q, v), peak_kinetic = 0;
  vsc_status status = VSC_OK;
  for (int step = 0; step < 500 && status == VSC_OK; ++step) {
    status = vsc_rod_step(rod, &world, q, v, NULL, 0.002, substeps);
    double k = vsc_rod_kinetic_energy(rod, v);
    peak_kinetic = k > peak_kinetic ? k : peak_kinetic;
  }
  ENSURE(status == VSC_OK);
  ENSURE(peak_kinetic > 0.1 * e0);  // energy did move between elastic and kinetic
  double drift = (total_energy(rod, q, v) - e0) / e0;
  printf("  %2d substeps (h = %.3g ms): energy drift over 1 s %.3g\n", substeps, 2.0 / substeps, drift);
  vsc_rod_destroy(rod);
  return drift;
}

// The forces are exact gradients, so energy is conserved up to RK4's error:
// under 1e-5 once the released motion is resolved, falling at fourth order or
// faster. At the default 1 ms substep RK4 damps the modes near its stability
// limit (|R(i w h)|^2 ~ 1 - (w h)^6 / 72): energy may only be lost, never gained.
static void energy_is_conserved(void) {
  double coarse = drift_over_one_second(2);
  double fine = drift_over_one_second(32), finer = drift_over_one_second(64);
  ENSURE(coarse < 0.0 && coarse > -0.9);
  ENSURE(fabs(finer) < 1e-5);
  ENSURE(fabs(fine) / fabs(finer) > 16.0);
}

// Halving the step divides the error at t = 20 ms by about 2^4 = 16 (a short
// horizon: the released rod buckles, and chaos would amplify any error).
static void converges_at_fourth_order(void) {
  double q0[750], v0[750], ref_q[750], ref_v[750], q[750], v[750];
  vsc_rod* rod = released(q0, v0);
  vsc_world world = {{0, 0, -9.81}, NULL, 0};
  memcpy(ref_q, q0, sizeof(q0)); memcpy(ref_v, v0, sizeof(v0));
  vsc_rod_step(rod, &world, ref_q, ref_v, NULL, 0.02, 1280);
  double error[3];
  int substeps[3] = {40, 80, 160};
  for (int i = 0; i < 3; ++i) {
    memcpy(q, q0, sizeof(q0)); memcpy(v, v0, sizeof(v0));
    vsc_rod_step(rod, &world, q, v, NULL, 0.02, substeps[i]);
    error[i] = 0;
    for (int j = 0; j < 750; ++j) error[i] = fmax(error[i], fabs(q[j] - ref_q[j]));
  }
  double order = log2(error[1] / error[2]);
  printf("  errors %.3g %.3g %.3g, observed order %.2f\n", error[0], error[1], error[2], order);
  ENSURE(order > 3.5 && order < 4.5);
  vsc_rod_destroy(rod);
}

static void divergence_keeps_state_finite(void) {
  double q[750], v[750];
  vsc_rod* rod = released(q, v);
  rod->stretch_spring *= 1e6;  // far beyond the explicit stability limit
  vsc_world world = {{0, 0, 0}, NULL, 0};
  vsc_status status = VSC_OK;
  for (int step = 0; step < 50 && status == VSC_OK; ++step) status = vsc_rod_step(rod, &world, q, v, NULL, 0.002, 1);
  ENSURE(status == VSC_ERROR_DIVERGED);
  for (int i = 0; i < 750; ++i) ENSURE(isfinite(q[i]) && v[i] == 0.0);
  vsc_rod_destroy(rod);
}

int main(void) {
  RUN(energy_is_conserved);
  RUN(converges_at_fourth_order);
  RUN(divergence_keeps_state_finite);
  TEST_MAIN_END();
}
