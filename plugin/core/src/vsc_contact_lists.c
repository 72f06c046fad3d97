// Candidate contact lists (Verlet lists, see viscera/vsc_contact.h): built by
// grid passes or, for short chains, by testing every pair; kept while nothing
// moved by half the margin; sorted, so forces do not depend on when or how
// they were built.
#include "vsc_contact_lists.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "vsc_capsule.h"

// pair capacities per sphere: dense piles hold ~30 neighbouring segments within 2r + m
#define SELF_PAIRS_PER_SPHERE 64
#define GEOM_PAIRS_PER_SPHERE 8
// up to this many spheres the lists are built by testing every pair (no
// hashing, cache-friendly, already sorted); past it through the grid, O(n)
#define DIRECT_BUILD_SPHERES 1024

// Partial rebuilds (rebuild_stale_geoms) run in the direct build's range only: their scratch is
// allocated there only.
static int rebuilds_geoms_alone(int spheres) { return spheres <= DIRECT_BUILD_SPHERES; }

double vsc_contact_lists_memory_bytes(int spheres) {
  double geom_lists = rebuilds_geoms_alone(spheres) ? 2.0 * GEOM_PAIRS_PER_SPHERE : GEOM_PAIRS_PER_SPHERE;
  double sweep = rebuilds_geoms_alone(spheres) ? sizeof(int) * (3.0 * SELF_PAIRS_PER_SPHERE + 4.0) : 0.0;
  return sizeof(vsc_contact_lists) + (rebuilds_geoms_alone(spheres) ? 4.0 * sizeof(int) : 0.0) +
         (double)spheres * ((2.0 * sizeof(int) + sizeof(double)) * (SELF_PAIRS_PER_SPHERE + geom_lists) +
                            22.0 * sizeof(double) + sweep);
}

