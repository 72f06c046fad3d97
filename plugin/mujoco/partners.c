// Contacts between intestine instances (see partners.h): the capsules, the loads, and
// the exchange between instances, gathered before a step and scattered after it.
#include "partners.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "viscera/vsc_base.h"
#include "viscera/vsc_contact.h"
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

int vsc_partners_create(vsc_partner_exchange* x, int instances, int control_count, int spheres) {
  memset(x, 0, sizeof(*x));
  x->instances = instances > 0 ? instances : 1;
  x->load = (double*)calloc(3 * (size_t)control_count, sizeof(double));
  x->pressed_by_several = (unsigned char*)calloc((size_t)spheres, 1);
  return x->load && x->pressed_by_several ? 0 : -1;
}

void vsc_partners_free(vsc_partner_exchange* x) {
  free(x->partners);
  free(x->centres);
  free(x->velocities);
  free(x->handed_offset);
  free(x->handed);
  free(x->handed_any);
  free(x->pressed_offset);
  free(x->pressed);
  free(x->waking_speed);
  free(x->all_geoms);
  free(x->all_wrench);
  free(x->load);
  free(x->pressed_by_several);
  memset(x, 0, sizeof(*x));
}

void vsc_partners_clear_handed(vsc_partner_exchange* x) {
  if (x->handed_any) memset(x->handed_any, 0, (size_t)x->instances);
}

// 1 if a view's 'exclude' names instance `other`.
static int excludes(const vsc_partner_view* view, int other) {
  for (int i = 0; i < view->exclude_count; ++i)
    if (view->exclude[i] == other) return 1;
  return 0;
}

int vsc_partners_find(vsc_partner_exchange* x, vsc_partner_viewer view, void* host, int self,
                      const vsc_partner_view* own, int geom_count) {
  x->known = 1;
  int instances = x->instances;
  x->partners = (int*)malloc(sizeof(int) * (size_t)instances);
  x->handed_offset = (int*)malloc(sizeof(int) * (size_t)instances);
  x->handed_any = (unsigned char*)calloc((size_t)instances, 1);
  x->pressed_offset = (int*)malloc(sizeof(int) * (size_t)instances);
  x->waking_speed = (double*)calloc((size_t)instances, sizeof(double));
  if (!x->partners || !x->handed_offset || !x->handed_any || !x->pressed_offset || !x->waking_speed) return -1;
  size_t handed = 0;
  for (int j = 0; j < instances; ++j) {
    x->handed_offset[j] = -1;
    x->pressed_offset[j] = x->geoms;
    if (j <= self) continue;
    vsc_partner_view other = view(host, j, 1);
    if (!other.rod || excludes(own, j) || excludes(&other, self)) continue;
    x->partners[x->count++] = j;
    x->geoms += other.spheres - 1;
    x->most_spheres = other.spheres > x->most_spheres ? other.spheres : x->most_spheres;
    x->handed_offset[j] = (int)handed;
    handed += 3 * (size_t)other.control_count;
    x->waking_speed[j] = VSC_SLEEP_GEOM_SPEED_SHARE * other.sleep->rest_speed;
  }
  if (x->count == 0) return 0;
  size_t total = (size_t)geom_count + (size_t)x->geoms;
  x->all_geoms = (vsc_geom*)calloc(total, sizeof(vsc_geom));
  x->all_wrench = (double*)calloc(6 * total, sizeof(double));
  x->centres = (double*)malloc(sizeof(double) * 3 * (size_t)x->most_spheres);
  x->velocities = (double*)malloc(sizeof(double) * 3 * (size_t)x->most_spheres);
  x->handed = (double*)calloc(handed, sizeof(double));
  x->pressed = (unsigned char*)calloc((size_t)x->geoms, 1);
  if (!x->all_geoms || !x->all_wrench || !x->centres || !x->velocities || !x->handed || !x->pressed) {
    x->count = x->geoms = 0;
    return -1;
  }
  return 0;
}

// The partners' tubes as capsules after the host's geoms, at the step start,
// placed from their states into this exchange's own buffers. Returns the
// geoms in all, or the host's count alone if a partner's view cannot be had.
static int add_capsules(vsc_partner_exchange* x, vsc_partner_viewer view, void* host, const vsc_geom* geoms,
                        int geom_count, double friction, double timestep) {
  memcpy(x->all_geoms, geoms, sizeof(vsc_geom) * (size_t)geom_count);
  int g = geom_count;
  for (int p = 0; p < x->count; ++p) {
    vsc_partner_view other = view(host, x->partners[p], 1);
    if (!other.rod) return geom_count;
    vsc_rod_sphere_points(other.rod, other.positions, other.velocities, x->centres, x->velocities);
    double mu = fmax(friction, other.self_friction);  // as a geom pair's
    vsc_partner_capsules(other.rod, x->centres, x->velocities, other.spheres, mu, 0.5 * timestep, x->all_geoms + g);
    for (int c = 0, before = vsc_sleep_sphere_resting(other.rod, other.sleep, other.rest, 0); c + 1 < other.spheres;
         ++c) {  // a capsule between resting spheres chatters
      int after = vsc_sleep_sphere_resting(other.rod, other.sleep, other.rest, c + 1);
      x->all_geoms[g + c].resting = before && after;
      before = after;
    }
    g += other.spheres - 1;
  }
  return g;
}

