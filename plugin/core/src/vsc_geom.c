// Exact signed distances to rigid primitives.
#include "viscera/vsc_geom.h"

#include <math.h>

static void to_local(const vsc_geom* g, const double p[3], double l[3]) {
  double d[3] = {p[0] - g->position[0], p[1] - g->position[1], p[2] - g->position[2]};
  const double* R = g->rotation;  // l = R^T d
  l[0] = R[0] * d[0] + R[3] * d[1] + R[6] * d[2];
  l[1] = R[1] * d[0] + R[4] * d[1] + R[7] * d[2];
  l[2] = R[2] * d[0] + R[5] * d[1] + R[8] * d[2];
}

static void to_world_direction(const vsc_geom* g, const double l[3], double w[3]) {
  const double* R = g->rotation;  // w = R l
  w[0] = R[0] * l[0] + R[1] * l[1] + R[2] * l[2];
  w[1] = R[3] * l[0] + R[4] * l[1] + R[5] * l[2];
  w[2] = R[6] * l[0] + R[7] * l[1] + R[8] * l[2];
}

// Distance from the origin-centred sphere of `radius` to local point l.
static double round_distance(const double l[3], double radius, double n[3]) {
  double r = sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
  if (r > 0.0) {
    n[0] = l[0] / r; n[1] = l[1] / r; n[2] = l[2] / r;
  } else {  // at the centre any direction is closest: pick +z
    n[0] = 0.0; n[1] = 0.0; n[2] = 1.0;
  }
  return r - radius;
}

static double cylinder_distance(const double l[3], double radius, double half, double n[3]) {
  double rho = sqrt(l[0] * l[0] + l[1] * l[1]);
  double ex = rho > 0.0 ? l[0] / rho : 1.0, ey = rho > 0.0 ? l[1] / rho : 0.0;
  double dr = rho - radius, dz = fabs(l[2]) - half, sz = l[2] >= 0.0 ? 1.0 : -1.0;
  if (dr <= 0.0 && dz <= 0.0) {  // inside: nearest of the side and the caps
    if (dr > dz) { n[0] = ex; n[1] = ey; n[2] = 0.0; return dr; }
    n[0] = 0.0; n[1] = 0.0; n[2] = sz; return dz;
  }
  double a = dr > 0.0 ? dr : 0.0, b = dz > 0.0 ? dz : 0.0, d = sqrt(a * a + b * b);
  n[0] = ex * a / d; n[1] = ey * a / d; n[2] = sz * b / d;
  return d;
}

static double box_distance(const double l[3], const double h[3], double n[3]) {
  double q[3], outside = 0.0;
  int axis = 0;
  for (int i = 0; i < 3; ++i) {
    q[i] = fabs(l[i]) - h[i];
    if (q[i] > q[axis]) axis = i;
    if (q[i] > 0.0) outside += q[i] * q[i];
  }
  if (outside > 0.0) {
    double d = sqrt(outside);
    for (int i = 0; i < 3; ++i) n[i] = (q[i] > 0.0 ? q[i] : 0.0) * (l[i] >= 0.0 ? 1.0 : -1.0) / d;
    return d;
  }
  n[0] = n[1] = n[2] = 0.0;  // inside: leave through the nearest face
  n[axis] = l[axis] >= 0.0 ? 1.0 : -1.0;
  return q[axis];
}

double vsc_geom_distance(const vsc_geom* g, const double point[3], double normal[3]) {
  double l[3], n[3], d;
  if (g->type == VSC_GEOM_PLANE) {  // the common floor: one dot product with the local z axis
    const double* R = g->rotation;
    normal[0] = R[2];
    normal[1] = R[5];
    normal[2] = R[8];
    return (point[0] - g->position[0]) * R[2] + (point[1] - g->position[1]) * R[5] +
           (point[2] - g->position[2]) * R[8];
  }
  to_local(g, point, l);
  switch (g->type) {
    case VSC_GEOM_PLANE:
      n[0] = 0.0; n[1] = 0.0; n[2] = 1.0;
      d = l[2];
      break;
    case VSC_GEOM_SPHERE:
      d = round_distance(l, g->size[0], n);
      break;
    case VSC_GEOM_CAPSULE: {
      double z = l[2] > g->size[1] ? g->size[1] : (l[2] < -g->size[1] ? -g->size[1] : l[2]);
      double r[3] = {l[0], l[1], l[2] - z};
      d = round_distance(r, g->size[0], n);
      break;
    }
    case VSC_GEOM_CYLINDER:
      d = cylinder_distance(l, g->size[0], g->size[1], n);
      break;
    case VSC_GEOM_BOX:
      d = box_distance(l, g->size, n);
      break;
    default:  // unknown type: never in contact
      normal[0] = 0.0; normal[1] = 0.0; normal[2] = 1.0;
      return INFINITY;
  }
  to_world_direction(g, n, normal);
  return d;
}

void vsc_geom_point_velocity(const vsc_geom* g, const double p[3], double v[3]) {
  if (g->is_static) {
    v[0] = v[1] = v[2] = 0.0;
    return;
  }
  double r[3] = {p[0] - g->position[0], p[1] - g->position[1], p[2] - g->position[2]};
  const double* w = g->angular_velocity;
  v[0] = g->linear_velocity[0] + w[1] * r[2] - w[2] * r[1];
  v[1] = g->linear_velocity[1] + w[2] * r[0] - w[0] * r[2];
  v[2] = g->linear_velocity[2] + w[0] * r[1] - w[1] * r[0];
}
