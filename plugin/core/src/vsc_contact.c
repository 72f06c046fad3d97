// Contacts: candidate lists from grid passes (segments, then spheres), and the narrow phase per evaluation.
#include "vsc_contact_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { RIGID = 0, SELF = 11 };  // offsets of the two records in a touch entry
// T_S, T_T: a self-contact's closest points on its segments (0 for rigid contacts)
enum { T_PARTNER = 0, T_NORMAL_FORCE = 1, T_MU = 2, T_NORMAL = 3, T_TANGENT_VELOCITY = 6, T_S = 9, T_T = 10 };

typedef struct pass {
  vsc_rod* rod;
  const vsc_world* world;
  double* Q;
  int contacts;
  int geom;                // index of the geom being queried
  const double* segment;   // per segment: midpoint (m, 3), half length (m); this evaluation's (NULL: not used)
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
  // weights and force in locals: the stores to Q then force no reloads
  const vsc_basis* b = &rod->sphere_basis[sphere];
  double* out = Q + 3 * b->first;
  const double f0 = f[0], f1 = f[1], f2 = f[2];
  const double w[VSC_SPLINE_SUPPORT] = {b->weight[0], b->weight[1], b->weight[2], b->weight[3]};
  for (int j = 0; j < VSC_SPLINE_SUPPORT; ++j) {
    out[3 * j] += w[j] * f0;
    out[3 * j + 1] += w[j] * f1;
    out[3 * j + 2] += w[j] * f2;
  }
}

// Share of the penalty spring's push at depth `depth` (m) and separation speed
// `separation` (m/s), see VSC_PUSH_OUT_SPEED: all of it down to
// VSC_DEEP_CONTACT radii; from twice that depth on, all of it below half
// VSC_PUSH_OUT_SPEED and none from VSC_PUSH_OUT_SPEED on (linear between).
static inline double push_share(double depth, double radius, double separation) {
  double deep = VSC_DEEP_CONTACT * radius;
  if (!(depth > deep) || !(separation > 0.5 * VSC_PUSH_OUT_SPEED)) return 1.0;  // the ordinary contacts
  double slowed = 2.0 - 2.0 * separation / VSC_PUSH_OUT_SPEED;  // 1 at half the speed, 0 at the speed
  double weight = depth < 2.0 * deep ? depth / deep - 1.0 : 1.0;
  return 1.0 - weight * (1.0 - (slowed > 0.0 ? slowed : 0.0));
}

// Normal force, plus the friction force of a contact with relative velocity
// `relative` (m/s); `elongation` is its stick spring (NULL: none). Writes the
// total force into f and the tangential velocity into tangent.
static double contact_force(const vsc_rod* rod, double depth, const double n[3], const double relative[3],
                            double mu, const double* elongation, double f[3], double tangent[3]) {
  double k = rod->def.contact_stiffness, c = rod->def.contact_damping;
  double separation = relative[0] * n[0] + relative[1] * n[1] + relative[2] * n[2];
  double cap = VSC_SPRING_DEPTH * rod->def.radius, spring = depth < cap ? depth : cap;  // see VSC_PUSH_OUT_SPEED
  double normal = push_share(depth, rod->def.radius, separation) * k * spring - c * separation;
  if (!(normal > 0.0)) return 0.0;  // penalty contacts push, never pull
  double ft[3];
  for (int a = 0; a < 3; ++a) {
    tangent[a] = relative[a] - separation * n[a];
    ft[a] = -c * tangent[a];
  }
  if (elongation) {
    double along = elongation[0] * n[0] + elongation[1] * n[1] + elongation[2] * n[2];
    for (int a = 0; a < 3; ++a) ft[a] -= k * (elongation[a] - along * n[a]);
  }
  double magnitude2 = ft[0] * ft[0] + ft[1] * ft[1] + ft[2] * ft[2], limit = mu * normal;
  double scale = magnitude2 > limit * limit ? limit / sqrt(magnitude2) : 1.0;  // sqrt only when slipping
  for (int a = 0; a < 3; ++a) f[a] = normal * n[a] + scale * ft[a];
  return normal;
}

static void record_touch(double* touch, int partner, double normal, double mu, const double n[3], const double vt[3],
                         double s, double t) {
  if (normal <= touch[T_NORMAL_FORCE]) return;  // keep the strongest contact
  touch[T_PARTNER] = partner;
  touch[T_S] = s;
  touch[T_T] = t;
  touch[T_NORMAL_FORCE] = normal;
  touch[T_MU] = mu;
  for (int a = 0; a < 3; ++a) {
    touch[T_NORMAL + a] = n[a];
    touch[T_TANGENT_VELOCITY + a] = vt[a];
  }
}

// Closest points P = p0 + s (p1 - p0), Q = q0 + t (q1 - q0) of two segments
// (Ericson, Real-Time Collision Detection, 5.1.9).
// x clamped to [0, 1], NaN to 0 (as fmin(fmax(x, 0), 1), which compiles to
// library calls without -ffast-math; this runs for every self-contact pair)
static inline double clamp01(double x) { return x > 0.0 ? (x < 1.0 ? x : 1.0) : 0.0; }

