// The intestine's skin: a generalised cylinder around the spline (France et
// al. 2002, 3.2), a triangle mesh recomputed every frame.
//
// Rings of `ring_points` vertices lie in the plane normal to the axis at
// `rings_per_segment` uniformly spaced abscissae per segment ((n-1) rpc + 1
// rings). Frames do not twist: with t_s the unit tangent,
//   b_s = normalise(t_s x k_{s-ds}),  k_s = b_s x t_s
// (the paper's update, normalised), so k is carried from ring to ring by the
// smallest rotation, across segment boundaries without a jump. The first k is
// the Frenet normal (from the tangent's turn over the first ring interval), or
// any unit vector normal to t where the axis starts straight. The radius
// R(u) = R_min + cos^2(pi u) (R_max - R_min), u in [0, 1] within a segment,
// is R_max at control points (the paper's text swaps the two words).
//
// Vertex i of ring r is r * ring_points + i; the two cap centres come last.
// Triangles wind counter-clockwise seen from outside (outward normals), and
// the mesh is closed: every edge is shared by exactly two triangles.
#ifndef VISCERA_VSC_SKIN_H
#define VISCERA_VSC_SKIN_H

#include "viscera/vsc_base.h"

/// Skin resolution and radii. Initialise with vsc_default_skin_def().
typedef struct vsc_skin_def {
  int rings_per_segment;  ///< rings per spline segment (>= 1)
  int ring_points;        ///< vertices per ring (>= 3)
  double radius_min;      ///< radius midway between control points (m, > 0)
  double radius_max;      ///< radius at control points (m, >= radius_min)
  double taper_end;       ///< a tapered tube: both radii scaled linearly from 1 at s = 0 to this at s = 1
                          ///< (> 0; 1: not tapered)
} vsc_skin_def;

/// 4 rings per segment, 16 points per ring, radius 12.5 mm.
vsc_skin_def vsc_default_skin_def(void);

/// The tube's radius (m) at fraction u in [0, 1] of a segment: radius_max at
/// the control points (u = 0, 1), radius_min mid-segment, cos^2 between (the
/// haustra-like bulges of the skin; the plugin draws its capsules with it too).
double vsc_skin_radius(double radius_min, double radius_max, double u);

/// Sizes of the arrays vsc_skin_build fills, for n control points.
int vsc_skin_vertex_count(int n, const vsc_skin_def* def);
int vsc_skin_triangle_count(int n, const vsc_skin_def* def);

/// Build the skin of the spline with n (>= 4) control points q (m, 3n) into
/// caller-owned arrays: vertices (m, 3 per vertex), unit normals (3 per
/// vertex) and triangles (3 vertex indices each). O(vertices).
vsc_status vsc_skin_build(const double* q, int n, const vsc_skin_def* def, double* vertices, double* normals,
                          int* triangles);

#endif  // VISCERA_VSC_SKIN_H
