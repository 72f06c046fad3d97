// Tissue damage (see vsc_damage.h).
#include "viscera/vsc_damage.h"

#include <math.h>

vsc_damage_limits vsc_default_damage_limits(void) {
  vsc_damage_limits limits = {10.3, 300.0, 1.4};
  return limits;
}

// Tear point k; 1 if it was whole.
static int tear(double* damage, int k) {
  double* point = damage + VSC_DAMAGE_SIZE * k;
  int was_whole = point[1] == 0.0;
  point[0] = 1.0;
  point[1] = 1.0;
  return was_whole;
}

int vsc_damage_pinch(const vsc_damage_limits* limits, int n, double abscissa, double pinch, double dt,
                     double* damage) {
  if (n < 2 || !(pinch > 0.0) || !(dt > 0.0)) return 0;
  double s = abscissa < 0.0 ? 0.0 : (abscissa > 1.0 ? 1.0 : abscissa);
  double x = s * (double)(n - 1);
  int j = (int)floor(x);
  if (j > n - 2) j = n - 2;
  double u = x - (double)j;
  double bruise = pinch * dt / limits->force_time_product;
  double* a = damage + VSC_DAMAGE_SIZE * j;
  double* b = a + VSC_DAMAGE_SIZE;
  a[0] = fmin(1.0, a[0] + (1.0 - u) * bruise);
  b[0] = fmin(1.0, b[0] + u * bruise);
  if (pinch < limits->perforation_pinch) return 0;
  return tear(damage, u < 0.5 ? j : j + 1);
}

int vsc_damage_stretch(const vsc_damage_limits* limits, int n, double rest_length, const double* q, double* damage) {
  if (n < 2 || !(rest_length > 0.0)) return 0;
  double torn_past = rest_length / (double)(n - 1) * (1.0 + limits->tear_strain);
  double torn_past2 = torn_past * torn_past;
  int torn = 0;
  for (int k = 0; k + 1 < n; ++k) {
    const double* p = q + 3 * k;
    double dx = p[3] - p[0], dy = p[4] - p[1], dz = p[5] - p[2];
    if (dx * dx + dy * dy + dz * dz > torn_past2) torn += tear(damage, k) + tear(damage, k + 1);
  }
  return torn;
}
