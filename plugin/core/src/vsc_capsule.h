// Capsules along the sphere chain: segment k joins collision spheres k and
// k + 1, and two segments collide as capsules of the tube's radius (see
// viscera/vsc_contact.h). Header-only: the narrow phase and the candidate
// lists call these for every pair, where a call across files would cost.
#ifndef VISCERA_SRC_VSC_CAPSULE_H
#define VISCERA_SRC_VSC_CAPSULE_H

#include <math.h>

// Closest points P = p0 + s (p1 - p0), Q = q0 + t (q1 - q0) of two segments
// (Ericson, Real-Time Collision Detection, 5.1.9).
// x clamped to [0, 1], NaN to 0 (as fmin(fmax(x, 0), 1), which compiles to
// library calls without -ffast-math; this runs for every self-contact pair). Two
// unconditional selects, so that loops over it vectorise.
static inline double vsc_clamp01(double x) {
  double above = x > 0.0 ? x : 0.0;
  return above < 1.0 ? above : 1.0;
}

// Every quotient and comparison is computed, then the right one selected (no branch): the
// narrow phase's batches run this in a loop the compiler vectorises (vsc_contact.c).
static inline void vsc_closest_segments(const double* p0, const double* p1, const double* q0, const double* q1, double* s_out,
                             double* t_out) {
  double d1[3], d2[3], r[3];
  for (int a = 0; a < 3; ++a) {
    d1[a] = p1[a] - p0[a];
    d2[a] = q1[a] - q0[a];
    r[a] = p0[a] - q0[a];
  }
  double aa = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2];
  double e = d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2];
  double f = d2[0] * r[0] + d2[1] * r[1] + d2[2] * r[2];
  double c = d1[0] * r[0] + d1[1] * r[1] + d1[2] * r[2];
  double b = d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2], denominator = aa * e - b * b, tiny = 1e-30;
  // the interior's s; s when t clamps to 0 or 1; t when segment a is a point
  double inner = vsc_clamp01((b * f - c * e) / denominator), low = vsc_clamp01(-c / aa);
  double high = vsc_clamp01((b - c) / aa), alone = vsc_clamp01(f / e);
  double s_inner = denominator > 0.0 ? inner : 0.0;  // parallel: any s, take 0
  double t_inner = (b * s_inner + f) / e;
  int below = t_inner < 0.0, above = t_inner > 1.0, a_point = aa <= tiny, b_point = e <= tiny;
  double s = below ? low : (above ? high : s_inner);
  double t = below ? 0.0 : (above ? 1.0 : t_inner);
  s = b_point ? low : s;  // segment b a point
  t = b_point ? 0.0 : t;
  s = a_point ? 0.0 : s;  // segment a a point (both: 0, 0)
  t = a_point ? (b_point ? 0.0 : alone) : t;
  *s_out = s;
  *t_out = t;
}

// Closest points of segments p0-p1 and q0-q1: their parameters s, t, the vector d from the
// second's point to the first's (m), and its squared length (m^2).
static inline double vsc_segment_points_gap2(const double* p0, const double* p1, const double* q0, const double* q1,
                                             double* s_out, double* t_out, double d[3]) {
  double s, t;
  vsc_closest_segments(p0, p1, q0, q1, &s, &t);
  *s_out = s;
  *t_out = t;
  for (int c = 0; c < 3; ++c) {
    double P = (1.0 - s) * p0[c] + s * p1[c];
    double Q = (1.0 - t) * q0[c] + t * q1[c];
    d[c] = P - Q;
  }
  return d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
}

// Capsule contact of segments a < b (segment k joins spheres k and k + 1).
// Closest points of segments a (sphere a to a + 1) and b of the sphere chain x:
// their parameters s, t, the vector d from b's point to a's (m), its length (m).
static inline double vsc_segment_gap(const double* x, int a, int b, double* s_out, double* t_out, double d[3]) {
  return sqrt(vsc_segment_points_gap2(x + 3 * a, x + 3 * a + 3, x + 3 * b, x + 3 * b + 3, s_out, t_out, d));
}

#endif  // VISCERA_SRC_VSC_CAPSULE_H
