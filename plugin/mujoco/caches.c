// A table of slots in chunks that are never freed: a handle is a slot's index
// plus one (0: none). A slot is published (its chunk pointer and the count
// stored with release order) before any handle to it is written, so a reader
// that sees a handle below the count reads an initialised slot.
#include "caches.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>

#define CHUNK_SLOTS 1024
#define MAX_CHUNKS 16384  // 16.7 million slots: more instances x datas than memory holds

typedef struct slot {
  _Atomic(const mjData*) owner;  // the data whose cache this is; NULL: free
  _Atomic int instance;
  _Atomic(void*) cache;
  int next_free;                 // under the mutex: the next free slot's index, or -1
} slot;

static pthread_mutex_t mutex = PTHREAD_MUTEX_INITIALIZER;
static _Atomic(slot*) chunks[MAX_CHUNKS];
static atomic_int slot_count;   // slots made so far
static int first_free = -1;     // under the mutex
static atomic_long locks_taken;  // times the mutex was taken (vsc_caches_locks_taken)

static void lock(void) {
  pthread_mutex_lock(&mutex);
  atomic_fetch_add_explicit(&locks_taken, 1, memory_order_relaxed);
}

long vsc_caches_locks_taken(void) { return atomic_load_explicit(&locks_taken, memory_order_relaxed); }

// The slot a handle names, or NULL: any number is safe to pass.
static slot* slot_of(uintptr_t handle) {
  if (handle == 0 || handle > (uintptr_t)atomic_load_explicit(&slot_count, memory_order_acquire)) return NULL;
  size_t index = (size_t)(handle - 1);
  slot* chunk = atomic_load_explicit(&chunks[index / CHUNK_SLOTS], memory_order_acquire);
  return chunk ? chunk + index % CHUNK_SLOTS : NULL;
}

static int owns(const slot* s, const mjData* d, int instance) {
  return s && atomic_load_explicit(&s->owner, memory_order_acquire) == d &&
         atomic_load_explicit(&s->instance, memory_order_relaxed) == instance;
}

void* vsc_caches_resolve(const mjData* d, int instance) {
  slot* s = slot_of(d->plugin_data[instance]);
  return owns(s, d, instance) ? atomic_load_explicit(&s->cache, memory_order_relaxed) : NULL;
}

// Under the mutex: the index of the slot d owns for `instance` (its plugin_data's, else a scan),
// or -1.
static int find_owned(const mjData* d, int instance) {
  uintptr_t handle = d->plugin_data[instance];
  if (owns(slot_of(handle), d, instance)) return (int)(handle - 1);
  int count = atomic_load_explicit(&slot_count, memory_order_relaxed);
  for (int i = 0; i < count; ++i)
    if (owns(slot_of((uintptr_t)i + 1), d, instance)) return i;
  return -1;
}

// Under the mutex: a free slot's index (a new one if none is free), or -1 if memory ran out.
static int take_slot(void) {
  if (first_free >= 0) {
    int index = first_free;
    first_free = slot_of((uintptr_t)index + 1)->next_free;
    return index;
  }
  int index = atomic_load_explicit(&slot_count, memory_order_relaxed);
  if (index >= CHUNK_SLOTS * MAX_CHUNKS) return -1;
  if (index % CHUNK_SLOTS == 0) {
    slot* chunk = (slot*)calloc(CHUNK_SLOTS, sizeof(slot));
    if (!chunk) return -1;
    atomic_store_explicit(&chunks[index / CHUNK_SLOTS], chunk, memory_order_release);
  }
  atomic_store_explicit(&slot_count, index + 1, memory_order_release);
  return index;
}

void* vsc_caches_install(mjData* d, int instance, void* cache, int fresh) {
  lock();
  void* replaced = NULL;
  // not find_owned's scan: a new data owns no slot yet (and its plugin_data is not yet written:
  // MuJoCo calls init before it zeroes them), and a copy's first step adopts its own first
  uintptr_t handle = fresh ? 0 : d->plugin_data[instance];
  int index = owns(slot_of(handle), d, instance) ? (int)(handle - 1) : take_slot();
  if (index < 0) {
    replaced = cache;  // out of memory: nothing installed
  } else {
    slot* s = slot_of((uintptr_t)index + 1);
    if (owns(s, d, instance)) {
      replaced = atomic_load_explicit(&s->cache, memory_order_relaxed);
    } else {
      atomic_store_explicit(&s->instance, instance, memory_order_relaxed);
      atomic_store_explicit(&s->owner, d, memory_order_release);
    }
    atomic_store_explicit(&s->cache, cache, memory_order_release);
    d->plugin_data[instance] = (uintptr_t)index + 1;
  }
  pthread_mutex_unlock(&mutex);
  return replaced;
}

void* vsc_caches_adopt(mjData* d, int instance) {
  lock();
  int index = find_owned(d, instance);
  void* cache = NULL;
  if (index >= 0) {
    d->plugin_data[instance] = (uintptr_t)index + 1;
    cache = atomic_load_explicit(&slot_of((uintptr_t)index + 1)->cache, memory_order_relaxed);
  }
  pthread_mutex_unlock(&mutex);
  return cache;
}

void* vsc_caches_release(mjData* d, int instance) {
  lock();
  int index = find_owned(d, instance);
  slot* s = index >= 0 ? slot_of((uintptr_t)index + 1) : NULL;
  void* cache = NULL;
  if (s) {
    cache = atomic_load_explicit(&s->cache, memory_order_relaxed);
    atomic_store_explicit(&s->cache, NULL, memory_order_relaxed);
    atomic_store_explicit(&s->owner, NULL, memory_order_release);
    s->next_free = first_free;
    first_free = index;
  }
  d->plugin_data[instance] = 0;
  pthread_mutex_unlock(&mutex);
  return cache;
}

int vsc_caches_visit(uintptr_t handle, int instance, void (*visit)(void* cache, void* context), void* context) {
  lock();
  slot* s = slot_of(handle);
  void* cache = s && atomic_load_explicit(&s->owner, memory_order_relaxed) &&
                        atomic_load_explicit(&s->instance, memory_order_relaxed) == instance
                    ? atomic_load_explicit(&s->cache, memory_order_relaxed)
                    : NULL;
  if (cache) visit(cache, context);
  pthread_mutex_unlock(&mutex);
  return cache != NULL;
}

int vsc_caches_with(const mjData* d, int instance, void (*visit)(void* cache, void* context), void* context) {
  lock();
  int index = find_owned(d, instance);
  void* cache = index >= 0 ? atomic_load_explicit(&slot_of((uintptr_t)index + 1)->cache, memory_order_relaxed) : NULL;
  if (cache) visit(cache, context);
  pthread_mutex_unlock(&mutex);
  return cache != NULL;
}
