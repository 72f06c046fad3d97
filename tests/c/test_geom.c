// Signed distances and normals of each primitive against hand-computed values.
#include "viscera/vsc_geom.h"
#include "vsc_test.h"

static vsc_geom make(vsc_geom_type type, double sx, double sy, double sz) {
  vsc_geom g = {0};
  g.type = type;
  g.rotation[0] = g.rotation[4] = g.rotation[8] = 1.0;
  g.size[0] = sx; g.size[1] = sy; g.size[2] = sz;
  return g;
}

static void check(const vsc_geom* g, double x, double y, double z, double distance, double nx, double ny, double nz) {
  double p[3] = {x, y, z}, n[3];
  ENSURE_NEAR(vsc_geom_distance(g, p, n), distance, 1e-12);
  ENSURE_NEAR(n[0], nx, 1e-12);
  ENSURE_NEAR(n[1], ny, 1e-12);
  ENSURE_NEAR(n[2], nz, 1e-12);
}

static void primitives(void) {
  vsc_geom plane = make(VSC_GEOM_PLANE, 0, 0, 0);
  check(&plane, 3, 4, -0.25, -0.25, 0, 0, 1);
  vsc_geom sphere = make(VSC_GEOM_SPHERE, 1, 0, 0);
  check(&sphere, 0, 3, 0, 2, 0, 1, 0);
  vsc_geom capsule = make(VSC_GEOM_CAPSULE, 0.5, 2, 0);
  check(&capsule, 1, 0, 1.5, 0.5, 1, 0, 0);
  check(&capsule, 0, 0, 3, 0.5, 0, 0, 1);
  vsc_geom cylinder = make(VSC_GEOM_CYLINDER, 1, 1, 0);
  check(&cylinder, 0, 0, 0.9, -0.1, 0, 0, 1);     // inside, nearest a cap
  check(&cylinder, 0.95, 0, 0, -0.05, 1, 0, 0);   // inside, nearest the side
  check(&cylinder, 4, 0, 5, 5, 0.6, 0, 0.8);      // outside, nearest the rim
  vsc_geom box = make(VSC_GEOM_BOX, 1, 2, 3);
  check(&box, 0, 0, 2.5, -0.5, 0, 0, 1);
  check(&box, 4, 6, 0, 5, 0.6, 0.8, 0);
}

static void rotated_and_moving(void) {
  vsc_geom plane = make(VSC_GEOM_PLANE, 0, 0, 0);
  // local z along world x: rotation columns (0,0,1)->x ... row-major R with R e_z = e_x
  double R[9] = {0, 0, 1, 0, 1, 0, -1, 0, 0};
  for (int i = 0; i < 9; ++i) plane.rotation[i] = R[i];
  plane.position[0] = 1.0;
  check(&plane, 3, 7, 7, 2, 1, 0, 0);
  vsc_geom g = make(VSC_GEOM_SPHERE, 1, 0, 0);
  g.linear_velocity[0] = 1.0;
  g.angular_velocity[2] = 2.0;  // about z
  double p[3] = {0, 1, 0}, v[3];
  vsc_geom_point_velocity(&g, p, v);
  ENSURE_NEAR(v[0], 1.0 - 2.0, 1e-15);  // w x r = (0,0,2) x (0,1,0) = (-2,0,0)
  ENSURE_NEAR(v[1], 0.0, 1e-15);
}


