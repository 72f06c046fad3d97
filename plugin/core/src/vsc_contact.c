// Penalty contacts (see viscera/vsc_contact.h), in two phases: the narrow phase
// over the candidate lists (vsc_contact_lists.c) finds every contact and its
// spheres' load; the damping is limited where that load passes its explicit
// limit (vsc_contact_load.h); then each contact's normal push and friction, the
// touch records friction reads. And the penalty's potential energy.
#include "vsc_contact.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "vsc_capsule.h"
#include "vsc_contact_lists.h"
#include "vsc_contact_load.h"
#include "vsc_place.h"
#include "vsc_sleep.h"

// A contact the narrow phase found, before its force: the pass finds them all
// first, so that their damping can be limited where it adds up (vsc_contact_load.h),
// then pushes them in the order found.
typedef struct found_contact {
  int a, b;             // self: segments a < b; rigid: sphere a, geom b
  int rigid;            // 1: sphere a against geom b
  double s, t;          // self: closest points' parameters on segments a and b
  double depth;         // m
  double radius;        // the tube's radius there (m): rigid, sphere a's; self, the mean at the closest points
  double n[3];          // unit normal, towards a
  double relative[3];   // a's velocity relative to b's at the contact (m/s)
  double point[3];      // rigid: the contact point on the geom's surface (m)
} found_contact;

