// Regular 3D grid of collision spheres (France et al. 2002, 3.3.1), as a
// spatial hash.
//
// Cells are cubes of side `cell` (m). Cell (i, j, k) lives in bucket
// hash(i, j, k) of a power-of-two table, sized from the most items one pass
// inserts, so the grid is unbounded in space and its memory is O(items).
// Each bucket remembers the pass that last wrote it: a stale bucket reads
// empty, so starting a pass is O(1) and no pass ever scans or clears all
// cells. An item is inserted into every cell its box overlaps (at most 8
// when the box is no larger than a cell) and is checked on insertion against
// the items already there. A pair sharing several cells is reported once:
// only in the cell holding the low corner of the two boxes' intersection.
// Cost per pass: O(items + reported pairs).
#ifndef VISCERA_VSC_GRID_H
#define VISCERA_VSC_GRID_H

#include "viscera/vsc_base.h"

/// Called with (context, earlier item, new item) for each overlapping pair.
typedef void (*vsc_pair_fn)(void* context, int earlier, int item);

/// Called with (context, item) for each item a query box touches.
typedef void (*vsc_item_fn)(void* context, int item);

typedef struct vsc_grid {
  double cell;             ///< cell side (m)
  int max_items;           ///< item ids are in [0, max_items)
  int bucket_mask;         ///< bucket count - 1
  int* bucket_head;        ///< first entry of each bucket, -1 for none
  unsigned* bucket_pass;   ///< pass that last wrote each bucket
  unsigned pass;           ///< current pass number
  int entry_count;         ///< entries used in this pass
  int entry_capacity;      ///< 8 x max_items
  int* entry_next;         ///< next entry in the same bucket
  int* entry_item;         ///< item of each entry
  int* entry_cell;         ///< cell coordinates of each entry (3 per entry)
  double* item_box;        ///< box of each inserted item: min xyz, max xyz (6 per item) (m)
  unsigned* item_mark;     ///< query stamp per item, to report each item once per query
  unsigned query;          ///< current query number
} vsc_grid;

/// A grid for at most `max_items` items per pass (release with vsc_grid_destroy).
vsc_status vsc_grid_create(int max_items, vsc_grid** out);
void vsc_grid_destroy(vsc_grid* grid);

/// Heap bytes vsc_grid_create(max_items) allocates.
double vsc_grid_memory_bytes(int max_items);

/// Start a pass with cells of side `cell` (m, > 0): O(1).
void vsc_grid_begin(vsc_grid* grid, double cell);

/// Insert item `id` (0 <= id < max_items, once per pass) with box [lo, hi]
/// (m, each side at most one cell), calling `pair` for every item inserted
/// earlier in this pass whose box overlaps it. Returns VSC_ERROR_INVALID_ARGUMENT
/// (and inserts nothing) if the box is larger than a cell or not finite, and
/// VSC_ERROR_OUT_OF_MEMORY if the pass ran out of entries (boxes a hair under a
/// cell take 8 entries, so keep them strictly smaller than the cell).
vsc_status vsc_grid_insert(vsc_grid* grid, int id, const double lo[3], const double hi[3], vsc_pair_fn pair,
                           void* context);

/// Call `visit` once for every item whose box overlaps [lo, hi] (any size).
/// Returns the number of cells visited, or -1 (and visits nothing) if the box
/// spans more than `max_cells` cells: the caller should then test all items.
int vsc_grid_query(vsc_grid* grid, const double lo[3], const double hi[3], int max_cells, vsc_item_fn visit,
                   void* context);

#endif  // VISCERA_VSC_GRID_H
