// Rod creation (mass matrix, basis tables), elastic forces and energies.
#include "viscera/vsc_rod.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "viscera/vsc_band.h"
#include "viscera/vsc_contact.h"
#include "viscera/vsc_grasp.h"


vsc_rod_def vsc_default_rod_def(void) {
  vsc_rod_def def;
  memset(&def, 0, sizeof(def));
  def.control_count = 250;
  def.length = 4.0;
  def.radius = 0.0125;
  def.mass = 1000.0 * VSC_PI * def.radius * def.radius * def.length;
  def.samples_per_segment = 2;
  def.stretch_stiffness = 10.0;
  def.bend_stiffness = 1.0;
  def.global_stretch_stiffness = 200.0;
  def.damping = 1.0;
  def.lumped_mass = 1;  // with leapfrog: 3 substeps per 2 ms where the consistent M needs 5 (README)
  def.collision_sphere_count = vsc_default_collision_sphere_count(def.length, def.radius);
  def.contact_stiffness = 2000.0;
  def.contact_damping = 2.0;
  def.self_collision = 1;
  def.self_friction = 0.3;
  return def;
}

int vsc_default_collision_sphere_count(double length, double radius) {
  double count = ceil(length / radius - 1e-9) + 1.0;  // in double: no int overflow
  return isfinite(count) && count <= VSC_MAX_COLLISION_SPHERES ? (int)count : -1;
}

static int finite_nonneg(double x) { return isfinite(x) && x >= 0.0; }
static int finite_pos(double x) { return isfinite(x) && x > 0.0; }

static vsc_status validate(const vsc_rod_def* d) {
  if (d->control_count < 4 || d->samples_per_segment < 1 || d->collision_sphere_count < 2)
    return VSC_ERROR_INVALID_ARGUMENT;
  if (d->control_count > VSC_MAX_CONTROL_POINTS || d->collision_sphere_count > VSC_MAX_COLLISION_SPHERES ||
      (double)(d->control_count - 1) * (double)d->samples_per_segment + 1.0 > VSC_MAX_SAMPLES)
    return VSC_ERROR_INVALID_ARGUMENT;
  if (!finite_pos(d->length) || !finite_pos(d->mass) || !finite_pos(d->radius) ||
      !finite_pos(d->contact_stiffness))
    return VSC_ERROR_INVALID_ARGUMENT;
  if (!finite_nonneg(d->stretch_stiffness) || !finite_nonneg(d->bend_stiffness) ||
      !finite_nonneg(d->global_stretch_stiffness) || !finite_nonneg(d->bending_rigidity) ||
      !finite_nonneg(d->damping) ||
      !finite_nonneg(d->contact_damping) || !finite_nonneg(d->self_friction))
    return VSC_ERROR_INVALID_ARGUMENT;
  if (d->pinned_count < 0 || (d->pinned_count > 0 && !d->pinned)) return VSC_ERROR_INVALID_ARGUMENT;
  if (d->mesentery_points < 0 || d->mesentery_points > VSC_MAX_COLLISION_SPHERES ||
      !finite_nonneg(d->mesentery_stiffness) || !finite_nonneg(d->mesentery_length))
    return VSC_ERROR_INVALID_ARGUMENT;
  for (int i = 0; i < 6; ++i)
    if (!isfinite(d->mesentery_root[i])) return VSC_ERROR_INVALID_ARGUMENT;
  const double* clamp_direction[2] = {d->clamp_direction_start, d->clamp_direction_end};
  int clamped[2] = {d->clamp_start, d->clamp_end};
  for (int end = 0; end < 2; ++end) {
    if (!clamped[end]) continue;
    const double* t = clamp_direction[end];
    double norm = t[0] * t[0] + t[1] * t[1] + t[2] * t[2];
    if (!(d->bending_rigidity > 0.0) || !isfinite(norm) || !(norm > 1e-24)) return VSC_ERROR_INVALID_ARGUMENT;
  }
  for (int i = 0; i < d->pinned_count; ++i)
    if (d->pinned[i] < 0 || d->pinned[i] >= d->control_count) return VSC_ERROR_INVALID_ARGUMENT;
  return VSC_OK;
}