static void closest_segments(const double* p0, const double* p1, const double* q0, const double* q1, double* s_out,
                             double* t_out) {
  double d1[3], d2[3], r[3];
  for (int a = 0; a < 3; ++a) {
    d1[a] = p1[a] - p0[a];
    d2[a] = q1[a] - q0[a];
    r[a] = p0[a] - q0[a];
  }
  double aa = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2];
  double e = d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2];
  double f = d2[0] * r[0] + d2[1] * r[1] + d2[2] * r[2];
  double s = 0.0, t = 0.0, tiny = 1e-30;
  if (aa <= tiny && e <= tiny) {
    s = t = 0.0;
  } else if (aa <= tiny) {
    t = clamp01(f / e);
  } else {
    double c = d1[0] * r[0] + d1[1] * r[1] + d1[2] * r[2];
    if (e <= tiny) {
      s = clamp01(-c / aa);
    } else {
      double b = d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2], denominator = aa * e - b * b;
      s = denominator > 0.0 ? clamp01((b * f - c * e) / denominator) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = clamp01(-c / aa);
      } else if (t > 1.0) {
        t = 1.0;
        s = clamp01((b - c) / aa);
      }
    }
  }
  *s_out = s;
  *t_out = t;
}

// Capsule contact of segments a < b (segment k joins spheres k and k + 1).
// Closest points of segments a (sphere a to a + 1) and b of the sphere chain x:
// their parameters s, t, the vector d from b's point to a's (m), its length (m).
static double segment_gap(const double* x, int a, int b, double* s_out, double* t_out, double d[3]) {
  double s, t;
  closest_segments(x + 3 * a, x + 3 * a + 3, x + 3 * b, x + 3 * b + 3, &s, &t);
  *s_out = s;
  *t_out = t;
  for (int c = 0; c < 3; ++c) {
    double P = (1.0 - s) * x[3 * a + c] + s * x[3 * a + 3 + c];
    double Q = (1.0 - t) * x[3 * b + c] + t * x[3 * b + 3 + c];
    d[c] = P - Q;
  }
  return sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
}

static void self_pair(void* context, int earlier, int item) {
  pass* p = (pass*)context;
  vsc_rod* rod = p->rod;
  int a = earlier < item ? earlier : item, b = earlier < item ? item : earlier;
  if (b - a < rod->self_gap) return;  // neighbours along the axis
  const double *x = rod->sphere_xyz, *v = rod->sphere_velocity;
  if (p->segment) {
    // testing every pair (no lists): a cheap exact rejection first, segments within
    // 2r of each other have midpoints within 2r + half of each length (the lists'
    // pairs need none: their build distances already rule out all but ~1 %)
    const double *sa = p->segment + 4 * a, *sb = p->segment + 4 * b;
    double gap2 = (sa[0] - sb[0]) * (sa[0] - sb[0]) + (sa[1] - sb[1]) * (sa[1] - sb[1]) + (sa[2] - sb[2]) * (sa[2] - sb[2]);
    double reach = 2.0 * rod->def.radius + (sa[3] + sb[3]);
    if (gap2 >= reach * reach) return;
  }
  double s, t, vp[3], vq[3], d[3];
  double distance = segment_gap(x, a, b, &s, &t, d);
  double depth = 2.0 * rod->def.radius - distance;
  if (!(depth > 0.0)) return;
  double n[3] = {0.0, 0.0, 1.0};  // crossing axes: any direction separates them
  if (distance > 0.0)
    for (int c = 0; c < 3; ++c) n[c] = d[c] / distance;
  for (int c = 0; c < 3; ++c) {
    vp[c] = (1.0 - s) * v[3 * a + c] + s * v[3 * a + 3 + c];
    vq[c] = (1.0 - t) * v[3 * b + c] + t * v[3 * b + 3 + c];
  }
  double relative[3] = {vp[0] - vq[0], vp[1] - vq[1], vp[2] - vq[2]};
  const double* stick = p->world->stick ? p->world->stick + VSC_STICK_SIZE * a : NULL;
  const double* elongation = stick && (int)stick[4] == b ? stick + 5 : NULL;
  double f[3], tangent[3], mu = rod->def.self_friction;
  double normal = contact_force(rod, depth, n, relative, mu, elongation, f, tangent);
  if (normal <= 0.0) return;
  double share[3];
  for (int c = 0; c < 3; ++c) share[c] = (1.0 - s) * f[c];
  add_at_sphere(rod, a, share, p->Q);
  for (int c = 0; c < 3; ++c) share[c] = s * f[c];
  add_at_sphere(rod, a + 1, share, p->Q);
  for (int c = 0; c < 3; ++c) share[c] = -(1.0 - t) * f[c];
  add_at_sphere(rod, b, share, p->Q);
  for (int c = 0; c < 3; ++c) share[c] = -t * f[c];
  add_at_sphere(rod, b + 1, share, p->Q);
  record_touch(rod->touch + VSC_TOUCH_SIZE * a + SELF, b, normal, mu, n, tangent, s, t);
  ++p->contacts;
}

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
    double arm[3] = {point[0] - geom->position[0], point[1] - geom->position[1], point[2] - geom->position[2]};
    vsc_wrench_add(p->world->geom_wrench + 6 * p->geom, -p->world->wrench_weight, f, NULL, arm);
  }
  record_touch(rod->touch + VSC_TOUCH_SIZE * i + RIGID, p->geom, normal, geom->friction, n, tangent, 0.0, 0.0);
  ++p->contacts;
}

