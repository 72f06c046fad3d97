// Band Cholesky factorisation and solves (layout in vsc_band.h).
#include "viscera/vsc_band.h"

#include <math.h>

#define A(i, j) band[VSC_BAND_WIDTH * (i) + 3 + (j) - (i)]

vsc_status vsc_band_factor(double* band, int n) {
  for (int i = 0; i < n; ++i) {
    int j0 = i - 3 < 0 ? 0 : i - 3;
    for (int j = j0; j <= i; ++j) {
      double sum = A(i, j);
      for (int k = j0; k < j; ++k) sum -= A(i, k) * A(j, k);
      if (j < i) {
        A(i, j) = sum * A(j, j);  // diagonal already holds 1 / L(j, j)
      } else {
        if (!(sum > 0.0)) return VSC_ERROR_NOT_POSITIVE_DEFINITE;
        A(i, i) = 1.0 / sqrt(sum);
      }
    }
  }
  return VSC_OK;
}

void vsc_band_solve3(const double* band, int n, double* x) {
  // forward: L y = b
  for (int i = 0; i < n; ++i) {
    int k0 = i - 3 < 0 ? 0 : i - 3;
    double s0 = x[3 * i], s1 = x[3 * i + 1], s2 = x[3 * i + 2];
    for (int k = k0; k < i; ++k) {
      double l = A(i, k);
      s0 -= l * x[3 * k];
      s1 -= l * x[3 * k + 1];
      s2 -= l * x[3 * k + 2];
    }
    double inv = A(i, i);
    x[3 * i] = s0 * inv;
    x[3 * i + 1] = s1 * inv;
    x[3 * i + 2] = s2 * inv;
  }
  // backward: L^T x = y
  for (int i = n - 1; i >= 0; --i) {
    int k1 = i + 3 > n - 1 ? n - 1 : i + 3;
    double s0 = x[3 * i], s1 = x[3 * i + 1], s2 = x[3 * i + 2];
    for (int k = i + 1; k <= k1; ++k) {
      double l = A(k, i);
      s0 -= l * x[3 * k];
      s1 -= l * x[3 * k + 1];
      s2 -= l * x[3 * k + 2];
    }
    double inv = A(i, i);
    x[3 * i] = s0 * inv;
    x[3 * i + 1] = s1 * inv;
    x[3 * i + 2] = s2 * inv;
  }
}

void vsc_band_multiply3(const double* band, int n, const double* x, double* y) {
  for (int i = 0; i < 3 * n; ++i) y[i] = 0.0;
  for (int i = 0; i < n; ++i) {
    int j0 = i - 3 < 0 ? 0 : i - 3;
    for (int j = j0; j <= i; ++j) {
      double a = A(i, j);
      for (int c = 0; c < 3; ++c) {
        y[3 * i + c] += a * x[3 * j + c];
        if (j != i) y[3 * j + c] += a * x[3 * i + c];
      }
    }
  }
}
