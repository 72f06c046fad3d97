// Exact signed distances to rigid primitives.
#include "viscera/vsc_geom.h"

#include <math.h>

static void to_local(const vsc_geom* g, const double p[3], double l[3]) {
  double d[3] = {p[0] - g->position[0], p[1] - g->position[1], p[2] - g->position[2]};
  const double* R = g->rotation;  // l = R^T d
  l[0] = R[0] * d[0] + R[3] * d[1] + R[6] * d[2];
  l[1] = R[1] * d[0] + R[4] * d[1] + R[7] * d[2];
  l[2] = R[2] * d[0] + R[5] * d[1] + R[8] * d[2];
}

static void to_world_direction(const vsc_geom* g, const double l[3], double w[3]) {
  const double* R = g->rotation;  // w = R l
  w[0] = R[0] * l[0] + R[1] * l[1] + R[2] * l[2];
  w[1] = R[3] * l[0] + R[4] * l[1] + R[5] * l[2];
  w[2] = R[6] * l[0] + R[7] * l[1] + R[8] * l[2];
}

// Distance from the origin-centred sphere of `radius` to local point l.
static double round_distance(const double l[3], double radius, double n[3]) {
  double r = sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
  if (r > 0.0) {
    n[0] = l[0] / r; n[1] = l[1] / r; n[2] = l[2] / r;
  } else {  // at the centre any direction is closest: pick +z
    n[0] = 0.0; n[1] = 0.0; n[2] = 1.0;
  }
  return r - radius;
}

static double cylinder_distance(const double l[3], double radius, double half, double n[3]) {
  double rho = sqrt(l[0] * l[0] + l[1] * l[1]);
  double ex = rho > 0.0 ? l[0] / rho : 1.0, ey = rho > 0.0 ? l[1] / rho : 0.0;
  double dr = rho - radius, dz = fabs(l[2]) - half, sz = l[2] >= 0.0 ? 1.0 : -1.0;
  if (dr <= 0.0 && dz <= 0.0) {  // inside: nearest of the side and the caps
    if (dr > dz) { n[0] = ex; n[1] = ey; n[2] = 0.0; return dr; }
    n[0] = 0.0; n[1] = 0.0; n[2] = sz; return dz;
  }
  double a = dr > 0.0 ? dr : 0.0, b = dz > 0.0 ? dz : 0.0, d = sqrt(a * a + b * b);
  n[0] = ex * a / d; n[1] = ey * a / d; n[2] = sz * b / d;
  return d;
}

static double box_distance(const double l[3], const double h[3], double n[3]) {
  double q[3], outside = 0.0;
  int axis = 0;
  for (int i = 0; i < 3; ++i) {
    q[i] = fabs(l[i]) - h[i];
    if (q[i] > q[axis]) axis = i;
    if (q[i] > 0.0) outside += q[i] * q[i];
  }
  if (outside > 0.0) {
    double d = sqrt(outside);
    for (int i = 0; i < 3; ++i) n[i] = (q[i] > 0.0 ? q[i] : 0.0) * (l[i] >= 0.0 ? 1.0 : -1.0) / d;
    return d;
  }
  n[0] = n[1] = n[2] = 0.0;  // inside: leave through the nearest face
  n[axis] = l[axis] >= 0.0 ? 1.0 : -1.0;
  return q[axis];
}