struct vsc_contact_lists {
  int sphere_count;
  int self_count, self_capacity;
  int* self_pairs;            // candidate sphere pairs a < b, sorted (2 per pair)
  double* self_distance;      // each self pair's segment distance at the build (m)
  int geom_count, geom_capacity;
  int* geom_pairs;            // candidate (geom, sphere) pairs, sorted (2 per pair)
  double* geom_distance;      // each geom pair's distance at the build (m; -inf: never skipped)
  int self_built;             // 0: the self pairs must be built
  int geoms_built;            // 0: the geom pairs must be built
  int built_geoms;            // geom count at the geom pairs' build
  int built_geom_capacity;
  double* sphere_xyz;         // sphere centres at the self pairs' build (3 per sphere) (m)
  double* geom_sphere_xyz;    // sphere centres at the geom pairs' build (3 per sphere) (m)
  double* geom_pose;          // geom position and rotation at build (12 per geom), then each
                              // geom's surface motion since (1 per geom) (m)
  double* segment;            // per segment, each evaluation: midpoint (m, 3), half length (m)
  double* moved;              // per sphere, each evaluation: distance moved since the self build (m)
  double* segment_moved;      // per segment: the larger of its two spheres' `moved` (m)
  double* geom_moved;         // per sphere: distance moved since the geom build (m)
  double* build_scratch;      // per segment, during a self build: midpoint (3), reach, excess
  const vsc_geom* geoms;      // the host's geom array at build
};

// pair capacities per sphere: dense piles hold ~30 neighbouring segments within 2r + m
#define SELF_PAIRS_PER_SPHERE 64
#define GEOM_PAIRS_PER_SPHERE 8
// up to this many spheres the lists are built by testing every pair (no
// hashing, cache-friendly, already sorted); past it through the grid, O(n)
#define DIRECT_BUILD_SPHERES 1024

double vsc_contact_lists_memory_bytes(int spheres) {
  return sizeof(vsc_contact_lists) +
         (double)spheres * ((2.0 * sizeof(int) + sizeof(double)) * (SELF_PAIRS_PER_SPHERE + GEOM_PAIRS_PER_SPHERE) +
                            18.0 * sizeof(double));
}

vsc_contact_lists* vsc_contact_lists_create(int spheres) {
  vsc_contact_lists* l = (vsc_contact_lists*)calloc(1, sizeof(vsc_contact_lists));
  if (!l) return NULL;
  l->sphere_count = spheres;
  l->self_capacity = SELF_PAIRS_PER_SPHERE * spheres;
  l->geom_capacity = GEOM_PAIRS_PER_SPHERE * spheres;
  l->self_pairs = (int*)malloc(sizeof(int) * 2 * (size_t)l->self_capacity);
  l->self_distance = (double*)malloc(sizeof(double) * (size_t)l->self_capacity);
  l->geom_pairs = (int*)malloc(sizeof(int) * 2 * (size_t)l->geom_capacity);
  l->geom_distance = (double*)malloc(sizeof(double) * (size_t)l->geom_capacity);
  l->sphere_xyz = (double*)malloc(sizeof(double) * 3 * (size_t)spheres);
  l->geom_sphere_xyz = (double*)malloc(sizeof(double) * 3 * (size_t)spheres);
  l->segment = (double*)malloc(sizeof(double) * 4 * (size_t)spheres);
  l->moved = (double*)malloc(sizeof(double) * 8 * (size_t)spheres);
  if (!l->self_pairs || !l->self_distance || !l->geom_pairs || !l->geom_distance || !l->sphere_xyz ||
      !l->geom_sphere_xyz || !l->segment || !l->moved) {
    vsc_contact_lists_destroy(l);
    return NULL;
  }
  l->segment_moved = l->moved + spheres;
  l->geom_moved = l->segment_moved + spheres;
  l->build_scratch = l->geom_moved + spheres;
  return l;
}

void vsc_contact_lists_destroy(vsc_contact_lists* l) {
  if (!l) return;
  free(l->self_pairs);
  free(l->self_distance);
  free(l->geom_pairs);
  free(l->geom_distance);
  free(l->sphere_xyz);
  free(l->geom_sphere_xyz);
  free(l->segment);
  free(l->moved);
  free(l->geom_pose);
  free(l);
}

// Pairs are sorted so that the force sum runs in one order whatever the grid's
// hash order: results do not depend on bucket layout. Heap sort, in place: the
// C library's qsort mallocs a buffer for more than 1 KB of pairs, and the step
// loop must not touch the heap.
static int pair_less(const int* pairs, int a, int b) {
  const int *x = pairs + 2 * a, *y = pairs + 2 * b;
  return x[0] < y[0] || (x[0] == y[0] && x[1] < y[1]);
}

