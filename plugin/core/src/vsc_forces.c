// The rod's generalised forces and energies: gravity, the paper's springs and
// the curvature bending on the samples, the mesentery, grasps and contacts
// gathered onto the control points; the accelerations the integrators read.
#include <math.h>
#include <string.h>

#include "viscera/vsc_band.h"
#include "vsc_contact_internal.h"
#include "viscera/vsc_grasp.h"
#include "viscera/vsc_rod.h"

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
