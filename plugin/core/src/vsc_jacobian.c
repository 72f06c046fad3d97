// Band force Jacobians (see vsc_jacobian.h): sample-level blocks first, then
// projected onto control points through the spline basis.
#include "vsc_jacobian.h"

#include <math.h>
#include <string.h>

#include "viscera/vsc_grasp.h"
#include "vsc_place.h"

// Entry (row, col), row >= col, of a wide band of half-width w.
#define BAND(band, w, row, col) (band)[(size_t)((w) + 1) * (size_t)(row) + (size_t)((w) + (col) - (row))]

// c H added at block (k, l) of the 3n x 3n matrix, k >= l (lower blocks only;
// on the diagonal only the lower triangle is stored).
static void add_block(double* band, int w, int k, int l, double c, const double H[9]) {
  // entry (3k + r, 3l + s) sits at (w + 1)(3k + r) + w + 3l + s - 3k - r = corner + r w + s
  double* corner = band + (size_t)(w + 1) * (size_t)(3 * k) + (size_t)(w + 3 * l - 3 * k);
  if (k != l) {
    for (int r = 0; r < 3; ++r) {
      double* row = corner + (size_t)r * (size_t)w;
      row[0] += c * H[3 * r];
      row[1] += c * H[3 * r + 1];
      row[2] += c * H[3 * r + 2];
    }
    return;
  }
  for (int r = 0; r < 3; ++r)
    for (int s = 0; s <= r; ++s) corner[(size_t)r * (size_t)w + (size_t)s] += c * H[3 * r + s];
}

static void transpose(const double H[9], double T[9]) {
  for (int r = 0; r < 3; ++r)
    for (int s = 0; s < 3; ++s) T[3 * s + r] = H[3 * r + s];
}

// c H (H symmetric, 3 x 3) at one abscissa's basis window: B^T H B.
static void add_at_basis(double* band, int w, const vsc_basis* b, double c, const double H[9]) {
  for (int i = 0; i < VSC_SPLINE_SUPPORT; ++i) {
    if (fabs(b->weight[i]) < VSC_NEGLIGIBLE_WEIGHT) continue;
    for (int j = 0; j <= i; ++j)
      if (fabs(b->weight[j]) >= VSC_NEGLIGIBLE_WEIGHT)
        add_block(band, w, b->first + i, b->first + j, c * b->weight[i] * b->weight[j], H);
  }
}

void vsc_rod_add_mass(const vsc_rod* rod, double mass_weight, double* band) {
  int w = rod->jacobian_half_width;
  for (int i = 0; i < rod->n; ++i)
    for (int d = 0; d < 4; ++d) {
      int j = i - 3 + d;
      if (j < 0) continue;
      double m = mass_weight * rod->mass_band[4 * i + d];
      for (int c = 0; c < 3; ++c) BAND(band, w, 3 * i + c, 3 * j + c) += m;
    }
}

// Spring Hessian k e e^T + max(T, 0) / l (I - e e^T) for the vector e of length l.
static void spring_hessian(const double e[3], double length, double k, double tension, double H[9]) {
  double inverse = length > 0.0 ? 1.0 / length : 0.0;
  double geometric = tension > 0.0 ? tension * inverse : 0.0;
  for (int r = 0; r < 3; ++r)
    for (int s = 0; s < 3; ++s) {
      double ee = e[r] * e[s] * inverse * inverse;
      H[3 * r + s] = k * ee + geometric * ((r == s) - ee);
    }
}

// (I - e e^T / |e|^2) / |e|: the derivative of e / |e|.
static void unit_derivative(const double e[3], double length, double P[9]) {
  double inverse = 1.0 / length;
  for (int r = 0; r < 3; ++r)
    for (int s = 0; s < 3; ++s) P[3 * r + s] = ((r == s) - e[r] * e[s] * inverse * inverse) * inverse;
}

static void multiply(const double A[9], const double B[9], double c, double out[9]) {
  for (int r = 0; r < 3; ++r)
    for (int s = 0; s < 3; ++s)
      out[3 * r + s] = c * (A[3 * r] * B[s] + A[3 * r + 1] * B[3 + s] + A[3 * r + 2] * B[6 + s]);
}

