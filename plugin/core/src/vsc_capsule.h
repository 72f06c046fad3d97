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
// library calls without -ffast-math; this runs for every self-contact pair)
static inline double vsc_clamp01(double x) { return x > 0.0 ? (x < 1.0 ? x : 1.0) : 0.0; }

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
  double s = 0.0, t = 0.0, tiny = 1e-30;
  if (aa <= tiny && e <= tiny) {
    s = t = 0.0;
  } else if (aa <= tiny) {
    t = vsc_clamp01(f / e);
  } else {
    double c = d1[0] * r[0] + d1[1] * r[1] + d1[2] * r[2];
    if (e <= tiny) {
      s = vsc_clamp01(-c / aa);
    } else {
      double b = d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2], denominator = aa * e - b * b;
      s = denominator > 0.0 ? vsc_clamp01((b * f - c * e) / denominator) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = vsc_clamp01(-c / aa);
      } else if (t > 1.0) {
        t = 1.0;
        s = vsc_clamp01((b - c) / aa);
      }
    }
  }
  *s_out = s;
  *t_out = t;
}

// Capsule contact of segments a < b (segment k joins spheres k and k + 1).
// Closest points of segments a (sphere a to a + 1) and b of the sphere chain x:
// their parameters s, t, the vector d from b's point to a's (m), its length (m).
static inline double vsc_segment_gap(const double* x, int a, int b, double* s_out, double* t_out, double d[3]) {
  double s, t;
  vsc_closest_segments(x + 3 * a, x + 3 * a + 3, x + 3 * b, x + 3 * b + 3, &s, &t);
  *s_out = s;
  *t_out = t;
  for (int c = 0; c < 3; ++c) {
    double P = (1.0 - s) * x[3 * a + c] + s * x[3 * a + 3 + c];
    double Q = (1.0 - t) * x[3 * b + c] + t * x[3 * b + 3 + c];
    d[c] = P - Q;
  }
  return sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
}

#endif  // VISCERA_SRC_VSC_CAPSULE_H
