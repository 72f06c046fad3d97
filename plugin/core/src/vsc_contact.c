// Sphere contacts through the grid: self pairs on insertion, geoms by query.
#include "viscera/vsc_contact.h"

#include <math.h>
#include <string.h>

enum { RIGID = 0, SELF = 9 };  // offsets of the two records in a touch entry
enum { T_PARTNER = 0, T_NORMAL_FORCE = 1, T_MU = 2, T_NORMAL = 3, T_TANGENT_VELOCITY = 6 };

typedef struct pass {
  vsc_rod* rod;
  const vsc_world* world;
  double* Q;
  int contacts;
  int geom;  // index of the geom being queried
} pass;

void vsc_stick_clear(double* stick, int count) {
  for (int i = 0; i < count; ++i) {
    double* s = stick + VSC_STICK_SIZE * i;
    memset(s, 0, sizeof(double) * VSC_STICK_SIZE);
    s[0] = -1.0;
    s[4] = -1.0;
  }
}

static void add_at_sphere(const vsc_rod* rod, int sphere, const double f[3], double* Q) {
  const vsc_basis* b = &rod->sphere_basis[sphere];
  double* out = Q + 3 * b->first;
  for (int j = 0; j < VSC_SPLINE_SUPPORT; ++j) {
    out[3 * j] += b->weight[j] * f[0];
    out[3 * j + 1] += b->weight[j] * f[1];
    out[3 * j + 2] += b->weight[j] * f[2];
  }
}

// Normal force, plus the friction force of a contact with relative velocity
// `relative` (m/s); `elongation` is its stick spring (NULL: none). Writes the
// total force into f and the tangential velocity into tangent.
static double contact_force(const vsc_rod* rod, double depth, const double n[3], const double relative[3],
                            double mu, const double* elongation, double f[3], double tangent[3]) {
  double k = rod->def.contact_stiffness, c = rod->def.contact_damping;
  double approach = relative[0] * n[0] + relative[1] * n[1] + relative[2] * n[2];
  double normal = k * depth - c * approach;
  if (!(normal > 0.0)) return 0.0;  // penalty contacts push, never pull
  double ft[3];
  for (int a = 0; a < 3; ++a) {
    tangent[a] = relative[a] - approach * n[a];
    ft[a] = -c * tangent[a];
  }
  if (elongation) {
    double along = elongation[0] * n[0] + elongation[1] * n[1] + elongation[2] * n[2];
    for (int a = 0; a < 3; ++a) ft[a] -= k * (elongation[a] - along * n[a]);
  }
  double magnitude = sqrt(ft[0] * ft[0] + ft[1] * ft[1] + ft[2] * ft[2]), limit = mu * normal;
  double scale = magnitude > limit ? limit / magnitude : 1.0;
  for (int a = 0; a < 3; ++a) f[a] = normal * n[a] + scale * ft[a];
  return normal;
}

static void record_touch(double* touch, int partner, double normal, double mu, const double n[3], const double vt[3]) {
  if (normal <= touch[T_NORMAL_FORCE]) return;  // keep the strongest contact
  touch[T_PARTNER] = partner;
  touch[T_NORMAL_FORCE] = normal;
  touch[T_MU] = mu;
  for (int a = 0; a < 3; ++a) {
    touch[T_NORMAL + a] = n[a];
    touch[T_TANGENT_VELOCITY + a] = vt[a];
  }
}

