// Sleeping (see viscera/vsc_sleep.h): the flags a step reads, the rod asleep
// everywhere, and the rest records' advance with every rule that wakes a point.
#include "vsc_sleep.h"

#include <string.h>

#include "viscera/vsc_grasp.h"
#include "viscera/vsc_spline.h"
#include "vsc_contact.h"

vsc_sleep_options vsc_default_sleep_options(void) {
  vsc_sleep_options options = {0, 0.005, 0.25};
  return options;
}

// Control point k's rest starts over at its position q_k (m), unwatched.
static void restart_rest(double* rest, const double* q, int k) {
  double* r = rest + VSC_REST_SIZE * k;
  memset(r, 0, sizeof(double) * VSC_REST_SIZE);
  memcpy(r + VSC_REST_ANCHOR, q + 3 * k, sizeof(double) * 3);
}

void vsc_rest_wake_all(int control_count, const double* q, double* rest) {
  for (int k = 0; k < control_count; ++k) restart_rest(rest, q, k);
}

void vsc_rest_wake(int k, const double* q, double* rest) { restart_rest(rest, q, k); }

int vsc_sleep_sphere_resting(const vsc_rod* rod, const vsc_sleep_options* options, const double* rest, int sphere) {
  if (!options->enabled) return 0;
  double resting = VSC_SLEEP_RESTING_SHARE * options->rest_time;
  const vsc_basis* b = &rod->sphere_basis[sphere];
  for (int k = b->first; k < b->first + VSC_SPLINE_SUPPORT; ++k)
    if (!(rest[VSC_REST_SIZE * k + VSC_REST_TIME] >= resting)) return 0;
  return 1;
}

void vsc_sleep_wake_sphere(const vsc_rod* rod, int sphere, const double* q, double* rest) {
  const vsc_basis* b = &rod->sphere_basis[sphere];
  for (int k = b->first; k < b->first + VSC_SPLINE_SUPPORT; ++k) restart_rest(rest, q, k);
}

void vsc_sleep_host_wakes(const vsc_rod* rod, const vsc_world* world, const double* q, double* rest) {
  if (!rest) return;
  if (world->wake_all) vsc_rest_wake_all(rod->n, q, rest);
  if (!world->wake_capsules) return;
  for (int c = 0; c + 1 < rod->def.collision_sphere_count; ++c)
    if (world->wake_capsules[c]) {
      vsc_sleep_wake_sphere(rod, c, q, rest);
      vsc_sleep_wake_sphere(rod, c + 1, q, rest);
    }
}

// 1 if point k at q (m) is within rest_speed x rest_time of where its rest began.
static int within_rest(const vsc_sleep_options* options, const double* q, const double* rest, int k) {
  const double *x = q + 3 * k, *r = rest + VSC_REST_SIZE * k + VSC_REST_ANCHOR;
  double dx = x[0] - r[0], dy = x[1] - r[1], dz = x[2] - r[2], reach = options->rest_speed * options->rest_time;
  return dx * dx + dy * dy + dz * dz < reach * reach;
}

int vsc_sleep_begin(const vsc_rod* rod, vsc_sleep_flags* f, const vsc_sleep_options* options, const double* q,
                    double* rest, double* v) {
  int n = rod->n, spheres = rod->def.collision_sphere_count, count = 0;
  if (f->asleep_count > 0) memset(f->asleep, 0, (size_t)(n + spheres));
  f->asleep_count = 0;
  if (!rest || !options || !options->enabled) return 0;
  for (int k = 0; k < n; ++k) {
    int asleep = vsc_sleeps(options, rest[VSC_REST_SIZE * k + VSC_REST_TIME]);
    if (asleep && !within_rest(options, q, rest, k)) {  // moved by the host (a state written): awake there
      restart_rest(rest, q, k);
      asleep = 0;
    }
    f->asleep[k] = (unsigned char)asleep;
    count += asleep;
  }
  if (count == 0) return 0;
  f->asleep_count = count;
  memset(f->unbalanced, 0, (size_t)n);
  if (count == n) {  // asleep everywhere (the common case at rest): all deep, held, nothing watched
    memset(v, 0, sizeof(double) * 3 * (size_t)n);
    memset(f->asleep, VSC_ASLEEP_DEEP, (size_t)(n + spheres));
    for (int k = 0; k < n; ++k) rest[VSC_REST_SIZE * k + VSC_REST_WATCHED] = 0.0;
    return count;
  }
  // asleep within reach of an awake point: at the edge, its forces watched; deeper: unwatched
  for (int k = 0; k < n; ++k)
    if (f->asleep[k]) f->asleep[k] = VSC_ASLEEP_DEEP;
  for (int pass = 0; pass < 2; ++pass) {  // awake points mark their sleeping neighbours on either side
    int last_awake = -VSC_SLEEP_REACH - 1;
    for (int i = 0; i < n; ++i) {
      int k = pass ? n - 1 - i : i;
      if (!f->asleep[k])
        last_awake = i;
      else if (i - last_awake <= VSC_SLEEP_REACH)
        f->asleep[k] = VSC_ASLEEP_EDGE;
    }
  }
  for (int k = 0; k < n; ++k) {
    if (f->asleep[k]) v[3 * k] = v[3 * k + 1] = v[3 * k + 2] = 0.0;
    if (f->asleep[k] != VSC_ASLEEP_EDGE) rest[VSC_REST_SIZE * k + VSC_REST_WATCHED] = 0.0;  // a new edge, a new load
  }
  for (int i = 0; i < spheres; ++i) {  // a sphere sleeps as the least asleep of the 4 points it depends on
    const unsigned char* a = f->asleep + rod->sphere_basis[i].first;
    unsigned char least = a[0] < a[1] ? a[0] : a[1], later = a[2] < a[3] ? a[2] : a[3];
    f->sphere_asleep[i] = least < later ? least : later;
  }
  return count;
}

