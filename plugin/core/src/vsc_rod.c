// The rod handle: its definition's defaults and checks, the mass matrix, the
// basis tables, the arrays it owns with each stage's state carved from them;
// and the public queries that hand a stage its state (the evaluation is in
// vsc_forces.c, the step in vsc_step.c).
#include "vsc_rod.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "viscera/vsc_band.h"
#include "viscera/vsc_friction.h"
#include "vsc_contact.h"
#include "vsc_elastic.h"
#include "vsc_place.h"
#include "vsc_schemes.h"
#include "vsc_sleep.h"
#include "vsc_step.h"

// Every stage's state, in one piece of the rod's block.
typedef struct stage_states {
  vsc_placement placement;
  vsc_elastic_scratch elastic;
  vsc_contact_pass contact;
  vsc_sleep_flags sleep;
  vsc_scheme_scratch scheme;
  vsc_step_backup backup;
} stage_states;


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
  def.lumped_mass = 1;  // with leapfrog: 3 substeps per 2 ms where the consistent M needs 5 (docs/benchmarks.md)
  def.collision_sphere_count = vsc_default_collision_sphere_count(def.length, def.radius);
  def.contact_stiffness = 2000.0;
  def.contact_damping = 2.0;
  def.self_collision = 1;
  def.self_friction = 0.3;
  return def;
}

double vsc_rod_def_radius_at(const vsc_rod_def* def, double s) {
  if (!(def->radius_end > 0.0)) return def->radius;
  return def->radius + s * (def->radius_end - def->radius);
}

double vsc_rod_def_radius_max(const vsc_rod_def* def) {
  return def->radius_end > def->radius ? def->radius_end : def->radius;
}

double vsc_rod_def_radius_min(const vsc_rod_def* def) {
  return def->radius_end > 0.0 && def->radius_end < def->radius ? def->radius_end : def->radius;
}

int vsc_default_collision_sphere_count(double length, double radius) {
  double count = ceil(length / radius - 1e-9) + 1.0;  // in double: no int overflow
  return isfinite(count) && count <= VSC_MAX_COLLISION_SPHERES ? (int)count : -1;
}

void vsc_tube_section(double radius, double wall_thickness, double* area, double* second_moment) {
  double inner = wall_thickness > 0.0 && wall_thickness < radius ? radius - wall_thickness : 0.0;  // else solid
  double r2 = radius * radius, i2 = inner * inner;
  *area = VSC_PI * (r2 - i2);
  *second_moment = 0.25 * VSC_PI * (r2 * r2 - i2 * i2);
}

void vsc_material_stiffnesses(double young_modulus, double radius, double wall_thickness, double length,
                              double* stretch_stiffness, double* bending_rigidity) {
  double area, second_moment;
  vsc_tube_section(radius, wall_thickness, &area, &second_moment);
  *stretch_stiffness = young_modulus * area / length;
  *bending_rigidity = young_modulus * second_moment;
}

static int finite_nonneg(double x) { return isfinite(x) && x >= 0.0; }
static int finite_pos(double x) { return isfinite(x) && x > 0.0; }

