// Band LDL^T factorisation and solves (layout in vsc_band.h).
#include "viscera/vsc_band.h"

#include <math.h>
#include <stddef.h>

#define A(i, j) band[VSC_BAND_WIDTH * (i) + 3 + (j) - (i)]

vsc_status vsc_band_factor(double* band, int n) {
  for (int i = 0; i < n; ++i) {
    int j0 = i - 3 < 0 ? 0 : i - 3;
    // L(i, j) D(j) = A(i, j) - sum_k L(i, k) D(k) L(j, k); the diagonal holds 1 / D
    for (int j = j0; j < i; ++j) {
      double sum = A(i, j);
      for (int k = j0; k < j; ++k) sum -= A(i, k) * A(j, k) / A(k, k);
      A(i, j) = sum * A(j, j);
    }
    double pivot = A(i, i);
    for (int k = j0; k < i; ++k) pivot -= A(i, k) * A(i, k) / A(k, k);
    if (!(pivot > 0.0)) return VSC_ERROR_NOT_POSITIVE_DEFINITE;
    A(i, i) = 1.0 / pivot;
  }
  return VSC_OK;
}

void vsc_band_solve3(const double* band, int n, double* x) {
  // forward: L z = b (unit diagonal); rows 0..2 have fewer than 3 neighbours
  for (int i = 0; i < n && i < 3; ++i)
    for (int k = 0; k < i; ++k)
      for (int c = 0; c < 3; ++c) x[3 * i + c] -= A(i, k) * x[3 * k + c];
  for (int i = 3; i < n; ++i) {
    const double* l = band + VSC_BAND_WIDTH * i;  // L(i, i-3), L(i, i-2), L(i, i-1)
    double* xi = x + 3 * i;
    for (int c = 0; c < 3; ++c) xi[c] -= l[0] * xi[c - 9] + l[1] * xi[c - 6] + l[2] * xi[c - 3];
  }
  // diagonal: y = D^-1 z
  for (int i = 0; i < n; ++i) {
    double inv = A(i, i);
    x[3 * i] *= inv;
    x[3 * i + 1] *= inv;
    x[3 * i + 2] *= inv;
  }
  // backward: L^T x = y; rows n-3..n-1 have fewer than 3 neighbours
  for (int i = n - 1; i >= 0 && i >= n - 3; --i)
    for (int k = i + 1; k < n; ++k)
      for (int c = 0; c < 3; ++c) x[3 * i + c] -= A(k, i) * x[3 * k + c];
  for (int i = n - 4; i >= 0; --i) {
    double l1 = A(i + 1, i), l2 = A(i + 2, i), l3 = A(i + 3, i);
    double* xi = x + 3 * i;
    for (int c = 0; c < 3; ++c) xi[c] -= l1 * xi[c + 3] + l2 * xi[c + 6] + l3 * xi[c + 9];
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

#define W(i, j) band[(size_t)(w + 1) * (size_t)(i) + (size_t)(w + (j) - (i))]

vsc_status vsc_band_wide_factor(double* band, int size, int w, double* ld) {
  size_t stride = (size_t)w + 1;
  for (int i = 0; i < size; ++i) {
    int j0 = i - w < 0 ? 0 : i - w;
    double* row_i = band + stride * (size_t)i + (size_t)(w - i);  // row_i[j] = A(i, j)
    // ld[k - j0] = L(i, k) D(k) as it is found, so each entry costs one dot product
    for (int j = j0; j < i; ++j) {
      const double* row_j = band + stride * (size_t)j + (size_t)(w - j);
      int k0 = j - w > j0 ? j - w : j0;
      double sum = row_i[j];
      for (int k = k0; k < j; ++k) sum -= ld[k - j0] * row_j[k];
      ld[j - j0] = sum;
      row_i[j] = sum * row_j[j];
    }
    double pivot = row_i[i];
    for (int k = j0; k < i; ++k) pivot -= ld[k - j0] * row_i[k];
    if (!(pivot > 0.0) || !isfinite(pivot)) return VSC_ERROR_NOT_POSITIVE_DEFINITE;
    row_i[i] = 1.0 / pivot;
  }
  return VSC_OK;
}

void vsc_band_wide_solve(const double* band, int size, int w, double* x) {
  for (int i = 0; i < size; ++i) {  // L z = b
    int j0 = i - w < 0 ? 0 : i - w;
    double sum = x[i];
    for (int j = j0; j < i; ++j) sum -= W(i, j) * x[j];
    x[i] = sum;
  }
  for (int i = 0; i < size; ++i) x[i] *= W(i, i);
  for (int i = size - 1; i >= 0; --i) {  // L^T x = y, column by column
    double xi = x[i];
    int j0 = i - w < 0 ? 0 : i - w;
    for (int j = j0; j < i; ++j) x[j] -= W(i, j) * xi;
  }
}

void vsc_band_wide_multiply(const double* band, int size, int w, const double* x, double* y) {
  for (int i = 0; i < size; ++i) y[i] = 0.0;
  for (int i = 0; i < size; ++i) {
    int j0 = i - w < 0 ? 0 : i - w;
    for (int j = j0; j < i; ++j) {
      y[i] += W(i, j) * x[j];
      y[j] += W(i, j) * x[i];
    }
    y[i] += W(i, i) * x[i];
  }
}
