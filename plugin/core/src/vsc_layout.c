// Initial layouts of the axis (see vsc_layout.h).
#include "viscera/vsc_layout.h"

#include <math.h>

vsc_status vsc_layout_line(int n, double length, const double start[3], const double dir[3], double* q) {
  double norm = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
  if (!(norm > 0.0) || !isfinite(norm) || n < 2 || !(length > 0.0)) return VSC_ERROR_INVALID_ARGUMENT;
  for (int k = 0; k < n; ++k) {
    double t = length * (double)k / (double)(n - 1);
    for (int c = 0; c < 3; ++c) q[3 * k + c] = start[c] + t * dir[c] / norm;
  }
  return VSC_OK;
}

vsc_status vsc_layout_polyline(int n, double length, const double* p, int count, double* q) {
  if (count < 2 || n < 2 || !(length > 0.0)) return VSC_ERROR_INVALID_ARGUMENT;
  double total = 0.0;
  for (int i = 0; i + 1 < count; ++i) {
    const double* a = p + 3 * i;
    const double* b = a + 3;
    total += sqrt((b[0] - a[0]) * (b[0] - a[0]) + (b[1] - a[1]) * (b[1] - a[1]) + (b[2] - a[2]) * (b[2] - a[2]));
  }
  if (!isfinite(total) || total < length * (1.0 - 1e-9)) return VSC_ERROR_INVALID_ARGUMENT;
  int edge = 0;
  double edge_start = 0.0;  // arc length at the start of `edge`
  for (int k = 0; k < n; ++k) {
    double t = length * (double)k / (double)(n - 1);
    for (;;) {
      const double* a = p + 3 * edge;
      const double* b = a + 3;
      double e = sqrt((b[0] - a[0]) * (b[0] - a[0]) + (b[1] - a[1]) * (b[1] - a[1]) + (b[2] - a[2]) * (b[2] - a[2]));
      if (t <= edge_start + e || edge == count - 2) {
        double f = e > 0.0 ? (t - edge_start) / e : 0.0;
        if (f > 1.0) f = 1.0;
        for (int c = 0; c < 3; ++c) q[3 * k + c] = a[c] + f * (b[c] - a[c]);
        break;
      }
      edge_start += e;
      ++edge;
    }
  }
  return VSC_OK;
}

typedef struct serpentine {
  double origin[3];  // first row start (m)
  double row;        // row length (m)
  double pitch;      // distance between rows and layers (m)
  int rows;          // rows per layer
  int layers;
} serpentine;

static int serpentine_make(double radius, const double box[6], serpentine* s) {
  double span[3];
  for (int c = 0; c < 3; ++c) {
    span[c] = box[3 + c] - box[c] - 2.0 * radius;
    s->origin[c] = box[c] + radius;
    if (!isfinite(span[c]) || span[c] < 0.0) return 0;
  }
  s->row = span[0];
  s->pitch = 4.0 * radius;
  double rows = floor(span[1] / s->pitch + 1e-9) + 1.0, layers = floor(span[2] / s->pitch + 1e-9) + 1.0;
  if (!(radius > 0.0) || !(s->row > 0.0) || !(rows * layers <= 1e9)) return 0;  // in double: no overflow
  s->rows = (int)rows;
  s->layers = (int)layers;
  return 1;
}

double vsc_layout_serpentine_capacity(double radius, const double box[6]) {
  serpentine s;
  if (!serpentine_make(radius, box, &s)) return 0.0;
  double rows = (double)s.rows * (double)s.layers;
  return rows * s.row + (rows - 1.0) * s.pitch;
}

// Point at arc length t: rows alternate +x/-x; within a layer rows step along
// y (forwards on even layers, backwards on odd ones); layers step up along z.
static void serpentine_point(const serpentine* s, double t, double out[3]) {
  double unit = s->row + s->pitch;
  int u = (int)floor(t / unit);
  int total = s->rows * s->layers;
  if (u > total - 1) u = total - 1;
  double along = t - (double)u * unit;
  int layer = u / s->rows, in_layer = u % s->rows;
  int y_index = (layer % 2 == 0) ? in_layer : s->rows - 1 - in_layer;
  int forward = (u % 2 == 0);
  double x_end = forward ? s->row : 0.0;
  out[0] = s->origin[0] + (forward ? 0.0 : s->row);
  out[1] = s->origin[1] + s->pitch * (double)y_index;
  out[2] = s->origin[2] + s->pitch * (double)layer;
  if (along <= s->row) {
    out[0] += forward ? along : -along;
    return;
  }
  double d = along - s->row;  // on the connector towards row u + 1
  out[0] = s->origin[0] + x_end;
  if ((u + 1) % s->rows != 0) {
    out[1] += (layer % 2 == 0 ? d : -d);
  } else {
    out[2] += d;
  }
}

vsc_status vsc_layout_serpentine(int n, double length, double radius, const double box[6], double* q) {
  serpentine s;
  if (n < 2 || !(length > 0.0) || !serpentine_make(radius, box, &s)) return VSC_ERROR_INVALID_ARGUMENT;
  if (vsc_layout_serpentine_capacity(radius, box) < length * (1.0 - 1e-9)) return VSC_ERROR_INVALID_ARGUMENT;
  for (int k = 0; k < n; ++k) serpentine_point(&s, length * (double)k / (double)(n - 1), q + 3 * k);
  return VSC_OK;
}
