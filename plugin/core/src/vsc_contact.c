// Sphere-geom penalty contacts. The broad phase rejects geoms whose bounding
// sphere misses the rod's bounding box; the sphere-grid broad phase of
// section 3.3.1 replaces this loop when self-collision arrives.
#include "viscera/vsc_contact.h"

#include <math.h>

static void bounding_box(const double* xyz, int count, double radius, double lo[3], double hi[3]) {
  for (int c = 0; c < 3; ++c) lo[c] = hi[c] = xyz[c];
  for (int i = 1; i < count; ++i)
    for (int c = 0; c < 3; ++c) {
      double x = xyz[3 * i + c];
      lo[c] = x < lo[c] ? x : lo[c];
      hi[c] = x > hi[c] ? x : hi[c];
    }
  for (int c = 0; c < 3; ++c) { lo[c] -= radius; hi[c] += radius; }
}

static int sphere_meets_box(const double centre[3], double radius, const double lo[3], const double hi[3]) {
  double d2 = 0.0;
  for (int c = 0; c < 3; ++c) {
    double e = centre[c] < lo[c] ? lo[c] - centre[c] : (centre[c] > hi[c] ? centre[c] - hi[c] : 0.0);
    d2 += e * e;
  }
  return d2 <= radius * radius;
}

int vsc_rod_contact_forces(vsc_rod* rod, const vsc_world* world, double* Q, double* geom_wrench) {
  int spheres = rod->def.collision_sphere_count, contacts = 0;
  double r = rod->def.radius, k = rod->def.contact_stiffness, c = rod->def.contact_damping;
  double lo[3], hi[3];
  bounding_box(rod->sphere_xyz, spheres, r, lo, hi);
  for (int g = 0; g < world->geom_count; ++g) {
    const vsc_geom* geom = &world->geoms[g];
    double bound = geom->bound_radius;
    if (bound > 0.0 && !sphere_meets_box(geom->position, bound, lo, hi)) continue;
    for (int i = 0; i < spheres; ++i) {
      const double* x = rod->sphere_xyz + 3 * i;
      if (bound > 0.0) {
        double dx = x[0] - geom->position[0], dy = x[1] - geom->position[1], dz = x[2] - geom->position[2];
        double reach = bound + r;
        if (dx * dx + dy * dy + dz * dz > reach * reach) continue;
      }
      double normal[3];
      double distance = vsc_geom_distance(geom, x, normal);
      double depth = r - distance;
      if (!(depth > 0.0)) continue;
      // contact point on the geom surface, and the relative normal speed there
      double point[3] = {x[0] - distance * normal[0], x[1] - distance * normal[1], x[2] - distance * normal[2]};
      double geom_velocity[3];
      vsc_geom_point_velocity(geom, point, geom_velocity);
      const double* v = rod->sphere_velocity + 3 * i;
      double approach = (v[0] - geom_velocity[0]) * normal[0] + (v[1] - geom_velocity[1]) * normal[1] +
                        (v[2] - geom_velocity[2]) * normal[2];
      double magnitude = k * depth - c * approach;
      if (!(magnitude > 0.0)) continue;  // penalty contacts push, never pull
      double f[3] = {magnitude * normal[0], magnitude * normal[1], magnitude * normal[2]};
      const vsc_basis* b = &rod->sphere_basis[i];
      double* out = Q + 3 * b->first;
      for (int j = 0; j < VSC_SPLINE_SUPPORT; ++j)
        for (int a = 0; a < 3; ++a) out[3 * j + a] += b->weight[j] * f[a];
      if (geom_wrench) {
        double* w = geom_wrench + 6 * g;
        double arm[3] = {point[0] - geom->position[0], point[1] - geom->position[1], point[2] - geom->position[2]};
        w[0] -= f[0];
        w[1] -= f[1];
        w[2] -= f[2];
        w[3] -= arm[1] * f[2] - arm[2] * f[1];
        w[4] -= arm[2] * f[0] - arm[0] * f[2];
        w[5] -= arm[0] * f[1] - arm[1] * f[0];
      }
      ++contacts;
    }
  }
  return contacts;
}