// Sample-level blocks: S(a + d, a) at sample_hessian + 27 a + 9 d, d = 0..2.
static double* sample_block(vsc_jacobian_scratch* j, int row, int col) { return j->sample_hessian + 27 * col + 9 * (row - col); }

static void add_sample(vsc_jacobian_scratch* j, int row, int col, double c, const double H[9]) {
  double* S = sample_block(j, row, col);
  for (int i = 0; i < 9; ++i) S[i] += c * H[i];
}

// A two-sample element of Hessian [[H, -H], [-H, H]] between samples a < b.
static void add_pair(vsc_jacobian_scratch* j, int a, int b, const double H[9]) {
  add_sample(j, a, a, 1.0, H);
  add_sample(j, b, b, 1.0, H);
  add_sample(j, b, a, -1.0, H);
}

static double edge(const vsc_elastic_scratch* p, int a, int b, double e[3]) {
  e[0] = p->sample_x[b] - p->sample_x[a];
  e[1] = p->sample_y[b] - p->sample_y[a];
  e[2] = p->sample_z[b] - p->sample_z[a];
  return sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
}

// Elastic sample blocks; returns the global term's tension (N). Samples must be current.
static double elastic_sample_hessian(const vsc_rod* rod, vsc_jacobian_scratch* j, const vsc_elastic_scratch* p) {
  int N = rod->sample_count;
  double l0 = rod->rest_spacing, H[9], e[3];
  memset(j->sample_hessian, 0, sizeof(double) * 27 * (size_t)N);
  double length = 0.0;
  for (int a = 0; a + 1 < N; ++a) length += edge(p, a, a + 1, e);
  double global_tension = rod->def.global_stretch_stiffness * (length - rod->def.length);
  for (int a = 0; a + 1 < N; ++a) {
    double l = edge(p, a, a + 1, e), k = rod->stretch_spring * (rod->stretch_scale ? rod->stretch_scale[a] : 1.0);
    spring_hessian(e, l, k, k * (l - l0) + global_tension, H);
    add_pair(j, a, a + 1, H);
  }
  if (rod->bend_spring > 0.0)
    for (int a = 0; a + 2 < N; ++a) {
      double l = edge(p, a, a + 2, e), k = rod->bend_spring * (rod->bend_scale ? rod->bend_scale[a] : 1.0);
      spring_hessian(e, l, k, k * (l - 2.0 * l0), H);
      add_pair(j, a, a + 2, H);
    }
  double k0 = rod->def.bending_rigidity / l0;
  if (!(k0 > 0.0)) return global_tension;
  const double* section = rod->curvature_scale;  // NULL untapered
  for (int a = 1; a + 1 < N; ++a) {
    double k = section ? k0 * section[a] : k0;
    double u[3], v[3], X[9], Y[9], XY[9], T[9];
    double lu = edge(p, a - 1, a, u), lv = edge(p, a, a + 1, v);
    if (!(lu > 0.0) || !(lv > 0.0)) continue;
    unit_derivative(u, lu, X);  // d(u/|u|)/du, symmetric, and X X = X / |u| (a projector over |u|)
    unit_derivative(v, lv, Y);
    double XX[9], YY[9], YX[9];
    multiply(Y, X, 1.0, YX);  // and X Y = (Y X)^T
    for (int i = 0; i < 9; ++i) {
      XX[i] = X[i] / lu;
      YY[i] = Y[i] / lv;
    }
    transpose(YX, XY);
    // J = (X, -(X + Y), Y) for samples a - 1, a, a + 1; blocks k J_i J_j
    for (int i = 0; i < 9; ++i) T[i] = XX[i] + YY[i] + XY[i] + YX[i];
    add_sample(j, a - 1, a - 1, k, XX);
    add_sample(j, a, a, k, T);
    add_sample(j, a + 1, a + 1, k, YY);
    for (int i = 0; i < 9; ++i) T[i] = XX[i] + YX[i];  // (X + Y) X
    add_sample(j, a, a - 1, -k, T);
    for (int i = 0; i < 9; ++i) T[i] = YX[i] + YY[i];  // Y (X + Y)
    add_sample(j, a + 1, a, -k, T);
    add_sample(j, a + 1, a - 1, k, YX);
  }
  int clamped[2] = {rod->def.clamp_start, rod->def.clamp_end};
  for (int end = 0; end < 2; ++end) {
    if (!clamped[end]) continue;
    int a = end ? N - 2 : 0;
    double k = section ? k0 * section[end ? N - 1 : 0] : k0;
    double l = edge(p, a, a + 1, e), P[9];
    if (!(l > 0.0)) continue;
    unit_derivative(e, l, P);  // 2k (I - e e^T / l^2) / l^2 = 2k P P
    multiply(P, P, 2.0 * k, H);
    add_pair(j, a, a + 1, H);
  }
  return global_tension;
}

