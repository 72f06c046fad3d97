// Open uniform cubic Catmull-Rom spline (France et al. 2002, section 3.1.1).
//
// n control points q_0..q_{n-1} (n >= 4) define n-1 segments; segment j joins
// q_j to q_{j+1} and is shaped by q_{j-1}..q_{j+2}. The global parametric
// abscissa s in [0, 1] maps to segment j = floor(s (n-1)) and local u = s (n-1) - j.
//
// End closure: the two missing neighbours are the phantom points
//   q_{-1} = 3 q_0 - 3 q_1 + q_2,    q_n = 3 q_{n-1} - 3 q_{n-2} + q_{n-3}
// (quadratic extrapolation). The curve passes through q_0 and q_{n-1}; the
// phantom weights sum to one, so the basis stays a partition of unity; the end
// segments involve only three real control points, which keeps the mass matrix
// band 7; and the spline reproduces every quadratic up to its ends. The
// paper's linear extrapolation (2 q_0 - q_1) does not: it forces the end
// tangent to q_1 - q_0, so a clamped end cannot carry its bending moment in
// the first segment, and a cantilever came out first order (33 % too stiff
// at 8 control points against 0.03 % with this closure).
//
// A point of the curve is a window of four consecutive control points starting
// at `first` with four weights (some may be zero at the ends): branch-free sums.
#ifndef VISCERA_VSC_SPLINE_H
#define VISCERA_VSC_SPLINE_H

/// Number of control points that influence one point of the curve.
#define VSC_SPLINE_SUPPORT 4

/// Basis window of one abscissa: P(s) = sum_i weight[i] q[first + i].
typedef struct vsc_basis {
  int first;                          ///< index of the first control point
  double weight[VSC_SPLINE_SUPPORT];  ///< basis values b_k(s), dimensionless
} vsc_basis;

/// Uniform Catmull-Rom weights (tension 1/2) of q_{j-1}, q_j, q_{j+1}, q_{j+2}
/// at local parameter u in [0, 1].
void vsc_catmull_rom_weights(double u, double weight[VSC_SPLINE_SUPPORT]);

/// Derivatives d weight / du of the weights above.
void vsc_catmull_rom_derivatives(double u, double derivative[VSC_SPLINE_SUPPORT]);

/// Basis window of the open spline with `control_count` (>= 4) points at
/// abscissa s (clamped to [0, 1]), end closure included.
vsc_basis vsc_spline_basis(int control_count, double s);

/// Same as vsc_spline_basis for d/ds of the basis (1/unit of s).
vsc_basis vsc_spline_basis_derivative(int control_count, double s);

/// Evaluate a basis window on interleaved xyz control points (3 per point).
/// Inline: it runs for every sphere of every force evaluation.
static inline void vsc_basis_point(const vsc_basis* basis, const double* control_xyz, double out[3]) {
  const double* p = control_xyz + 3 * basis->first;
  const double* w = basis->weight;
  for (int c = 0; c < 3; ++c) out[c] = w[0] * p[c] + w[1] * p[3 + c] + w[2] * p[6 + c] + w[3] * p[9 + c];
}

#endif  // VISCERA_VSC_SPLINE_H