static void swap_pairs(int* pairs, int a, int b) {
  int first = pairs[2 * a], second = pairs[2 * a + 1];
  pairs[2 * a] = pairs[2 * b];
  pairs[2 * a + 1] = pairs[2 * b + 1];
  pairs[2 * b] = first;
  pairs[2 * b + 1] = second;
}

static void sift_down(int* pairs, int root, int count) {
  for (;;) {
    int child = 2 * root + 1;
    if (child >= count) return;
    if (child + 1 < count && pair_less(pairs, child, child + 1)) ++child;
    if (!pair_less(pairs, root, child)) return;
    swap_pairs(pairs, root, child);
    root = child;
  }
}

static void sort_pairs(int* pairs, int count) {
  for (int root = count / 2 - 1; root >= 0; --root) sift_down(pairs, root, count);
  for (int end = count - 1; end > 0; --end) {
    swap_pairs(pairs, 0, end);
    sift_down(pairs, 0, end);
  }
}

typedef struct build {
  vsc_rod* rod;
  const vsc_world* world;
  int geom;
  double reach;   // sphere-geom candidate distance, r + m (m)
  int overflow;
} build;

// Add self pair (lo, hi) if its segments are within 2r + m (exact distance):
// while no sphere moves m / 2 the distance shrinks by less than m, so the
// others cannot touch before the lists are rebuilt; overlapping grid boxes alone
// admit several times more pairs.
static void keep_self(build* b, int lo, int hi) {
  vsc_contact_lists* l = b->rod->lists;
  double s, t, d[3], limit = (2.0 + VSC_CONTACT_MARGIN) * b->rod->def.radius;
  double distance = segment_gap(b->rod->sphere_xyz, lo, hi, &s, &t, d);
  if (distance > limit) return;
  if (l->self_count >= l->self_capacity) {
    b->overflow = 1;
    return;
  }
  l->self_pairs[2 * l->self_count] = lo;
  l->self_pairs[2 * l->self_count + 1] = hi;
  l->self_distance[l->self_count] = distance;
  ++l->self_count;
}

static void collect_self(void* context, int earlier, int item) {
  build* b = (build*)context;
  int lo = earlier < item ? earlier : item, hi = earlier < item ? item : earlier;
  if (hi - lo < b->rod->self_gap) return;
  keep_self(b, lo, hi);
}

// The distance filter needs a distance that changes no faster than the point
// moves: exact distances do, a height field's does not (it jumps at its
// sides), so a height field keeps every grid candidate and is never skipped.
static double filter_distance(const vsc_geom* geom, const double* x) {
  double n[3];
  return geom->type != VSC_GEOM_HEIGHTFIELD ? vsc_geom_distance(geom, x, n) : -INFINITY;
}

static void collect_geom(void* context, int i) {
  build* b = (build*)context;
  vsc_contact_lists* l = b->rod->lists;
  double distance = filter_distance(&b->world->geoms[b->geom], b->rod->sphere_xyz + 3 * i);
  if (distance > b->reach) return;
  if (l->geom_count >= l->geom_capacity) {
    b->overflow = 1;
    return;
  }
  l->geom_pairs[2 * l->geom_count] = b->geom;
  l->geom_pairs[2 * l->geom_count + 1] = i;
  l->geom_distance[l->geom_count] = distance;
  ++l->geom_count;
}

static void no_pair(void* context, int earlier, int item) { (void)context; (void)earlier; (void)item; }

// Every segment pair beyond the neighbours, in order: a bounding-sphere test
// over contiguous arrays (vectorised), then the exact distance. For chains up
// to DIRECT_BUILD_SPHERES this costs a fraction of a grid pass, whose cells at
// the pair reach hold dozens of segments in a pile.
// Midpoint and half length of every segment into the lists' segment array.
static void update_segments(vsc_rod* rod) {
  const double* x = rod->sphere_xyz;
  for (int a = 0; a + 1 < rod->def.collision_sphere_count; ++a) {
    double* out = rod->lists->segment + 4 * a;
    double length2 = 0.0;
    for (int c = 0; c < 3; ++c) {
      out[c] = 0.5 * (x[3 * a + c] + x[3 * a + 3 + c]);
      length2 += (x[3 * a + 3 + c] - x[3 * a + c]) * (x[3 * a + 3 + c] - x[3 * a + c]);
    }
    out[3] = 0.5 * sqrt(length2);
  }
}

static void build_self_direct(vsc_rod* rod, build* b) {
  vsc_contact_lists* l = rod->lists;
  update_segments(rod);
  int segments = rod->def.collision_sphere_count - 1;
  double limit = (2.0 + VSC_CONTACT_MARGIN) * rod->def.radius;
  const double* seg = l->segment;  // midpoints and half lengths, current
  double* mx = l->build_scratch;
  double* my = mx + segments;
  double* mz = my + segments;
  double* half = mz + segments;
  double* excess = half + segments;  // per segment: squared distance less squared reach
  for (int a = 0; a < segments; ++a) {
    mx[a] = seg[4 * a];
    my[a] = seg[4 * a + 1];
    mz[a] = seg[4 * a + 2];
    half[a] = seg[4 * a + 3] + 0.5 * limit;
  }
  for (int a = 0; a < segments && !b->overflow; ++a) {
    int first = a + rod->self_gap;
    double x = mx[a], y = my[a], z = mz[a], ha = half[a];
    for (int c = first; c < segments; ++c) {  // |m_a - m_c| <= 2r + m + half lengths
      double dx = mx[c] - x, dy = my[c] - y, dz = mz[c] - z, r = ha + half[c];
      excess[c] = dx * dx + dy * dy + dz * dz - r * r;
    }
    for (int c = first; c < segments; ++c)
      if (excess[c] <= 0.0) keep_self(b, a, c);
  }
}

