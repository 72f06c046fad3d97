// Spatial hash of sphere boxes (see vsc_grid.h).
#include "viscera/vsc_grid.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#define COORDINATE_LIMIT 1.0e9  // cell indices stay far inside int

static int bucket_count(int max_items) {
  int buckets = 16;
  while (buckets < 8 * max_items) buckets *= 2;  // about one entry per bucket: short chains, small table
  return buckets;
}

double vsc_grid_memory_bytes(int max_items) {
  double buckets = bucket_count(max_items), entries = 8.0 * max_items;
  return sizeof(vsc_grid) + buckets * (sizeof(int) + sizeof(unsigned)) + entries * 5.0 * sizeof(int) +
         (double)max_items * (6.0 * sizeof(double) + sizeof(unsigned));
}

vsc_status vsc_grid_create(int max_items, vsc_grid** out) {
  *out = NULL;
  if (max_items < 1 || max_items > (1 << 26)) return VSC_ERROR_INVALID_ARGUMENT;
  vsc_grid* g = (vsc_grid*)calloc(1, sizeof(vsc_grid));
  if (!g) return VSC_ERROR_OUT_OF_MEMORY;
  int buckets = bucket_count(max_items);
  g->max_items = max_items;
  g->bucket_mask = buckets - 1;
  g->entry_capacity = 8 * max_items;
  g->bucket_head = (int*)malloc(sizeof(int) * (size_t)buckets);
  g->bucket_pass = (unsigned*)calloc((size_t)buckets, sizeof(unsigned));
  g->entry_next = (int*)malloc(sizeof(int) * (size_t)g->entry_capacity);
  g->entry_item = (int*)malloc(sizeof(int) * (size_t)g->entry_capacity);
  g->entry_cell = (int*)malloc(sizeof(int) * 3 * (size_t)g->entry_capacity);
  g->item_box = (double*)malloc(sizeof(double) * 6 * (size_t)max_items);
  g->item_mark = (unsigned*)calloc((size_t)max_items, sizeof(unsigned));
  if (!g->bucket_head || !g->bucket_pass || !g->entry_next || !g->entry_item || !g->entry_cell || !g->item_box ||
      !g->item_mark) {
    vsc_grid_destroy(g);
    return VSC_ERROR_OUT_OF_MEMORY;
  }
  g->cell = 1.0;
  *out = g;
  return VSC_OK;
}

void vsc_grid_destroy(vsc_grid* g) {
  if (!g) return;
  free(g->bucket_head);
  free(g->bucket_pass);
  free(g->entry_next);
  free(g->entry_item);
  free(g->entry_cell);
  free(g->item_box);
  free(g->item_mark);
  free(g);
}

static void wrap_counter(unsigned* counter, unsigned* marks, int count) {
  if (++*counter == 0) {  // after 2^32 passes: forget every mark once
    for (int i = 0; i < count; ++i) marks[i] = 0;
    *counter = 1;
  }
}

void vsc_grid_begin(vsc_grid* g, double cell) {
  g->cell = cell;
  g->entry_count = 0;
  wrap_counter(&g->pass, g->bucket_pass, g->bucket_mask + 1);
}

static int cell_index(double x, double cell) {
  double c = floor(x / cell);
  if (c > COORDINATE_LIMIT) c = COORDINATE_LIMIT;
  if (c < -COORDINATE_LIMIT) c = -COORDINATE_LIMIT;
  return (int)c;
}

static int bucket_of(const vsc_grid* g, int i, int j, int k) {
  uint32_t h = (uint32_t)i * 73856093u ^ (uint32_t)j * 19349663u ^ (uint32_t)k * 83492791u;
  h ^= h >> 15;
  h *= 0x2c1b3c6dU;
  h ^= h >> 12;
  return (int)(h & (uint32_t)g->bucket_mask);
}

static int boxes_overlap(const double* a, const double* b) {
  return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
}

