// Grasp springs and the nearest axis point (see viscera/vsc_grasp.h).
#include "vsc_grasp.h"

#include <math.h>

#include "vsc_place.h"

void vsc_rod_add_grasp_forces(const vsc_step_context* context, const double* q, const double* v, double* Q) {
  const vsc_rod* rod = context->rod;
  const vsc_world* world = context->world;
  double* reaction = context->reactions->grasp_force;
  for (int g = 0; g < world->grasp_count; ++g) {
    const vsc_grasp* grasp = &world->grasps[g];
    vsc_basis basis = vsc_spline_basis(rod->n, grasp->abscissa);
    double position[3], velocity[3], force[3];
    vsc_basis_point(&basis, q, position);
    vsc_basis_point(&basis, v, velocity);
    for (int c = 0; c < 3; ++c) {
      force[c] = grasp->stiffness * (grasp->anchor[c] - position[c]) +
                 grasp->damping * (grasp->anchor_velocity[c] - velocity[c]);
      if (reaction) reaction[3 * g + c] -= context->wrench_weight * force[c];
    }
    for (int j = 0; j < VSC_SPLINE_SUPPORT; ++j)
      for (int c = 0; c < 3; ++c) Q[3 * (basis.first + j) + c] += basis.weight[j] * force[c];
  }
}

double vsc_rod_nearest_abscissa(const vsc_rod* rod, const double* q, const double point[3], double* abscissa) {
  int N = rod->sample_count;
  double best = INFINITY, best_s = 0.0, next[3];
  vsc_rod_sample_point(rod, q, 0, next);
  for (int a = 0; a + 1 < N; ++a) {
    double here[3] = {next[0], next[1], next[2]};
    vsc_rod_sample_point(rod, q, a + 1, next);
    double e[3] = {next[0] - here[0], next[1] - here[1], next[2] - here[2]};
    double w[3] = {point[0] - here[0], point[1] - here[1], point[2] - here[2]};
    double ee = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
    double t = ee > 0.0 ? (w[0] * e[0] + w[1] * e[1] + w[2] * e[2]) / ee : 0.0;
    t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
    double d[3] = {w[0] - t * e[0], w[1] - t * e[1], w[2] - t * e[2]};
    double distance2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    if (distance2 < best) {
      best = distance2;
      best_s = ((double)a + t) / (double)(N - 1);
    }
  }
  *abscissa = best_s;
  return sqrt(best);
}