// Ellipsoid, exact: the closest point is x_i = l_i s_i^2 / (s_i^2 + t) where t
// is the root of f(t) = sum (s_i l_i / (s_i^2 + t))^2 - 1, decreasing on
// t > -min s_i^2: t > 0 outside, t <= 0 inside. Newton safeguarded by bisection.
static double ellipsoid_distance(const double l[3], const double s[3], double n[3]) {
  double s2[3] = {s[0] * s[0], s[1] * s[1], s[2] * s[2]};
  double inside = (l[0] * l[0]) / s2[0] + (l[1] * l[1]) / s2[1] + (l[2] * l[2]) / s2[2] - 1.0;
  double smallest = fmin(s2[0], fmin(s2[1], s2[2]));
  double norm = sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
  double lo = inside > 0.0 ? 0.0 : -smallest * (1.0 - 1e-12);
  double hi = inside > 0.0 ? norm * sqrt(fmax(s2[0], fmax(s2[1], s2[2]))) : 0.0;
  double t = inside > 0.0 ? 0.5 * hi : 0.5 * lo;
  for (int iteration = 0; iteration < 100; ++iteration) {
    double f = -1.0, df = 0.0;
    for (int i = 0; i < 3; ++i) {
      double q = s[i] * l[i] / (s2[i] + t);
      f += q * q;
      df -= 2.0 * q * q / (s2[i] + t);
    }
    if (f > 0.0) lo = t; else hi = t;
    double next = df < 0.0 ? t - f / df : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);  // Newton left the bracket: bisect
    if (fabs(next - t) <= 1e-15 * (1.0 + fabs(t))) { t = next; break; }
    t = next;
  }
  double x[3], d[3], g[3];
  for (int i = 0; i < 3; ++i) {
    x[i] = l[i] * s2[i] / (s2[i] + t);
    d[i] = l[i] - x[i];
    g[i] = x[i] / s2[i];  // outward normal direction at x
  }
  double gn = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
  if (!(gn > 0.0)) {  // the centre: leave along the shortest semi-axis
    int axis = s[0] <= s[1] && s[0] <= s[2] ? 0 : (s[1] <= s[2] ? 1 : 2);
    n[0] = n[1] = n[2] = 0.0;
    n[axis] = 1.0;
    return -s[axis];
  }
  for (int i = 0; i < 3; ++i) n[i] = g[i] / gn;
  double distance = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  return inside > 0.0 ? distance : -distance;
}

// Closest point of triangle abc to p (Ericson, Real-Time Collision Detection, 5.1.5).
static void closest_on_triangle(const double* p, const double* a, const double* b, const double* c, double* out) {
  double ab[3], ac[3], ap[3];
  for (int i = 0; i < 3; ++i) { ab[i] = b[i] - a[i]; ac[i] = c[i] - a[i]; ap[i] = p[i] - a[i]; }
#define DOT(u, v) ((u)[0] * (v)[0] + (u)[1] * (v)[1] + (u)[2] * (v)[2])
  double d1 = DOT(ab, ap), d2 = DOT(ac, ap);
  if (d1 <= 0.0 && d2 <= 0.0) { for (int i = 0; i < 3; ++i) out[i] = a[i]; return; }
  double bp[3];
  for (int i = 0; i < 3; ++i) bp[i] = p[i] - b[i];
  double d3 = DOT(ab, bp), d4 = DOT(ac, bp);
  if (d3 >= 0.0 && d4 <= d3) { for (int i = 0; i < 3; ++i) out[i] = b[i]; return; }
  double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    double v = d1 / (d1 - d3);
    for (int i = 0; i < 3; ++i) out[i] = a[i] + v * ab[i];
    return;
  }
  double cp[3];
  for (int i = 0; i < 3; ++i) cp[i] = p[i] - c[i];
  double d5 = DOT(ab, cp), d6 = DOT(ac, cp);
  if (d6 >= 0.0 && d5 <= d6) { for (int i = 0; i < 3; ++i) out[i] = c[i]; return; }
  double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    double w = d2 / (d2 - d6);
    for (int i = 0; i < 3; ++i) out[i] = a[i] + w * ac[i];
    return;
  }
  double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    for (int i = 0; i < 3; ++i) out[i] = b[i] + w * (c[i] - b[i]);
    return;
  }
  double denominator = 1.0 / (va + vb + vc), v = vb * denominator, w = vc * denominator;
  for (int i = 0; i < 3; ++i) out[i] = a[i] + ab[i] * v + ac[i] * w;
#undef DOT
}