// M_ij = m integral b_i b_j ds: per segment the integrand is a degree-6
// polynomial in u, integrated exactly by 4-point Gauss-Legendre (exact to degree 7).
static void assemble_mass(vsc_rod* rod) {
  static const double node[4] = {0.0694318442029737, 0.3300094782075719, 0.6699905217924281,
                                 0.9305681557970263};
  static const double weight[4] = {0.1739274225687269, 0.3260725774312731, 0.3260725774312731,
                                   0.1739274225687269};
  int n = rod->n;
  double segment_mass = rod->def.mass / (double)(n - 1);  // ds = du / (n-1)
  memset(rod->mass_band, 0, sizeof(double) * 4 * n);
  for (int j = 0; j < n - 1; ++j) {
    for (int g = 0; g < 4; ++g) {
      vsc_basis b = vsc_spline_basis(n, ((double)j + node[g]) / (double)(n - 1));
      for (int r = 0; r < 4; ++r) {
        for (int c = 0; c <= r; ++c) {  // lower band: row first+r, column first+c
          int row = b.first + r, col = b.first + c;
          rod->mass_band[4 * row + 3 + col - row] += segment_mass * weight[g] * b.weight[r] * b.weight[c];
        }
      }
    }
  }
  for (int k = 0; k < n; ++k) rod->mass_row_sum[k] = 0.0;
  for (int i = 0; i < n; ++i) {
    for (int d = 0; d < 4; ++d) {
      int j = i - 3 + d;
      if (j < 0) continue;
      double a = rod->mass_band[4 * i + d];
      rod->mass_row_sum[i] += a;
      if (j != i) rod->mass_row_sum[j] += a;
    }
  }
  if (!rod->def.lumped_mass) return;
  // lumped: each row's sum on the diagonal (same total mass and gravity forces)
  memset(rod->mass_band, 0, sizeof(double) * 4 * n);
  for (int k = 0; k < n; ++k) rod->mass_band[4 * k + 3] = rod->mass_row_sum[k];
}

// The pinned points' accelerations are zero: solving the principal submatrix of
// the free points equals solving M with pinned rows and columns replaced by identity.
static vsc_status factor_mass(vsc_rod* rod) {
  int n = rod->n;
  memcpy(rod->mass_factor, rod->mass_band, sizeof(double) * 4 * n);
  for (int k = 0; k < n; ++k) {
    if (!rod->is_pinned[k]) continue;
    for (int d = 0; d < 3; ++d) rod->mass_factor[4 * k + d] = 0.0;  // row k, left of diagonal
    rod->mass_factor[4 * k + 3] = 1.0;
    for (int r = k + 1; r <= k + 3 && r < n; ++r) rod->mass_factor[4 * r + 3 + k - r] = 0.0;  // column k
  }
  return vsc_band_factor(rod->mass_factor, n);
}

// Transpose the sample basis: control point k depends on the consecutive
// samples whose window [first, first + 3] contains k.
static void build_gather(vsc_rod* rod) {
  int n = rod->n, N = rod->sample_count, offset = 0, a0 = 0;
  rod->gather_count = rod->gather_first + n;
  rod->gather_offset = rod->gather_first + 2 * n;
  for (int k = 0; k < n; ++k) {
    // windows' first points rise with the sample, so a0 only moves forward: O(N) in all
    while (rod->sample_basis[a0].first + VSC_SPLINE_SUPPORT - 1 < k) ++a0;
    int a1 = a0;
    while (a1 + 1 < N && rod->sample_basis[a1 + 1].first <= k) ++a1;
    rod->gather_first[k] = a0;
    rod->gather_count[k] = a1 - a0 + 1;
    rod->gather_offset[k] = offset;
    for (int a = a0; a <= a1; ++a) {
      int i = k - rod->sample_basis[a].first;
      rod->gather_weight[offset++] = (i >= 0 && i < VSC_SPLINE_SUPPORT) ? rod->sample_basis[a].weight[i] : 0.0;
    }
  }
}

// Bound on the Jacobian's half-bandwidth (scalars), for the memory estimate:
// samples two apart span at most 3 + ceil(2 / S) control points.
static int jacobian_half_width_bound(int samples_per_segment) {
  return 3 * (3 + (2 + samples_per_segment - 1) / samples_per_segment) + 2;
}

