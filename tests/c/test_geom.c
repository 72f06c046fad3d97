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

int main(void) {
  RUN(primitives);
  RUN(rotated_and_moving);
  TEST_MAIN_END();
}