// The self pairs: segments within 2r + m, with their distances. Returns 0 if
// the list overflowed (the caller then evaluates without lists).
static int build_self(vsc_rod* rod, const vsc_world* world) {
  vsc_contact_lists* l = rod->lists;
  int spheres = rod->def.collision_sphere_count;
  double r = rod->def.radius, margin = VSC_CONTACT_MARGIN * r, inflated = r + 0.5 * margin;
  build b = {rod, world, -1, r + margin, 0};
  l->self_count = 0;
  if (spheres <= DIRECT_BUILD_SPHERES) {
    build_self_direct(rod, &b);
  } else {  // a grid pass over segment boxes inflated by half the margin, sized to the longest segment
    double longest = 0.0;
    for (int k = 0; k + 1 < spheres; ++k)
      for (int a = 0; a < 3; ++a)
        longest = fmax(longest, fabs(rod->sphere_xyz[3 * k + 3 + a] - rod->sphere_xyz[3 * k + a]));
    vsc_grid_begin(rod->grid, (longest + 2.0 * inflated) * (1.0 + 1e-6));
    for (int k = 0; k + 1 < spheres; ++k) {
      const double* x0 = rod->sphere_xyz + 3 * k;
      const double* x1 = x0 + 3;
      double lo[3], hi[3];
      for (int a = 0; a < 3; ++a) {
        lo[a] = fmin(x0[a], x1[a]) - inflated;
        hi[a] = fmax(x0[a], x1[a]) + inflated;
      }
      vsc_grid_insert(rod->grid, k, lo, hi, collect_self, &b);  // boxes under a cell: cannot fail
    }
    sort_pairs(l->self_pairs, l->self_count);
    for (int k = 0; k < l->self_count; ++k) {  // the distances, in the sorted order
      double s, t, d[3];
      l->self_distance[k] = segment_gap(rod->sphere_xyz, l->self_pairs[2 * k], l->self_pairs[2 * k + 1], &s, &t, d);
    }
  }
  memcpy(l->sphere_xyz, rod->sphere_xyz, sizeof(double) * 3 * (size_t)spheres);
  l->self_built = !b.overflow;
  return l->self_built;
}

// The (geom, sphere) pairs: for a few hundred spheres, each geom against every
// sphere in its box (no hashing); else a grid pass over sphere boxes, then a
// query per geom. Built apart from the self pairs, so a tool moving through a
// resting bowel costs only this. Returns 0 if the list overflowed.
static int build_geoms(vsc_rod* rod, const vsc_world* world) {
  vsc_contact_lists* l = rod->lists;
  int spheres = rod->def.collision_sphere_count;
  double r = rod->def.radius, margin = VSC_CONTACT_MARGIN * r, inflated = r + 0.5 * margin;
  build b = {rod, world, -1, r + margin, 0};
  l->geom_count = 0;
  double rod_box[6] = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
  int direct = spheres <= DIRECT_BUILD_SPHERES;
  if (!direct) vsc_grid_begin(rod->grid, 2.0 * inflated * (1.0 + 1e-6));  // a hair above a box: <= 2 cells per axis
  for (int i = 0; i < spheres; ++i) {
    const double* x = rod->sphere_xyz + 3 * i;
    double lo[3] = {x[0] - inflated, x[1] - inflated, x[2] - inflated};
    double hi[3] = {x[0] + inflated, x[1] + inflated, x[2] + inflated};
    for (int a = 0; a < 3; ++a) {
      rod_box[a] = lo[a] < rod_box[a] ? lo[a] : rod_box[a];
      rod_box[3 + a] = hi[a] > rod_box[3 + a] ? hi[a] : rod_box[3 + a];
    }
    if (!direct) vsc_grid_insert(rod->grid, i, lo, hi, no_pair, &b);
  }
  for (int g = 0; g < world->geom_count; ++g) {
    const vsc_geom* geom = &world->geoms[g];
    b.geom = g;
    int first = l->geom_count, visited = -1;
    if (geom->bound_radius > 0.0) {
      double lo[3], hi[3];
      for (int a = 0; a < 3; ++a) {
        lo[a] = fmax(geom->box[a] - 0.5 * margin, rod_box[a]);
        hi[a] = fmin(geom->box[3 + a] + 0.5 * margin, rod_box[3 + a]);
      }
      if (direct) {  // the spheres whose boxes overlap the geom's, in order
        visited = 0;
        if (lo[0] <= hi[0] && lo[1] <= hi[1] && lo[2] <= hi[2])
          for (int i = 0; i < spheres; ++i) {
            const double* x = rod->sphere_xyz + 3 * i;
            if (x[0] + inflated >= lo[0] && x[0] - inflated <= hi[0] && x[1] + inflated >= lo[1] &&
                x[1] - inflated <= hi[1] && x[2] + inflated >= lo[2] && x[2] - inflated <= hi[2])
              collect_geom(&b, i);
          }
      } else {
        visited = vsc_grid_query(rod->grid, lo, hi, 8 * spheres, collect_geom, &b);
      }
    }
    if (visited < 0)  // unbounded (planes), or a box over more cells than spheres: test all
      for (int i = 0; i < spheres; ++i) collect_geom(&b, i);
    if (!direct) {  // grid order: sort, then the distances in that order
      sort_pairs(l->geom_pairs + 2 * first, l->geom_count - first);
      for (int k = first; k < l->geom_count; ++k)
        l->geom_distance[k] = filter_distance(geom, rod->sphere_xyz + 3 * l->geom_pairs[2 * k + 1]);
    }
  }
  memcpy(l->geom_sphere_xyz, rod->sphere_xyz, sizeof(double) * 3 * (size_t)spheres);
  if (world->geom_count > l->built_geom_capacity) {
    double* poses = (double*)realloc(l->geom_pose, sizeof(double) * 13 * (size_t)world->geom_count);
    if (!poses) return 0;
    l->geom_pose = poses;
    l->built_geom_capacity = world->geom_count;
  }
  for (int g = 0; g < world->geom_count; ++g) {
    memcpy(l->geom_pose + 12 * g, world->geoms[g].position, sizeof(double) * 3);
    memcpy(l->geom_pose + 12 * g + 3, world->geoms[g].rotation, sizeof(double) * 9);
  }
  l->built_geoms = world->geom_count;
  l->geoms = world->geoms;
  l->geoms_built = !b.overflow;
  return l->geoms_built;
}

