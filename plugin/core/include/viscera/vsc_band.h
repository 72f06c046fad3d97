// Symmetric positive definite band matrices of half-bandwidth 3 (band 7),
// the shape of a cubic spline's mass matrix (France et al. 2002, 3.1.4).
//
// Storage (n x 4, row-major, caller-owned): row i holds the lower band
//   band[4 i + d] = A(i, i - 3 + d),  d = 0..3,  so band[4 i + 3] is the diagonal.
// Entries with column i - 3 + d < 0 are ignored (keep them zero).
// vsc_band_factor overwrites the band with its LDL^T factors (A = L D L^T, L
// unit lower triangular) in the same layout: band[4 i + d] = L(i, i - 3 + d)
// for d < 3 and band[4 i + 3] = 1 / D(i). With a unit diagonal each sweep of a
// solve is a bare multiply-subtract recurrence. Factor O(n), solve O(n).
#ifndef VISCERA_VSC_BAND_H
#define VISCERA_VSC_BAND_H

#include "viscera/vsc_base.h"

/// Number of stored entries per row.
#define VSC_BAND_WIDTH 4

/// In-place LDL^T factorisation of an n x n band matrix (layout above).
/// Returns VSC_ERROR_NOT_POSITIVE_DEFINITE if a pivot D(i) is not positive.
vsc_status vsc_band_factor(double* band, int n);

/// Solve A x = b in place for three right-hand sides stored interleaved
/// (xyz[3 i + c] is row i of column c), given the factor from vsc_band_factor.
void vsc_band_solve3(const double* factor, int n, double* xyz);

/// y = A x for three interleaved columns, with A in unfactored band layout.
void vsc_band_multiply3(const double* band, int n, const double* x, double* y);

// Wide bands: symmetric positive definite matrices of any half-bandwidth w, one
// right-hand side (the implicit integrator's 3n x 3n system, see vsc_jacobian.h).
// Storage (size x (w + 1), row-major, caller-owned): row i holds
//   band[(w + 1) i + d] = A(i, i - w + d),  d = 0..w,  so band[(w + 1) i + w] is the diagonal;
// entries with column < 0 are ignored (keep them zero). The factor has the
// same LDL^T layout as above: the diagonal slot holds 1 / D(i). Factor
// O(size w^2), solve O(size w).

/// In-place LDL^T factorisation; `row` is caller scratch of w + 1 doubles.
/// Returns VSC_ERROR_NOT_POSITIVE_DEFINITE if a pivot is not positive.
vsc_status vsc_band_wide_factor(double* band, int size, int half_width, double* row);

/// Solve A x = b in place, given the factor from vsc_band_wide_factor.
void vsc_band_wide_solve(const double* factor, int size, int half_width, double* x);

/// y = A x with A in unfactored wide band layout.
void vsc_band_wide_multiply(const double* band, int size, int half_width, const double* x, double* y);

#endif  // VISCERA_VSC_BAND_H