// Project the sample blocks onto control points: K(k, l) = sum b_k(a) b_l(b) S(a, b).
static void project_samples(const vsc_rod* rod, vsc_jacobian_scratch* j, double c, double* band) {
  int N = rod->sample_count, w = rod->jacobian_half_width;
  for (int a = 0; a < N; ++a) {
    const vsc_basis* ba = &rod->sample_basis[a];
    for (int d = 0; d < 3 && a + d < N; ++d) {
      const vsc_basis* bd = &rod->sample_basis[a + d];
      const double* H = sample_block(j, a + d, a);
      double Ht[9], sum[9];
      transpose(H, Ht);
      for (int i = 0; i < 9; ++i) sum[i] = H[i] + Ht[i];
      for (int i = 0; i < VSC_SPLINE_SUPPORT; ++i) {
        if (fabs(bd->weight[i]) < VSC_NEGLIGIBLE_WEIGHT) continue;
        for (int j = 0; j < VSC_SPLINE_SUPPORT; ++j) {
          if (fabs(ba->weight[j]) < VSC_NEGLIGIBLE_WEIGHT) continue;
          double weight = c * bd->weight[i] * ba->weight[j];
          int k = bd->first + i, l = ba->first + j;
          if (d == 0) {  // S(a, a) is symmetric: its mirror term is this sum's own (l, k)
            if (k >= l) add_block(band, w, k, l, weight, H);
          } else if (k > l) {
            add_block(band, w, k, l, weight, H);
          } else if (k < l) {  // the mirror S(a, a + d) = H^T lands at (l, k)
            add_block(band, w, l, k, weight, Ht);
          } else {
            add_block(band, w, k, k, weight, sum);
          }
        }
      }
    }
  }
}

// dl/dp at sample a (3): +e/l of the spring before it, -e/l of the one after (none past the ends,
// nor for a collapsed spring), summed in that order from zero.
static void sample_length_gradient(const vsc_elastic_scratch* p, int N, int a, double g[3]) {
  double before[3], after[3];
  double l_before = a > 0 ? edge(p, a - 1, a, before) : 0.0, l_after = a + 1 < N ? edge(p, a, a + 1, after) : 0.0;
  for (int c = 0; c < 3; ++c) {
    g[c] = 0.0;
    if (l_before > 0.0) g[c] += before[c] / l_before;
    if (l_after > 0.0) g[c] -= after[c] / l_after;
  }
}