// Distance each sphere moved (m) from `snapshot` to `x` (3 per sphere) into
// `moved`; restrict parameters: the loop vectorises.
VSC_VECTOR_CLONES static void distances_moved(const double* restrict x, const double* restrict snapshot,
                                              double* restrict moved, int spheres) {
  for (int i = 0; i < spheres; ++i) {
    double dx = x[3 * i] - snapshot[3 * i], dy = x[3 * i + 1] - snapshot[3 * i + 1], dz = x[3 * i + 2] - snapshot[3 * i + 2];
    moved[i] = sqrt(dx * dx + dy * dy + dz * dz);
  }
}

// Distance each sphere moved from `snapshot` (3 per sphere) into `moved`;
// returns 1 while none moved by more than half the margin.
static int sphere_moves(const vsc_rod* rod, const double* snapshot, double* moved) {
  double half = 0.5 * VSC_CONTACT_MARGIN * rod->def.radius;
  int spheres = rod->def.collision_sphere_count;
  distances_moved(rod->sphere_xyz, snapshot, moved, spheres);
  double most = 0.0;
  for (int i = 0; i < spheres; ++i) most = moved[i] > most ? moved[i] : most;
  return most <= half;  // NaN: never valid
}

// The self pairs still hold every possible self-contact while no sphere moved
// by half the margin since they were built.
static int self_valid(const vsc_rod* rod) {
  vsc_contact_lists* l = rod->lists;
  if (!l->self_built || !sphere_moves(rod, l->sphere_xyz, l->moved)) return 0;
  for (int a = 0; a + 1 < rod->def.collision_sphere_count; ++a)
    l->segment_moved[a] = l->moved[a] > l->moved[a + 1] ? l->moved[a] : l->moved[a + 1];
  return 1;
}

// The geom pairs still hold every possible contact while no sphere and no geom
// moved by half the margin since they were built. Writes each geom's surface
// motion bound after the poses.
static int geoms_valid(const vsc_rod* rod, const vsc_world* world) {
  vsc_contact_lists* l = rod->lists;
  if (!l->geoms_built || l->built_geoms != world->geom_count || l->geoms != world->geoms) return 0;
  if (!sphere_moves(rod, l->geom_sphere_xyz, l->geom_moved)) return 0;
  double half = 0.5 * VSC_CONTACT_MARGIN * rod->def.radius;
  for (int g = 0; g < world->geom_count; ++g) {
    const vsc_geom* geom = &world->geoms[g];
    double* shift = l->geom_pose + 12 * (size_t)l->built_geom_capacity;
    const double* pose = l->geom_pose + 12 * g;
    double moved = 0.0, turned = 0.0;
    for (int a = 0; a < 3; ++a) moved += (geom->position[a] - pose[a]) * (geom->position[a] - pose[a]);
    for (int a = 0; a < 9; ++a) turned += (geom->rotation[a] - pose[3 + a]) * (geom->rotation[a] - pose[3 + a]);
    if (geom->bound_radius > 0.0) {
      // no surface point moved more than |dp| + R ||dR||_F
      shift[g] = sqrt(moved) + geom->bound_radius * sqrt(turned);
      if (!(shift[g] <= half)) return 0;
    } else if (moved != 0.0 || turned != 0.0) {
      return 0;  // an unbounded geom (plane) moved: its far parts may have swept anywhere
    } else {
      shift[g] = 0.0;
    }
  }
  return 1;
}

