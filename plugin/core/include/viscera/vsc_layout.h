// Initial shapes of the axis: control points laid uniformly by arc length
// along a line, a polyline or a serpentine. Outputs are caller-owned arrays of
// 3 n doubles (m, interleaved xyz).
#ifndef VISCERA_VSC_LAYOUT_H
#define VISCERA_VSC_LAYOUT_H

#include "viscera/vsc_base.h"

/// Straight line of `length` (m) from `start` (m) along `direction` (any
/// non-zero length). Fails on a zero or non-finite direction.
vsc_status vsc_layout_line(int n, double length, const double start[3], const double direction[3], double* q);

/// Along the polyline `points` (m, 3 per vertex, `point_count` >= 2) from its
/// first vertex, over the first `length` m. Fails if the polyline is shorter
/// than `length` or has fewer than two vertices.
vsc_status vsc_layout_polyline(int n, double length, const double* points, int point_count, double* q);

/// Serpentine filling the axis-aligned box `box` (m: min x y z, max x y z),
/// keeping `radius` (m) from every face: rows along x, one tube diameter of
/// clearance between rows (pitch 4 radius), rows stacked along y, then layers
/// along z. Fails if the box cannot hold `length`.
vsc_status vsc_layout_serpentine(int n, double length, double radius, const double box[6], double* q);

/// Length (m) a serpentine of the given radius can hold in `box`, 0 if none.
double vsc_layout_serpentine_capacity(double radius, const double box[6]);

#endif  // VISCERA_VSC_LAYOUT_H
