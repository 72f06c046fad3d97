// Catmull-Rom basis: partition of unity, interpolation, C1 continuity, end closure.
#include "viscera/vsc_spline.h"
#include "vsc_test.h"

static void partition_of_unity(void) {
  for (int n = 4; n <= 12; n += 4)
    for (int i = 0; i <= 1000; ++i) {
      vsc_basis b = vsc_spline_basis(n, i / 1000.0);
      vsc_basis d = vsc_spline_basis_derivative(n, i / 1000.0);
      ENSURE(b.first >= 0 && b.first + 3 < n);
      ENSURE_NEAR(b.weight[0] + b.weight[1] + b.weight[2] + b.weight[3], 1.0, 1e-14);
      ENSURE_NEAR(d.weight[0] + d.weight[1] + d.weight[2] + d.weight[3], 0.0, 1e-11);
    }
}

// The curve passes through every control point, the first and last included.
static void interpolates_control_points(void) {
  int n = 9;
  for (int k = 0; k < n; ++k) {
    vsc_basis b = vsc_spline_basis(n, (double)k / (n - 1));
    for (int i = 0; i < 4; ++i) ENSURE_NEAR(b.weight[i], b.first + i == k ? 1.0 : 0.0, 1e-14);
  }
}

// A parabola sampled at evenly spaced control points is reproduced exactly,
// also in the end segments (the quadratic phantom closure; the paper's linear
// one, 2 q_0 - q_1, bends the end segments off it), and so is its tangent.
static void reproduces_quadratics(void) {
  int n = 7;
  double q[21];
  for (int k = 0; k < n; ++k) { q[3 * k] = 2.0 * k; q[3 * k + 1] = -k; q[3 * k + 2] = 0.5 * k * k - k; }
  for (int i = 0; i <= 100; ++i) {
    double s = i / 100.0, x = s * (n - 1), p[3], dp[3];
    vsc_basis b = vsc_spline_basis(n, s), d = vsc_spline_basis_derivative(n, s);
    vsc_basis_point(&b, q, p);
    vsc_basis_point(&d, q, dp);
    ENSURE_NEAR(p[0], 2.0 * x, 1e-12);
    ENSURE_NEAR(p[1], -x, 1e-12);
    ENSURE_NEAR(p[2], 0.5 * x * x - x, 1e-12);
    ENSURE_NEAR(dp[2], (x - 1.0) * (n - 1), 1e-10);  // d/ds = d/dx (n - 1)
  }
}

static void derivative_matches_finite_difference_and_is_continuous(void) {
  int n = 8;
  double h = 1e-6;
  for (int i = 1; i < 200; ++i) {
    double s = i / 200.0;
    vsc_basis d = vsc_spline_basis_derivative(n, s);
    vsc_basis hi = vsc_spline_basis(n, s + h), lo = vsc_spline_basis(n, s - h);
    for (int k = 0; k < n; ++k) {
      double dv = 0, fh = 0, fl = 0;
      for (int j = 0; j < 4; ++j) {
        if (d.first + j == k) dv += d.weight[j];
        if (hi.first + j == k) fh += hi.weight[j];
        if (lo.first + j == k) fl += lo.weight[j];
      }
      ENSURE_NEAR(dv, (fh - fl) / (2 * h), 1e-5);  // also across segment joints: C1
    }
  }
}

int main(void) {
  RUN(partition_of_unity);
  RUN(interpolates_control_points);
  RUN(reproduces_quadratics);
  RUN(derivative_matches_finite_difference_and_is_continuous);
  TEST_MAIN_END();
}
