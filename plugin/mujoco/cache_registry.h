// Ownership of the plugin's per-mjData caches, keyed by (mjData address, instance).
//
// Why not d->plugin_data alone: pickling an MjData (or a dm_control Physics)
// copies the raw plugin_data pointer into the copy, so two datas would share,
// and both free, one cache; a pickle loaded in another process carries a
// pointer into a foreign address space. The registry is the only owner: the
// plugin never dereferences plugin_data, and each mjData gets its own cache.
// Thread-safe (one mutex); holds no simulation state.
#ifndef VISCERA_PLUGIN_CACHE_REGISTRY_H
#define VISCERA_PLUGIN_CACHE_REGISTRY_H

/// The cache registered for (data, instance), or NULL.
void* vsc_registry_find(const void* data, int instance);

/// Register `cache` for (data, instance); returns the cache it replaces (or
/// NULL), which the caller frees. Returns `cache` itself if memory ran out
/// (nothing was registered; the caller keeps ownership).
void* vsc_registry_insert(const void* data, int instance, void* cache);

/// Unregister (data, instance) and return its cache (or NULL) for the caller to free.
void* vsc_registry_remove(const void* data, int instance);

/// If `cache` is registered as instance `instance`'s cache of some data, call
/// visit(cache, context) while holding the registry's lock (so no thread frees
/// it meanwhile) and return 1; else return 0. Scans the table: for resets, not steps.
int vsc_registry_visit(const void* cache, int instance, void (*visit)(void* cache, void* context), void* context);

/// If (data, instance) has a cache, call visit(cache, context) while holding the
/// registry's lock and return 1; else return 0.
int vsc_registry_with(const void* data, int instance, void (*visit)(void* cache, void* context), void* context);

#endif  // VISCERA_PLUGIN_CACHE_REGISTRY_H
