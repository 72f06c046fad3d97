// viscera core: common definitions.
//
// The core is plain C11 with no dependency on MuJoCo. It never prints, never
// aborts and never allocates behind the caller's back: every allocation is made
// by a `vsc_*_create` function and released by its `vsc_*_destroy` twin.
// All quantities are SI: metres, kilograms, seconds, newtons.
#ifndef VISCERA_VSC_BASE_H
#define VISCERA_VSC_BASE_H

/// Status codes returned by core functions (0 is success).
typedef enum vsc_status {
  VSC_OK = 0,
  VSC_ERROR_INVALID_ARGUMENT = -1,  ///< a parameter is out of its documented range
  VSC_ERROR_OUT_OF_MEMORY = -2,     ///< an allocation failed
  VSC_ERROR_NOT_POSITIVE_DEFINITE = -3,  ///< a matrix factorisation met a non-positive pivot
  VSC_ERROR_DIVERGED = -4,          ///< the state became non-finite; it was restored
} vsc_status;

#include <limits.h>  // on glibc, defines __GLIBC__ (features.h) for the test below

/// Marks a hot loop's function for runtime dispatch on x86-64: an AVX2 clone
/// (4 doubles a vector, where baseline SSE2 has 2) chosen at load time where the
/// CPU has it, the baseline elsewhere. No FMA: every operation rounds as in the
/// baseline (results are bit-identical), so the wheel runs on any x86-64. Empty
/// on other targets, without glibc's ifunc (musl) and under the sanitizers.
#if defined(__x86_64__) && defined(__GNUC__) && defined(__GLIBC__) && !defined(VSC_NO_CLONES)
#define VSC_VECTOR_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define VSC_VECTOR_CLONES
#endif

/// pi, the one definition the core and the adapter use.
#define VSC_PI 3.14159265358979323846

/// out = a x b (3-vectors; out must not alias a or b).
static inline void vsc_cross(const double a[3], const double b[3], double out[3]) {
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}

/// Human-readable name of a status code (static storage, never NULL).
const char* vsc_status_string(vsc_status status);

#endif  // VISCERA_VSC_BASE_H