typedef struct pass {
  const vsc_step_context* context;
  const vsc_rod* rod;
  vsc_contact_pass* state;       // the pass's own: found contacts, load, touch records
  const double* x;               // the placed sphere centres (m, 3 per sphere)
  const double* velocity;        // and velocities (m/s)
  const unsigned char* asleep;   // per sphere, its sleep (vsc_rod.h); NULL: none sleeps
  const vsc_world* world;
  double* Q;
  int contacts;
  int geom;                // index of the geom being queried
  const double* segment;   // per segment: midpoint (m, 3), half length (m); this evaluation's (NULL: not used)
  const double* damping_scale;  // per sphere, the factor on the contact damping (NULL: none)
} pass;

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
static inline __attribute__((always_inline)) double contact_force(const vsc_rod* rod, double depth, double radius,
                            const double n[3], const double relative[3], double mu, double c,
                            const double* elongation, double f[3], double tangent[3]) {
  double k = rod->def.contact_stiffness;
  double separation = relative[0] * n[0] + relative[1] * n[1] + relative[2] * n[2];
  double cap = VSC_SPRING_DEPTH * radius, spring = depth < cap ? depth : cap;  // see VSC_PUSH_OUT_SPEED
  double normal = push_share(depth, radius, separation) * k * spring - c * separation;
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

// Room for `more` found contacts; 0 if the buffer cannot grow.
static int reserve(vsc_contact_pass* c, int more) {
  if (c->found_count + more <= c->found_capacity) return 1;
  int capacity = c->found_capacity > 0 ? c->found_capacity : 256;
  while (capacity < c->found_count + more) capacity *= 2;
  found_contact* grown = (found_contact*)realloc(c->found, sizeof(found_contact) * (size_t)capacity);
  if (!grown) return 0;
  c->found = grown;
  c->found_capacity = capacity;
  return 1;
}

static void push(pass* p, const found_contact* found);

// Keep a found contact, built in `found`, for the push, with its spheres' load;
// with no room, push it at once, unlimited.
static void keep(pass* p, found_contact* found) {
  const vsc_rod* rod = p->rod;
  vsc_contact_pass* c = p->state;
  if (found->rigid) {
    vsc_contact_load_add(&c->load, found->a, rod->def.contact_stiffness);
  } else {
    double twice_k = 2.0 * rod->def.contact_stiffness;
    vsc_contact_load_add(&c->load, found->a, twice_k * (1.0 - found->s));
    vsc_contact_load_add(&c->load, found->a + 1, twice_k * found->s);
    vsc_contact_load_add(&c->load, found->b, twice_k * (1.0 - found->t));
    vsc_contact_load_add(&c->load, found->b + 1, twice_k * found->t);
  }
  if (c->found && found == (found_contact*)c->found + c->found_count)
    ++c->found_count;
  else
    push(p, found);
}

// Where the next found contact is built: the buffer's next slot, or `spare`.
static found_contact* next_slot(pass* p, found_contact* spare) {
  vsc_contact_pass* c = p->state;
  return c->found_count < c->found_capacity || reserve(c, 1) ? (found_contact*)c->found + c->found_count : spare;
}

// 1 if segment a's and segment b's four spheres all sleep deep: their contact cannot change
// and no point whose forces are watched feels it.
static inline int segments_asleep(const unsigned char* asleep, int a, int b) {
  return asleep && (asleep[a] & asleep[a + 1] & asleep[b] & asleep[b + 1]) == VSC_ASLEEP_DEEP;
}

// Keep the contact of segments a < b if their closest points, at parameters s and t with d
// from b's point to a's (m) and `distance` its length (m), lie within the tube's radii.
static void self_contact(pass* p, int a, int b, double s, double t, const double d[3], double distance) {
  const vsc_rod* rod = p->rod;
  const double* v = p->velocity;
  double ra = rod->def.radius, rb = ra;
  if (rod->tapered) {  // the tube's radius at the closest points
    const double* R = rod->sphere_radius;
    ra = R[a] + s * (R[a + 1] - R[a]), rb = R[b] + t * (R[b + 1] - R[b]);
  }
  double depth = (ra + rb) - distance;
  if (!(depth > 0.0)) return;
  found_contact spare, *found = next_slot(p, &spare);
  found->a = a;
  found->b = b;
  found->rigid = 0;
  found->s = s;
  found->t = t;
  found->depth = depth;
  found->radius = 0.5 * (ra + rb);
  found->n[0] = found->n[1] = 0.0;  // crossing axes: any direction separates them
  found->n[2] = 1.0;
  if (distance > 0.0)
    for (int c = 0; c < 3; ++c) found->n[c] = d[c] / distance;
  for (int c = 0; c < 3; ++c) {
    double vp = (1.0 - s) * v[3 * a + c] + s * v[3 * a + 3 + c];
    double vq = (1.0 - t) * v[3 * b + c] + t * v[3 * b + 3 + c];
    found->relative[c] = vp - vq;
  }
  keep(p, found);
}

static void self_pair(void* context, int earlier, int item) {
  pass* p = (pass*)context;
  const vsc_rod* rod = p->rod;
  int a = earlier < item ? earlier : item, b = earlier < item ? item : earlier;
  if (b - a < rod->self_gap) return;  // neighbours along the axis
  if (segments_asleep(p->asleep, a, b)) return;
  if (p->segment) {
    // testing every pair (no lists): a cheap exact rejection first, segments within
    // 2r of each other have midpoints within 2r + half of each length (the lists'
    // pairs need none: their build distances already rule out all but ~1 %)
    const double *sa = p->segment + 4 * a, *sb = p->segment + 4 * b;
    double gap2 = (sa[0] - sb[0]) * (sa[0] - sb[0]) + (sa[1] - sb[1]) * (sa[1] - sb[1]) + (sa[2] - sb[2]) * (sa[2] - sb[2]);
    double reach = 2.0 * rod->radius_max + (sa[3] + sb[3]);
    if (gap2 >= reach * reach) return;
  }
  double s, t, d[3];
  double distance = vsc_segment_gap(p->x, a, b, &s, &t, d);
  self_contact(p, a, b, s, t, d, distance);
}

// The listed self pairs the skip filter keeps go through the narrow phase in batches: their
// endpoints gathered side by side, the closest points of a whole batch computed in one loop
// the compiler vectorises (vsc_capsule.h's, branch-free: the same bits one by one), then each
// pair's contact kept in the list's order.
#define SELF_BATCH 64

typedef struct self_batch {
  int count;
  int a[SELF_BATCH], b[SELF_BATCH];
  double end[12][SELF_BATCH];   // p0, p1 (segment a's spheres), q0, q1 (b's), x y z each (m)
  double s[SELF_BATCH], t[SELF_BATCH];
  double d[3][SELF_BATCH];      // from b's closest point to a's (m)
  double distance2[SELF_BATCH]; // its squared length (m^2)
} self_batch;

VSC_VECTOR_CLONES static void closest_points_batch(int count, const double (*restrict end)[SELF_BATCH],
                                                   double* restrict s_out, double* restrict t_out,
                                                   double (*restrict d)[SELF_BATCH], double* restrict distance2) {
  for (int i = 0; i < count; ++i) {
    double p0[3] = {end[0][i], end[1][i], end[2][i]}, p1[3] = {end[3][i], end[4][i], end[5][i]};
    double q0[3] = {end[6][i], end[7][i], end[8][i]}, q1[3] = {end[9][i], end[10][i], end[11][i]};
    double gap[3];
    distance2[i] = vsc_segment_points_gap2(p0, p1, q0, q1, s_out + i, t_out + i, gap);
    for (int a = 0; a < 3; ++a) d[a][i] = gap[a];
  }
}

// The narrow phase of the batch's pairs, then the batch emptied.
static void flush_self_batch(pass* p, self_batch* batch) {
  closest_points_batch(batch->count, (const double (*)[SELF_BATCH])batch->end, batch->s, batch->t, batch->d,
                       batch->distance2);
  for (int i = 0; i < batch->count; ++i) {
    double d[3] = {batch->d[0][i], batch->d[1][i], batch->d[2][i]};
    self_contact(p, batch->a[i], batch->b[i], batch->s[i], batch->t[i], d, sqrt(batch->distance2[i]));
  }
  batch->count = 0;
}

static void batch_self_pair(pass* p, self_batch* batch, int a, int b) {
  if (segments_asleep(p->asleep, a, b)) return;
  const double* x = p->x;
  int i = batch->count++;
  batch->a[i] = a;
  batch->b[i] = b;
  for (int c = 0; c < 3; ++c) {
    batch->end[c][i] = x[3 * a + c];
    batch->end[3 + c][i] = x[3 * a + 3 + c];
    batch->end[6 + c][i] = x[3 * b + c];
    batch->end[9 + c][i] = x[3 * b + 3 + c];
  }
  if (batch->count == SELF_BATCH) flush_self_batch(p, batch);
}

// Narrow phase of sphere i against geom p->geom.
static void sphere_geom(void* context, int i) {
  pass* p = (pass*)context;
  const vsc_rod* rod = p->rod;
  const vsc_geom* geom = &p->world->geoms[p->geom];
  // a sleeping sphere on a static geom stays as it was; a moving body's geom still pushes it
  if (p->asleep && p->asleep[i] == VSC_ASLEEP_DEEP && geom->is_static) return;
  double r = rod->sphere_radius[i];
  const double* x = p->x + 3 * i;
  if (geom->bound_radius > 0.0) {
    double dx = x[0] - geom->position[0], dy = x[1] - geom->position[1], dz = x[2] - geom->position[2];
    double reach = geom->bound_radius + r;
    if (dx * dx + dy * dy + dz * dz > reach * reach) return;
  }
  double n[3];
  double distance = vsc_geom_distance(geom, x, n);
  double depth = r - distance;
  if (!(depth > 0.0)) return;
  found_contact spare, *found = next_slot(p, &spare);
  found->a = i;
  found->b = p->geom;
  found->rigid = 1;
  found->s = found->t = 0.0;
  found->depth = depth;
  found->radius = r;
  // contact point on the geom surface, and the sphere's velocity relative to it
  for (int c = 0; c < 3; ++c) {
    found->n[c] = n[c];
    found->point[c] = x[c] - distance * n[c];
  }
  double geom_velocity[3];
  vsc_geom_point_velocity(geom, found->point, geom_velocity);
  const double* v = p->velocity + 3 * i;
  for (int c = 0; c < 3; ++c) found->relative[c] = v[c] - geom_velocity[c];
  keep(p, found);
}

// The force of a found contact: its normal push and friction on the rod, the
// reaction on the geom, the touch record friction reads.
static void push(pass* p, const found_contact* found) {
  const vsc_rod* rod = p->rod;
  double* touch = p->state->touch.record;
  const double* scale = p->damping_scale;
  double f[3], tangent[3], c = rod->def.contact_damping;
  int a = found->a, b = found->b;
  if (found->rigid) {
    const vsc_geom* geom = &p->world->geoms[b];
    const double* stick = p->context->stick ? p->context->stick + VSC_STICK_SIZE * a : NULL;
    const double* elongation = stick && (int)stick[0] == b ? stick + 1 : NULL;
    if (scale) c *= scale[a];
    double normal = contact_force(rod, found->depth, found->radius, found->n, found->relative, geom->friction, c,
                                  elongation, f, tangent);
    if (normal <= 0.0) return;
    vsc_place_add_at_sphere(rod, a, f, p->Q);
    double* geom_wrench = p->context->reactions->geom_wrench;
    if (geom_wrench) {
      double arm[3] = {found->point[0] - geom->position[0], found->point[1] - geom->position[1],
                       found->point[2] - geom->position[2]};
      vsc_wrench_add(geom_wrench + 6 * b, -p->context->wrench_weight, f, NULL, arm);
    }
    vsc_record_touch(touch + VSC_TOUCH_SIZE * a + VSC_TOUCH_RIGID, b, normal, geom->friction, found->n, tangent,
                     0.0, 0.0);
    ++p->contacts;
    return;
  }
  const double* stick = p->context->stick ? p->context->stick + VSC_STICK_SIZE * a : NULL;
  const double* elongation = stick && (int)stick[4] == b ? stick + 5 : NULL;
  double mu = rod->def.self_friction, s = found->s, t = found->t;
  if (scale) {  // the most limited of its four spheres: the pair's forces stay equal and opposite
    double least = scale[a] < scale[a + 1] ? scale[a] : scale[a + 1];
    least = scale[b] < least ? scale[b] : least;
    c *= scale[b + 1] < least ? scale[b + 1] : least;
  }
  double normal = contact_force(rod, found->depth, found->radius, found->n, found->relative, mu, c, elongation, f,
                                tangent);
  if (normal <= 0.0) return;
  double share[3];
  for (int k = 0; k < 3; ++k) share[k] = (1.0 - s) * f[k];
  vsc_place_add_at_sphere(rod, a, share, p->Q);
  for (int k = 0; k < 3; ++k) share[k] = s * f[k];
  vsc_place_add_at_sphere(rod, a + 1, share, p->Q);
  for (int k = 0; k < 3; ++k) share[k] = -(1.0 - t) * f[k];
  vsc_place_add_at_sphere(rod, b, share, p->Q);
  for (int k = 0; k < 3; ++k) share[k] = -t * f[k];
  vsc_place_add_at_sphere(rod, b + 1, share, p->Q);
  vsc_record_touch(touch + VSC_TOUCH_SIZE * a + VSC_TOUCH_SELF, b, normal, mu, found->n, tangent, s, t);
  ++p->contacts;
}

// A pair whose distance at the build, less what its parts moved since (the
// distance changes no faster than they move), still exceeds the contact
// distance cannot touch: skip it. The relative slack covers rounding.
#define SKIP_SLACK (1.0 + 1e-9)

// Find every contact of this evaluation (keep()).
static void find_contacts(pass* p, const vsc_contact_lists* l, int listed, int all_asleep) {
  const vsc_rod* rod = p->rod;
  const vsc_world* world = p->world;
  int spheres = rod->def.collision_sphere_count;
  if (!listed) {  // a list overflowed: this evaluation tests everything directly
    p->segment = l->segment;
    for (int a = 0; a + 1 < spheres && rod->def.self_collision; ++a)
      for (int b = a + rod->self_gap; b + 1 < spheres; ++b) self_pair(p, a, b);
    for (int g = 0; g < world->geom_count; ++g) {
      p->geom = g;
      for (int i = 0; i < spheres; ++i) sphere_geom(p, i);
    }
    return;
  }
  reserve(p->state, (rod->def.self_collision ? l->self_count : 0) + l->geom_count);  // the most the lists can find
  if (rod->def.self_collision && !all_asleep) {
    double contact = 2.0 * rod->radius_max * SKIP_SLACK;
    const double* moved = l->segment_moved;
    self_batch batch;
    batch.count = 0;
    for (int k = 0; k < l->self_count; ++k) {
      int a = l->self_pairs[2 * k], b = l->self_pairs[2 * k + 1];
      if (l->self_distance[k] - moved[a] - moved[b] > contact) continue;
      batch_self_pair(p, &batch, a, b);
    }
    flush_self_batch(p, &batch);
  }
  if (l->geom_count == 0) return;
  const double* shift = l->geom_pose + VSC_GEOM_POSE_SIZE * (size_t)l->built_geom_capacity;
  double contact = rod->radius_max * SKIP_SLACK;
  for (int k = 0; k < l->geom_count; ++k) {
    int g = l->geom_pairs[2 * k], i = l->geom_pairs[2 * k + 1];
    if (all_asleep && world->geoms[g].is_static) continue;
    if (l->geom_distance[k] - l->geom_moved[i] - shift[g] > contact) continue;
    p->geom = g;
    sphere_geom(p, i);
  }
}

int vsc_contact_add_forces(const vsc_step_context* context, vsc_contact_pass* state, const vsc_contact_lists* lists,
                           int listed, const vsc_placement* placement, const vsc_sleep_flags* sleep, double* Q) {
  const vsc_rod* rod = context->rod;
  int sleeping = sleep && sleep->asleep_count > 0;
  pass p = {context,  rod, state, placement->sphere_xyz, placement->sphere_velocity, sleeping ? sleep->sphere_asleep : NULL,
            context->world, Q, 0, -1, NULL, NULL};
  vsc_touch_clear(rod, &state->touch);
  state->touch.current = 1;
  state->found_count = 0;
  // a rod asleep everywhere: only moving bodies' geoms can touch it
  find_contacts(&p, lists, listed, sleeping && sleep->asleep_count == rod->n);
  // in a step, the damping limited where it adds up past its explicit limit (none in a lone evaluation)
  if (vsc_contact_load_limit_damping(rod, &state->load, context->substep, context->damping_limit))
    p.damping_scale = state->load.damping_scale;
  const found_contact* found = (const found_contact*)state->found;
  for (int k = 0; k < state->found_count; ++k) push(&p, &found[k]);
  return p.contacts;
}

void vsc_contact_forget(vsc_contact_pass* state) {
  state->touch.current = 0;
  state->found_count = 0;
}

void vsc_contact_pass_free(vsc_contact_pass* state) {
  free(state->found);
  state->found = NULL;
  state->found_count = state->found_capacity = 0;
}

void vsc_contact_visit(const vsc_contact_pass* state,
                       void (*visit)(void* data, int rigid, int a, int b, double speed, double depth), void* data) {
  const found_contact* found = (const found_contact*)state->found;
  for (int k = 0; k < state->found_count; ++k) {
    const double* r = found[k].relative;
    visit(data, found[k].rigid, found[k].a, found[k].b, sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]), found[k].depth);
  }
}