void vsc_sleep_hold(const vsc_rod* rod, vsc_sleep_flags* f, double* rest, double* a) {
  if (f->asleep_count == 0) return;
  const double limit2 = VSC_SLEEP_WAKE_ACCELERATION * VSC_SLEEP_WAKE_ACCELERATION;
  for (int k = 0; k < rod->n; ++k) {
    if (!f->asleep[k]) continue;
    double* ak = a + 3 * k;
    if (f->asleep[k] == VSC_ASLEEP_EDGE) {  // ... and one next to awake points wakes when its forces change
      double* record = rest + VSC_REST_SIZE * k;
      double* load = record + VSC_REST_LOAD;
      if (record[VSC_REST_WATCHED] == 0.0) {
        load[0] = ak[0];
        load[1] = ak[1];
        load[2] = ak[2];
        record[VSC_REST_WATCHED] = 1.0;
      }
      double d0 = ak[0] - load[0], d1 = ak[1] - load[1], d2 = ak[2] - load[2];
      if (d0 * d0 + d1 * d1 + d2 * d2 > limit2) f->unbalanced[k] = 1;
    }
    ak[0] = ak[1] = ak[2] = 0.0;
  }
}

void vsc_sleep_retry(const vsc_rod* rod, vsc_sleep_flags* f) {
  if (f->asleep_count > 0) memset(f->unbalanced, 0, (size_t)rod->n);
}

void vsc_sleep_end(const vsc_rod* rod, vsc_sleep_flags* f) {
  if (f->asleep_count > 0) memset(f->asleep, 0, (size_t)(rod->n + rod->def.collision_sphere_count));
  f->asleep_count = 0;
}

void vsc_sleep_wake_all(const vsc_rod* rod, vsc_sleep_flags* f, const double* q, double* rest) {
  if (rest) vsc_rest_wake_all(rod->n, q, rest);
  vsc_sleep_end(rod, f);
}

typedef struct waking {
  const vsc_rod* rod;
  const vsc_sleep_flags* flags;
  const vsc_sleep_options* options;
  const double* q;
  double* rest;
  int woken;  // sleeping points woken
  const vsc_world* world;
} waking;

// The sleeping ones of the 4 control points sphere `sphere` depends on wake.
static void wake_sphere(waking* w, int sphere) {
  const unsigned char* asleep = w->flags->asleep;
  int first = w->rod->sphere_basis[sphere].first;
  for (int k = first; k < first + VSC_SPLINE_SUPPORT; ++k)
    if (asleep[k] && w->rest[VSC_REST_SIZE * k + VSC_REST_TIME] >= 0.0) {
      restart_rest(w->rest, w->q, k);
      w->rest[VSC_REST_SIZE * k + VSC_REST_TIME] = -1.0;  // woken this step (set to 0 once every rule has read the flags)
      ++w->woken;
    }
}

// 1 if a point sphere `sphere` depends on moved this step.
static int sphere_moved(const vsc_rod* rod, const vsc_sleep_flags* f, int sphere) {
  const unsigned char* moved = f->moved + rod->sphere_basis[sphere].first;
  return moved[0] | moved[1] | moved[2] | moved[3];
}