// A pair whose distance at the build, less what its parts moved since (the
// distance changes no faster than they move), still exceeds the contact
// distance cannot touch: skip it. The relative slack covers rounding.
#define SKIP_SLACK (1.0 + 1e-9)

int vsc_rod_contact_forces(vsc_rod* rod, const vsc_world* world, double* Q) {
  int spheres = rod->def.collision_sphere_count;
  pass p = {rod, world, Q, 0, -1};
  for (int i = 0; i < spheres; ++i) {
    double* touch = rod->touch + VSC_TOUCH_SIZE * i;
    touch[RIGID + T_PARTNER] = touch[SELF + T_PARTNER] = -1.0;
    touch[RIGID + T_NORMAL_FORCE] = touch[SELF + T_NORMAL_FORCE] = 0.0;
  }
  vsc_contact_lists* l = rod->lists;
  int self_fresh = 0, geoms_fresh = 0;
  int self_ok = !rod->def.self_collision || self_valid(rod) || (self_fresh = 1, build_self(rod, world));
  int geoms_ok = geoms_valid(rod, world) || (geoms_fresh = 1, build_geoms(rod, world));
  if (!self_ok || !geoms_ok) {
    // a list overflowed (an extreme pile): this evaluation tests everything directly
    l->self_built = l->geoms_built = 0;
    if (rod->def.self_collision) update_segments(rod);
    p.segment = l->segment;
    for (int a = 0; a + 1 < spheres && rod->def.self_collision; ++a)
      for (int b = a + rod->self_gap; b + 1 < spheres; ++b) self_pair(&p, a, b);
    for (int g = 0; g < world->geom_count; ++g) {
      p.geom = g;
      for (int i = 0; i < spheres; ++i) sphere_geom(&p, i);
    }
    return p.contacts;
  }
  if (rod->def.self_collision) {
    // just built: nothing moved since
    if (self_fresh) memset(l->segment_moved, 0, sizeof(double) * (size_t)spheres);
    double contact = 2.0 * rod->def.radius * SKIP_SLACK;
    const double* moved = l->segment_moved;
    for (int k = 0; k < l->self_count; ++k) {
      int a = l->self_pairs[2 * k], b = l->self_pairs[2 * k + 1];
      if (l->self_distance[k] - moved[a] - moved[b] > contact) continue;
      self_pair(&p, a, b);
    }
  }
  if (l->geom_count == 0) return p.contacts;
  const double* shift = l->geom_pose + 12 * (size_t)l->built_geom_capacity;
  if (geoms_fresh) {  // just built: nothing moved since
    memset(l->geom_moved, 0, sizeof(double) * (size_t)spheres);
    memset(l->geom_pose + 12 * (size_t)l->built_geom_capacity, 0, sizeof(double) * (size_t)world->geom_count);
  }
  double contact = rod->def.radius * SKIP_SLACK;
  for (int k = 0; k < l->geom_count; ++k) {
    int g = l->geom_pairs[2 * k], i = l->geom_pairs[2 * k + 1];
    if (l->geom_distance[k] - l->geom_moved[i] - shift[g] > contact) continue;
    p.geom = g;
    sphere_geom(&p, i);
  }
  return p.contacts;
}

// Potential of a penalty spring at depth d > 0 (J): 1/2 k d^2, linear past
// VSC_SPRING_DEPTH radii, where its force stops growing.
static double spring_energy(const vsc_rod* rod, double depth) {
  double k = rod->def.contact_stiffness, cap = VSC_SPRING_DEPTH * rod->def.radius;
  return depth < cap ? 0.5 * k * depth * depth : k * cap * (depth - 0.5 * cap);
}

// Penalty potential of one sphere-geom candidate (J), and the deepest rigid contact.
static double sphere_geom_energy(const vsc_rod* rod, const vsc_world* world, int g, int i, vsc_deepest_contact* deepest) {
  const vsc_geom* geom = &world->geoms[g];
  double r = rod->def.radius, n[3];
  const double* x = rod->sphere_xyz + 3 * i;
  if (geom->bound_radius > 0.0) {
    double dx = x[0] - geom->position[0], dy = x[1] - geom->position[1], dz = x[2] - geom->position[2];
    double reach = geom->bound_radius + r;
    if (dx * dx + dy * dy + dz * dz > reach * reach) return 0.0;
  }
  double depth = r - vsc_geom_distance(geom, x, n);
  if (!(depth > 0.0)) return 0.0;
  if (deepest && depth > deepest->depth) {
    deepest->depth = depth;
    deepest->geom = g;
    deepest->sphere = i;
  }
  return spring_energy(rod, depth);
}

static double self_pair_energy(const vsc_rod* rod, int a, int b) {
  if (b - a < rod->self_gap) return 0.0;
  double s, t, d[3];
  double depth = 2.0 * rod->def.radius - segment_gap(rod->sphere_xyz, a, b, &s, &t, d);
  return depth > 0.0 ? spring_energy(rod, depth) : 0.0;
}