double vsc_rod_memory_bytes(const vsc_rod_def* def) {
  double n = def->control_count, S = def->samples_per_segment, N = (n - 1.0) * S + 1.0;
  double spheres = def->collision_sphere_count;
  double tethers = def->mesentery_points > 0 ? def->mesentery_points : 1;
  double per_sample = sizeof(vsc_basis) + 10.0 * sizeof(double) + 27.0 * sizeof(double);
  double per_point = 9.0 * sizeof(double) + 1.0 + 3.0 * sizeof(int) + (4.0 * S + 1.0) * sizeof(double) +
                     24.0 * sizeof(double) + 12.0 * sizeof(double) +
                     3.0 * (jacobian_half_width_bound(def->samples_per_segment) + 1.0) * sizeof(double);
  double per_sphere = sizeof(vsc_basis) + 6.0 * sizeof(double) + (VSC_STICK_SIZE + VSC_TOUCH_SIZE) * sizeof(double);
  double bytes = sizeof(vsc_rod) + N * per_sample + n * per_point + spheres * per_sphere +
                 tethers * sizeof(vsc_basis) + (def->pinned_count > 0 ? def->pinned_count : 1) * sizeof(int);
  if (spheres >= 1.0 && spheres <= (double)VSC_MAX_COLLISION_SPHERES)
    bytes += vsc_grid_memory_bytes((int)spheres) + vsc_contact_lists_memory_bytes((int)spheres);
  return bytes;
}