// A contact wakes a sleeping side (a sphere whose 4 points all sleep) when the
// other moves: a geom whose surface moves at all (but a resting rod's chatter) or that presses it deeper than
// a sleeping sphere may be pressed (a mocap body moves with no velocity), a
// segment whose points moved. A side partly awake moves with its awake points.
static void wake_by_contact(void* data, int rigid, int a, int b, double speed, double depth) {
  waking* w = (waking*)data;
  const vsc_rod* rod = w->rod;
  const unsigned char* asleep = w->flags->sphere_asleep;
  if (rigid) {
    int chatter = w->world->geoms[b].resting;  // a resting rod's capsule: its speed is no motion
    if (asleep[a] && vsc_sleep_contact_wakes(chatter, speed, VSC_SLEEP_GEOM_SPEED_SHARE * w->options->rest_speed,
                                             depth, rod->sphere_radius[a]))
      wake_sphere(w, a);
    return;
  }
  if ((asleep[a] || asleep[a + 1]) && (sphere_moved(rod, w->flags, b) || sphere_moved(rod, w->flags, b + 1))) {
    wake_sphere(w, a);
    wake_sphere(w, a + 1);
  }
  if ((asleep[b] || asleep[b + 1]) && (sphere_moved(rod, w->flags, a) || sphere_moved(rod, w->flags, a + 1))) {
    wake_sphere(w, b);
    wake_sphere(w, b + 1);
  }
}

// Touches and holds: contacts whose partner moves, and every point a jaw holds.
static void wake_touched(waking* w, const vsc_contact_pass* contacts, const vsc_world* world) {
  const vsc_rod* rod = w->rod;
  vsc_contact_visit(contacts, wake_by_contact, w);
  for (int g = 0; g < world->grasp_count; ++g) {
    vsc_basis b = vsc_spline_basis(rod->n, world->grasps[g].abscissa);
    for (int k = b.first; k < b.first + VSC_SPLINE_SUPPORT; ++k) {
      w->woken += w->flags->asleep[k] && w->rest[VSC_REST_SIZE * k + VSC_REST_TIME] >= 0.0;
      restart_rest(w->rest, w->q, k);  // held: never at rest
    }
  }
  for (int k = 0; k < rod->n; ++k)
    if (w->rest[VSC_REST_SIZE * k + VSC_REST_TIME] < 0.0) w->rest[VSC_REST_SIZE * k + VSC_REST_TIME] = 0.0;
}

int vsc_sleep_rest(const vsc_rod* rod, vsc_sleep_flags* f, const vsc_contact_pass* contacts, const vsc_world* world,
                   const vsc_sleep_options* options, const double* q, double* rest) {
  memset(f->moved, 0, (size_t)rod->n);
  waking w = {rod, f, options, q, rest, 0, world};
  wake_touched(&w, contacts, world);
  return w.woken == 0;
}

void vsc_sleep_advance(const vsc_rod* rod, vsc_sleep_flags* f, const vsc_contact_pass* contacts, const vsc_world* world,
                       const vsc_sleep_options* options, const double* start_q, const double* q, double dt, double* rest) {
  int n = rod->n;
  const unsigned char* asleep = f->asleep;  // all 0 when nothing sleeps
  unsigned char* moved = f->moved;
  double step_reach = options->rest_speed * dt;
  double away = VSC_SLEEP_MOVE_SHARE * options->rest_speed * options->rest_time;  // (m)
  for (int k = 0; k < n; ++k) {
    moved[k] = 0;
    if (asleep[k]) continue;
    // moved: its mean speed over the step reached rest_speed, away from where its rest began
    // (VSC_SLEEP_MOVE_SHARE of the rest reach: a contact's chatter, micrometres about a point,
    // is not motion, even where one substep a step leaves its swing uncancelled) ...
    const double *x = q + 3 * k, *x0 = start_q + 3 * k, *anchor = rest + VSC_REST_SIZE * k + VSC_REST_ANCHOR;
    double dx = x[0] - x0[0], dy = x[1] - x0[1], dz = x[2] - x0[2];
    double ax = x[0] - anchor[0], ay = x[1] - anchor[1], az = x[2] - anchor[2];
    moved[k] = dx * dx + dy * dy + dz * dz >= step_reach * step_reach &&
               ax * ax + ay * ay + az * az >= away * away;
    // ... or, creeping slower, it left the reach of where its rest began; within it, its rest goes on
    if (within_rest(options, q, rest, k)) {
      rest[VSC_REST_SIZE * k + VSC_REST_TIME] += dt;
    } else {
      restart_rest(rest, q, k);
      moved[k] = 1;
    }
  }
  waking w = {rod, f, options, q, rest, 0, world};
  if (f->asleep_count > 0) {  // a point that moved wakes the sleeping ones within reach
    for (int k = 0; k < n; ++k)  // and one at the edge whose forces changed wakes
      if (f->unbalanced[k]) restart_rest(rest, q, k);
    int last_moved = -VSC_SLEEP_REACH - 1;
    for (int k = 0; k < n; ++k) {
      if (moved[k]) {
        last_moved = k;
        for (int j = k - 1; j >= 0 && j >= k - VSC_SLEEP_REACH; --j)
          if (asleep[j]) restart_rest(rest, q, j);
      } else if (asleep[k] && k - last_moved <= VSC_SLEEP_REACH) {
        restart_rest(rest, q, k);
      }
    }
  }
  wake_touched(&w, contacts, world);
}