vsc_contact_lists* vsc_contact_lists_create(int spheres) {
  vsc_contact_lists* l = (vsc_contact_lists*)calloc(1, sizeof(vsc_contact_lists));
  if (!l) return NULL;
  l->sphere_count = spheres;
  if (vsc_grid_create(spheres, &l->grid) != VSC_OK) {
    free(l);
    return NULL;
  }
  l->self_capacity = SELF_PAIRS_PER_SPHERE * spheres;
  l->geom_capacity = GEOM_PAIRS_PER_SPHERE * spheres;
  l->self_pairs = (int*)malloc(sizeof(int) * 2 * (size_t)l->self_capacity);
  l->self_distance = (double*)malloc(sizeof(double) * (size_t)l->self_capacity);
  l->geom_pairs = (int*)malloc(sizeof(int) * 2 * (size_t)l->geom_capacity);
  l->geom_distance = (double*)malloc(sizeof(double) * (size_t)l->geom_capacity);
  if (rebuilds_geoms_alone(spheres)) {
    l->merged_pairs = (int*)malloc(sizeof(int) * 2 * (size_t)l->geom_capacity);
    l->merged_distance = (double*)malloc(sizeof(double) * (size_t)l->geom_capacity);
    l->sweep_order = (int*)malloc(sizeof(int) * 4 * ((size_t)spheres + 1));
    l->sweep_pairs = (int*)malloc(sizeof(int) * 3 * (size_t)l->self_capacity);
    if (l->sweep_order)
      for (int k = 0; k < spheres; ++k) l->sweep_order[k] = k;
  }
  l->sphere_xyz = (double*)malloc(sizeof(double) * 3 * (size_t)spheres);
  l->geom_sphere_xyz = (double*)malloc(sizeof(double) * 3 * (size_t)spheres);
  l->segment = (double*)malloc(sizeof(double) * 4 * (size_t)spheres);
  l->moved = (double*)malloc(sizeof(double) * 12 * (size_t)spheres);
  if (!l->self_pairs || !l->self_distance || !l->geom_pairs || !l->geom_distance ||
      (rebuilds_geoms_alone(spheres) && (!l->merged_pairs || !l->merged_distance || !l->sweep_order ||
                                         !l->sweep_pairs)) || !l->sphere_xyz ||
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
  vsc_grid_destroy(l->grid);
  free(l->self_pairs);
  free(l->self_distance);
  free(l->geom_pairs);
  free(l->geom_distance);
  free(l->merged_pairs);
  free(l->merged_distance);
  free(l->sweep_order);
  free(l->sweep_pairs);
  free(l->geom_stale);
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
  const vsc_rod* rod;
  vsc_contact_lists* l;
  const double* x;  // the placed sphere centres (m)
  const vsc_world* world;
  int geom;
  double reach;   // sphere-geom candidate distance, r + m (m)
  double motion;  // the most a sphere and a geom move apart until the next build: m (m)
  int overflow;
} build;

// Add self pair (lo, hi) if its segments are within 2r + m (exact distance):
// while no sphere moves m / 2 the distance shrinks by less than m, so the
// others cannot touch before the lists are rebuilt; overlapping grid boxes alone
// admit several times more pairs.
static void keep_self(build* b, int lo, int hi) {
  vsc_contact_lists* l = b->l;
  double s, t, d[3], limit = (2.0 + VSC_CONTACT_MARGIN) * b->rod->radius_max;
  double distance = vsc_segment_gap(b->x, lo, hi, &s, &t, d);
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

// The distance filter needs a distance that changes no faster than the point moves, over
// `motion` (m), the most the sphere and the geom may move apart before the pair's next build:
// exact distances do; a height field's does not (it jumps at its sides and turns with its
// normal), so it is bounded by the height above the vertices near the sphere (vsc_geom.h).
static double filter_distance(const vsc_geom* geom, const double* x, double motion) {
  return vsc_geom_distance_bound(geom, x, motion);
}

static void collect_geom(void* context, int i) {
  build* b = (build*)context;
  vsc_contact_lists* l = b->l;
  double distance = filter_distance(&b->world->geoms[b->geom], b->x + 3 * i, b->motion);
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

// One geom's pairs rebuilt alone (a partial rebuild), into merged_*: the spheres in reach at
// their current places, each reach widened by what the sphere moved since the snapshot
// (geom_moved), and each distance stored less it. A pair left out was farther than
// r + m + moved(snapshot -> now) away; until the next whole build no sphere moves past half
// the margin from the snapshot (so at most moved(snapshot -> now) + m / 2 from now) and this
// geom moves less than m / 2 from here: it stays beyond r. The same bound keeps the skip filter
// of a stored distance less the sphere's motion since the snapshot valid.
static int collect_geom_alone(const vsc_rod* rod, vsc_contact_lists* l, const double* xyz, const vsc_world* world, int g,
                              int count) {
  const vsc_geom* geom = &world->geoms[g];
  int spheres = rod->def.collision_sphere_count;
  double r = rod->radius_max, margin = VSC_CONTACT_MARGIN * r, reach = r + margin;
  for (int i = 0; i < spheres; ++i) {
    const double* x = xyz + 3 * i;
    double widened = reach + l->geom_moved[i];
    if (geom->bound_radius > 0.0) {  // the box test of a whole build, widened alike
      double w = r + 0.5 * margin + l->geom_moved[i];
      if (x[0] + w < geom->box[0] - 0.5 * margin || x[0] - w > geom->box[3] + 0.5 * margin ||
          x[1] + w < geom->box[1] - 0.5 * margin || x[1] - w > geom->box[4] + 0.5 * margin ||
          x[2] + w < geom->box[2] - 0.5 * margin || x[2] - w > geom->box[5] + 0.5 * margin)
        continue;
    }
    double distance = filter_distance(geom, x, margin + l->geom_moved[i]);
    if (distance > widened) continue;
    if (count >= l->geom_capacity) return -1;
    l->merged_pairs[2 * count] = g;
    l->merged_pairs[2 * count + 1] = i;
    l->merged_distance[count] = distance - l->geom_moved[i];
    ++count;
  }
  return count;
}

// Rebuild the stale geoms' pairs alone (geom_stale), keeping every other geom's, in the
// list's order (geom, then sphere): what a whole build would test, found in the same
// order. Returns 0 if the list overflowed.
static int rebuild_stale_geoms(const vsc_rod* rod, vsc_contact_lists* l, const double* x, const vsc_world* world) {
  int count = 0, k = 0;
  for (int g = 0; g < world->geom_count; ++g) {
    int first = k;
    while (k < l->geom_count && l->geom_pairs[2 * k] == g) ++k;
    if (l->geom_stale[g]) {
      count = collect_geom_alone(rod, l, x, world, g, count);
      if (count < 0) return 0;
      double* pose = l->geom_pose + VSC_GEOM_POSE_SIZE * g;
      memcpy(pose, world->geoms[g].position, sizeof(double) * 3);
      memcpy(pose + 3, world->geoms[g].rotation, sizeof(double) * 9);
      memcpy(pose + 12, world->geoms[g].size, sizeof(double) * 3);
      l->geom_pose[VSC_GEOM_POSE_SIZE * (size_t)l->built_geom_capacity + g] = 0.0;  // its shift: none since
      continue;
    }
    memcpy(l->merged_pairs + 2 * count, l->geom_pairs + 2 * first, sizeof(int) * 2 * (size_t)(k - first));
    memcpy(l->merged_distance + count, l->geom_distance + first, sizeof(double) * (size_t)(k - first));
    count += k - first;
  }
  int* pairs = l->geom_pairs;
  double* distance = l->geom_distance;
  l->geom_pairs = l->merged_pairs, l->geom_distance = l->merged_distance;
  l->merged_pairs = pairs, l->merged_distance = distance;
  l->geom_count = count;
  return 1;
}

static void no_pair(void* context, int earlier, int item) { (void)context; (void)earlier; (void)item; }

// Midpoint and half length of every segment (m) into l->segment, from the placed spheres x.
static void update_segments(const vsc_rod* rod, vsc_contact_lists* l, const double* x) {
  for (int a = 0; a + 1 < rod->def.collision_sphere_count; ++a) {
    double* out = l->segment + 4 * a;
    double length2 = 0.0;
    for (int c = 0; c < 3; ++c) {
      out[c] = 0.5 * (x[3 * a + c] + x[3 * a + 3 + c]);
      length2 += (x[3 * a + 3 + c] - x[3 * a + c]) * (x[3 * a + 3 + c] - x[3 * a + c]);
    }
    out[3] = 0.5 * sqrt(length2);
  }
}

// The same pairs as build_self_direct, by testing every pair in order: for a pile with more
// candidates than the list holds pairs (the list may still hold those that touch).
static void build_self_every_pair(const vsc_rod* rod, build* b) {
  const double* mx = b->l->build_scratch;
  int segments = rod->def.collision_sphere_count - 1;
  const double *my = mx + segments, *mz = my + segments, *half = mz + segments;
  for (int a = 0; a < segments && !b->overflow; ++a)
    for (int c = a + rod->self_gap; c < segments && !b->overflow; ++c) {
      double dx = mx[c] - mx[a], dy = my[c] - my[a], dz = mz[c] - mz[a], r = half[a] + half[c];
      if (dx * dx + dy * dy + dz * dz - r * r <= 0.0) keep_self(b, a, c);
    }
}

// The segment pairs beyond the neighbours whose bounding spheres, grown by half the pair reach
// each, overlap (midpoints within 2r + m + both half lengths), then the exact distance. For
// chains up to DIRECT_BUILD_SPHERES, a sweep along x: the segments sorted by their midpoints'
// x (the last build's order, sorted again by insertion: the chain moved little since, so
// nearly sorted), each tested against those after it until their x alone rules the rest out.
// A pile's cells at the pair reach hold dozens of segments, where a grid pass costs more.
// The candidates are then put in (a, c) order, so the pairs and their distances are those, in
// the order, that testing every pair would find.
static void build_self_direct(const vsc_rod* rod, build* b) {
  vsc_contact_lists* l = b->l;
  update_segments(rod, l, b->x);
  int segments = rod->def.collision_sphere_count - 1;
  double limit = (2.0 + VSC_CONTACT_MARGIN) * rod->radius_max;
  const double* seg = l->segment;  // midpoints and half lengths, current
  double* mx = l->build_scratch;
  double* my = mx + segments;
  double* mz = my + segments;
  double* half = mz + segments;
  double widest = 0.0, sum = 0.0;
  for (int a = 0; a < segments; ++a) {
    mx[a] = seg[4 * a];
    my[a] = seg[4 * a + 1];
    mz[a] = seg[4 * a + 2];
    half[a] = seg[4 * a + 3] + 0.5 * limit;
    widest = half[a] > widest ? half[a] : widest;
    sum += mx[a] + my[a] + mz[a] + half[a];
  }
  if (!isfinite(sum)) {  // a diverged chain: no order to sort by, test every pair as before
    build_self_every_pair(rod, b);
    return;
  }
  int* order = l->sweep_order;  // segment indices by midpoint x
  for (int k = 1; k < segments; ++k) {
    int item = order[k], j = k;
    while (j > 0 && mx[order[j - 1]] > mx[item]) {
      order[j] = order[j - 1];
      --j;
    }
    order[j] = item;
  }
  // the midpoints and grown half lengths in that order, side by side
  double* sorted_x = half + segments;
  double* sorted_y = sorted_x + segments;
  double* sorted_z = sorted_y + segments;
  double* sorted_half = sorted_z + segments;
  double* excess = sorted_half + segments;  // per sorted segment: squared distance less squared reach
  for (int k = 0; k < segments; ++k) {
    sorted_x[k] = mx[order[k]];
    sorted_y[k] = my[order[k]];
    sorted_z[k] = mz[order[k]];
    sorted_half[k] = half[order[k]];
  }
  // the candidates (lo, hi), counted per lo and per hi
  int* lo_count = order + segments;       // segments + 1 each: counts, then each bucket's first slot
  int* hi_count = lo_count + segments + 1;
  int* lo_next = hi_count + segments + 1;  // segments: each lo bucket's next slot
  int capacity = l->self_capacity, candidates = 0;
  int *found_lo = l->sweep_pairs, *found_hi = found_lo + capacity, *by_hi = found_hi + capacity;
  memset(lo_count, 0, sizeof(int) * 2 * ((size_t)segments + 1));
  for (int k = 0; k < segments; ++k) {
    // apart in x by more than both grown half lengths, no pair can pass the test below (the
    // slack keeps every pair it could pass)
    double x = sorted_x[k], y = sorted_y[k], z = sorted_z[k], ha = sorted_half[k];
    double window = (ha + widest) * (1.0 + 1e-9);
    int end = k + 1;
    while (end < segments && sorted_x[end] - x <= window) ++end;
    // the squared midpoint distance less the squared reach, as testing every pair computes it
    // (a difference's square and a sum do not depend on the pair's order)
    for (int j = k + 1; j < end; ++j) {
      double dx = sorted_x[j] - x, dy = sorted_y[j] - y, dz = sorted_z[j] - z, r = ha + sorted_half[j];
      excess[j] = dx * dx + dy * dy + dz * dz - r * r;
    }
    int a = order[k];
    for (int j = k + 1; j < end; ++j) {
      if (!(excess[j] <= 0.0)) continue;
      int c = order[j], lo = a < c ? a : c, hi = a < c ? c : a;
      if (hi - lo < rod->self_gap) continue;
      if (candidates >= capacity) {  // more candidates than the list holds pairs: test them all
        build_self_every_pair(rod, b);
        return;
      }
      found_lo[candidates] = lo;
      found_hi[candidates] = hi;
      ++candidates;
      ++lo_count[lo + 1];
      ++hi_count[hi + 1];
    }
  }
  // into (lo, hi) order by two stable counting sorts: by hi, then by lo
  for (int a = 0; a < segments; ++a) {
    lo_count[a + 1] += lo_count[a];
    hi_count[a + 1] += hi_count[a];
  }
  for (int k = 0; k < candidates; ++k) by_hi[hi_count[found_hi[k]]++] = found_lo[k];  // now each bucket's end
  int* his = found_lo;  // read no more
  memcpy(lo_next, lo_count, sizeof(int) * (size_t)segments);
  for (int hi = 0, k = 0; hi < segments; ++hi)
    for (; k < hi_count[hi]; ++k) his[lo_next[by_hi[k]]++] = hi;
  for (int a = 0; a < segments; ++a)
    for (int k = lo_count[a]; k < lo_count[a + 1] && !b->overflow; ++k) keep_self(b, a, his[k]);
}

// The self pairs: segments within 2r + m, with their distances. Returns 0 if
// the list overflowed (the caller then evaluates without lists).
static int build_self(const vsc_rod* rod, vsc_contact_lists* l, const double* x, const vsc_world* world) {
  int spheres = rod->def.collision_sphere_count;
  double r = rod->radius_max, margin = VSC_CONTACT_MARGIN * r, inflated = r + 0.5 * margin;
  build b = {rod, l, x, world, -1, r + margin, margin, 0};
  l->self_count = 0;
  if (spheres <= DIRECT_BUILD_SPHERES) {
    build_self_direct(rod, &b);
  } else {  // a grid pass over segment boxes inflated by half the margin, sized to the longest segment
    double longest = 0.0;
    for (int k = 0; k + 1 < spheres; ++k)
      for (int a = 0; a < 3; ++a)
        longest = fmax(longest, fabs(x[3 * k + 3 + a] - x[3 * k + a]));
    vsc_grid_begin(l->grid, (longest + 2.0 * inflated) * (1.0 + 1e-6));
    for (int k = 0; k + 1 < spheres; ++k) {
      const double* x0 = x + 3 * k;
      const double* x1 = x0 + 3;
      double lo[3], hi[3];
      for (int a = 0; a < 3; ++a) {
        lo[a] = fmin(x0[a], x1[a]) - inflated;
        hi[a] = fmax(x0[a], x1[a]) + inflated;
      }
      vsc_grid_insert(l->grid, k, lo, hi, collect_self, &b);  // boxes under a cell: cannot fail
    }
    sort_pairs(l->self_pairs, l->self_count);
    for (int k = 0; k < l->self_count; ++k) {  // the distances, in the sorted order
      double s, t, d[3];
      l->self_distance[k] = vsc_segment_gap(x, l->self_pairs[2 * k], l->self_pairs[2 * k + 1], &s, &t, d);
    }
  }
  memcpy(l->sphere_xyz, x, sizeof(double) * 3 * (size_t)spheres);
  l->self_built = !b.overflow;
  return l->self_built;
}

// The (geom, sphere) pairs: for a few hundred spheres, each geom against every
// sphere in its box (no hashing); else a grid pass over sphere boxes, then a
// query per geom. Built apart from the self pairs, so a tool moving through a
// resting bowel costs only this. Returns 0 if the list overflowed.
static int build_geoms(const vsc_rod* rod, vsc_contact_lists* l, const double* xyz, const vsc_world* world) {
  int spheres = rod->def.collision_sphere_count;
  double r = rod->radius_max, margin = VSC_CONTACT_MARGIN * r, inflated = r + 0.5 * margin;
  build b = {rod, l, xyz, world, -1, r + margin, margin, 0};
  l->geom_count = 0;
  double rod_box[6] = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
  int direct = spheres <= DIRECT_BUILD_SPHERES;
  if (!direct) vsc_grid_begin(l->grid, 2.0 * inflated * (1.0 + 1e-6));  // a hair above a box: <= 2 cells per axis
  for (int i = 0; i < spheres; ++i) {
    const double* x = xyz + 3 * i;
    double lo[3] = {x[0] - inflated, x[1] - inflated, x[2] - inflated};
    double hi[3] = {x[0] + inflated, x[1] + inflated, x[2] + inflated};
    for (int a = 0; a < 3; ++a) {
      rod_box[a] = lo[a] < rod_box[a] ? lo[a] : rod_box[a];
      rod_box[3 + a] = hi[a] > rod_box[3 + a] ? hi[a] : rod_box[3 + a];
    }
    if (!direct) vsc_grid_insert(l->grid, i, lo, hi, no_pair, &b);
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
            const double* x = xyz + 3 * i;
            if (x[0] + inflated >= lo[0] && x[0] - inflated <= hi[0] && x[1] + inflated >= lo[1] &&
                x[1] - inflated <= hi[1] && x[2] + inflated >= lo[2] && x[2] - inflated <= hi[2])
              collect_geom(&b, i);
          }
      } else {
        visited = vsc_grid_query(l->grid, lo, hi, 8 * spheres, collect_geom, &b);
      }
    }
    if (visited < 0)  // unbounded (planes), or a box over more cells than spheres: test all
      for (int i = 0; i < spheres; ++i) collect_geom(&b, i);
    if (!direct) {  // grid order: sort, then the distances in that order
      sort_pairs(l->geom_pairs + 2 * first, l->geom_count - first);
      for (int k = first; k < l->geom_count; ++k)
        l->geom_distance[k] = filter_distance(geom, xyz + 3 * l->geom_pairs[2 * k + 1], b.motion);
    }
  }
  memcpy(l->geom_sphere_xyz, xyz, sizeof(double) * 3 * (size_t)spheres);
  if (world->geom_count > l->built_geom_capacity) {
    double* poses = (double*)realloc(l->geom_pose, sizeof(double) * (VSC_GEOM_POSE_SIZE + 1) * (size_t)world->geom_count);
    if (!poses) return 0;
    l->geom_pose = poses;
    unsigned char* stale = (unsigned char*)realloc(l->geom_stale, (size_t)world->geom_count);
    if (!stale) return 0;
    l->geom_stale = stale;
    l->built_geom_capacity = world->geom_count;
  }
  for (int g = 0; g < world->geom_count; ++g) {
    double* pose = l->geom_pose + VSC_GEOM_POSE_SIZE * g;
    memcpy(pose, world->geoms[g].position, sizeof(double) * 3);
    memcpy(pose + 3, world->geoms[g].rotation, sizeof(double) * 9);
    memcpy(pose + 12, world->geoms[g].size, sizeof(double) * 3);
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
static int sphere_moves(const vsc_rod* rod, const double* x, const double* snapshot, double* moved) {
  double half = 0.5 * VSC_CONTACT_MARGIN * rod->radius_max;
  int spheres = rod->def.collision_sphere_count;
  distances_moved(x, snapshot, moved, spheres);
  double most = 0.0;
  for (int i = 0; i < spheres; ++i) most = moved[i] > most ? moved[i] : most;
  return most <= half;  // NaN: never valid
}

// The self pairs still hold every possible self-contact while no sphere moved
// by half the margin since they were built.
static int self_valid(const vsc_rod* rod, vsc_contact_lists* l, const double* x) {
  if (!l->self_built || !sphere_moves(rod, x, l->sphere_xyz, l->moved)) return 0;
  for (int a = 0; a + 1 < rod->def.collision_sphere_count; ++a)
    l->segment_moved[a] = l->moved[a] > l->moved[a + 1] ? l->moved[a] : l->moved[a + 1];
  return 1;
}

// The most any surface point of `geom` moved since its build `pose` (m): |dp| + R ||dR||_F + the
// sum of the size changes for a bounded geom; for an unbounded one (a plane), 0 if it did not
// move at all, else infinity (its far parts may have swept anywhere).
static double geom_shift(const vsc_geom* geom, const double* pose) {
  double moved = 0.0, turned = 0.0, grown = 0.0;
  for (int a = 0; a < 3; ++a) moved += (geom->position[a] - pose[a]) * (geom->position[a] - pose[a]);
  for (int a = 0; a < 9; ++a) turned += (geom->rotation[a] - pose[3 + a]) * (geom->rotation[a] - pose[3 + a]);
  for (int a = 0; a < 3; ++a) grown += fabs(geom->size[a] - pose[12 + a]);
  if (geom->bound_radius > 0.0) return sqrt(moved) + geom->bound_radius * sqrt(turned) + grown;
  return moved != 0.0 || turned != 0.0 || grown != 0.0 ? INFINITY : 0.0;
}

// Whole geom builds kept while a few geoms move: past this share of the geoms
// stale at once, a whole build costs no more than rebuilding them alone.
#define STALE_GEOMS_SHARE 0.25

// The geom pairs still hold every possible contact while no sphere moved by
// half the margin since the last whole build, nor any geom since its own
// build. Writes each geom's surface motion bound after the poses, and marks
// the geoms past it stale (geom_stale). Returns 1 if none is, 2 if a few are
// (rebuild those alone: rebuild_stale_geoms), 0 if a whole build is due.
static int geoms_valid(const vsc_rod* rod, vsc_contact_lists* l, const double* x, const vsc_world* world) {
  if (!l->geoms_built || l->built_geoms != world->geom_count || l->geoms != world->geoms) return 0;
  if (!sphere_moves(rod, x, l->geom_sphere_xyz, l->geom_moved)) return 0;
  double half = 0.5 * VSC_CONTACT_MARGIN * rod->radius_max;
  int stale = 0;
  double* shift = l->geom_pose + VSC_GEOM_POSE_SIZE * (size_t)l->built_geom_capacity;
  for (int g = 0; g < world->geom_count; ++g) {
    const vsc_geom* geom = &world->geoms[g];
    shift[g] = geom_shift(geom, l->geom_pose + VSC_GEOM_POSE_SIZE * g);
    if (!(geom->bound_radius > 0.0) && shift[g] > 0.0)
      return 0;  // an unbounded geom (plane) moved: its far parts may have swept anywhere
    l->geom_stale[g] = !(shift[g] <= half);  // NaN: stale
    stale += l->geom_stale[g];
  }
  if (stale == 0) return 1;
  // alone only in the direct build's range (a grid pass's order is sorted after, its grid reused)
  return rebuilds_geoms_alone(rod->def.collision_sphere_count) && stale <= STALE_GEOMS_SHARE * world->geom_count ? 2 : 0;
}

int vsc_contact_lists_refresh(const vsc_rod* rod, vsc_contact_lists* l, const double* x, const vsc_world* world) {
  int self_fresh = 0, geoms_fresh = 0, spheres = rod->def.collision_sphere_count;
  int self_ok = !rod->def.self_collision || self_valid(rod, l, x) || (self_fresh = 1, build_self(rod, l, x, world));
  int geoms_state = geoms_valid(rod, l, x, world);
  int geoms_ok = geoms_state == 1 || (geoms_state == 2 && rebuild_stale_geoms(rod, l, x, world)) ||
                 (geoms_fresh = 1, build_geoms(rod, l, x, world));
  if (!self_ok || !geoms_ok) {  // a list overflowed (an extreme pile): the narrow phase tests every pair
    l->self_built = l->geoms_built = 0;
    if (rod->def.self_collision) update_segments(rod, l, x);
    return 0;
  }
  // just built: nothing moved since
  if (self_fresh) memset(l->segment_moved, 0, sizeof(double) * (size_t)spheres);
  if (geoms_fresh) {
    memset(l->geom_moved, 0, sizeof(double) * (size_t)spheres);
    if (world->geom_count > 0)  // (no geoms: no poses allocated)
      memset(l->geom_pose + VSC_GEOM_POSE_SIZE * (size_t)l->built_geom_capacity, 0,
             sizeof(double) * (size_t)world->geom_count);
  }
  return 1;
}

// 1 if every sphere at control points q lies within half the margin of `snapshot` (3 per
// sphere), each placed where it is needed; no writes.
static int spheres_within(const vsc_rod* rod, const double* q, const double* snapshot) {
  double half = 0.5 * VSC_CONTACT_MARGIN * rod->radius_max;
  for (int i = 0; i < rod->def.collision_sphere_count; ++i) {
    double x[3];
    vsc_basis_point(&rod->sphere_basis[i], q, x);
    double dx = x[0] - snapshot[3 * i], dy = x[1] - snapshot[3 * i + 1], dz = x[2] - snapshot[3 * i + 2];
    if (!(sqrt(dx * dx + dy * dy + dz * dz) <= half)) return 0;
  }
  return 1;
}

int vsc_contact_lists_cover(const vsc_contact_lists* l, const vsc_rod* rod, const double* q, const vsc_world* world) {
  if (rod->def.self_collision && !(l->self_built && spheres_within(rod, q, l->sphere_xyz))) return 0;
  if (!l->geoms_built || l->built_geoms != world->geom_count || l->geoms != world->geoms ||
      !spheres_within(rod, q, l->geom_sphere_xyz))
    return 0;
  double half = 0.5 * VSC_CONTACT_MARGIN * rod->radius_max;
  for (int g = 0; g < world->geom_count; ++g)  // as geoms_valid: no geom past half the margin
    if (!(geom_shift(&world->geoms[g], l->geom_pose + VSC_GEOM_POSE_SIZE * g) <= half)) return 0;
  return 1;
}