// Potential of a penalty spring at depth d > 0 (J): 1/2 k d^2, linear past
// VSC_SPRING_DEPTH radii, where its force stops growing.
static double spring_energy(const vsc_rod* rod, double depth, double radius) {
  double k = rod->def.contact_stiffness, cap = VSC_SPRING_DEPTH * radius;
  return depth < cap ? 0.5 * k * depth * depth : k * cap * (depth - 0.5 * cap);
}

// Penalty potential of one sphere-geom candidate at q (J), and the deepest rigid contact;
// the sphere placed where it is needed (the same bits as the evaluation's placement).
static double sphere_geom_energy(const vsc_rod* rod, const vsc_world* world, const double* q, int g, int i,
                                 vsc_deepest_contact* deepest) {
  const vsc_geom* geom = &world->geoms[g];
  double r = rod->sphere_radius[i], n[3], x[3];
  vsc_basis_point(&rod->sphere_basis[i], q, x);
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
  return spring_energy(rod, depth, r);
}

static double self_pair_energy(const vsc_rod* rod, const double* q, int a, int b) {
  if (b - a < rod->self_gap) return 0.0;
  double ends[12], s, t, d[3];  // segment a's spheres, then b's
  vsc_basis_point(&rod->sphere_basis[a], q, ends);
  vsc_basis_point(&rod->sphere_basis[a + 1], q, ends + 3);
  vsc_basis_point(&rod->sphere_basis[b], q, ends + 6);
  vsc_basis_point(&rod->sphere_basis[b + 1], q, ends + 9);
  double distance = vsc_segment_gap(ends, 0, 2, &s, &t, d);
  double ra = rod->def.radius, rb = ra;
  if (rod->tapered) {
    const double* R = rod->sphere_radius;
    ra = R[a] + s * (R[a + 1] - R[a]), rb = R[b] + t * (R[b + 1] - R[b]);
  }
  double depth = (ra + rb) - distance;
  return depth > 0.0 ? spring_energy(rod, depth, 0.5 * (ra + rb)) : 0.0;
}

