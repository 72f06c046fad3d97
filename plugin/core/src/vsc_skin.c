// Generalised-cylinder skin with twist-free frames (see vsc_skin.h).
#include "viscera/vsc_skin.h"

#include <math.h>

#include "viscera/vsc_base.h"
#include "viscera/vsc_spline.h"


double vsc_skin_radius(double radius_min, double radius_max, double u) {
  double c = cos(VSC_PI * u);
  return radius_min + c * c * (radius_max - radius_min);
}

vsc_skin_def vsc_default_skin_def(void) {
  vsc_skin_def def = {4, 16, 0.0125, 0.0125, 1.0};
  return def;
}

static int ring_count(int n, const vsc_skin_def* def) { return (n - 1) * def->rings_per_segment + 1; }

int vsc_skin_vertex_count(int n, const vsc_skin_def* def) { return ring_count(n, def) * def->ring_points + 2; }

int vsc_skin_triangle_count(int n, const vsc_skin_def* def) { return 2 * ring_count(n, def) * def->ring_points; }

static double normalise(double v[3]) {
  double norm = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (norm > 0.0) {
    v[0] /= norm; v[1] /= norm; v[2] /= norm;
  }
  return norm;
}

// A unit vector normal to unit t: t crossed with the axis it is least aligned with.
static void any_normal(const double t[3], double out[3]) {
  double axis[3] = {0, 0, 0};
  int i = fabs(t[0]) <= fabs(t[1]) && fabs(t[0]) <= fabs(t[2]) ? 0 : (fabs(t[1]) <= fabs(t[2]) ? 1 : 2);
  axis[i] = 1.0;
  vsc_cross(t, axis, out);
  normalise(out);
}

static void axis_point(const double* q, int n, double s, double p[3], double t[3]) {
  vsc_basis b = vsc_spline_basis(n, s), d = vsc_spline_basis_derivative(n, s);
  vsc_basis_point(&b, q, p);
  vsc_basis_point(&d, q, t);
  if (!(normalise(t) > 0.0)) {  // a stalled parametrisation: use the chord to a neighbour
    double s2 = s < 0.5 ? s + 1e-6 : s - 1e-6, p2[3];
    vsc_basis b2 = vsc_spline_basis(n, s2);
    vsc_basis_point(&b2, q, p2);
    for (int c = 0; c < 3; ++c) t[c] = s < 0.5 ? p2[c] - p[c] : p[c] - p2[c];
    if (!(normalise(t) > 0.0)) { t[0] = 1.0; t[1] = 0.0; t[2] = 0.0; }
  }
}

vsc_status vsc_skin_build(const double* q, int n, const vsc_skin_def* def, double* vertices, double* normals,
                          int* triangles) {
  if (n < 4 || def->rings_per_segment < 1 || def->ring_points < 3 || !(def->radius_min > 0.0) ||
      !(def->radius_max >= def->radius_min) || !(def->taper_end > 0.0))
    return VSC_ERROR_INVALID_ARGUMENT;
  int rings = ring_count(n, def), m = def->ring_points;
  double p[3], t[3], k[3], b[3], t_next[3], p_next[3];
  // first frame: the Frenet normal from the tangent's turn, else any normal
  axis_point(q, n, 0.0, p, t);
  axis_point(q, n, 1.0 / (double)(rings - 1), p_next, t_next);
  double turn = t_next[0] * t[0] + t_next[1] * t[1] + t_next[2] * t[2];
  for (int c = 0; c < 3; ++c) k[c] = t_next[c] - turn * t[c];
  if (!(normalise(k) > 1e-9)) any_normal(t, k);
  for (int r = 0; r < rings; ++r) {
    double s = (double)r / (double)(rings - 1);
    axis_point(q, n, s, p, t);
    // carry k by the smallest rotation: b = normalise(t x k_prev), k = b x t
    vsc_cross(t, k, b);
    if (!(normalise(b) > 1e-12)) {  // t turned onto k: restart from any normal
      any_normal(t, k);
      vsc_cross(t, k, b);
      normalise(b);
    }
    vsc_cross(b, t, k);
    normalise(k);
    double u = s * (double)(n - 1) - floor(s * (double)(n - 1));
    if (r == rings - 1) u = 1.0;
    double radius = vsc_skin_radius(def->radius_min, def->radius_max, u);
    if (def->taper_end != 1.0) radius *= 1.0 + s * (def->taper_end - 1.0);
    for (int i = 0; i < m; ++i) {
      double angle = 2.0 * VSC_PI * (double)i / (double)m, ca = cos(angle), sa = sin(angle);
      double* v = vertices + 3 * (r * m + i);
      double* nv = normals + 3 * (r * m + i);
      for (int c = 0; c < 3; ++c) {
        nv[c] = ca * k[c] + sa * b[c];
        v[c] = p[c] + radius * nv[c];
      }
    }
  }
  // cap centres and their normals (-t at the start, +t at the end)
  int start = rings * m, end = start + 1;
  double t0[3], t1[3];
  axis_point(q, n, 0.0, vertices + 3 * start, t0);
  axis_point(q, n, 1.0, vertices + 3 * end, t1);
  for (int c = 0; c < 3; ++c) {
    normals[3 * start + c] = -t0[c];
    normals[3 * end + c] = t1[c];
  }
  // around x along the axis points outwards: (r, i), (r, i+1), (r+1, i)
  int* tri = triangles;
  for (int r = 0; r + 1 < rings; ++r)
    for (int i = 0; i < m; ++i) {
      int a = r * m + i, a1 = r * m + (i + 1) % m, c = a + m, c1 = a1 + m;
      tri[0] = a; tri[1] = a1; tri[2] = c;
      tri[3] = a1; tri[4] = c1; tri[5] = c;
      tri += 6;
    }
  for (int i = 0; i < m; ++i) {
    int i1 = (i + 1) % m, last = (rings - 1) * m;
    tri[0] = start; tri[1] = i1; tri[2] = i;                 // faces -t
    tri[3] = end; tri[4] = last + i; tri[5] = last + i1;     // faces +t
    tri += 6;
  }
  return VSC_OK;
}
