// The rod's elastic forces and energy on the sample points (the model is in
// viscera/vsc_rod.h): stretch and bend springs with the global stretch term,
// curvature bending and clamps, the mesentery's tethers; forces gathered onto
// the control points by virtual work.
#include "vsc_elastic.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "vsc_place.h"

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
static double spring_edges(const vsc_rod* rod, vsc_elastic_scratch* s, int gap) {
  int count = rod->sample_count - gap;
  edge_vectors(s->sample_x, s->sample_y, s->sample_z, s->edge_x, s->edge_y, s->edge_z,
               s->edge_length, count, gap);
  const double* el = s->edge_length;
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

// The same with each spring's stiffness k section[a] (a tapered tube).
VSC_VECTOR_CLONES static void scale_edges_each(double* restrict ex, double* restrict ey, double* restrict ez,
                                               const double* restrict el, const double* restrict section,
                                               int count, double k, double rest, double extra) {
  for (int a = 0; a < count; ++a) {
    double scale = (k * section[a] * (el[a] - rest) + extra) / (el[a] + 1e-300);
    ex[a] *= scale;
    ey[a] *= scale;
    ez[a] *= scale;
  }
}

// Turn the edges into tension vectors (k (l - rest) + extra) e / l in place
// (N); `section` (NULL: 1 for all) scales each spring's k. The tiny addend
// keeps a zero-length spring finite: its vector is zero.
static void spring_tensions(vsc_elastic_scratch* s, int count, double k, const double* section, double rest, double extra) {
  if (section)
    scale_edges_each(s->edge_x, s->edge_y, s->edge_z, s->edge_length, section, count, k, rest, extra);
  else
    scale_edges(s->edge_x, s->edge_y, s->edge_z, s->edge_length, count, k, rest, extra);
}

// f_a += t_a - t_{a-gap}: a stretched spring pulls its first sample forwards
// and its last one back. `first`: f starts from zero, written here (no
// clearing pass). Each element sums in the same order as two separate passes
// would: (f_a + t_a) - t_{a-gap}, with f_a = 0.0 when first.
static void add_spring_forces(const vsc_rod* rod, vsc_elastic_scratch* s, int gap, int first) {
  int N = rod->sample_count, count = N - gap;
  // distinct blocks of the scratch (restrict: the loops vectorise)
  const double *restrict tx = s->edge_x, *restrict ty = s->edge_y, *restrict tz = s->edge_z;
  double *restrict fx = s->force_x, *restrict fy = s->force_y, *restrict fz = s->force_z;
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

// Curvature bending on the sample polyline (see vsc_rod.h): adds its forces
// F = -dE/dp to force_* if `forces`; returns its energy (J).
static double curvature_bending(const vsc_rod* rod, vsc_elastic_scratch* s, int forces) {
  int N = rod->sample_count;
  double k0 = rod->def.bending_rigidity / rod->rest_spacing, energy = 0.0;
  if (!(k0 > 0.0) || N < 3) return 0.0;
  const double* section = rod->curvature_scale;  // NULL untapered
  const double *x = s->sample_x, *y = s->sample_y, *z = s->sample_z;
  double *fx = s->force_x, *fy = s->force_y, *fz = s->force_z;
  for (int a = 1; a + 1 < N; ++a) {
    double u[3] = {x[a] - x[a - 1], y[a] - y[a - 1], z[a] - z[a - 1]};
    double w[3] = {x[a + 1] - x[a], y[a + 1] - y[a], z[a + 1] - z[a]};
    double uu = u[0] * u[0] + u[1] * u[1] + u[2] * u[2], ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
    double inverse = 1.0 / sqrt(uu * ww);
    if (!isfinite(inverse)) continue;  // coincident samples: no angle
    double c = (u[0] * w[0] + u[1] * w[1] + u[2] * w[2]) * inverse, k = section ? k0 * section[a] : k0;
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
    double k = section ? k0 * section[end ? N - 1 : 0] : k0;  // the clamped end's section
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

// Elastic sample forces -dE/dp into force_* (samples must be current).
static void elastic_sample_forces(const vsc_rod* rod, vsc_elastic_scratch* s) {
  int N = rod->sample_count;
  // stretch springs and the global term: dE_g/dl = K_g (l - length) is a
  // tension shared by every stretch spring
  double length = spring_edges(rod, s, 1);
  double global_tension = rod->def.global_stretch_stiffness * (length - rod->def.length);
  spring_tensions(s, N - 1, rod->stretch_spring, rod->stretch_scale, rod->rest_spacing, global_tension);
  add_spring_forces(rod, s, 1, 1);  // clears the forces first
  if (rod->bend_spring > 0.0 && N > 2) {
    spring_edges(rod, s, 2);
    spring_tensions(s, N - 2, rod->bend_spring, rod->bend_scale, 2.0 * rod->rest_spacing, 0.0);
    add_spring_forces(rod, s, 2, 0);
  }
  curvature_bending(rod, s, 1);
}

// Virtual work as a gather: Q_k += sum over samples a of b_k(s_a) F_a, each
// control point reading its own contiguous range of samples; one asleep deep
// is held still and unwatched, so its forces are not needed (vsc_sleep.h).
static void gather_to_control(const vsc_rod* rod, const vsc_elastic_scratch* s, const unsigned char* asleep,
                              double* Q) {
  const double *fx = s->force_x, *fy = s->force_y, *fz = s->force_z;
  for (int k = 0; k < rod->n; ++k) {
    if (asleep && asleep[k] == VSC_ASLEEP_DEEP) continue;
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

// dl/dp at every sample from the unit spring edges u: u_(a-1) - u_a (no edge
// before the first sample or after the last); restrict parameters: the loop vectorises.
VSC_VECTOR_CLONES static void edge_differences(const double* restrict u, double* restrict g, int samples) {
  g[0] = -u[0];
  for (int a = 1; a + 1 < samples; ++a) g[a] = u[a - 1] - u[a];
  g[samples - 1] = u[samples - 2];
}

void vsc_elastic_length_gradient(const vsc_rod* rod, vsc_elastic_scratch* s, const unsigned char* asleep,
                                 double* gradient) {
  int N = rod->sample_count;
  spring_edges(rod, s, 1);
  double* u[3] = {s->edge_x, s->edge_y, s->edge_z};
  const double* el = s->edge_length;
  for (int c = 0; c < 3; ++c)  // unit edges (a collapsed one has no direction)
    for (int a = 0; a + 1 < N; ++a) u[c][a] = el[a] > 0.0 ? u[c][a] / el[a] : 0.0;
  // the sample forces were gathered in the evaluation: their arrays hold dl/dp, gathered as forces are
  edge_differences(u[0], s->force_x, N);
  edge_differences(u[1], s->force_y, N);
  edge_differences(u[2], s->force_z, N);
  memset(gradient, 0, sizeof(double) * 3 * (size_t)rod->n);
  gather_to_control(rod, s, asleep, gradient);
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

void vsc_elastic_add_forces(const vsc_rod* rod, vsc_elastic_scratch* s, const unsigned char* asleep, const double* q,
                            double* Q) {
  vsc_place_samples(rod, q, s->sample_x, s->sample_y, s->sample_z);
  elastic_sample_forces(rod, s);
  gather_to_control(rod, s, asleep, Q);
  mesentery(rod, q, Q);
}

void vsc_elastic_scratch_carve(vsc_elastic_scratch* s, double* block, int N) {
  double** arrays[10] = {&s->sample_x, &s->sample_y, &s->sample_z, &s->force_x,  &s->force_y,
                         &s->force_z,  &s->edge_x,   &s->edge_y,   &s->edge_z,   &s->edge_length};
  for (int i = 0; i < 10; ++i) *arrays[i] = block + (size_t)i * (size_t)N;
}

void vsc_elastic_place(const vsc_rod* rod, vsc_elastic_scratch* s, const double* q) {
  vsc_place_samples(rod, q, s->sample_x, s->sample_y, s->sample_z);
}

// The energy and the length below place no samples: each sample is computed where it is
// needed, each spring and angle as the forces' arrays compute it, and they write nothing
// (the divergence guard's pass). The energy sums its terms by kind, then the kinds.


// The bending angle's energy at sample a from its neighbours (J), as curvature_bending's; 0 where
// two samples coincide.
static double angle_energy(const vsc_rod* rod, double k0, const double before[3], const double here[3],
                           const double after[3], int a) {
  double u[3] = {here[0] - before[0], here[1] - before[1], here[2] - before[2]};
  double w[3] = {after[0] - here[0], after[1] - here[1], after[2] - here[2]};
  double uu = u[0] * u[0] + u[1] * u[1] + u[2] * u[2], ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
  double inverse = 1.0 / sqrt(uu * ww);
  if (!isfinite(inverse)) return 0.0;
  double c = (u[0] * w[0] + u[1] * w[1] + u[2] * w[2]) * inverse;
  return (rod->curvature_scale ? k0 * rod->curvature_scale[a] : k0) * (1.0 - c);
}

// The clamps' energy at q (J), as curvature_bending's, added to `energy` end by end.
static double clamp_energy(const vsc_rod* rod, double k0, const double* q, double energy) {
  int N = rod->sample_count;
  const double* section = rod->curvature_scale;
  int clamped[2] = {rod->def.clamp_start, rod->def.clamp_end};
  const double* direction[2] = {rod->def.clamp_direction_start, rod->def.clamp_direction_end};
  for (int end = 0; end < 2; ++end) {
    if (!clamped[end]) continue;
    int a = end ? N - 2 : 0;
    double k = section ? k0 * section[end ? N - 1 : 0] : k0;
    const double* t = direction[end];
    double p[3], r[3];
    vsc_rod_sample_point(rod, q, a, p);
    vsc_rod_sample_point(rod, q, a + 1, r);
    double e[3] = {r[0] - p[0], r[1] - p[1], r[2] - p[2]};
    double length = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
    if (!(length > 0.0)) continue;
    double c = (t[0] * e[0] + t[1] * e[1] + t[2] * e[2]) / length;
    energy += 2.0 * k * (1.0 - c);
  }
  return energy;
}

// |r - p| (m), as edge_vectors computes it.
static double distance(const double p[3], const double r[3]) {
  double dx = r[0] - p[0], dy = r[1] - p[1], dz = r[2] - p[2];
  return sqrt(dx * dx + dy * dy + dz * dz);
}

double vsc_rod_length(const vsc_rod* rod, const double* q) {
  double total = 0.0, p[3], r[3];
  vsc_rod_sample_point(rod, q, 0, r);
  for (int a = 0; a + 1 < rod->sample_count; ++a) {
    for (int c = 0; c < 3; ++c) p[c] = r[c];
    vsc_rod_sample_point(rod, q, a + 1, r);
    total += distance(p, r);
  }
  return total;
}

// Samples the energy reads at a time: placed on the stack, block by block.
#define ENERGY_BLOCK 128

// Lengths of the springs from sample a to a + gap for a < count, from samples x, y, z (m);
// restrict parameters: the loop vectorises, as edge_vectors does, with the same bits.
VSC_VECTOR_CLONES static void spring_lengths(const double* restrict x, const double* restrict y,
                                             const double* restrict z, double* restrict length, int count, int gap) {
  for (int a = 0; a < count; ++a) {
    double dx = x[a + gap] - x[a], dy = y[a + gap] - y[a], dz = z[a + gap] - z[a];
    length[a] = sqrt(dx * dx + dy * dy + dz * dz);
  }
}

double vsc_rod_elastic_energy(const vsc_rod* rod, const double* q) {
  int N = rod->sample_count;
  double k0 = rod->def.bending_rigidity / rod->rest_spacing;
  int bending = k0 > 0.0 && N >= 3;
  // Each term by kind, summed in sample order: for a spring start a, the stretch spring a, a + 1
  // and the lengths' sum; the bending angle at a and the bend spring a - 1, a + 1 (a >= 1). A
  // block of starts [first, first + count) reads samples first - 1 to first + count.
  double stretch = 0.0, total = 0.0, curvature = 0.0, bend = 0.0;
  double x[ENERGY_BLOCK + 2], y[ENERGY_BLOCK + 2], z[ENERGY_BLOCK + 2];  // sample first - 1 + i at i
  double length[ENERGY_BLOCK], bend_length[ENERGY_BLOCK];
  for (int first = 0; first + 1 < N; first += ENERGY_BLOCK) {
    int count = N - 1 - first < ENERGY_BLOCK ? N - 1 - first : ENERGY_BLOCK;
    if (first == 0) x[0] = y[0] = z[0] = 0.0;  // no sample before the first
    for (int i = first > 0 ? 0 : 1; i < count + 2; ++i) {
      double p[3];
      vsc_rod_sample_point(rod, q, first - 1 + i, p);
      x[i] = p[0], y[i] = p[1], z[i] = p[2];
    }
    spring_lengths(x + 1, y + 1, z + 1, length, count, 1);
    spring_lengths(x, y, z, bend_length, count, 2);  // a's bend spring starts at a - 1 (unread at a = 0)
    for (int i = 0; i < count; ++i) {
      int a = first + i;
      double d = length[i] - rod->rest_spacing;
      total += length[i];
      stretch += 0.5 * rod->stretch_spring * (rod->stretch_scale ? rod->stretch_scale[a] : 1.0) * d * d;
      if (a < 1) continue;
      if (bending) {
        double before[3] = {x[i], y[i], z[i]}, here[3] = {x[i + 1], y[i + 1], z[i + 1]};
        double after[3] = {x[i + 2], y[i + 2], z[i + 2]};
        curvature += angle_energy(rod, k0, before, here, after, a);
      }
      double b = bend_length[i] - 2.0 * rod->rest_spacing;
      bend += 0.5 * rod->bend_spring * (rod->bend_scale ? rod->bend_scale[a - 1] : 1.0) * b * b;
    }
  }
  if (bending) curvature = clamp_energy(rod, k0, q, curvature);
  double dl = total - rod->def.length;
  return stretch + 0.5 * rod->def.global_stretch_stiffness * dl * dl + mesentery(rod, q, NULL) + curvature + bend;
}