// Convex polytope: inside, the nearest face plane (exact); outside, the
// nearest point of its faces (exact).
static double convex_distance(const vsc_convex* c, const double l[3], double n[3]) {
  int best = 0;
  double inside = -INFINITY;
  for (int f = 0; f < c->face_count; ++f) {
    const double* pl = c->planes + 4 * f;
    double d = pl[0] * l[0] + pl[1] * l[1] + pl[2] * l[2] - pl[3];
    if (d > inside) { inside = d; best = f; }
  }
  if (inside <= 0.0) {
    for (int i = 0; i < 3; ++i) n[i] = c->planes[4 * best + i];
    return inside;
  }
  double nearest2 = INFINITY, nearest[3] = {0, 0, 0};
  for (int f = 0; f < c->face_count; ++f) {
    const double* t = c->triangles + 9 * f;
    double q[3];
    closest_on_triangle(l, t, t + 3, t + 6, q);
    double d2 = (l[0] - q[0]) * (l[0] - q[0]) + (l[1] - q[1]) * (l[1] - q[1]) + (l[2] - q[2]) * (l[2] - q[2]);
    if (d2 < nearest2) { nearest2 = d2; nearest[0] = q[0]; nearest[1] = q[1]; nearest[2] = q[2]; }
  }
  double d = sqrt(nearest2);
  for (int i = 0; i < 3; ++i) n[i] = d > 0.0 ? (l[i] - nearest[i]) / d : c->planes[4 * best + i];
  return d;
}

// Height field: bilinear surface z = h(x, y); distance (z - h) n_z along the
// surface normal n ~ (-gx, -gy, 1), with the slope (gx, gy) interpolated
// bilinearly from each grid vertex's central differences. The bilinear
// patches' own slopes jump at the cells' edges, and so would the distance
// (z - h) n_z: a sphere resting beside a steep fold crossed an edge and was
// kicked back, a bounce that never settled. Both are continuous this way.
// Outside its x-y extent or below its base there is no contact.
static double heightfield_elevation(const vsc_heightfield* h, int row, int column) {
  return h->size[2] * h->elevation[row * h->columns + column];
}

// The slope (dz/dx, dz/dy) at grid vertex (row, column): central differences, one-sided at the border.
static void heightfield_vertex_slope(const vsc_heightfield* h, int row, int column, double slope[2]) {
  int c0 = column > 0 ? column - 1 : 0, c1 = column < h->columns - 1 ? column + 1 : column;
  int r0 = row > 0 ? row - 1 : 0, r1 = row < h->rows - 1 ? row + 1 : row;
  double cell_x = 2.0 * h->size[0] / (h->columns - 1), cell_y = 2.0 * h->size[1] / (h->rows - 1);
  slope[0] = (heightfield_elevation(h, row, c1) - heightfield_elevation(h, row, c0)) / ((c1 - c0) * cell_x);
  slope[1] = (heightfield_elevation(h, r1, column) - heightfield_elevation(h, r0, column)) / ((r1 - r0) * cell_y);
}

int vsc_heightfield_vertex_size(const vsc_heightfield* h) { return 3 * h->rows * h->columns; }

void vsc_heightfield_vertices(const vsc_heightfield* h, double* out) {
  for (int row = 0; row < h->rows; ++row)
    for (int column = 0; column < h->columns; ++column) {
      double* vertex = out + 3 * (row * h->columns + column);
      vertex[0] = heightfield_elevation(h, row, column);
      heightfield_vertex_slope(h, row, column, vertex + 1);
    }
}

// Vertex (row, column)'s height and slopes: its record, or derived into `scratch` (3).
static const double* heightfield_vertex(const vsc_heightfield* h, int row, int column, double* scratch) {
  if (h->vertices) return h->vertices + 3 * (row * h->columns + column);
  scratch[0] = heightfield_elevation(h, row, column);
  heightfield_vertex_slope(h, row, column, scratch + 1);
  return scratch;
}