vsc_status vsc_rod_create(const vsc_rod_def* def, vsc_rod** out) {
  *out = NULL;
  vsc_status status = validate(def);
  if (status != VSC_OK) return status;
  if (vsc_rod_memory_bytes(def) > VSC_MAX_ROD_BYTES) return VSC_ERROR_OUT_OF_MEMORY;
  vsc_rod* rod = (vsc_rod*)calloc(1, sizeof(vsc_rod));
  if (!rod) return VSC_ERROR_OUT_OF_MEMORY;
  int n = def->control_count, spheres = def->collision_sphere_count, S = def->samples_per_segment;
  rod->def = *def;
  rod->contact_damping_rate = 0.0;
  double* clamp_direction[2] = {rod->def.clamp_direction_start, rod->def.clamp_direction_end};
  for (int end = 0; end < 2; ++end) {
    double* t = clamp_direction[end];
    double norm = sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
    if (norm > 0.0)
      for (int i = 0; i < 3; ++i) t[i] /= norm;
  }
  rod->n = n;
  rod->sample_count = (n - 1) * S + 1;
  int N = rod->sample_count;
  rod->rest_spacing = def->length / (double)(N - 1);
  rod->stretch_spring = def->stretch_stiffness * (double)(N - 1);
  rod->bend_spring = def->bend_stiffness * (double)(N - 1);
  rod->sample_basis = (vsc_basis*)malloc(sizeof(vsc_basis) * N);
  rod->sphere_basis = (vsc_basis*)malloc(sizeof(vsc_basis) * spheres);
  rod->mass_band = (double*)malloc(sizeof(double) * 4 * n);
  rod->mass_factor = (double*)malloc(sizeof(double) * 4 * n);
  rod->mass_row_sum = (double*)malloc(sizeof(double) * n);
  rod->pinned = (int*)malloc(sizeof(int) * (def->pinned_count > 0 ? def->pinned_count : 1));
  rod->is_pinned = (unsigned char*)calloc((size_t)n, 1);
  rod->gather_first = (int*)malloc(sizeof(int) * 3 * (size_t)n);
  // each sample feeds 4 control points, so the transpose holds 4 N <= n (4 S + 1) weights
  rod->gather_weight = (double*)malloc(sizeof(double) * (size_t)n * (4 * (size_t)S + 1));
  rod->scratch = (double*)malloc(sizeof(double) * 10 * (size_t)N);
  rod->sphere_xyz = (double*)malloc(sizeof(double) * 3 * spheres);
  rod->sphere_velocity = (double*)calloc(3 * (size_t)spheres, sizeof(double));
  rod->stage = (double*)malloc(sizeof(double) * 8 * 3 * n);
  rod->sample_hessian = (double*)malloc(sizeof(double) * 27 * (size_t)N);
  rod->backup = (double*)malloc(sizeof(double) * (12 * (size_t)n + VSC_STICK_SIZE * (size_t)spheres));
  rod->touch = (double*)calloc((size_t)spheres * VSC_TOUCH_SIZE, sizeof(double));
  rod->tether_basis = (vsc_basis*)malloc(sizeof(vsc_basis) * (size_t)(def->mesentery_points > 0 ? def->mesentery_points : 1));
  vsc_grid_create(spheres, &rod->grid);
  rod->lists = vsc_contact_lists_create(spheres);
  if (!rod->sample_basis || !rod->sphere_basis || !rod->mass_band || !rod->mass_factor ||
      !rod->mass_row_sum || !rod->pinned || !rod->is_pinned || !rod->gather_first || !rod->gather_weight ||
      !rod->scratch || !rod->sphere_xyz || !rod->sphere_velocity || !rod->stage || !rod->sample_hessian || !rod->backup || !rod->touch || !rod->grid || !rod->lists || !rod->tether_basis) {
    vsc_rod_destroy(rod);
    return VSC_ERROR_OUT_OF_MEMORY;
  }
  double* block[10];
  for (int i = 0; i < 10; ++i) block[i] = rod->scratch + (size_t)i * N;
  rod->sample_x = block[0]; rod->sample_y = block[1]; rod->sample_z = block[2];
  rod->force_x = block[3]; rod->force_y = block[4]; rod->force_z = block[5];
  rod->edge_x = block[6]; rod->edge_y = block[7]; rod->edge_z = block[8];
  rod->edge_length = block[9];
  for (int i = 0; i < def->pinned_count; ++i) {
    rod->pinned[i] = def->pinned[i];
    rod->is_pinned[def->pinned[i]] = 1;
  }
  rod->def.pinned = rod->pinned;
  rod->energy_state = rod->backup + 6 * (size_t)n + VSC_STICK_SIZE * (size_t)spheres;
  for (int a = 0; a < N; ++a) rod->sample_basis[a] = vsc_spline_basis(n, (double)a / (double)(N - 1));
  for (int i = 0; i < spheres; ++i)
    rod->sphere_basis[i] = vsc_spline_basis(n, (double)i / (double)(spheres - 1));
  build_gather(rod);
  // the Jacobian couples the control points of samples up to two apart (bend
  // springs, bending angles), the mass matrix those up to three apart
  // (weights below VSC_NEGLIGIBLE_WEIGHT, rounding's leftovers at knots, do not count)
  int reach = 3;
  for (int a = 0; a + 2 < N; ++a) {
    const vsc_basis *low = &rod->sample_basis[a], *high = &rod->sample_basis[a + 2];
    int first = 0, last = VSC_SPLINE_SUPPORT - 1;
    while (first < VSC_SPLINE_SUPPORT - 1 && fabs(low->weight[first]) < VSC_NEGLIGIBLE_WEIGHT) ++first;
    while (last > 0 && fabs(high->weight[last]) < VSC_NEGLIGIBLE_WEIGHT) --last;
    int span = high->first + last - (low->first + first);
    reach = span > reach ? span : reach;
  }
  rod->jacobian_half_width = 3 * reach + 2;
  rod->system = (double*)malloc(sizeof(double) * 3 * (size_t)n * (size_t)(rod->jacobian_half_width + 1));
  rod->factor_row = (double*)malloc(sizeof(double) * (size_t)(rod->jacobian_half_width + 1));
  if (!rod->system || !rod->factor_row) {
    vsc_rod_destroy(rod);
    return VSC_ERROR_OUT_OF_MEMORY;
  }
  for (int i = 0; i < def->mesentery_points; ++i)
    rod->tether_basis[i] = vsc_spline_basis(n, ((double)i + 0.5) / (double)def->mesentery_points);
  // self-contact exclusion: segments whose nearest points are closer along
  // the rest axis than pi r (the arc of the tightest fold, whose centre line
  // has radius r) are neighbours: collide when (b - a - 1) spacing >= pi r
  double sphere_spacing = def->length / (double)(spheres - 1);
  rod->self_gap = (int)ceil(VSC_PI * def->radius / sphere_spacing - 1e-9) + 1;
  assemble_mass(rod);
  status = factor_mass(rod);
  if (status != VSC_OK) {
    vsc_rod_destroy(rod);
    return status;
  }
  *out = rod;
  return VSC_OK;
}

void vsc_rod_destroy(vsc_rod* rod) {
  if (!rod) return;
  free(rod->sample_basis);
  free(rod->sphere_basis);
  free(rod->mass_band);
  free(rod->mass_factor);
  free(rod->mass_row_sum);
  free(rod->pinned);
  free(rod->is_pinned);
  free(rod->gather_first);
  free(rod->gather_weight);
  free(rod->scratch);
  free(rod->sphere_xyz);
  free(rod->sphere_velocity);
  free(rod->stage);
  free(rod->sample_hessian);
  free(rod->system);
  free(rod->factor_row);
  free(rod->backup);
  free(rod->touch);
  free(rod->tether_basis);
  vsc_grid_destroy(rod->grid);
  vsc_contact_lists_destroy(rod->lists);
  free(rod);
}

