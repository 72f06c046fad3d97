// Band Cholesky: solves agree with products; non-positive-definite is reported.
#include <stdlib.h>

#include "viscera/vsc_band.h"
#include "vsc_test.h"

static void solve_inverts_multiply(void) {
  unsigned seed = 7;
  for (int n = 1; n <= 40; n += 13) {
    double* a = calloc(4 * n, sizeof(double));
    double* f = calloc(4 * n, sizeof(double));
    double* x = malloc(sizeof(double) * 3 * n);
    double* b = malloc(sizeof(double) * 3 * n);
    for (int i = 0; i < n; ++i) {
      for (int d = 0; d < 3; ++d)
        if (i - 3 + d >= 0) a[4 * i + d] = vsc_test_random(&seed);
      a[4 * i + 3] = 7.0;  // diagonally dominant: SPD
    }
    for (int i = 0; i < 3 * n; ++i) x[i] = vsc_test_random(&seed);
    vsc_band_multiply3(a, n, x, b);
    for (int i = 0; i < 4 * n; ++i) f[i] = a[i];
    ENSURE(vsc_band_factor(f, n) == VSC_OK);
    vsc_band_solve3(f, n, b);
    for (int i = 0; i < 3 * n; ++i) ENSURE_NEAR(b[i], x[i], 1e-12);
    free(a); free(f); free(x); free(b);
  }
}

static void indefinite_is_reported(void) {
  double a[16] = {0, 0, 0, 1, 0, 0, 2, 1, 0, 0, 0, 1, 0, 0, 0, 1};  // [[1,2],[2,1]] block
  ENSURE(vsc_band_factor(a, 4) == VSC_ERROR_NOT_POSITIVE_DEFINITE);
}

// Wide bands of several half-widths, including one wider than the matrix.
static void wide_solve_inverts_multiply(void) {
  unsigned seed = 11;
  int widths[3] = {1, 14, 50};
  for (int t = 0; t < 3; ++t)
    for (int size = 1; size <= 60; size += 29) {
      int w = widths[t], row = w + 1;
      double* a = calloc((size_t)row * size, sizeof(double));
      double* f = calloc((size_t)row * size, sizeof(double));
      double* x = malloc(sizeof(double) * size);
      double* b = malloc(sizeof(double) * size);
      double* scratch = malloc(sizeof(double) * row);
      for (int i = 0; i < size; ++i) {
        for (int d = 0; d < w; ++d)
          if (i - w + d >= 0) a[row * i + d] = vsc_test_random(&seed);
        a[row * i + w] = 2.0 * w + 1.0;  // diagonally dominant: SPD
      }
      for (int i = 0; i < size; ++i) x[i] = vsc_test_random(&seed);
      vsc_band_wide_multiply(a, size, w, x, b);
      for (int i = 0; i < row * size; ++i) f[i] = a[i];
      ENSURE(vsc_band_wide_factor(f, size, w, scratch) == VSC_OK);
      vsc_band_wide_solve(f, size, w, b);
      for (int i = 0; i < size; ++i) ENSURE_NEAR(b[i], x[i], 1e-12);
      free(a); free(f); free(x); free(b); free(scratch);
    }
  double indefinite[4] = {0, 1, 2, 1};  // [[1, 2], [2, 1]], w = 1
  double scratch[2];
  ENSURE(vsc_band_wide_factor(indefinite, 2, 1, scratch) == VSC_ERROR_NOT_POSITIVE_DEFINITE);
}

int main(void) {
  RUN(solve_inverts_multiply);
  RUN(indefinite_is_reported);
  RUN(wide_solve_inverts_multiply);
  TEST_MAIN_END();
}
