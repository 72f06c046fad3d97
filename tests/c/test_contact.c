// Contact lists: forces from the cached Verlet lists equal a fresh build's at
// every evaluation while a tool sweeps through a coiled, drifting rod (the
// lists are rebuilt apart, self pairs when spheres move, geom pairs when
// either spheres or geoms move; neither may miss a contact).
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "viscera/vsc_contact.h"
#include "viscera/vsc_rod.h"
#include "vsc_contact.h"
#include "vsc_capsule.h"
#include "vsc_contact_lists.h"
#include "vsc_place.h"
#include "vsc_touch.h"
#include "viscera/viscera.h"
#include "vsc_test.h"

#define N 60

static vsc_rod* coiled_rod(void) {
  vsc_rod_def def = vsc_default_rod_def();
  def.control_count = N;
  def.length = 1.5;
  def.collision_sphere_count = 121;
  vsc_rod* rod = NULL;
  ENSURE(vsc_rod_create(&def, &rod) == VSC_OK);
  return rod;
}

// A helix of radius 5 cm whose turns are 1.8 radii apart (touching), drifting,
// breathing and twisting with time t (s): spheres move past the lists' margin
// and each turn slides along its neighbours, so the touching pairs change.
static void coil(double t, double* q) {
  double radius = 0.0125, turn = 2.0 * 3.14159265358979 * 0.05, pitch = 1.8 * radius;
  for (int k = 0; k < N; ++k) {
    double s = 1.5 * k / (N - 1), base = s / turn * 2.0 * 3.14159265358979, angle = base + 2.0 * t * s;
    double R = 0.05 * (1.0 + 0.05 * sin(3.0 * t + s));
    q[3 * k] = R * cos(angle) + 0.02 * t;
    q[3 * k + 1] = R * sin(angle);
    q[3 * k + 2] = pitch * base / (2.0 * 3.14159265358979) * (1.0 + 0.03 * sin(2.0 * t));
  }
}

// A tool shaft (capsule, radius 5 mm, half length 10 cm) crossing the coil
// along y, sliding along x and turning about z with time t.
static vsc_geom shaft(double t) {
  vsc_geom g;
  memset(&g, 0, sizeof(g));
  g.type = VSC_GEOM_CAPSULE;
  g.size[0] = 0.005;
  g.size[1] = 0.1;
  double x = -0.06 + 0.12 * t, turn = 0.8 * t, c = cos(turn), s = sin(turn);
  double position[3] = {x, 0.0, 0.05};
  memcpy(g.position, position, sizeof(position));
  // local z (the capsule's axis) along world y, turned about world z
  double rotation[9] = {c, 0.0, -s, s, 0.0, c, 0.0, 1.0, 0.0};
  memcpy(g.rotation, rotation, sizeof(rotation));
  g.bound_radius = 0.105;
  for (int a = 0; a < 3; ++a) {
    g.box[a] = position[a] - 0.105;
    g.box[3 + a] = position[a] + 0.105;
  }
  g.friction = 0.3;
  return g;
}

// The contact stages of one evaluation: place the spheres, the broad phase, the narrow phase.
static int contact_forces(vsc_rod* rod, const vsc_world* world, const double* q, const double* v, double* Q) {
  vsc_reactions none = {NULL, NULL};
  vsc_step_context context = {rod, world, &none, NULL, 1.0, 1.0, NULL};
  const vsc_rod_stages* stage = &rod->stages;
  vsc_place_spheres(rod, q, v, stage->placement);
  int listed = vsc_contact_lists_refresh(rod, stage->broad_phase, stage->placement->sphere_xyz, world);
  return vsc_contact_add_forces(&context, stage->contact, stage->broad_phase, listed, stage->placement, NULL, Q);
}

static void cached_lists_match_fresh_builds(void) {
  vsc_rod* cached = coiled_rod();
  double q[3 * N], v[3 * N] = {0}, cached_force[3 * N], fresh_force[3 * N];
  int contacts = 0, mismatches = 0;
  for (int step = 0; step < 400; ++step) {
    double t = step * 0.0025;  // 1 s: the shaft sweeps 12 cm, the coil drifts 2 cm
    coil(t, q);
    vsc_geom tool = shaft(t);
    vsc_world world = {{0, 0, 0}, &tool, 1};
    memset(cached_force, 0, sizeof(cached_force));
    contacts += contact_forces(cached, &world, q, v, cached_force);
    vsc_rod* fresh = coiled_rod();
    memset(fresh_force, 0, sizeof(fresh_force));
    contact_forces(fresh, &world, q, v, fresh_force);
    for (int i = 0; i < 3 * N; ++i) mismatches += cached_force[i] != fresh_force[i];
    vsc_rod_destroy(fresh);
  }
  ENSURE(mismatches == 0);
  ENSURE(contacts > 400 * 50);  // the coil's turns and the shaft do touch
  printf("  %d contacts over 400 evaluations, %d mismatching forces\n", contacts, mismatches);
  vsc_rod_destroy(cached);
}

// A self build (a sweep over the segments sorted by x, kept sorted from one build to the next)
// lists exactly the segment pairs beyond the neighbours within 2r + m, in (a, b) order, with
// their distances: checked against every pair, over a tangle that moves, turns and folds so
// that the kept order goes stale between builds.
static void self_build_lists_every_near_pair(void) {
  vsc_rod* rod = coiled_rod();
  double q[3 * N], v[3 * N] = {0};
  vsc_world world = {{0, 0, 0}, NULL, 0};
  int listed = 0, builds = 0;
  for (int step = 0; step < 60; ++step) {
    double t = 0.05 * step, c = cos(1.3 * t), s = sin(1.3 * t);
    coil(t, q);
    for (int k = 0; k < N; ++k) {  // turned about y and folded, so x order changes
      double x = q[3 * k], z = q[3 * k + 2] * (1.0 + 0.5 * sin(0.2 * k + t));
      q[3 * k] = c * x + s * z;
      q[3 * k + 2] = -s * x + c * z;
    }
    vsc_place_spheres(rod, q, v, rod->stages.placement);
    vsc_contact_lists* l = rod->stages.broad_phase;
    l->self_built = 0;  // a fresh self build every time
    ENSURE(vsc_contact_lists_refresh(rod, l, rod->stages.placement->sphere_xyz, &world));
    ++builds;
    int spheres = rod->def.collision_sphere_count, k = 0, mismatches = 0;
    double limit = (2.0 + VSC_CONTACT_MARGIN) * rod->radius_max;
    for (int a = 0; a + 1 < spheres; ++a)
      for (int b = a + rod->self_gap; b + 1 < spheres; ++b) {
        double u, w, d[3];
        double distance = vsc_segment_gap(rod->stages.placement->sphere_xyz, a, b, &u, &w, d);
        if (!(distance <= limit)) continue;
        mismatches += k >= l->self_count || l->self_pairs[2 * k] != a || l->self_pairs[2 * k + 1] != b ||
                      l->self_distance[k] != distance;
        ++k;
      }
    ENSURE(mismatches == 0);
    ENSURE(k == l->self_count);
    listed += k;
  }
  ENSURE(listed > builds * 100);  // the turns lie within reach of each other
  printf("  %d pairs over %d builds, each as testing every pair finds\n", listed, builds);
  vsc_rod_destroy(rod);
}

int main(void) {
  RUN(cached_lists_match_fresh_builds);
  RUN(self_build_lists_every_near_pair);
  TEST_MAIN_END();
}
