// Benchmark of the paper's collision pass (France et al. 2002, 3.3.1): fill the
// sphere grid with every sphere, checking each against those already in its
// cells, and count the overlapping pairs. Not a test (ctest does not run it):
// python/tools/bench_fall.py builds it and times piles of 250 to 8000 spheres.
//
//     bench_collision_pass FILE RADIUS REPEATS
//
// FILE holds the sphere centres as raw little-endian doubles (m, x y z per
// sphere); RADIUS is theirs (m). Prints "SECONDS CONTACTS": the fastest of
// REPEATS passes (s, CLOCK_MONOTONIC) and the overlapping pairs (2 r apart or closer).
#define _POSIX_C_SOURCE 199309L  // clock_gettime
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "viscera/vsc_grid.h"

typedef struct pass_count {
  const double* xyz;
  double reach2;  // (2 r)^2 (m^2)
  int contacts;
} pass_count;

static void count_contact(void* context, int a, int b) {
  pass_count* p = (pass_count*)context;
  const double* x = p->xyz + 3 * a;
  const double* y = p->xyz + 3 * b;
  double d2 = (x[0] - y[0]) * (x[0] - y[0]) + (x[1] - y[1]) * (x[1] - y[1]) + (x[2] - y[2]) * (x[2] - y[2]);
  p->contacts += d2 < p->reach2;
}

static double seconds_now(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

int main(int argc, char** argv) {
  if (argc != 4) {
    fprintf(stderr, "usage: %s FILE RADIUS REPEATS\n", argv[0]);
    return 2;
  }
  double radius = atof(argv[2]);
  int repeats = atoi(argv[3]);
  FILE* file = fopen(argv[1], "rb");
  if (!file || !(radius > 0.0) || repeats < 1) {
    fprintf(stderr, "%s: cannot read %s, or RADIUS or REPEATS not positive\n", argv[0], argv[1]);
    return 2;
  }
  fseek(file, 0, SEEK_END);
  long bytes = ftell(file);
  fseek(file, 0, SEEK_SET);
  int count = (int)(bytes / (long)(3 * sizeof(double)));
  double* xyz = (double*)malloc(sizeof(double) * 3 * (size_t)(count > 0 ? count : 1));
  vsc_grid* grid = NULL;
  if (count < 1 || !xyz || fread(xyz, sizeof(double) * 3, (size_t)count, file) != (size_t)count ||
      vsc_grid_create(count, &grid) != VSC_OK) {
    fprintf(stderr, "%s: %s holds no spheres, or out of memory\n", argv[0], argv[1]);
    return 2;
  }
  fclose(file);
  double best = INFINITY;
  pass_count p = {xyz, 4.0 * radius * radius, 0};
  for (int r = 0; r < repeats; ++r) {
    double start = seconds_now();
    p.contacts = 0;
    vsc_grid_begin(grid, 2.0 * radius * (1.0 + 1e-6));
    for (int i = 0; i < count; ++i) {
      const double* x = xyz + 3 * i;
      double lo[3] = {x[0] - radius, x[1] - radius, x[2] - radius}, hi[3] = {x[0] + radius, x[1] + radius, x[2] + radius};
      vsc_grid_insert(grid, i, lo, hi, count_contact, &p);
    }
    double seconds = seconds_now() - start;
    best = seconds < best ? seconds : best;
  }
  printf("%.9g %d\n", best, p.contacts);
  vsc_grid_destroy(grid);
  free(xyz);
  return 0;
}