static vsc_status validate(const vsc_rod_def* d) {
  if (d->control_count < 4 || d->samples_per_segment < 1 || d->collision_sphere_count < 2)
    return VSC_ERROR_INVALID_ARGUMENT;
  if (d->control_count > VSC_MAX_CONTROL_POINTS || d->collision_sphere_count > VSC_MAX_COLLISION_SPHERES ||
      (double)(d->control_count - 1) * (double)d->samples_per_segment + 1.0 > VSC_MAX_SAMPLES)
    return VSC_ERROR_INVALID_ARGUMENT;
  if (!(d->radius_end == 0.0 || finite_pos(d->radius_end))) return VSC_ERROR_INVALID_ARGUMENT;
  if (!finite_nonneg(d->wall_thickness)) return VSC_ERROR_INVALID_ARGUMENT;
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

// A tapered tube's springs follow its section (vsc_rod.h): area at each
// stretch spring's middle, second moment at each sample for the curvature term
// (and for the bend spring whose middle it is: bend_scale points into it), over
// the section at s = 0.
static void section_scales(vsc_rod* rod) {
  const vsc_rod_def* d = &rod->def;
  int N = rod->sample_count;
  double area0, moment0, area, moment;
  vsc_tube_section(d->radius, d->wall_thickness, &area0, &moment0);
  for (int a = 0; a < N; ++a) {
    vsc_tube_section(vsc_rod_def_radius_at(d, (double)a / (double)(N - 1)), d->wall_thickness, &area, &moment);
    rod->curvature_scale[a] = moment / moment0;
    if (a + 1 < N) {
      vsc_tube_section(vsc_rod_def_radius_at(d, ((double)a + 0.5) / (double)(N - 1)), d->wall_thickness, &area, &moment);
      rod->stretch_scale[a] = area / area0;
    }
  }
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
  // a tapered tube's mass per length follows its section, radius^2 (the lumen full), about its
  // mean over the length, (r0^2 + r0 r1 + r1^2) / 3, so that the total stays `mass`; this
  // quadratic times the basis's degree 6 is not integrated exactly, but the total is (the basis
  // sums to 1)
  double r0 = rod->def.radius, r1 = vsc_rod_def_radius_at(&rod->def, 1.0);
  double mean_square = (r0 * r0 + r0 * r1 + r1 * r1) / 3.0;
  int tapered = r1 != r0;
  memset(rod->mass_band, 0, sizeof(double) * 4 * n);
  for (int j = 0; j < n - 1; ++j) {
    for (int g = 0; g < 4; ++g) {
      double s = ((double)j + node[g]) / (double)(n - 1);
      vsc_basis b = vsc_spline_basis(n, s);
      double here = vsc_rod_def_radius_at(&rod->def, s);
      double share = tapered ? segment_mass * weight[g] * (here * here / mean_square) : segment_mass * weight[g];
      for (int r = 0; r < 4; ++r) {
        for (int c = 0; c <= r; ++c) {  // lower band: row first+r, column first+c
          int row = b.first + r, col = b.first + c;
          rod->mass_band[4 * row + 3 + col - row] += share * b.weight[r] * b.weight[c];
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

// The arrays a rod owns, all in one block. Their sizes come from the
// definition alone, in one table that vsc_rod_memory_bytes sums and
// vsc_rod_create carves the block from.
enum {
  ARRAY_SAMPLE_BASIS,    // vsc_basis per sample (N)
  ARRAY_SPHERE_BASIS,    // vsc_basis per sphere
  ARRAY_TETHER_BASIS,    // vsc_basis per mesentery tether (at least 1)
  ARRAY_MASS_BAND,       // 4 n
  ARRAY_MASS_FACTOR,     // 4 n
  ARRAY_MASS_ROW_SUM,    // n
  ARRAY_GATHER_WEIGHT,   // n (4 S + 1): each sample feeds 4 control points, so the transpose holds 4 N <= n (4 S + 1)
  ARRAY_STAGE_STATES,    // the stages' structs (stage_states)
  ARRAY_ELASTIC,         // 10 N: the elastic pass's sample_x .. edge_length
  ARRAY_SPHERE_XYZ,      // 3 per sphere
  ARRAY_SPHERE_VELOCITY, // 3 per sphere
  ARRAY_SPHERE_RADIUS,   // 1 per sphere
  ARRAY_STAGE,           // 8 x 3n
  ARRAY_JACOBIAN,        // 27 N: the implicit step's Jacobian scratch
  ARRAY_SYSTEM,          // 3n x (half width + 1), at the half width's bound
  ARRAY_FACTOR_ROW,      // half width + 1
  ARRAY_BACKUP,          // the step's backup (VSC_STEP_BACKUP_DOUBLES)
  ARRAY_TOUCH,           // VSC_TOUCH_SIZE per sphere
  ARRAY_CONTACT_LOAD,    // 1 per sphere, then 2n
  ARRAY_DAMPING_SCALE,   // 1 per sphere
  ARRAY_GATHER_FIRST,    // 3n ints: gather_first, gather_count, gather_offset
  ARRAY_PINNED,          // pinned indices (at least 1)
  ARRAY_IS_PINNED,       // n bytes
  ARRAY_ASLEEP,          // n bytes, 1 byte per sphere, then 2 x n bytes
  ARRAY_SECTION_SCALE,   // 2 N - 1 if tapered (stretch, curvature factors), else none
  ARRAY_COUNT
};

// Each array starts at a multiple of this (bytes): a cache line.
#define ARRAY_ALIGNMENT 64.0

// Bytes of each array (doubles: no product overflows), from the definition.
static void array_bytes(const vsc_rod_def* def, double bytes[ARRAY_COUNT]) {
  double n = def->control_count, S = def->samples_per_segment, N = (n - 1.0) * S + 1.0;
  double spheres = def->collision_sphere_count, half_width = jacobian_half_width_bound(def->samples_per_segment);
  double d = sizeof(double), basis = sizeof(vsc_basis);
  bytes[ARRAY_SAMPLE_BASIS] = N * basis;
  bytes[ARRAY_SPHERE_BASIS] = spheres * basis;
  bytes[ARRAY_TETHER_BASIS] = (def->mesentery_points > 0 ? def->mesentery_points : 1) * basis;
  bytes[ARRAY_MASS_BAND] = 4.0 * n * d;
  bytes[ARRAY_MASS_FACTOR] = 4.0 * n * d;
  bytes[ARRAY_MASS_ROW_SUM] = n * d;
  bytes[ARRAY_GATHER_WEIGHT] = n * (4.0 * S + 1.0) * d;
  bytes[ARRAY_STAGE_STATES] = sizeof(stage_states);
  bytes[ARRAY_ELASTIC] = 10.0 * N * d;
  bytes[ARRAY_SPHERE_XYZ] = 3.0 * spheres * d;
  bytes[ARRAY_SPHERE_VELOCITY] = 3.0 * spheres * d;
  bytes[ARRAY_SPHERE_RADIUS] = spheres * d;
  bytes[ARRAY_STAGE] = 24.0 * n * d;
  bytes[ARRAY_JACOBIAN] = VSC_JACOBIAN_SCRATCH_DOUBLES(N) * d;
  bytes[ARRAY_SYSTEM] = 3.0 * n * (half_width + 1.0) * d;
  bytes[ARRAY_FACTOR_ROW] = (half_width + 1.0) * d;
  bytes[ARRAY_BACKUP] = VSC_STEP_BACKUP_DOUBLES(n, spheres) * d;
  bytes[ARRAY_TOUCH] = VSC_TOUCH_SIZE * spheres * d;
  bytes[ARRAY_CONTACT_LOAD] = (spheres + 2.0 * n) * d;
  bytes[ARRAY_DAMPING_SCALE] = spheres * d;
  bytes[ARRAY_GATHER_FIRST] = 3.0 * n * sizeof(int);
  bytes[ARRAY_PINNED] = (def->pinned_count > 0 ? def->pinned_count : 1) * sizeof(int);
  bytes[ARRAY_IS_PINNED] = n;
  bytes[ARRAY_ASLEEP] = 3.0 * n + spheres;
  bytes[ARRAY_SECTION_SCALE] = vsc_rod_def_radius_at(def, 1.0) != def->radius ? (2.0 * N - 1.0) * d : 0.0;
}

// Offsets of the arrays in the block (bytes, aligned) and the block's size.
static double array_offsets(const vsc_rod_def* def, double offset[ARRAY_COUNT]) {
  double bytes[ARRAY_COUNT], total = 0.0;
  array_bytes(def, bytes);
  for (int i = 0; i < ARRAY_COUNT; ++i) {
    offset[i] = total;
    total += ceil(bytes[i] / ARRAY_ALIGNMENT) * ARRAY_ALIGNMENT;
  }
  return total;
}

double vsc_rod_memory_bytes(const vsc_rod_def* def) {
  double offset[ARRAY_COUNT];
  double bytes = sizeof(vsc_rod) + array_offsets(def, offset) + ARRAY_ALIGNMENT;
  double spheres = def->collision_sphere_count;
  if (spheres >= 1.0 && spheres <= (double)VSC_MAX_COLLISION_SPHERES)
    bytes += vsc_grid_memory_bytes((int)spheres) + vsc_contact_lists_memory_bytes((int)spheres);
  return bytes;
}

// Point every array of `rod` into one zeroed block carved by the size table.
// Returns 0, or -1 if memory ran out.
static int allocate_arrays(vsc_rod* rod, const vsc_rod_def* def) {
  double offset[ARRAY_COUNT];
  double total = array_offsets(def, offset);
  rod->block = calloc(1, (size_t)(total + ARRAY_ALIGNMENT));
  if (!rod->block) return -1;
  char* base = (char*)rod->block;
  base += (size_t)((ARRAY_ALIGNMENT - (double)((uintptr_t)base % (uintptr_t)ARRAY_ALIGNMENT)));
  #define AT(index) ((void*)(base + (size_t)offset[index]))
  rod->sample_basis = (vsc_basis*)AT(ARRAY_SAMPLE_BASIS);
  rod->sphere_basis = (vsc_basis*)AT(ARRAY_SPHERE_BASIS);
  rod->tether_basis = (vsc_basis*)AT(ARRAY_TETHER_BASIS);
  rod->mass_band = (double*)AT(ARRAY_MASS_BAND);
  rod->mass_factor = (double*)AT(ARRAY_MASS_FACTOR);
  rod->mass_row_sum = (double*)AT(ARRAY_MASS_ROW_SUM);
  rod->gather_weight = (double*)AT(ARRAY_GATHER_WEIGHT);
  rod->sphere_radius = (double*)AT(ARRAY_SPHERE_RADIUS);
  rod->gather_first = (int*)AT(ARRAY_GATHER_FIRST);
  rod->pinned = (int*)AT(ARRAY_PINNED);
  rod->is_pinned = (unsigned char*)AT(ARRAY_IS_PINNED);
  // each stage's state
  int n = def->control_count, spheres = def->collision_sphere_count;
  int N = (n - 1) * def->samples_per_segment + 1;
  stage_states* states = (stage_states*)AT(ARRAY_STAGE_STATES);
  vsc_rod_stages* stage = &rod->stages;
  stage->placement = &states->placement;
  stage->placement->sphere_xyz = (double*)AT(ARRAY_SPHERE_XYZ);
  stage->placement->sphere_velocity = (double*)AT(ARRAY_SPHERE_VELOCITY);
  stage->elastic = &states->elastic;
  vsc_elastic_scratch_carve(stage->elastic, (double*)AT(ARRAY_ELASTIC), N);
  stage->contact = &states->contact;
  stage->contact->touch.record = (double*)AT(ARRAY_TOUCH);
  stage->contact->load.stiffness = (double*)AT(ARRAY_CONTACT_LOAD);
  stage->contact->load.damping_scale = (double*)AT(ARRAY_DAMPING_SCALE);
  stage->sleep = &states->sleep;
  stage->sleep->asleep = (unsigned char*)AT(ARRAY_ASLEEP);
  stage->sleep->sphere_asleep = stage->sleep->asleep + n;
  stage->sleep->moved = stage->sleep->sphere_asleep + spheres;
  stage->sleep->unbalanced = stage->sleep->moved + n;
  stage->scheme = &states->scheme;
  stage->scheme->stage = (double*)AT(ARRAY_STAGE);
  stage->scheme->system = (double*)AT(ARRAY_SYSTEM);
  stage->scheme->factor_row = (double*)AT(ARRAY_FACTOR_ROW);
  stage->scheme->jacobian.sample_hessian = (double*)AT(ARRAY_JACOBIAN);
  stage->backup = &states->backup;
  vsc_step_backup_carve(stage->backup, (double*)AT(ARRAY_BACKUP), n, spheres);
  if (vsc_rod_def_radius_at(def, 1.0) != def->radius) {
    int N = (def->control_count - 1) * def->samples_per_segment + 1;
    rod->stretch_scale = (double*)AT(ARRAY_SECTION_SCALE);
    rod->curvature_scale = rod->stretch_scale + (N - 1);
    rod->bend_scale = rod->curvature_scale + 1;  // bend spring a's middle is sample a + 1
  }
  #undef AT
  return 0;
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
  if (allocate_arrays(rod, def) || !(rod->stages.broad_phase = vsc_contact_lists_create(spheres))) {
    vsc_rod_destroy(rod);
    return VSC_ERROR_OUT_OF_MEMORY;
  }
  for (int i = 0; i < def->pinned_count; ++i) {
    rod->pinned[i] = def->pinned[i];
    rod->is_pinned[def->pinned[i]] = 1;
  }
  rod->def.pinned = rod->pinned;
  for (int a = 0; a < N; ++a) rod->sample_basis[a] = vsc_spline_basis(n, (double)a / (double)(N - 1));
  for (int i = 0; i < spheres; ++i) {
    rod->sphere_basis[i] = vsc_spline_basis(n, (double)i / (double)(spheres - 1));
    rod->sphere_radius[i] = vsc_rod_def_radius_at(def, (double)i / (double)(spheres - 1));
  }
  rod->radius_max = vsc_rod_def_radius_max(def);
  rod->tapered = vsc_rod_def_radius_at(def, 1.0) != def->radius;
  if (rod->tapered) section_scales(rod);
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
  if (rod->jacobian_half_width > jacobian_half_width_bound(S)) {  // the bound sized `system`; never past it
    vsc_rod_destroy(rod);
    return VSC_ERROR_INVALID_ARGUMENT;
  }
  for (int i = 0; i < def->mesentery_points; ++i)
    rod->tether_basis[i] = vsc_spline_basis(n, ((double)i + 0.5) / (double)def->mesentery_points);
  // self-contact exclusion: segments whose nearest points are closer along
  // the rest axis than pi r (the arc of the tightest fold, whose centre line
  // has radius r) are neighbours: collide when (b - a - 1) spacing >= pi r
  double sphere_spacing = def->length / (double)(spheres - 1);
  rod->self_gap = (int)ceil(VSC_PI * rod->radius_max / sphere_spacing - 1e-9) + 1;  // tapered: the widest fold
  assemble_mass(rod);
  vsc_contact_load_prepare(rod, &rod->stages.contact->load);
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
  if (rod->stages.contact) vsc_contact_pass_free(rod->stages.contact);
  vsc_contact_lists_destroy(rod->stages.broad_phase);
  free(rod->block);
  free(rod);
}

int vsc_rod_control_count(const vsc_rod* rod) { return rod->n; }

int vsc_rod_sample_count(const vsc_rod* rod) { return rod->sample_count; }

double vsc_rod_contact_damping_rate(const vsc_rod* rod) { return rod->contact_damping_rate; }

const double* vsc_rod_sphere_centres(const vsc_rod* rod) { return rod->stages.placement->sphere_xyz; }

const double* vsc_rod_sphere_velocities(const vsc_rod* rod) { return rod->stages.placement->sphere_velocity; }

const double* vsc_rod_sphere_radii(const vsc_rod* rod) { return rod->sphere_radius; }

int vsc_rod_jacobian_half_width(const vsc_rod* rod) { return rod->jacobian_half_width; }

// The public queries that need a stage's state: each hands it over.

double vsc_rod_contact_energy(vsc_rod* rod, const vsc_world* world, const double* q, vsc_deepest_contact* deepest) {
  return vsc_step_contact_energy(rod, world, q, deepest);
}

void vsc_rod_visit_contacts(const vsc_rod* rod,
                            void (*visit)(void* data, int rigid, int a, int b, double speed, double depth), void* data) {
  vsc_contact_visit(rod->stages.contact, visit, data);
}

void vsc_rod_add_jacobian(vsc_rod* rod, const vsc_world* world, const double* q, double stiffness_weight,
                          double damping_weight, double* band, double* global_gradient) {
  vsc_elastic_place(rod, rod->stages.elastic, q);
  vsc_jacobian_add(rod, &rod->stages.scheme->jacobian, rod->stages.elastic, &rod->stages.contact->touch, world, q,
                   stiffness_weight, damping_weight, band, global_gradient);
}
