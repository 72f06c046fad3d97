// Placement: the sample points and collision spheres from the control points,
// the first stage of every evaluation (see viscera/vsc_place.h).
#include "vsc_place.h"

void vsc_place_samples(const vsc_rod* rod, const double* q, double* x, double* y, double* z) {
  for (int a = 0; a < rod->sample_count; ++a) {
    const vsc_basis* b = &rod->sample_basis[a];
    const double* p = q + 3 * b->first;
    double w0 = b->weight[0], w1 = b->weight[1], w2 = b->weight[2], w3 = b->weight[3];
    x[a] = w0 * p[0] + w1 * p[3] + w2 * p[6] + w3 * p[9];
    y[a] = w0 * p[1] + w1 * p[4] + w2 * p[7] + w3 * p[10];
    z[a] = w0 * p[2] + w1 * p[5] + w2 * p[8] + w3 * p[11];
  }
}

void vsc_rod_sphere_points(const vsc_rod* rod, const double* q, const double* v, double* centres, double* velocities) {
  int spheres = rod->def.collision_sphere_count;
  for (int i = 0; i < spheres; ++i) {
    vsc_basis_point(&rod->sphere_basis[i], q, centres + 3 * i);
    if (v) vsc_basis_point(&rod->sphere_basis[i], v, velocities + 3 * i);
  }
}

void vsc_place_spheres(const vsc_rod* rod, const double* q, const double* v, vsc_placement* placement) {
  vsc_rod_sphere_points(rod, q, v, placement->sphere_xyz, placement->sphere_velocity);
}

void vsc_rod_sample_point(const vsc_rod* rod, const double* q, int a, double out[3]) {
  // as vsc_place_samples, the same bits
  const vsc_basis* b = &rod->sample_basis[a];
  const double* p = q + 3 * b->first;
  double w0 = b->weight[0], w1 = b->weight[1], w2 = b->weight[2], w3 = b->weight[3];
  for (int c = 0; c < 3; ++c) out[c] = w0 * p[c] + w1 * p[3 + c] + w2 * p[6 + c] + w3 * p[9 + c];
}

void vsc_rod_add_sphere_force(const vsc_rod* rod, int sphere, const double f[3], double* Q) {
  vsc_place_add_at_sphere(rod, sphere, f, Q);
}