void vsc_jacobian_add(const vsc_rod* rod, vsc_jacobian_scratch* j, const vsc_elastic_scratch* placed,
                      const vsc_touch_records* touch, const vsc_world* world, const double* q, double stiffness_weight,
                      double damping_weight, double* band, double* global_gradient) {
  int w = rod->jacobian_half_width, n = rod->n;
  elastic_sample_hessian(rod, j, placed);
  project_samples(rod, j, stiffness_weight, band);
  if (global_gradient) {
    memset(global_gradient, 0, sizeof(double) * 3 * (size_t)n);
    for (int a = 0; a < rod->sample_count; ++a) {
      const vsc_basis* b = &rod->sample_basis[a];
      double g[3];
      sample_length_gradient(placed, rod->sample_count, a, g);
      for (int i = 0; i < VSC_SPLINE_SUPPORT; ++i)
        for (int c = 0; c < 3; ++c) global_gradient[3 * (b->first + i) + c] += b->weight[i] * g[c];
    }
  }
  const vsc_rod_def* d = &rod->def;
  double H[9], identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  for (int i = 0; i < d->mesentery_points && d->mesentery_stiffness > 0.0; ++i) {
    double f = ((double)i + 0.5) / (double)d->mesentery_points, p[3], e[3];
    vsc_basis_point(&rod->tether_basis[i], q, p);
    for (int c = 0; c < 3; ++c) e[c] = d->mesentery_root[c] + f * (d->mesentery_root[3 + c] - d->mesentery_root[c]) - p[c];
    double length = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]), stretch = length - d->mesentery_length;
    if (!(stretch > 0.0)) continue;
    spring_hessian(e, length, d->mesentery_stiffness, d->mesentery_stiffness * stretch, H);
    add_at_basis(band, w, &rod->tether_basis[i], stiffness_weight, H);
  }
  for (int g = 0; g < world->grasp_count; ++g) {
    const vsc_grasp* grasp = &world->grasps[g];
    vsc_basis b = vsc_spline_basis(n, grasp->abscissa);
    add_at_basis(band, w, &b, stiffness_weight * grasp->stiffness + damping_weight * grasp->damping, identity);
  }
  double k = d->contact_stiffness, c = d->contact_damping, normal[3];
  for (int i = 0; i < d->collision_sphere_count && world->geom_count > 0 && touch; ++i) {
    if (vsc_touch_rigid(touch, i, normal) < 0) continue;
    for (int r = 0; r < 3; ++r)
      for (int s = 0; s < 3; ++s) H[3 * r + s] = normal[r] * normal[s];
    add_at_basis(band, w, &rod->sphere_basis[i], stiffness_weight * k + damping_weight * c, H);
  }
}

void vsc_jacobian_add_damping_force(const vsc_rod* rod, const vsc_touch_records* touch, const vsc_world* world,
                                    const double* v, double* out) {
  int n = rod->n;
  for (int g = 0; g < world->grasp_count; ++g) {
    const vsc_grasp* grasp = &world->grasps[g];
    vsc_basis b = vsc_spline_basis(n, grasp->abscissa);
    double velocity[3];
    vsc_basis_point(&b, v, velocity);
    for (int j = 0; j < VSC_SPLINE_SUPPORT; ++j)
      for (int c = 0; c < 3; ++c) out[3 * (b.first + j) + c] += b.weight[j] * grasp->damping * velocity[c];
  }
  double normal[3];
  for (int i = 0; i < rod->def.collision_sphere_count && world->geom_count > 0 && touch; ++i) {
    if (vsc_touch_rigid(touch, i, normal) < 0) continue;
    const vsc_basis* b = &rod->sphere_basis[i];
    double velocity[3];
    vsc_basis_point(b, v, velocity);
    double along = rod->def.contact_damping * (velocity[0] * normal[0] + velocity[1] * normal[1] + velocity[2] * normal[2]);
    for (int j = 0; j < VSC_SPLINE_SUPPORT; ++j)
      for (int c = 0; c < 3; ++c) out[3 * (b->first + j) + c] += b->weight[j] * along * normal[c];
  }
}

void vsc_rod_pin_band(const vsc_rod* rod, double* band) {
  int w = rod->jacobian_half_width, size = 3 * rod->n;
  for (int p = 0; p < rod->def.pinned_count; ++p)
    for (int c = 0; c < 3; ++c) {
      int i = 3 * rod->pinned[p] + c;
      for (int j = i - w < 0 ? 0 : i - w; j < i; ++j) BAND(band, w, i, j) = 0.0;  // row
      for (int r = i + 1; r <= i + w && r < size; ++r) BAND(band, w, r, i) = 0.0;  // column
      BAND(band, w, i, i) = 1.0;
    }
}