static double heightfield_distance(const vsc_heightfield* h, const double l[3], double n[3]) {
  n[0] = 0.0; n[1] = 0.0; n[2] = 1.0;
  double fx = (l[0] + h->size[0]) / (2.0 * h->size[0]) * (h->columns - 1);
  double fy = (l[1] + h->size[1]) / (2.0 * h->size[1]) * (h->rows - 1);
  if (!(fx >= 0.0 && fy >= 0.0 && fx <= h->columns - 1 && fy <= h->rows - 1) || l[2] < -h->size[3]) return INFINITY;
  int c0 = (int)fx, r0 = (int)fy;
  if (c0 > h->columns - 2) c0 = h->columns - 2;
  if (r0 > h->rows - 2) r0 = h->rows - 2;
  double u = fx - c0, v = fy - r0;
  double weight[4] = {(1 - u) * (1 - v), u * (1 - v), (1 - u) * v, u * v};
  int rows[4] = {r0, r0, r0 + 1, r0 + 1}, columns[4] = {c0, c0 + 1, c0, c0 + 1};
  double height = 0.0, dx = 0.0, dy = 0.0;
  for (int k = 0; k < 4; ++k) {
    double scratch[3];
    const double* vertex = heightfield_vertex(h, rows[k], columns[k], scratch);
    height += weight[k] * vertex[0];
    dx += weight[k] * vertex[1];
    dy += weight[k] * vertex[2];
  }
  double norm = sqrt(dx * dx + dy * dy + 1.0);
  n[0] = -dx / norm; n[1] = -dy / norm; n[2] = 1.0 / norm;
  return (l[2] - height) / norm;
}

// The bound of vsc_geom_distance_bound for a height field, at local point l: every vertex
// whose cells y may lie in (one more each side, for rounding at the cells' edges).
static double heightfield_distance_bound(const vsc_heightfield* h, const double l[3], double reach) {
  if (l[2] + reach < -h->size[3]) return INFINITY;  // below its base throughout: no contact
  double columns_per_m = (h->columns - 1) / (2.0 * h->size[0]), rows_per_m = (h->rows - 1) / (2.0 * h->size[1]);
  double x0 = (l[0] - reach + h->size[0]) * columns_per_m, x1 = (l[0] + reach + h->size[0]) * columns_per_m;
  double y0 = (l[1] - reach + h->size[1]) * rows_per_m, y1 = (l[1] + reach + h->size[1]) * rows_per_m;
  if (!(x1 >= -1.0 && y1 >= -1.0 && x0 <= h->columns && y0 <= h->rows)) return INFINITY;  // beside it throughout
  x0 = x0 > -1.0 ? x0 : -1.0, y0 = y0 > -1.0 ? y0 : -1.0;  // within int range before the casts
  x1 = x1 < h->columns ? x1 : h->columns, y1 = y1 < h->rows ? y1 : h->rows;
  int c0 = (int)floor(x0) - 1, c1 = (int)ceil(x1) + 1, r0 = (int)floor(y0) - 1, r1 = (int)ceil(y1) + 1;
  c0 = c0 < 0 ? 0 : c0, r0 = r0 < 0 ? 0 : r0;
  c1 = c1 > h->columns - 1 ? h->columns - 1 : c1, r1 = r1 > h->rows - 1 ? h->rows - 1 : r1;
  double highest = -INFINITY, steepest2 = 0.0;
  for (int row = r0; row <= r1; ++row)
    for (int column = c0; column <= c1; ++column) {
      double scratch[3];
      const double* vertex = heightfield_vertex(h, row, column, scratch);
      highest = vertex[0] > highest ? vertex[0] : highest;
      double slope2 = vertex[1] * vertex[1] + vertex[2] * vertex[2];
      steepest2 = slope2 > steepest2 ? slope2 : steepest2;
    }
  // a point y within reach lies over these vertices' cells, at most `highest` high, its normal's
  // slant sqrt(1 + g^2) at most sqrt(1 + steepest2): its distance (z_y - h) / slant is at least
  // (l_z - reach - highest) / sqrt(1 + steepest2) >= clearance - reach while that is positive
  double clearance = (l[2] - highest) / sqrt(1.0 + steepest2);
  return clearance > 0.0 ? clearance * (1.0 - 1e-9) : -INFINITY;
}