double vsc_contact_energy(const vsc_rod* rod, const vsc_world* world, const double* q, const vsc_contact_lists* lists,
                          int listed, vsc_deepest_contact* deepest) {
  if (deepest) {
    deepest->depth = 0.0;
    deepest->geom = deepest->sphere = -1;
  }
  if (world->geom_count <= 0 && !rod->def.self_collision) return 0.0;
  int spheres = rod->def.collision_sphere_count;
  double energy = 0.0;
  // the candidate lists, so the energy costs one narrow phase; if they overflowed, every pair,
  // in the lists' order: the same terms in the same order, the same bits
  if (!listed) {
    for (int a = 0; a + 1 < spheres && rod->def.self_collision; ++a)
      for (int b = a + rod->self_gap; b + 1 < spheres; ++b) energy += self_pair_energy(rod, q, a, b);
    for (int g = 0; g < world->geom_count; ++g)
      for (int i = 0; i < spheres; ++i) energy += sphere_geom_energy(rod, world, q, g, i, deepest);
    return energy;
  }
  const vsc_contact_lists* l = lists;
  for (int k = 0; k < l->self_count && rod->def.self_collision; ++k)
    energy += self_pair_energy(rod, q, l->self_pairs[2 * k], l->self_pairs[2 * k + 1]);
  for (int k = 0; k < l->geom_count; ++k)
    energy += sphere_geom_energy(rod, world, q, l->geom_pairs[2 * k], l->geom_pairs[2 * k + 1], deepest);
  return energy;
}
