// Contacts between intestine instances (see partners.h).
#include "partners.h"

#include <math.h>
#include <string.h>

#include "viscera/vsc_base.h"
#include "viscera/vsc_place.h"

// A rotation (row-major, columns the local axes) whose local z is the unit vector z.
static void frame_along(const double z[3], double rotation[9]) {
  double helper[3] = {1.0, 0.0, 0.0};
  if (fabs(z[0]) > 0.9) helper[0] = 0.0, helper[1] = 1.0;
  double x[3], y[3];
  vsc_cross(helper, z, x);
  double norm = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
  for (int c = 0; c < 3; ++c) x[c] /= norm;
  vsc_cross(z, x, y);
  for (int row = 0; row < 3; ++row) {
    rotation[3 * row] = x[row];
    rotation[3 * row + 1] = y[row];
    rotation[3 * row + 2] = z[row];
  }
}

void vsc_partner_capsules(const vsc_rod* rod, const double* centres, const double* velocities, int spheres,
                          double friction, double ahead, vsc_geom* out) {
  const double *x = centres, *v = velocities;
  const double* radii = vsc_rod_sphere_radii(rod);
  for (int k = 0; k + 1 < spheres; ++k) {
    double radius = 0.5 * (radii[k] + radii[k + 1]);  // a tapered tube's: its mean over the capsule
    const double *va = v + 3 * k, *vb = v + 3 * k + 3;
    double a[3], b[3];
    for (int c = 0; c < 3; ++c) {
      a[c] = x[3 * k + c] + ahead * va[c];
      b[c] = x[3 * k + 3 + c] + ahead * vb[c];
    }
    vsc_geom* g = out + k;
    memset(g, 0, sizeof(*g));
    g->type = VSC_GEOM_CAPSULE;
    double axis[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double length2 = axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2], length = sqrt(length2);
    double unit[3] = {0.0, 0.0, 1.0};
    if (length > 0.0)
      for (int c = 0; c < 3; ++c) unit[c] = axis[c] / length;
    frame_along(unit, g->rotation);
    double spin[3] = {0.0, 0.0, 0.0}, relative[3] = {vb[0] - va[0], vb[1] - va[1], vb[2] - va[2]};
    if (length2 > 0.0) {  // the axis turns at axis x relative / |axis|^2 (its stretch is the capsule's no concern)
      vsc_cross(axis, relative, spin);
      for (int c = 0; c < 3; ++c) spin[c] /= length2;
    }
    for (int c = 0; c < 3; ++c) {
      g->position[c] = 0.5 * (a[c] + b[c]);
      g->linear_velocity[c] = 0.5 * (va[c] + vb[c]);
      g->angular_velocity[c] = spin[c];
      g->box[c] = fmin(a[c], b[c]) - radius;
      g->box[3 + c] = fmax(a[c], b[c]) + radius;
    }
    g->size[0] = radius;
    g->size[1] = 0.5 * length;
    g->bound_radius = 0.5 * length + radius;
    g->friction = friction;
    g->is_static = 0;
  }
}

void vsc_partner_add_load(const vsc_rod* rod, int spheres, const vsc_geom* capsules, const double* wrench,
                          double* load) {
  for (int k = 0; k + 1 < spheres; ++k) {
    const double *f = wrench + 6 * k, *torque = wrench + 6 * k + 3;
    if (f[0] == 0.0 && f[1] == 0.0 && f[2] == 0.0 && torque[0] == 0.0 && torque[1] == 0.0 && torque[2] == 0.0)
      continue;
    // forces f/2 -+ d at the ends -e and +e of the half axis e: e x 2d = the torque across the axis
    double e[3], d[3];
    const double* rotation = capsules[k].rotation;
    for (int c = 0; c < 3; ++c) e[c] = capsules[k].size[1] * rotation[3 * c + 2];
    double e2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
    d[0] = d[1] = d[2] = 0.0;
    if (e2 > 0.0) {
      vsc_cross(torque, e, d);
      for (int c = 0; c < 3; ++c) d[c] /= 2.0 * e2;
    }
    double at_start[3] = {0.5 * f[0] - d[0], 0.5 * f[1] - d[1], 0.5 * f[2] - d[2]};
    double at_end[3] = {0.5 * f[0] + d[0], 0.5 * f[1] + d[1], 0.5 * f[2] + d[2]};
    vsc_rod_add_sphere_force(rod, k, at_start, load);
    vsc_rod_add_sphere_force(rod, k + 1, at_end, load);
  }
}
