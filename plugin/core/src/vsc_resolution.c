// The resolution a tolerance chooses (see viscera/vsc_resolution.h).
#include "viscera/vsc_resolution.h"

#include <math.h>

#include "vsc_schemes.h"
#include "vsc_tolerance_table.h"

#define ROWS(table) ((int)(sizeof(table) / sizeof(table[0])))

// Fewest segments N (real) at which the envelope (rows {N, E}, N increasing, E
// non-increasing) is within `tolerance`, log-log interpolated between rows; -1
// below the last row's error (the group's floor).
static double segments_for(const double (*rows)[2], int count, double tolerance) {
  if (tolerance < rows[count - 1][1]) return -1.0;
  if (tolerance >= rows[0][1]) return rows[0][0];
  for (int i = 1; i < count; ++i) {
    if (rows[i][1] > tolerance) continue;
    double n0 = rows[i - 1][0], n1 = rows[i][0], e0 = rows[i - 1][1], e1 = rows[i][1];
    if (!(e0 > e1)) return n1;
    double f = log(e0 / tolerance) / log(e0 / e1);  // in (0, 1]: where the line crosses the tolerance
    return exp(log(n0) + f * log(n1 / n0));
  }
  return rows[count - 1][0];
}

// The envelope at N (real), log-log interpolated; the first row's below it.
static double envelope_at(const double (*rows)[2], int count, double segments) {
  if (segments <= rows[0][0]) return rows[0][1];
  for (int i = 1; i < count; ++i)
    if (segments <= rows[i][0]) {
      double f = log(segments / rows[i - 1][0]) / log(rows[i][0] / rows[i - 1][0]);
      return exp(log(rows[i - 1][1]) + f * log(rows[i][1] / rows[i - 1][1]));
    }
  return rows[count - 1][1];
}

static int positive(double x) { return x > 0.0 && isfinite(x); }

vsc_resolution_limit vsc_resolution_choose(const vsc_resolution_request* q, vsc_resolution* out) {
  *out = (vsc_resolution){0};
  if (!(q->tolerance > 0.0 && q->tolerance < 1.0) || !positive(q->length) || !positive(q->radius) ||
      !positive(q->mass_per_length) || !(q->bending_rigidity >= 0.0) || !isfinite(q->bending_rigidity) ||
      !(q->axial_stiffness >= 0.0) || !isfinite(q->axial_stiffness) || !(q->gravity >= 0.0) ||
      !isfinite(q->gravity) || (unsigned)q->integrator >= VSC_INTEGRATOR_COUNT)
    return VSC_RESOLUTION_INVALID;
  int bending = q->bending_rigidity > 0.0;
  const double(*rows)[2] = bending ? vsc_tolerance_envelope_bending : vsc_tolerance_envelope_springs;
  int count = bending ? ROWS(vsc_tolerance_envelope_bending) : ROWS(vsc_tolerance_envelope_springs);
  out->floor = rows[count - 1][1] / VSC_TOLERANCE_MARGIN;

  // l: the shortest length the shape varies over
  double bend_length = 0.0;  // the paper's springs alone: no length of their own
  if (bending) bend_length = q->gravity > 0.0 ? cbrt(q->bending_rigidity / (q->mass_per_length * q->gravity))
                                              : INFINITY;  // weightless: shaped by its loads and supports
  double fold_length = q->contacts ? 2.0 * VSC_PI * q->radius : q->length;
  double shape = fmin(q->length, fmax(bend_length, fold_length));
  out->shape_length = shape;

  double segments = segments_for(rows, count, VSC_TOLERANCE_MARGIN * q->tolerance);
  if (segments < 0.0) return VSC_RESOLUTION_BELOW_FLOOR;
  out->segments_per_shape = segments;
  vsc_resolution_limit limit = VSC_RESOLUTION_OK;
  double total = ceil(segments * q->length / shape - 1e-9);  // segments over the whole rod
  out->error_bound = envelope_at(rows, count, total * shape / q->length);
  out->needed_control_points = fmax(4.0, total + 1.0);
  if (out->needed_control_points > VSC_MAX_CONTROL_POINTS) limit = VSC_RESOLUTION_CONTROL_POINTS;
  out->control_points = (int)fmin(out->needed_control_points, VSC_MAX_CONTROL_POINTS);
  out->samples_per_segment = 1;

  // spheres: the chain's sagitta d^2 / (8 r) within tolerance x r, never wider than r apart; one
  // radius apart (the default) where nothing can touch them
  double spacing = q->radius * (q->contacts ? fmin(1.0, sqrt(8.0 * q->tolerance)) : 1.0);
  out->needed_spheres = fmax(2.0, ceil(q->length / spacing - 1e-9) + 1.0);
  if (out->needed_spheres > VSC_MAX_COLLISION_SPHERES && limit == VSC_RESOLUTION_OK)
    limit = VSC_RESOLUTION_COLLISION_SPHERES;
  out->collision_spheres = (int)fmin(out->needed_spheres, VSC_MAX_COLLISION_SPHERES);

  // the fastest wave of length l: bending (2 pi / l)^2 sqrt(EI / mu), axial (2 pi / l) sqrt(EA / mu)
  double k = 2.0 * VSC_PI / shape;
  double bend_wave = k * k * sqrt(q->bending_rigidity / q->mass_per_length);
  double axial_wave = k * sqrt(q->axial_stiffness / q->mass_per_length);
  out->accuracy_frequency = fmax(bend_wave, axial_wave);
  const vsc_scheme* scheme = &vsc_schemes[q->integrator];  // error ~ c (omega h)^p
  out->accuracy_omega_h = pow(q->tolerance / scheme->phase_coefficient, 1.0 / scheme->phase_order);
  return limit;
}

double vsc_resolution_substeps(const vsc_resolution* resolution, double dt) {
  if (!(resolution->accuracy_frequency > 0.0) || !(resolution->accuracy_omega_h > 0.0) || !(dt > 0.0)) return 1.0;
  double substeps = ceil(dt * resolution->accuracy_frequency / resolution->accuracy_omega_h * (1.0 - 1e-12));
  return substeps < 1.0 ? 1.0 : substeps;
}