void vsc_rod_update_samples(vsc_rod* rod, const double* q) {
  double *x = rod->sample_x, *y = rod->sample_y, *z = rod->sample_z;
  for (int a = 0; a < rod->sample_count; ++a) {
    const vsc_basis* b = &rod->sample_basis[a];
    const double* p = q + 3 * b->first;
    double w0 = b->weight[0], w1 = b->weight[1], w2 = b->weight[2], w3 = b->weight[3];
    x[a] = w0 * p[0] + w1 * p[3] + w2 * p[6] + w3 * p[9];
    y[a] = w0 * p[1] + w1 * p[4] + w2 * p[7] + w3 * p[10];
    z[a] = w0 * p[2] + w1 * p[5] + w2 * p[8] + w3 * p[11];
  }
}

void vsc_rod_update_spheres(vsc_rod* rod, const double* q, const double* v) {
  int spheres = rod->def.collision_sphere_count;
  for (int i = 0; i < spheres; ++i) {
    vsc_basis_point(&rod->sphere_basis[i], q, rod->sphere_xyz + 3 * i);
    if (v) vsc_basis_point(&rod->sphere_basis[i], v, rod->sphere_velocity + 3 * i);
  }
}

// Vectors and lengths of the springs from sample a to a + gap. Restrict
// parameters (not restrict locals) are what lets GCC vectorise it.
VSC_VECTOR_CLONES static void edge_vectors(const double* restrict x, const double* restrict y,
                                           const double* restrict z, double* restrict ex, double* restrict ey,
                                           double* restrict ez, double* restrict el, int count, int gap) {
  for (int a = 0; a < count; ++a) {
    double dx = x[a + gap] - x[a], dy = y[a + gap] - y[a], dz = z[a + gap] - z[a];
    ex[a] = dx;
    ey[a] = dy;
    ez[a] = dz;
    el[a] = sqrt(dx * dx + dy * dy + dz * dz);
  }
}

// Vectors and lengths of the springs from sample a to a + gap (N - gap of
// them) into edge_*; returns the sum of their lengths (m).
static double spring_edges(vsc_rod* rod, int gap) {
  int count = rod->sample_count - gap;
  edge_vectors(rod->sample_x, rod->sample_y, rod->sample_z, rod->edge_x, rod->edge_y, rod->edge_z,
               rod->edge_length, count, gap);
  const double* el = rod->edge_length;
  double total = 0.0;  // apart and in order: an ordered sum does not vectorise
  for (int a = 0; a < count; ++a) total += el[a];
  return total;
}

VSC_VECTOR_CLONES static void scale_edges(double* restrict ex, double* restrict ey, double* restrict ez,
                                          const double* restrict el, int count, double k, double rest,
                                          double extra) {
  for (int a = 0; a < count; ++a) {
    double scale = (k * (el[a] - rest) + extra) / (el[a] + 1e-300);
    ex[a] *= scale;
    ey[a] *= scale;
    ez[a] *= scale;
  }
}

// Turn the edges into tension vectors (k (l - rest) + extra) e / l in place
// (N). The tiny addend keeps a zero-length spring finite: its vector is zero.
static void spring_tensions(vsc_rod* rod, int count, double k, double rest, double extra) {
  scale_edges(rod->edge_x, rod->edge_y, rod->edge_z, rod->edge_length, count, k, rest, extra);
}