// Grid callback: spheres `earlier` and `item` have overlapping boxes.
static void self_pair(void* context, int earlier, int item) {
  pass* p = (pass*)context;
  vsc_rod* rod = p->rod;
  int a = earlier < item ? earlier : item, b = earlier < item ? item : earlier;
  if (b - a < rod->self_gap) return;  // neighbours along the axis
  const double* xa = rod->sphere_xyz + 3 * a;
  const double* xb = rod->sphere_xyz + 3 * b;
  double d[3] = {xa[0] - xb[0], xa[1] - xb[1], xa[2] - xb[2]};
  double distance = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  double depth = 2.0 * rod->def.radius - distance;
  if (!(depth > 0.0)) return;
  double n[3] = {0.0, 0.0, 1.0};  // coincident centres: any direction separates them
  if (distance > 0.0)
    for (int c = 0; c < 3; ++c) n[c] = d[c] / distance;
  const double* va = rod->sphere_velocity + 3 * a;
  const double* vb = rod->sphere_velocity + 3 * b;
  double relative[3] = {va[0] - vb[0], va[1] - vb[1], va[2] - vb[2]};
  const double* stick = p->world->stick ? p->world->stick + VSC_STICK_SIZE * a : NULL;
  const double* elongation = stick && (int)stick[4] == b ? stick + 5 : NULL;
  double f[3], tangent[3], mu = rod->def.self_friction;
  double normal = contact_force(rod, depth, n, relative, mu, elongation, f, tangent);
  if (normal <= 0.0) return;
  add_at_sphere(rod, a, f, p->Q);
  double opposite[3] = {-f[0], -f[1], -f[2]};
  add_at_sphere(rod, b, opposite, p->Q);
  record_touch(rod->touch + VSC_TOUCH_SIZE * a + SELF, b, normal, mu, n, tangent);
  ++p->contacts;
}

static void no_pair(void* context, int earlier, int item) { (void)context; (void)earlier; (void)item; }

// Narrow phase of sphere i against geom p->geom.
static void sphere_geom(void* context, int i) {
  pass* p = (pass*)context;
  vsc_rod* rod = p->rod;
  const vsc_geom* geom = &p->world->geoms[p->geom];
  double r = rod->def.radius;
  const double* x = rod->sphere_xyz + 3 * i;
  if (geom->bound_radius > 0.0) {
    double dx = x[0] - geom->position[0], dy = x[1] - geom->position[1], dz = x[2] - geom->position[2];
    double reach = geom->bound_radius + r;
    if (dx * dx + dy * dy + dz * dz > reach * reach) return;
  }
  double n[3];
  double distance = vsc_geom_distance(geom, x, n);
  double depth = r - distance;
  if (!(depth > 0.0)) return;
  // contact point on the geom surface, and the sphere's velocity relative to it
  double point[3] = {x[0] - distance * n[0], x[1] - distance * n[1], x[2] - distance * n[2]};
  double geom_velocity[3];
  vsc_geom_point_velocity(geom, point, geom_velocity);
  const double* v = rod->sphere_velocity + 3 * i;
  double relative[3] = {v[0] - geom_velocity[0], v[1] - geom_velocity[1], v[2] - geom_velocity[2]};
  const double* stick = p->world->stick ? p->world->stick + VSC_STICK_SIZE * i : NULL;
  const double* elongation = stick && (int)stick[0] == p->geom ? stick + 1 : NULL;
  double f[3], tangent[3];
  double normal = contact_force(rod, depth, n, relative, geom->friction, elongation, f, tangent);
  if (normal <= 0.0) return;
  add_at_sphere(rod, i, f, p->Q);
  if (p->world->geom_wrench) {
    double w = p->world->wrench_weight, *out = p->world->geom_wrench + 6 * p->geom;
    double arm[3] = {point[0] - geom->position[0], point[1] - geom->position[1], point[2] - geom->position[2]};
    out[0] -= w * f[0];
    out[1] -= w * f[1];
    out[2] -= w * f[2];
    out[3] -= w * (arm[1] * f[2] - arm[2] * f[1]);
    out[4] -= w * (arm[2] * f[0] - arm[0] * f[2]);
    out[5] -= w * (arm[0] * f[1] - arm[1] * f[0]);
  }
  record_touch(rod->touch + VSC_TOUCH_SIZE * i + RIGID, p->geom, normal, geom->friction, n, tangent);
  ++p->contacts;
}