vsc_status vsc_grid_insert(vsc_grid* g, int id, const double lo[3], const double hi[3], vsc_pair_fn pair,
                           void* context) {
  if (id < 0 || id >= g->max_items) return VSC_ERROR_INVALID_ARGUMENT;
  int c0[3], c1[3];
  for (int a = 0; a < 3; ++a) {
    if (!isfinite(lo[a]) || !isfinite(hi[a]) || hi[a] < lo[a] || hi[a] - lo[a] > g->cell * (1.0 + 1e-9))
      return VSC_ERROR_INVALID_ARGUMENT;
    c0[a] = cell_index(lo[a], g->cell);
    c1[a] = cell_index(hi[a], g->cell);
  }
  int cells = (c1[0] - c0[0] + 1) * (c1[1] - c0[1] + 1) * (c1[2] - c0[2] + 1);  // 27 at most
  if (g->entry_count + cells > g->entry_capacity) return VSC_ERROR_OUT_OF_MEMORY;
  double* box = g->item_box + 6 * id;
  for (int a = 0; a < 3; ++a) {
    box[a] = lo[a];
    box[3 + a] = hi[a];
  }
  for (int i = c0[0]; i <= c1[0]; ++i)
    for (int j = c0[1]; j <= c1[1]; ++j)
      for (int k = c0[2]; k <= c1[2]; ++k) {
        int b = bucket_of(g, i, j, k);
        if (g->bucket_pass[b] != g->pass) {  // stale bucket: empty in this pass
          g->bucket_pass[b] = g->pass;
          g->bucket_head[b] = -1;
        }
        for (int e = g->bucket_head[b]; e >= 0; e = g->entry_next[e]) {
          const int* cell = g->entry_cell + 3 * e;
          if (cell[0] != i || cell[1] != j || cell[2] != k) continue;  // another cell, same bucket
          int other = g->entry_item[e];
          const double* other_box = g->item_box + 6 * other;
          if (!boxes_overlap(box, other_box)) continue;
          // report in one shared cell only: the one holding the intersection's low corner
          int owner = 1;
          for (int a = 0; a < 3 && owner; ++a) {
            double corner = box[a] > other_box[a] ? box[a] : other_box[a];
            owner = cell_index(corner, g->cell) == (a == 0 ? i : a == 1 ? j : k);
          }
          if (owner) pair(context, other, id);
        }
        int e = g->entry_count++;
        g->entry_item[e] = id;
        g->entry_cell[3 * e] = i;
        g->entry_cell[3 * e + 1] = j;
        g->entry_cell[3 * e + 2] = k;
        g->entry_next[e] = g->bucket_head[b];
        g->bucket_head[b] = e;
      }
  return VSC_OK;
}

int vsc_grid_query(vsc_grid* g, const double lo[3], const double hi[3], int max_cells, vsc_item_fn visit,
                   void* context) {
  int c0[3], c1[3];
  double cells = 1.0;
  for (int a = 0; a < 3; ++a) {
    if (!(lo[a] <= hi[a])) return 0;  // empty (or NaN) box
    c0[a] = cell_index(lo[a], g->cell);
    c1[a] = cell_index(hi[a], g->cell);
    cells *= (double)c1[a] - (double)c0[a] + 1.0;
  }
  if (cells > (double)max_cells) return -1;
  wrap_counter(&g->query, g->item_mark, g->max_items);
  double box[6] = {lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]};
  for (int i = c0[0]; i <= c1[0]; ++i)
    for (int j = c0[1]; j <= c1[1]; ++j)
      for (int k = c0[2]; k <= c1[2]; ++k) {
        int b = bucket_of(g, i, j, k);
        if (g->bucket_pass[b] != g->pass) continue;
        for (int e = g->bucket_head[b]; e >= 0; e = g->entry_next[e]) {
          const int* cell = g->entry_cell + 3 * e;
          int item = g->entry_item[e];
          if (cell[0] != i || cell[1] != j || cell[2] != k || g->item_mark[item] == g->query) continue;
          if (!boxes_overlap(box, g->item_box + 6 * item)) continue;
          g->item_mark[item] = g->query;
          visit(context, item);
        }
      }
  return (int)cells;
}
