// Catmull-Rom basis and the open-spline end closure (see vsc_spline.h).
#include "viscera/vsc_spline.h"

void vsc_catmull_rom_weights(double u, double w[VSC_SPLINE_SUPPORT]) {
  // Catmull & Rom (1974), uniform parametrisation, tension 1/2.
  double u2 = u * u, u3 = u2 * u;
  w[0] = 0.5 * (-u3 + 2.0 * u2 - u);
  w[1] = 0.5 * (3.0 * u3 - 5.0 * u2 + 2.0);
  w[2] = 0.5 * (-3.0 * u3 + 4.0 * u2 + u);
  w[3] = 0.5 * (u3 - u2);
}

void vsc_catmull_rom_derivatives(double u, double d[VSC_SPLINE_SUPPORT]) {
  double u2 = u * u;
  d[0] = 0.5 * (-3.0 * u2 + 4.0 * u - 1.0);
  d[1] = 0.5 * (9.0 * u2 - 10.0 * u);
  d[2] = 0.5 * (-9.0 * u2 + 8.0 * u + 1.0);
  d[3] = 0.5 * (3.0 * u2 - 2.0 * u);
}

// Fold the weights of q_{j-1}..q_{j+2} of segment j onto real control points
// (phantoms q_{-1} = 3q_0 - 3q_1 + q_2 and q_n = 3q_{n-1} - 3q_{n-2} + q_{n-3}) and place them in
// a window of four that always lies inside [0, n).
static vsc_basis fold_segment(int n, int j, const double local[VSC_SPLINE_SUPPORT]) {
  double w[VSC_SPLINE_SUPPORT] = {local[0], local[1], local[2], local[3]};
  vsc_basis b;
  if (j == 0) {  // q_{-1} folds onto q_0 (x3), q_1 (x-3) and q_2 (x1)
    b.first = 0;
    b.weight[0] = w[1] + 3.0 * w[0];
    b.weight[1] = w[2] - 3.0 * w[0];
    b.weight[2] = w[3] + w[0];
    b.weight[3] = 0.0;  // n >= 4, so segment 0 is never also the last one
    return b;
  }
  if (j == n - 2) {  // q_n folds onto q_{n-1} (x3), q_{n-2} (x-3) and q_{n-3} (x1)
    b.first = n - 4;
    b.weight[0] = 0.0;
    b.weight[1] = w[0] + w[3];
    b.weight[2] = w[1] - 3.0 * w[3];
    b.weight[3] = w[2] + 3.0 * w[3];
    return b;
  }
  b.first = j - 1;
  for (int i = 0; i < VSC_SPLINE_SUPPORT; ++i) b.weight[i] = w[i];
  return b;
}

static void locate(int n, double s, int* segment, double* u) {
  if (!(s >= 0.0)) s = 0.0;  // also NaN
  if (s > 1.0) s = 1.0;
  double x = s * (double)(n - 1);
  int j = (int)x;
  if (j > n - 2) j = n - 2;
  *segment = j;
  *u = x - (double)j;
}

vsc_basis vsc_spline_basis(int n, double s) {
  int j;
  double u, local[VSC_SPLINE_SUPPORT];
  locate(n, s, &j, &u);
  vsc_catmull_rom_weights(u, local);
  return fold_segment(n, j, local);
}

vsc_basis vsc_spline_basis_derivative(int n, double s) {
  int j;
  double u, local[VSC_SPLINE_SUPPORT];
  locate(n, s, &j, &u);
  vsc_catmull_rom_derivatives(u, local);
  for (int i = 0; i < VSC_SPLINE_SUPPORT; ++i) local[i] *= (double)(n - 1);  // du/ds
  return fold_segment(n, j, local);
}