int vsc_rod_contact_forces(vsc_rod* rod, const vsc_world* world, double* Q) {
  int spheres = rod->def.collision_sphere_count;
  double r = rod->def.radius;
  pass p = {rod, world, Q, 0, -1};
  for (int i = 0; i < spheres; ++i) {
    double* touch = rod->touch + VSC_TOUCH_SIZE * i;
    touch[RIGID + T_PARTNER] = touch[SELF + T_PARTNER] = -1.0;
    touch[RIGID + T_NORMAL_FORCE] = touch[SELF + T_NORMAL_FORCE] = 0.0;
  }
  // fill the grid; self pairs are found as spheres go in
  double rod_box[6] = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
  vsc_grid_begin(rod->grid, 2.0 * r * (1.0 + 1e-6));  // a hair above a box: at most 2 cells per axis
  vsc_pair_fn pair = rod->def.self_collision ? self_pair : no_pair;
  for (int i = 0; i < spheres; ++i) {
    const double* x = rod->sphere_xyz + 3 * i;
    double lo[3] = {x[0] - r, x[1] - r, x[2] - r}, hi[3] = {x[0] + r, x[1] + r, x[2] + r};
    for (int a = 0; a < 3; ++a) {
      rod_box[a] = lo[a] < rod_box[a] ? lo[a] : rod_box[a];
      rod_box[3 + a] = hi[a] > rod_box[3 + a] ? hi[a] : rod_box[3 + a];
    }
    vsc_grid_insert(rod->grid, i, lo, hi, pair, &p);  // cannot fail: finite boxes of one cell
  }
  // each geom meets the spheres in the cells its box shares with the rod's
  for (int g = 0; g < world->geom_count; ++g) {
    const vsc_geom* geom = &world->geoms[g];
    p.geom = g;
    int visited = -1;
    if (geom->bound_radius > 0.0) {
      double lo[3], hi[3];
      for (int a = 0; a < 3; ++a) {
        lo[a] = geom->box[a] > rod_box[a] ? geom->box[a] : rod_box[a];
        hi[a] = geom->box[3 + a] < rod_box[3 + a] ? geom->box[3 + a] : rod_box[3 + a];
      }
      visited = vsc_grid_query(rod->grid, lo, hi, 8 * spheres, sphere_geom, &p);
    }
    if (visited < 0)  // unbounded (planes) or a box spanning more cells than spheres: test all
      for (int i = 0; i < spheres; ++i) sphere_geom(&p, i);
  }
  return p.contacts;
}

// One friction slot: follow the partner of the last evaluation, advance the
// elongation by v_t h in the tangent plane, clamp it at the slip limit.
static void update_slot(double* slot, const double* touch, double k, double h) {
  int partner = (int)touch[T_PARTNER];
  if (partner < 0) {
    slot[0] = -1.0;
    slot[1] = slot[2] = slot[3] = 0.0;
    return;
  }
  if ((int)slot[0] != partner) {  // a new contact starts unstretched
    slot[0] = partner;
    slot[1] = slot[2] = slot[3] = 0.0;
  }
  double* e = slot + 1;
  const double* n = touch + T_NORMAL;
  const double* vt = touch + T_TANGENT_VELOCITY;
  for (int a = 0; a < 3; ++a) e[a] += vt[a] * h;
  double along = e[0] * n[0] + e[1] * n[1] + e[2] * n[2];
  for (int a = 0; a < 3; ++a) e[a] -= along * n[a];
  double length = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
  double limit = touch[T_MU] * touch[T_NORMAL_FORCE] / k;
  if (length > limit)  // slipping: the spring stays at the Coulomb limit
    for (int a = 0; a < 3; ++a) e[a] *= limit / length;
}

void vsc_rod_update_stick(const vsc_rod* rod, double* stick, double h) {
  double k = rod->def.contact_stiffness;
  for (int i = 0; i < rod->def.collision_sphere_count; ++i) {
    const double* touch = rod->touch + VSC_TOUCH_SIZE * i;
    update_slot(stick + VSC_STICK_SIZE * i, touch + RIGID, k, h);
    update_slot(stick + VSC_STICK_SIZE * i + 4, touch + SELF, k, h);
  }
}
