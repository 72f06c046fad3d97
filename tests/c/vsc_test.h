// Minimal assertions for the core's C tests: a failing check prints where and
// makes the test executable exit non-zero.
#ifndef VISCERA_TESTS_VSC_TEST_H
#define VISCERA_TESTS_VSC_TEST_H

#include <math.h>
#include <stdio.h>

static int vsc_test_failures = 0;

#define ENSURE(condition)                                                        \
  do {                                                                           \
    if (!(condition)) {                                                          \
      fprintf(stderr, "%s:%d: ENSURE(%s) failed\n", __FILE__, __LINE__, #condition); \
      ++vsc_test_failures;                                                       \
    }                                                                            \
  } while (0)

#define ENSURE_NEAR(actual, expected, tolerance)                                 \
  do {                                                                           \
    double a_ = (actual), e_ = (expected), t_ = (tolerance);                     \
    if (!(fabs(a_ - e_) <= t_)) {                                                \
      fprintf(stderr, "%s:%d: %s = %.12g, expected %.12g +- %.3g\n", __FILE__, __LINE__, #actual, a_, e_, t_); \
      ++vsc_test_failures;                                                       \
    }                                                                            \
  } while (0)

#define RUN(test)                                                                \
  do {                                                                           \
    int before_ = vsc_test_failures;                                             \
    test();                                                                      \
    printf("%s %s\n", vsc_test_failures == before_ ? "ok  " : "FAIL", #test);     \
  } while (0)

#define TEST_MAIN_END() return vsc_test_failures == 0 ? 0 : 1

// Deterministic pseudo-random numbers in [-1, 1] (tests must not depend on rand()).
static inline double vsc_test_random(unsigned* seed) {
  *seed = *seed * 1664525u + 1013904223u;
  return (double)(*seed >> 8) / (double)(1u << 23) - 1.0;
}

#endif  // VISCERA_TESTS_VSC_TEST_H
