// Sphere grid: the pairs it reports equal the brute-force O(n^2) set, each once;
// a pass costs O(items) also when everything is piled into a few cells.
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "viscera/vsc_grid.h"
#include "vsc_test.h"

typedef struct pairs {
  int n;
  unsigned char* seen;  // n x n
  int count;
  int duplicates;
} pairs;

static void record(void* context, int a, int b) {
  pairs* p = (pairs*)context;
  int i = a < b ? a : b, j = a < b ? b : a;
  if (p->seen[i * p->n + j]) ++p->duplicates;
  p->seen[i * p->n + j] = 1;
  ++p->count;
}

static void random_spheres(unsigned* seed, int n, double spread, double* x) {
  for (int i = 0; i < 3 * n; ++i) x[i] = spread * vsc_test_random(seed);
}

static void pairs_equal_brute_force(void) {
  unsigned seed = 5;
  int sizes[3] = {50, 400, 1500};
  double spreads[3] = {0.05, 0.2, 2.0};  // piled, dense, sparse
  for (int t = 0; t < 9; ++t) {
    int n = sizes[t % 3];
    double r = 0.0125, spread = spreads[t / 3];
    double* x = malloc(sizeof(double) * 3 * n);
    random_spheres(&seed, n, spread, x);
    vsc_grid* grid = NULL;
    ENSURE(vsc_grid_create(n, &grid) == VSC_OK);
    pairs found = {n, calloc((size_t)n * n, 1), 0, 0};
    vsc_grid_begin(grid, 2 * r);
    vsc_status status = VSC_OK;
    for (int i = 0; i < n && status == VSC_OK; ++i) {
      double lo[3] = {x[3 * i] - r, x[3 * i + 1] - r, x[3 * i + 2] - r};
      double hi[3] = {x[3 * i] + r, x[3 * i + 1] + r, x[3 * i + 2] + r};
      status = vsc_grid_insert(grid, i, lo, hi, record, &found);
    }
    ENSURE(status == VSC_OK);
    int expected = 0, missing = 0;
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j) {
        int overlap = 1;
        for (int a = 0; a < 3; ++a) overlap &= fabs(x[3 * i + a] - x[3 * j + a]) <= 2 * r;
        expected += overlap;
        missing += overlap && !found.seen[i * n + j];
      }
    ENSURE(found.duplicates == 0);
    ENSURE(missing == 0);
    ENSURE(found.count == expected);  // nothing extra: each reported pair's boxes overlap
    free(found.seen);
    free(x);
    vsc_grid_destroy(grid);
  }
}

static int query_hits;
static void count_hit(void* context, int item) { (void)context; (void)item; ++query_hits; }

static void query_finds_items_once(void) {
  enum { n = 300 };
  unsigned seed = 9;
  double x[3 * n], r = 0.01;
  random_spheres(&seed, n, 0.3, x);
  vsc_grid* grid = NULL;
  vsc_grid_create(n, &grid);
  pairs ignore = {n, calloc(n * n, 1), 0, 0};
  vsc_grid_begin(grid, 2 * r);
  for (int i = 0; i < n; ++i) {
    double lo[3] = {x[3 * i] - r, x[3 * i + 1] - r, x[3 * i + 2] - r};
    double hi[3] = {x[3 * i] + r, x[3 * i + 1] + r, x[3 * i + 2] + r};
    vsc_grid_insert(grid, i, lo, hi, record, &ignore);
  }
  double lo[3] = {-0.1, -0.05, -0.2}, hi[3] = {0.05, 0.1, 0.0};
  int expected = 0;
  for (int i = 0; i < n; ++i) {
    int overlap = 1;
    for (int a = 0; a < 3; ++a) overlap &= x[3 * i + a] + r >= lo[a] && x[3 * i + a] - r <= hi[a];
    expected += overlap;
  }
  query_hits = 0;
  ENSURE(vsc_grid_query(grid, lo, hi, 1000000, count_hit, NULL) > 0);
  ENSURE(query_hits == expected);
  ENSURE(vsc_grid_query(grid, lo, hi, 10, count_hit, NULL) == -1);  // too many cells: caller goes brute force
  double wide[3] = {1e300, 0, 0};
  ENSURE(vsc_grid_insert(grid, 0, lo, wide, record, &ignore) == VSC_ERROR_INVALID_ARGUMENT);
  free(ignore.seen);
  vsc_grid_destroy(grid);
}

int main(void) {
  RUN(pairs_equal_brute_force);
  RUN(query_finds_items_once);
  TEST_MAIN_END();
}