// f_a += t_a - t_{a-gap}: a stretched spring pulls its first sample forwards
// and its last one back. `first`: f starts from zero, written here (no
// clearing pass). Each element sums in the same order as two separate passes
// would: (f_a + t_a) - t_{a-gap}, with f_a = 0.0 when first.
static void add_spring_forces(vsc_rod* rod, int gap, int first) {
  int N = rod->sample_count, count = N - gap;
  // distinct blocks of rod->scratch (restrict: the loops vectorise)
  const double *restrict tx = rod->edge_x, *restrict ty = rod->edge_y, *restrict tz = rod->edge_z;
  double *restrict fx = rod->force_x, *restrict fy = rod->force_y, *restrict fz = rod->force_z;
  int low = gap < count ? gap : count, high = gap > count ? gap : count;
  // [0, low): + only; [gap, count): both; [count, gap): neither; [high, N): - only
  if (first) {
    for (int a = 0; a < low; ++a) {
      fx[a] = 0.0 + tx[a];
      fy[a] = 0.0 + ty[a];
      fz[a] = 0.0 + tz[a];
    }
    for (int a = gap; a < count; ++a) {
      fx[a] = (0.0 + tx[a]) - tx[a - gap];
      fy[a] = (0.0 + ty[a]) - ty[a - gap];
      fz[a] = (0.0 + tz[a]) - tz[a - gap];
    }
    for (int a = count; a < gap; ++a) fx[a] = fy[a] = fz[a] = 0.0;
    for (int a = high; a < N; ++a) {
      fx[a] = 0.0 - tx[a - gap];
      fy[a] = 0.0 - ty[a - gap];
      fz[a] = 0.0 - tz[a - gap];
    }
    return;
  }
  for (int a = 0; a < low; ++a) {
    fx[a] += tx[a];
    fy[a] += ty[a];
    fz[a] += tz[a];
  }
  for (int a = gap; a < count; ++a) {
    fx[a] = (fx[a] + tx[a]) - tx[a - gap];
    fy[a] = (fy[a] + ty[a]) - ty[a - gap];
    fz[a] = (fz[a] + tz[a]) - tz[a - gap];
  }
  for (int a = high; a < N; ++a) {
    fx[a] -= tx[a - gap];
    fy[a] -= ty[a - gap];
    fz[a] -= tz[a - gap];
  }
}

// Elastic sample forces -dE/dp into force_* (samples must be current).
// Curvature bending on the sample polyline (see vsc_rod.h): adds its forces
// F = -dE/dp to force_* if `forces`; returns its energy (J).
static double curvature_bending(vsc_rod* rod, int forces) {
  int N = rod->sample_count;
  double k = rod->def.bending_rigidity / rod->rest_spacing, energy = 0.0;
  if (!(k > 0.0) || N < 3) return 0.0;
  const double *x = rod->sample_x, *y = rod->sample_y, *z = rod->sample_z;
  double *fx = rod->force_x, *fy = rod->force_y, *fz = rod->force_z;
  for (int a = 1; a + 1 < N; ++a) {
    double u[3] = {x[a] - x[a - 1], y[a] - y[a - 1], z[a] - z[a - 1]};
    double w[3] = {x[a + 1] - x[a], y[a + 1] - y[a], z[a + 1] - z[a]};
    double uu = u[0] * u[0] + u[1] * u[1] + u[2] * u[2], ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
    double inverse = 1.0 / sqrt(uu * ww);
    if (!isfinite(inverse)) continue;  // coincident samples: no angle
    double c = (u[0] * w[0] + u[1] * w[1] + u[2] * w[2]) * inverse;
    energy += k * (1.0 - c);
    if (!forces) continue;
    double du[3], dw[3];  // dc/du and dc/dw
    for (int i = 0; i < 3; ++i) {
      du[i] = w[i] * inverse - c * u[i] / uu;
      dw[i] = u[i] * inverse - c * w[i] / ww;
    }
    // F = k dc/dp: p_{a-1} enters u with -1, p_a enters u with +1 and w with -1
    fx[a - 1] -= k * du[0];
    fy[a - 1] -= k * du[1];
    fz[a - 1] -= k * du[2];
    fx[a] += k * (du[0] - dw[0]);
    fy[a] += k * (du[1] - dw[1]);
    fz[a] += k * (du[2] - dw[2]);
    fx[a + 1] += k * dw[0];
    fy[a + 1] += k * dw[1];
    fz[a + 1] += k * dw[2];
  }
  // clamps: 2k (1 - t . e / |e|) on the first and last spring edges e
  int clamped[2] = {rod->def.clamp_start, rod->def.clamp_end};
  const double* direction[2] = {rod->def.clamp_direction_start, rod->def.clamp_direction_end};
  for (int end = 0; end < 2; ++end) {
    if (!clamped[end]) continue;
    int a = end ? N - 2 : 0;  // edge from sample a to a + 1
    const double* t = direction[end];
    double e[3] = {x[a + 1] - x[a], y[a + 1] - y[a], z[a + 1] - z[a]};
    double length = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
    if (!(length > 0.0)) continue;
    double c = (t[0] * e[0] + t[1] * e[1] + t[2] * e[2]) / length;
    energy += 2.0 * k * (1.0 - c);
    if (!forces) continue;
    double g[3];  // F on sample a + 1 = 2k dc/de
    for (int i = 0; i < 3; ++i) g[i] = 2.0 * k * (t[i] - c * e[i] / length) / length;
    fx[a + 1] += g[0];
    fy[a + 1] += g[1];
    fz[a + 1] += g[2];
    fx[a] -= g[0];
    fy[a] -= g[1];
    fz[a] -= g[2];
  }
  return energy;
}