double vsc_rod_contact_energy(vsc_rod* rod, const vsc_world* world, const double* q, vsc_deepest_contact* deepest) {
  if (deepest) {
    deepest->depth = 0.0;
    deepest->geom = deepest->sphere = -1;
  }
  if (world->geom_count <= 0 && !rod->def.self_collision) return 0.0;
  int spheres = rod->def.collision_sphere_count;
  vsc_rod_update_spheres(rod, q, NULL);
  vsc_contact_lists* l = rod->lists;
  // the same candidate lists as the forces (rebuilt here if stale), so the
  // energy costs one narrow phase; the touch records are left alone
  int self_ok = !rod->def.self_collision || self_valid(rod) || build_self(rod, world);
  int geoms_ok = geoms_valid(rod, world) || build_geoms(rod, world);
  double energy = 0.0;
  if (!self_ok || !geoms_ok) {  // a list overflowed: test everything
    l->self_built = l->geoms_built = 0;
    for (int a = 0; a + 1 < spheres && rod->def.self_collision; ++a)
      for (int b = a + rod->self_gap; b + 1 < spheres; ++b) energy += self_pair_energy(rod, a, b);
    for (int g = 0; g < world->geom_count; ++g)
      for (int i = 0; i < spheres; ++i) energy += sphere_geom_energy(rod, world, g, i, deepest);
    return energy;
  }
  for (int k = 0; k < l->self_count && rod->def.self_collision; ++k)
    energy += self_pair_energy(rod, l->self_pairs[2 * k], l->self_pairs[2 * k + 1]);
  for (int k = 0; k < l->geom_count; ++k)
    energy += sphere_geom_energy(rod, world, l->geom_pairs[2 * k], l->geom_pairs[2 * k + 1], deepest);
  return energy;
}

int vsc_rod_rigid_touch(const vsc_rod* rod, int sphere, double normal[3]) {
  const double* touch = rod->touch + VSC_TOUCH_SIZE * sphere + RIGID;
  if (!rod->touched || touch[T_PARTNER] < 0.0 || !(touch[T_NORMAL_FORCE] > 0.0)) return -1;
  for (int a = 0; a < 3; ++a) normal[a] = touch[T_NORMAL + a];
  return (int)touch[T_PARTNER];
}

// One friction slot: follow the partner of the last evaluation, advance the
// elongation by (v_t + unseen) h in the tangent plane, clamp it at the slip
// limit. `unseen` (m/s) is the relative velocity change the evaluation did not see.
static void update_slot(double* slot, const double* touch, const double unseen[3], double k, double h) {
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
  for (int a = 0; a < 3; ++a) e[a] += (vt[a] + unseen[a]) * h;
  double along = e[0] * n[0] + e[1] * n[1] + e[2] * n[2];
  for (int a = 0; a < 3; ++a) e[a] -= along * n[a];
  double length2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
  double friction = touch[T_MU] * touch[T_NORMAL_FORCE];  // the slip limit is friction / k (m)
  if (length2 * k * k > friction * friction) {  // slipping: the spring stays at the Coulomb limit
    double scale = friction / k / sqrt(length2);  // (division and sqrt only then)
    for (int a = 0; a < 3; ++a) e[a] *= scale;
  }
}

void vsc_rod_update_stick(const vsc_rod* rod, double* stick, double h, const double* velocity_change) {
  if (!rod->touched) {  // no contact was looked for: none holds
    vsc_stick_clear(stick, rod->def.collision_sphere_count);
    return;
  }
  double k = rod->def.contact_stiffness;
  int spheres = rod->def.collision_sphere_count;
  for (int i = 0; i < spheres; ++i) {
    const double* touch = rod->touch + VSC_TOUCH_SIZE * i;
    const double* rigid = touch + RIGID;
    double unseen[3] = {0.0, 0.0, 0.0};
    if (velocity_change && rigid[T_PARTNER] >= 0.0) vsc_basis_point(&rod->sphere_basis[i], velocity_change, unseen);
    update_slot(stick + VSC_STICK_SIZE * i, rigid, unseen, k, h);
    const double* self = touch + SELF;
    if (velocity_change && self[T_PARTNER] >= 0.0) {  // (1 - s) a + s (a + 1) - (1 - t) b - t (b + 1)
      int b = (int)self[T_PARTNER];
      double s = self[T_S], t = self[T_T], a0[3], a1[3], b0[3], b1[3];
      vsc_basis_point(&rod->sphere_basis[i], velocity_change, a0);
      vsc_basis_point(&rod->sphere_basis[i + 1], velocity_change, a1);
      vsc_basis_point(&rod->sphere_basis[b], velocity_change, b0);
      vsc_basis_point(&rod->sphere_basis[b + 1], velocity_change, b1);
      for (int a = 0; a < 3; ++a)
        unseen[a] = (1.0 - s) * a0[a] + s * a1[a] - (1.0 - t) * b0[a] - t * b1[a];
    }
    update_slot(stick + VSC_STICK_SIZE * i + 4, self, unseen, k, h);
  }
}
