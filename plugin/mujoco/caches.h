// Each mjData's caches of an instance, owned through d->plugin_data.
//
// plugin_data holds a handle, not the cache's address: pickling an MjData
// copies plugin_data raw into the copy (MuJoCo 3.17), so a copy may carry its
// original's handle, or, loaded in another process, a number from a foreign
// address space. A handle indexes a table of slots that is never unmapped, so
// any number resolves safely, and each slot names the data and the instance it
// belongs to: a borrowed handle is recognised without touching a foreign
// pointer. Resolving is lock-free, for the step's path; making, adopting and
// freeing slots take a mutex (init, destroy, a copy's first step).
#ifndef VISCERA_PLUGIN_CACHES_H
#define VISCERA_PLUGIN_CACHES_H

#include <mujoco/mujoco.h>

/// The cache `d` owns for `instance` (through d->plugin_data), or NULL: none
/// yet, or plugin_data holds a handle d does not own (a pickled copy's). Lock-free.
void* vsc_caches_resolve(const mjData* d, int instance);

/// Make `cache` d's cache of `instance`: in the slot d's plugin_data names if d
/// owns it, else in a new slot; d->plugin_data[instance] then names it. (A
/// pickled copy adopts its own slot first: see vsc_caches_adopt.) `fresh`: d is
/// being made (init), its plugin_data not read.
/// Returns the cache it replaces (the caller frees it), or `cache` itself if
/// memory ran out (nothing changed; the caller keeps ownership).
void* vsc_caches_install(mjData* d, int instance, void* cache, int fresh);

/// The cache `d` owns for `instance`: its plugin_data's slot if d owns it, else
/// the slot d owns found by a scan (a pickled copy's plugin_data names its
/// original's; the copy's own slot, made by its init, is found again), or NULL;
/// d->plugin_data then names that slot. The slow path of a copy's first step.
void* vsc_caches_adopt(mjData* d, int instance);

/// Release the slot `d` owns for `instance` and return its cache for the caller
/// to free (NULL if it owns none); d->plugin_data[instance] becomes 0.
void* vsc_caches_release(mjData* d, int instance);

/// Call visit(cache, context) on the cache of the slot `handle` names if it is a
/// live slot of `instance`, whichever data owns it, under the mutex (no thread
/// frees it meanwhile); returns 1 if it did. For reset, which is given
/// plugin_data but not its mjData.
int vsc_caches_visit(uintptr_t handle, int instance, void (*visit)(void* cache, void* context), void* context);

/// The same for the cache `d` owns for `instance` (as vsc_caches_adopt finds
/// it, leaving plugin_data as it is): the exports Python calls between steps.
int vsc_caches_with(const mjData* d, int instance, void (*visit)(void* cache, void* context), void* context);

/// How many times the mutex was taken in this process: a step takes it never
/// (tests/python/test_copies.py counts).
long vsc_caches_locks_taken(void);

#endif  // VISCERA_PLUGIN_CACHES_H
