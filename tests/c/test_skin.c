// Skin: closed, outward, the right radius and volume, frames that do not twist.
#include <stdlib.h>

#include "viscera/vsc_layout.h"
#include "viscera/vsc_skin.h"
#include "vsc_test.h"

typedef struct mesh {
  int vertices, triangles;
  double *v, *normal;
  int* tri;
} mesh;

static mesh build(const double* q, int n, vsc_skin_def def) {
  mesh s = {vsc_skin_vertex_count(n, &def), vsc_skin_triangle_count(n, &def), 0, 0, 0};
  s.v = malloc(sizeof(double) * 3 * s.vertices);
  s.normal = malloc(sizeof(double) * 3 * s.vertices);
  s.tri = malloc(sizeof(int) * 3 * s.triangles);
  ENSURE(vsc_skin_build(q, n, &def, s.v, s.normal, s.tri) == VSC_OK);
  return s;
}

static void release(mesh* s) { free(s->v); free(s->normal); free(s->tri); }

// Signed volume by the divergence theorem: positive iff triangles face outwards.
static double volume(const mesh* s) {
  double total = 0;
  for (int f = 0; f < s->triangles; ++f) {
    const double *a = s->v + 3 * s->tri[3 * f], *b = s->v + 3 * s->tri[3 * f + 1], *c = s->v + 3 * s->tri[3 * f + 2];
    total += (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])) / 6.0;
  }
  return total;
}

// Closed and consistently oriented: every directed edge appears once and its reverse once.
static int closed(const mesh* s) {
  int nv = s->vertices, bad = 0;
  int* count = calloc((size_t)nv * nv, sizeof(int));
  for (int f = 0; f < s->triangles; ++f)
    for (int e = 0; e < 3; ++e) count[s->tri[3 * f + e] * nv + s->tri[3 * f + (e + 1) % 3]]++;
  for (int i = 0; i < nv; ++i)
    for (int j = 0; j < nv; ++j)
      if (count[i * nv + j] > 1 || (count[i * nv + j] == 1 && count[j * nv + i] != 1)) bad++;
  free(count);
  return bad == 0;
}

static void straight_tube(void) {
  double q[30], start[3] = {0, 0, 0}, dir[3] = {1, 1, 0};
  vsc_layout_line(10, 0.5, start, dir, q);
  vsc_skin_def def = vsc_default_skin_def();
  def.ring_points = 24;
  mesh s = build(q, 10, def);
  ENSURE(closed(&s));
  double r = def.radius_max, m = def.ring_points;
  double polygon = 0.5 * m * sin(2 * 3.14159265358979 / m) * r * r;  // inscribed polygon area
  ENSURE_NEAR(volume(&s), polygon * 0.5, 1e-9);
  for (int i = 0; i < s.vertices - 2; ++i) {  // every ring vertex at the radius, normal radial
    const double* v = s.v + 3 * i;
    double along = (v[0] + v[1]) / sqrt(2.0);
    double radial = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] - along * along);
    ENSURE_NEAR(radial, r, 1e-12);
  }
  release(&s);
}

static void radius_profile_and_planar_frames(void) {
  enum { n = 40 };
  double q[3 * n];
  for (int k = 0; k < n; ++k) {  // a planar wave: twist-free frames keep b along z
    double x = 0.02 * k;
    q[3 * k] = x; q[3 * k + 1] = 0.05 * sin(8 * x); q[3 * k + 2] = 0;
  }
  vsc_skin_def def = {4, 12, 0.008, 0.012, 1.0};
  mesh s = build(q, n, def);
  ENSURE(closed(&s));
  ENSURE(volume(&s) > 0);
  int m = def.ring_points, rings = (n - 1) * def.rings_per_segment + 1;
  for (int r = 0; r < rings; ++r) {
    // ring vertex 0 lies along k; a planar curve's twist-free k stays in the plane
    ENSURE_NEAR(s.normal[3 * (r * m) + 2], 0.0, 1e-9);
    const double* c0 = s.v + 3 * (r * m);
    const double* c6 = s.v + 3 * (r * m + m / 2);  // opposite vertex: the ring's diameter
    double diameter = sqrt(pow(c0[0] - c6[0], 2) + pow(c0[1] - c6[1], 2) + pow(c0[2] - c6[2], 2));
    double u = (double)(r % def.rings_per_segment) / def.rings_per_segment;
    double expected = def.radius_min + pow(cos(3.14159265358979 * u), 2) * (def.radius_max - def.radius_min);
    ENSURE_NEAR(diameter / 2, expected, 1e-12);  // R_max at control points, R_min midway
  }
  release(&s);
}

static void no_jump_across_segments(void) {
  enum { n = 30 };
  double q[3 * n];
  for (int k = 0; k < n; ++k) {  // a helix: frames must turn smoothly, ring to ring
    double a = 0.3 * k;
    q[3 * k] = 0.05 * cos(a); q[3 * k + 1] = 0.05 * sin(a); q[3 * k + 2] = 0.01 * k;
  }
  vsc_skin_def def = vsc_default_skin_def();
  mesh s = build(q, n, def);
  ENSURE(closed(&s));
  int m = def.ring_points, rings = (n - 1) * def.rings_per_segment + 1;
  double worst = 0;
  for (int r = 0; r + 1 < rings; ++r) {
    const double *k0 = s.normal + 3 * (r * m), *k1 = s.normal + 3 * ((r + 1) * m);
    double c = k0[0] * k1[0] + k0[1] * k1[1] + k0[2] * k1[2];
    worst = fmax(worst, acos(fmin(1.0, c)));
  }
  ENSURE(worst < 0.15);  // the tangent turns by ~0.07 rad a ring: k follows, never jumps
  release(&s);
}

int main(void) {
  RUN(straight_tube);
  RUN(radius_profile_and_planar_frames);
  RUN(no_jump_across_segments);
  TEST_MAIN_END();
}
