// Initial layouts: lengths, spacing, containment, and the errors they report.
#include <math.h>

#include "viscera/vsc_layout.h"
#include "vsc_test.h"

static double polyline_length(const double* q, int n) {
  double l = 0;
  for (int k = 0; k + 1 < n; ++k)
    l += sqrt(pow(q[3 * k + 3] - q[3 * k], 2) + pow(q[3 * k + 4] - q[3 * k + 1], 2) + pow(q[3 * k + 5] - q[3 * k + 2], 2));
  return l;
}

static void line(void) {
  double q[30], start[3] = {1, 2, 3}, dir[3] = {0, 0, -2};
  ENSURE(vsc_layout_line(10, 0.9, start, dir, q) == VSC_OK);
  ENSURE_NEAR(q[29], 3 - 0.9, 1e-15);
  ENSURE_NEAR(polyline_length(q, 10), 0.9, 1e-14);
  double zero[3] = {0, 0, 0};
  ENSURE(vsc_layout_line(10, 1, start, zero, q) == VSC_ERROR_INVALID_ARGUMENT);
}

static void polyline(void) {
  double p[9] = {0, 0, 0, 1, 0, 0, 1, 1, 0}, q[15];
  ENSURE(vsc_layout_polyline(5, 2.0, p, 3, q) == VSC_OK);
  ENSURE_NEAR(q[3 * 2], 1.0, 1e-15);  // the corner is the middle point
  ENSURE_NEAR(q[3 * 4 + 1], 1.0, 1e-15);
  ENSURE(vsc_layout_polyline(5, 2.5, p, 3, q) == VSC_ERROR_INVALID_ARGUMENT);  // too short
  ENSURE(vsc_layout_polyline(5, 0.5, p, 1, q) == VSC_ERROR_INVALID_ARGUMENT);  // one vertex
}

static void serpentine(void) {
  enum { n = 250 };
  double q[3 * n], r = 0.0125, box[6] = {-0.2, -0.15, 0.3, 0.2, 0.15, 0.5};
  ENSURE(vsc_layout_serpentine(n, 4.0, r, box, q) == VSC_OK);
  for (int k = 0; k < n; ++k)
    for (int c = 0; c < 3; ++c) ENSURE(q[3 * k + c] >= box[c] + r - 1e-12 && q[3 * k + c] <= box[3 + c] - r + 1e-12);
  // points are uniform in arc length: chords never exceed the spacing, and
  // equal it on straight runs (the total chord length is within corner cuts)
  double spacing = 4.0 / (n - 1), longest = 0;
  for (int k = 0; k + 1 < n; ++k) {
    double d = sqrt(pow(q[3 * k + 3] - q[3 * k], 2) + pow(q[3 * k + 4] - q[3 * k + 1], 2) + pow(q[3 * k + 5] - q[3 * k + 2], 2));
    ENSURE(d <= spacing + 1e-12);
    longest = d > longest ? d : longest;
  }
  ENSURE_NEAR(longest, spacing, 1e-12);
  double small[6] = {0, 0, 0, 0.3, 0.1, 0.05};
  ENSURE(vsc_layout_serpentine(n, 4.0, r, small, q) == VSC_ERROR_INVALID_ARGUMENT);
  ENSURE(vsc_layout_serpentine_capacity(r, small) < 4.0);
}

int main(void) {
  RUN(line);
  RUN(polyline);
  RUN(serpentine);
  TEST_MAIN_END();
}