static void elastic_sample_forces(vsc_rod* rod) {
  int N = rod->sample_count;
  // stretch springs and the global term: dE_g/dl = K_g (l - length) is a
  // tension shared by every stretch spring
  double length = spring_edges(rod, 1);
  double global_tension = rod->def.global_stretch_stiffness * (length - rod->def.length);
  spring_tensions(rod, N - 1, rod->stretch_spring, rod->rest_spacing, global_tension);
  add_spring_forces(rod, 1, 1);  // clears the forces first
  if (rod->bend_spring > 0.0 && N > 2) {
    spring_edges(rod, 2);
    spring_tensions(rod, N - 2, rod->bend_spring, 2.0 * rod->rest_spacing, 0.0);
    add_spring_forces(rod, 2, 0);
  }
  curvature_bending(rod, 1);
}

// Virtual work as a gather: Q_k += sum over samples a of b_k(s_a) F_a, each
// control point reading its own contiguous range of samples.
static void gather_to_control(const vsc_rod* rod, double* Q) {
  const double *fx = rod->force_x, *fy = rod->force_y, *fz = rod->force_z;
  for (int k = 0; k < rod->n; ++k) {
    int a0 = rod->gather_first[k], count = rod->gather_count[k];
    const double* w = rod->gather_weight + rod->gather_offset[k];
    double sx = 0.0, sy = 0.0, sz = 0.0;
    for (int i = 0; i < count; ++i) {
      sx += w[i] * fx[a0 + i];
      sy += w[i] * fy[a0 + i];
      sz += w[i] * fz[a0 + i];
    }
    Q[3 * k] += sx;
    Q[3 * k + 1] += sy;
    Q[3 * k + 2] += sz;
  }
}

double vsc_rod_length(vsc_rod* rod, const double* q) {
  vsc_rod_update_samples(rod, q);
  return spring_edges(rod, 1);
}

// Mesentery tether i: from the axis at abscissa (i + 1/2) / count to the
// same fraction of the root line; it pulls only when longer than its slack
// length: E_i = 1/2 k max(0, d - L)^2. Adds -dE/dq to Q if Q is not NULL;
// returns the tethers' energy (J).
static double mesentery(const vsc_rod* rod, const double* q, double* Q) {
  const vsc_rod_def* d = &rod->def;
  if (d->mesentery_points <= 0 || d->mesentery_stiffness <= 0.0) return 0.0;
  double energy = 0.0;
  for (int i = 0; i < d->mesentery_points; ++i) {
    double f = ((double)i + 0.5) / (double)d->mesentery_points, p[3], e[3];
    vsc_basis_point(&rod->tether_basis[i], q, p);
    for (int c = 0; c < 3; ++c) e[c] = d->mesentery_root[c] + f * (d->mesentery_root[3 + c] - d->mesentery_root[c]) - p[c];
    double length = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]), stretch = length - d->mesentery_length;
    if (!(stretch > 0.0)) continue;  // slack: no force
    energy += 0.5 * d->mesentery_stiffness * stretch * stretch;
    if (!Q) continue;
    double scale = d->mesentery_stiffness * stretch / length, force[3] = {scale * e[0], scale * e[1], scale * e[2]};
    const vsc_basis* b = &rod->tether_basis[i];
    for (int j = 0; j < VSC_SPLINE_SUPPORT; ++j)
      for (int c = 0; c < 3; ++c) Q[3 * (b->first + j) + c] += b->weight[j] * force[c];
  }
  return energy;
}