double vsc_geom_distance_bound(const vsc_geom* g, const double point[3], double reach) {
  double n[3];
  if (g->type != VSC_GEOM_HEIGHTFIELD) return vsc_geom_distance(g, point, n);
  // a moving one: a turn moves a point's local place by its distance from the origin times the
  // turn, which the lists' geom motion bound does not cover for every point near the field
  if (!g->is_static) return -INFINITY;
  if (!g->heightfield || g->heightfield->rows < 2 || g->heightfield->columns < 2) return -INFINITY;
  double l[3];
  to_local(g, point, l);
  return heightfield_distance_bound(g->heightfield, l, reach);
}

double vsc_geom_distance(const vsc_geom* g, const double point[3], double normal[3]) {
  double l[3], n[3], d;
  if (g->type == VSC_GEOM_PLANE) {  // the common floor: one dot product with the local z axis
    const double* R = g->rotation;
    normal[0] = R[2];
    normal[1] = R[5];
    normal[2] = R[8];
    return (point[0] - g->position[0]) * R[2] + (point[1] - g->position[1]) * R[5] +
           (point[2] - g->position[2]) * R[8];
  }
  to_local(g, point, l);
  switch (g->type) {
    case VSC_GEOM_PLANE:
      n[0] = 0.0; n[1] = 0.0; n[2] = 1.0;
      d = l[2];
      break;
    case VSC_GEOM_SPHERE:
      d = round_distance(l, g->size[0], n);
      break;
    case VSC_GEOM_CAPSULE: {
      double z = l[2] > g->size[1] ? g->size[1] : (l[2] < -g->size[1] ? -g->size[1] : l[2]);
      double r[3] = {l[0], l[1], l[2] - z};
      d = round_distance(r, g->size[0], n);
      break;
    }
    case VSC_GEOM_CYLINDER:
      d = cylinder_distance(l, g->size[0], g->size[1], n);
      break;
    case VSC_GEOM_BOX:
      d = box_distance(l, g->size, n);
      break;
    case VSC_GEOM_ELLIPSOID:
      d = ellipsoid_distance(l, g->size, n);
      break;
    case VSC_GEOM_CONVEX:
      if (!g->convex || g->convex->face_count < 1) goto never;
      d = convex_distance(g->convex, l, n);
      break;
    case VSC_GEOM_HEIGHTFIELD:
      if (!g->heightfield || g->heightfield->rows < 2 || g->heightfield->columns < 2) goto never;
      d = heightfield_distance(g->heightfield, l, n);
      break;
    default:
    never:  // unknown or empty: never in contact
      normal[0] = 0.0; normal[1] = 0.0; normal[2] = 1.0;
      return INFINITY;
  }
  to_world_direction(g, n, normal);
  return d;
}

void vsc_wrench_add(double out[6], double scale, const double f[3], const double* torque, const double arm[3]) {
  for (int a = 0; a < 3; ++a) out[a] += scale * f[a];
  out[3] += scale * ((torque ? torque[0] : 0.0) + arm[1] * f[2] - arm[2] * f[1]);
  out[4] += scale * ((torque ? torque[1] : 0.0) + arm[2] * f[0] - arm[0] * f[2]);
  out[5] += scale * ((torque ? torque[2] : 0.0) + arm[0] * f[1] - arm[1] * f[0]);
}

void vsc_geom_point_velocity(const vsc_geom* g, const double p[3], double v[3]) {
  if (g->is_static) {
    v[0] = v[1] = v[2] = 0.0;
    return;
  }
  double r[3] = {p[0] - g->position[0], p[1] - g->position[1], p[2] - g->position[2]};
  const double* w = g->angular_velocity;
  v[0] = g->linear_velocity[0] + w[1] * r[2] - w[2] * r[1];
  v[1] = g->linear_velocity[1] + w[2] * r[0] - w[0] * r[2];
  v[2] = g->linear_velocity[2] + w[0] * r[1] - w[1] * r[0];
}