// The loads the lower instances handed this one this step (they advanced
// first), read from their own buffers: one's as it is, several summed in
// instance order into `load`; with them, the capsules their moving spheres
// pressed, several or-ed into `pressed_by_several`. NULL if none did.
static const double* received(vsc_partner_exchange* x, vsc_partner_viewer view, void* host, int self,
                              const vsc_partner_view* own, const unsigned char** pressed) {
  const double* load = NULL;
  *pressed = NULL;
  int senders = 0, size = 3 * own->control_count, capsules = own->spheres - 1;
  for (int i = 0; i < self; ++i) {
    vsc_partner_view lower = view(host, i, 0);
    const vsc_partner_exchange* sent = lower.exchange;
    if (!lower.rod || !sent || !sent->handed_any || !sent->handed_any[self]) continue;
    const double* part = sent->handed + sent->handed_offset[self];
    const unsigned char* flags = sent->pressed + sent->pressed_offset[self];
    if (++senders == 1) {
      load = part;
      *pressed = flags;
      continue;
    }
    if (senders == 2) {
      memcpy(x->load, load, sizeof(double) * (size_t)size);
      memcpy(x->pressed_by_several, *pressed, (size_t)capsules);
    }
    for (int k = 0; k < size; ++k) x->load[k] += part[k];
    for (int c = 0; c < capsules; ++c) x->pressed_by_several[c] |= flags[c];
    load = x->load;
    *pressed = x->pressed_by_several;
  }
  return load;
}

void vsc_partners_gather(vsc_partner_exchange* x, vsc_partner_viewer view, void* host, int self, int contacts,
                         const vsc_geom* geoms, int geom_count, double friction, double timestep, vsc_world* world,
                         vsc_reactions* reactions) {
  if (x->count > 0 && contacts) {
    world->geoms = x->all_geoms;
    world->geom_count = add_capsules(x, view, host, geoms, geom_count, friction, timestep);
    reactions->geom_wrench = x->all_wrench;
  }
  vsc_partner_view own = view(host, self, 0);
  const unsigned char* pressed;
  const double* load = received(x, view, host, self, &own, &pressed);
  if (load) {
    world->wake_capsules = pressed;
    world->control_load = load;
  }
}

typedef struct pressing {
  vsc_partner_exchange* x;
  const vsc_rod* rod;
  const vsc_sleep_options* sleep;
  const double* rest;  // this instance's rest records, after its step
  int first, geoms;    // the partners' capsules: from `first` to `geoms` of the step's geoms
} pressing;

// A contact of this instance's sphere a against a partner's capsule b: flag the
// capsule if it would wake a sleeping sphere of the partner, with this
// instance as the geom pressing it (vsc_sleep_contact_wakes): the sphere's own
// speed, not the relative one (that counts the partner's own motion).
static void flag_pressed(void* data, int rigid, int a, int b, double speed, double depth) {
  (void)speed;
  pressing* p = (pressing*)data;
  vsc_partner_exchange* x = p->x;
  if (!rigid || b < p->first || b >= p->geoms) return;
  int capsule = b - p->first, j = -1;  // whose: the partner whose capsules span b
  for (int q = 0; q < x->count; ++q) {
    int first = x->pressed_offset[x->partners[q]];
    int count = q + 1 < x->count ? x->pressed_offset[x->partners[q + 1]] - first : x->geoms - first;
    if (capsule >= first && capsule < first + count) j = x->partners[q];
  }
  if (j < 0) return;
  const double* v = vsc_rod_sphere_velocities(p->rod) + 3 * a;
  int chatter = vsc_sleep_sphere_resting(p->rod, p->sleep, p->rest, a);
  if (vsc_sleep_contact_wakes(chatter, sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]), x->waking_speed[j], depth,
                              x->all_geoms[b].size[0]))
    x->pressed[capsule] = 1;
}

void vsc_partners_scatter(vsc_partner_exchange* x, vsc_partner_viewer view, void* host, const vsc_rod* rod,
                          const vsc_sleep_options* sleep, const double* rest, int geom_count,
                          const vsc_world* world, const vsc_reactions* reactions) {
  if (world->geom_count <= geom_count) return;  // no partner this step
  int g = geom_count;
  for (int p = 0; p < x->count; ++p) {
    int j = x->partners[p];
    vsc_partner_view other = view(host, j, 1);
    if (!other.rod) return;  // (its capsules were added this step, so its caches exist)
    double* handed = x->handed + x->handed_offset[j];
    memset(handed, 0, sizeof(double) * 3 * (size_t)other.control_count);
    vsc_partner_add_load(other.rod, other.spheres, world->geoms + g, reactions->geom_wrench + 6 * g, handed);
    memset(x->pressed + x->pressed_offset[j], 0, (size_t)(other.spheres - 1));
    x->handed_any[j] = 1;
    g += other.spheres - 1;
  }
  pressing request = {x, rod, sleep, rest, geom_count, world->geom_count};
  vsc_rod_visit_contacts(rod, flag_pressed, &request);
}