void vsc_rod_forces(vsc_rod* rod, const vsc_world* world, const double* q, const double* v, double* Q) {
  int n = rod->n;
  for (int k = 0; k < n; ++k) {  // gravity, distributed exactly: Q_k = g sum_j M_kj
    double m = rod->mass_row_sum[k];
    Q[3 * k] = m * world->gravity[0];
    Q[3 * k + 1] = m * world->gravity[1];
    Q[3 * k + 2] = m * world->gravity[2];
  }
  vsc_rod_update_samples(rod, q);
  elastic_sample_forces(rod);
  gather_to_control(rod, Q);
  mesentery(rod, q, Q);
  if (world->grasp_count > 0) vsc_rod_grasp_forces(rod, world, q, v, Q);
  rod->touched = world->geom_count > 0 || rod->def.self_collision;
  if (rod->touched) {
    vsc_rod_update_spheres(rod, q, v);
    vsc_rod_contact_forces(rod, world, Q);
  }
}

void vsc_rod_acceleration(vsc_rod* rod, const vsc_world* world, const double* q, const double* v,
                          double* a) {
  int n = rod->n;
  vsc_rod_forces(rod, world, q, v, a);
  for (int k = 0; k < n; ++k)
    if (rod->is_pinned[k]) a[3 * k] = a[3 * k + 1] = a[3 * k + 2] = 0.0;
  if (rod->def.lumped_mass) {  // a diagonal factor: the band solve's off-diagonal terms are all zero
    for (int k = 0; k < n; ++k) {
      double inverse = rod->mass_factor[4 * k + 3];
      a[3 * k] *= inverse;
      a[3 * k + 1] *= inverse;
      a[3 * k + 2] *= inverse;
    }
  } else {
    vsc_band_solve3(rod->mass_factor, n, a);
  }
  // damping force -c M v gives acceleration -c v without a solve
  double c = rod->def.damping;
  for (int i = 0; i < 3 * n; ++i) a[i] -= c * v[i];
  for (int k = 0; k < n; ++k)
    if (rod->is_pinned[k]) a[3 * k] = a[3 * k + 1] = a[3 * k + 2] = 0.0;
}

double vsc_rod_elastic_energy(vsc_rod* rod, const double* q) {
  vsc_rod_update_samples(rod, q);
  int N = rod->sample_count;
  double e = 0.0, dl = spring_edges(rod, 1) - rod->def.length;
  for (int a = 0; a + 1 < N; ++a) {
    double d = rod->edge_length[a] - rod->rest_spacing;
    e += 0.5 * rod->stretch_spring * d * d;
  }
  e += 0.5 * rod->def.global_stretch_stiffness * dl * dl + mesentery(rod, q, NULL) + curvature_bending(rod, 0);
  if (N > 2) {
    spring_edges(rod, 2);
    for (int a = 0; a + 2 < N; ++a) {
      double d = rod->edge_length[a] - 2.0 * rod->rest_spacing;
      e += 0.5 * rod->bend_spring * d * d;
    }
  }
  return e;
}

double vsc_rod_active_energy(vsc_rod* rod, const double* q, const double* v) {
  size_t bytes = sizeof(double) * 3 * (size_t)rod->n;
  double* known_q = rod->energy_state;
  double* known_v = known_q + 3 * rod->n;
  if (rod->energy_known && memcmp(known_q, q, bytes) == 0 && memcmp(known_v, v, bytes) == 0)
    return rod->energy_active;  // the step's end, now the next step's start
  rod->energy_active = vsc_rod_kinetic_energy(rod, v) + vsc_rod_elastic_energy(rod, q);
  memcpy(known_q, q, bytes);
  memcpy(known_v, v, bytes);
  rod->energy_known = 1;
  return rod->energy_active;
}

double vsc_rod_gravity_energy(const vsc_rod* rod, const double gravity[3], const double* q) {
  double e = 0.0;
  for (int k = 0; k < rod->n; ++k)
    e -= rod->mass_row_sum[k] * (gravity[0] * q[3 * k] + gravity[1] * q[3 * k + 1] + gravity[2] * q[3 * k + 2]);
  return e;
}

double vsc_rod_kinetic_energy(vsc_rod* rod, const double* v) {
  if (rod->def.lumped_mass) {
    double e = 0.0;
    for (int k = 0; k < rod->n; ++k) {
      const double* vk = v + 3 * k;
      e += 0.5 * rod->mass_band[4 * k + 3] * (vk[0] * vk[0] + vk[1] * vk[1] + vk[2] * vk[2]);
    }
    return e;
  }
  double* Mv = rod->stage;  // scratch
  vsc_band_multiply3(rod->mass_band, rod->n, v, Mv);
  double e = 0.0;
  for (int i = 0; i < 3 * rod->n; ++i) e += 0.5 * v[i] * Mv[i];
  return e;
}