// A 2 x 2 x 2 cube as a convex polytope: 12 triangles with outward planes.
static void cube_polytope(double planes[48], double triangles[108]) {
  static const int quads[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
  double v[8][3];
  for (int i = 0; i < 8; ++i) {
    v[i][0] = (i & 4) ? 1 : -1;
    v[i][1] = (i & 2) ? 1 : -1;
    v[i][2] = (i & 1) ? 1 : -1;
  }
  for (int q = 0; q < 6; ++q) {
    double centre[3] = {0, 0, 0};
    for (int k = 0; k < 4; ++k)
      for (int a = 0; a < 3; ++a) centre[a] += v[quads[q][k]][a] / 4.0;
    for (int half = 0; half < 2; ++half) {
      int f = 2 * q + half, idx[3] = {quads[q][0], quads[q][1 + half], quads[q][2 + half]};
      for (int k = 0; k < 3; ++k)
        for (int a = 0; a < 3; ++a) triangles[9 * f + 3 * k + a] = v[idx[k]][a];
      for (int a = 0; a < 3; ++a) planes[4 * f + a] = centre[a];  // the face centre is its unit normal
      planes[4 * f + 3] = 1.0;
    }
  }
}

static void new_primitives(void) {
  vsc_geom ellipsoid = make(VSC_GEOM_ELLIPSOID, 1, 2, 3);
  check(&ellipsoid, 0, 0, 4, 1, 0, 0, 1);     // on an axis
  check(&ellipsoid, 0, 1.5, 0, -0.5, 0, 1, 0);
  // anywhere, inside and out, even for a flat one: against the nearest of 400k surface samples
  vsc_geom thin = make(VSC_GEOM_ELLIPSOID, 0.2, 0.2, 0.01);
  const vsc_geom* shapes[2] = {&ellipsoid, &thin};
  double probes[4][3] = {{0.7, 1.1, 2.4}, {0.3, -0.4, 0.5}, {0.15, 0.1, 0.05}, {0.05, 0.02, 0.004}};
  for (int e = 0; e < 2; ++e)
    for (int k = 0; k < 4; ++k) {
      const double* s = shapes[e]->size;
      double best = INFINITY, p[3] = {probes[k][0], probes[k][1], probes[k][2]}, nrm[3];
      for (int i = 0; i <= 400; ++i)
        for (int j = 0; j < 1000; ++j) {
          double th = 3.14159265358979 * i / 400, ph = 2 * 3.14159265358979 * j / 1000;
          double x = s[0] * sin(th) * cos(ph) - p[0], y = s[1] * sin(th) * sin(ph) - p[1], z = s[2] * cos(th) - p[2];
          best = fmin(best, sqrt(x * x + y * y + z * z));
        }
      double inside = p[0] * p[0] / (s[0] * s[0]) + p[1] * p[1] / (s[1] * s[1]) + p[2] * p[2] / (s[2] * s[2]) < 1;
      ENSURE_NEAR(vsc_geom_distance(shapes[e], p, nrm), inside ? -best : best, 2e-3 * fmax(s[0], fmax(s[1], s[2])));
    }
  double planes[48], triangles[108];
  cube_polytope(planes, triangles);
  vsc_convex cube = {12, planes, triangles};
  vsc_geom convex = make(VSC_GEOM_CONVEX, 0, 0, 0);
  convex.convex = &cube;
  check(&convex, 0, 0, 0.75, -0.25, 0, 0, 1);  // inside: nearest face
  check(&convex, 0.2, 0.3, 3, 2, 0, 0, 1);     // over a face
  check(&convex, 4, 5, 0, 5, 0.6, 0.8, 0);     // over an edge: exact, not the planes' 4
  double p[3] = {2, 2, 2}, n[3];
  ENSURE_NEAR(vsc_geom_distance(&convex, p, n), sqrt(3.0), 1e-12);  // corner
  float flat[4] = {0.5f, 0.5f, 0.5f, 0.5f}, slope[4] = {0.0f, 1.0f, 0.0f, 1.0f};  // rising along x
  vsc_heightfield field = {2, 2, flat, {1, 1, 2, 0.5}};
  vsc_geom heightfield = make(VSC_GEOM_HEIGHTFIELD, 0, 0, 0);
  heightfield.heightfield = &field;
  check(&heightfield, 0.3, -0.2, 1.25, 0.25, 0, 0, 1);  // 0.25 above the flat surface at 1
  double outside[3] = {1.5, 0, 1};
  ENSURE(isinf(vsc_geom_distance(&heightfield, outside, n)));
  field.elevation = slope;  // z = x + 1 over [-1, 1]: 45 degrees
  check(&heightfield, 0, 0, 2, 1 / sqrt(2.0), -1 / sqrt(2.0), 0, 1 / sqrt(2.0));
}

// A height field's distance and normal are continuous across its cells' edges,
// where the bilinear patches' own slopes jump (a resting sphere that crossed one
// was kicked: an energy source that kept the colon bouncing on the posterior wall).
static void heightfield_continuous(void) {
  // 1 row of cells over x in [-1, 1], 4 columns: flat, then a rise of 1 per cell, then flat
  float kink[8] = {0.0f, 0.0f, 1.0f, 1.0f, 0.0f, 0.0f, 1.0f, 1.0f};
  vsc_heightfield field = {2, 4, kink, {1.5, 1, 1, 0.5}};  // cells 1 m wide, heights in m
  vsc_geom g = make(VSC_GEOM_HEIGHTFIELD, 0, 0, 0);
  g.heightfield = &field;
  for (int edge = 0; edge < 2; ++edge) {  // the interior edges at x = -0.5 and 0.5
    double x = edge ? 0.5 : -0.5, below[3] = {x - 1e-9, 0.3, 1.2}, above[3] = {x + 1e-9, 0.3, 1.2}, na[3], nb[3];
    double da = vsc_geom_distance(&g, below, na), db = vsc_geom_distance(&g, above, nb);
    ENSURE_NEAR(da, db, 1e-8);
    for (int c = 0; c < 3; ++c) ENSURE_NEAR(na[c], nb[c], 1e-8);
  }
  // at a grid vertex the slope is the central difference: 1/2 at the foot of the rise
  double foot[3] = {-0.5, 0, 1}, n[3];
  ENSURE_NEAR(vsc_geom_distance(&g, foot, n), 1 / sqrt(1.25), 1e-12);
  ENSURE_NEAR(n[0], -0.5 / sqrt(1.25), 1e-12);
  ENSURE_NEAR(n[2], 1 / sqrt(1.25), 1e-12);
}

// The vertex records a host writes once (vsc_heightfield_vertices) give the very bits a query
// derives without them, anywhere over a rough field.
static void heightfield_vertices_same_bits(void) {
  enum { ROWS = 5, COLUMNS = 7 };
  float rough[ROWS * COLUMNS];
  for (int k = 0; k < ROWS * COLUMNS; ++k) rough[k] = (float)(0.5 + 0.5 * sin(1.7 * k) * cos(0.3 * k * k));
  vsc_heightfield derived = {ROWS, COLUMNS, rough, {0.3, 0.2, 0.1, 0.02}};
  vsc_heightfield kept = derived;
  double vertices[3 * ROWS * COLUMNS];
  ENSURE(vsc_heightfield_vertex_size(&kept) == 3 * ROWS * COLUMNS);
  vsc_heightfield_vertices(&kept, vertices);
  kept.vertices = vertices;
  vsc_geom a = make(VSC_GEOM_HEIGHTFIELD, 0.01, -0.02, 0.005), b = a;
  a.heightfield = &derived;
  b.heightfield = &kept;
  for (int k = 0; k < 500; ++k) {  // spread over the field and past its sides
    double p[3] = {0.35 * sin(0.91 * k), 0.25 * cos(1.33 * k), 0.06 * sin(0.27 * k) + 0.05}, na[3], nb[3];
    double da = vsc_geom_distance(&a, p, na), db = vsc_geom_distance(&b, p, nb);
    ENSURE(da == db || (isinf(da) && isinf(db)));
    for (int c = 0; c < 3; ++c) ENSURE(na[c] == nb[c]);
  }
}

// A height field's distance bound holds: wherever a point moves within the reach, it stays
// at least the bound less its move from the surface while that is positive, over a rough,
// steep field, around its sides and under its base; and it skips most points above it.
static void heightfield_bound_holds(void) {
  enum { ROWS = 9, COLUMNS = 11 };
  float rough[ROWS * COLUMNS];
  for (int k = 0; k < ROWS * COLUMNS; ++k) rough[k] = (float)(0.5 + 0.5 * sin(2.3 * k) * cos(0.7 * k));
  vsc_heightfield field = {ROWS, COLUMNS, rough, {0.1, 0.08, 0.05, 0.01}};
  double vertices[3 * ROWS * COLUMNS];
  vsc_heightfield_vertices(&field, vertices);
  field.vertices = vertices;
  vsc_geom g = make(VSC_GEOM_HEIGHTFIELD, 0, 0, 0);
  g.heightfield = &field;
  g.is_static = 1;
  double reach = 0.0125;
  int bounded = 0, violations = 0;
  for (int k = 0; k < 4000; ++k) {
    double x[3] = {0.13 * sin(0.77 * k), 0.11 * cos(1.21 * k), 0.04 * sin(0.31 * k) + 0.03}, n[3];
    double bound = vsc_geom_distance_bound(&g, x, reach);
    for (int j = 0; j < 20; ++j) {  // moves within the reach
      double u[3] = {sin(3.1 * j + k), cos(1.7 * j - k), sin(0.9 * j * k)}, norm = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
      double step = reach * (j + 1) / 20.0, y[3];
      for (int c = 0; c < 3; ++c) y[c] = x[c] + step * u[c] / norm;
      if (!(bound - step > 0.0)) continue;
      ++bounded;
      violations += !(vsc_geom_distance(&g, y, n) >= bound - step);
    }
  }
  ENSURE(violations == 0);
  ENSURE(bounded > 4000);  // most points high above it are bounded
  printf("  %d moves bounded, %d below their bound\n", bounded, violations);
  // the bound read from the elevations equals the one from the vertex records; a height field
  // that may move or turn is never bounded
  vsc_heightfield derived = field;
  derived.vertices = NULL;
  vsc_geom plain = g;
  plain.heightfield = &derived;
  for (int k = 0; k < 200; ++k) {
    double x[3] = {0.12 * sin(1.9 * k), 0.1 * cos(0.8 * k), 0.05 * sin(0.4 * k) + 0.03};
    ENSURE(vsc_geom_distance_bound(&plain, x, reach) == vsc_geom_distance_bound(&g, x, reach));
  }
  g.is_static = 0;
  double above[3] = {0.0, 0.0, 0.5};
  ENSURE(vsc_geom_distance_bound(&g, above, reach) == -INFINITY);
}

int main(void) {
  RUN(heightfield_bound_holds);
  RUN(primitives);
  RUN(heightfield_continuous);
  RUN(heightfield_vertices_same_bits);
  RUN(rotated_and_moving);
  RUN(new_primitives);
  TEST_MAIN_END();
}
