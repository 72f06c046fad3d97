// Open-addressing hash table (linear probing, backward-shift deletion) under a mutex.
#include "cache_registry.h"

#include <pthread.h>
#include <stdint.h>
#include <stdlib.h>

typedef struct entry {
  const void* data;  // NULL: empty slot
  int instance;
  void* cache;
} entry;

static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
static entry* table = NULL;
static size_t capacity = 0;  // power of two
static size_t count = 0;

static size_t slot_of(const void* data, int instance) {
  uint64_t h = ((uint64_t)(uintptr_t)data >> 4) ^ ((uint64_t)(unsigned)instance * 0x9E3779B97F4A7C15ull);
  h *= 0xBF58476D1CE4E5B9ull;
  return (size_t)(h ^ (h >> 31)) & (capacity - 1);
}

static entry* lookup(const void* data, int instance) {
  if (!capacity) return NULL;
  for (size_t i = slot_of(data, instance);; i = (i + 1) & (capacity - 1)) {
    if (!table[i].data) return NULL;
    if (table[i].data == data && table[i].instance == instance) return &table[i];
  }
}

static int grow(void) {
  size_t old_capacity = capacity, new_capacity = capacity ? 2 * capacity : 64;
  entry* fresh = (entry*)calloc(new_capacity, sizeof(entry));
  if (!fresh) return 0;
  entry* old = table;
  table = fresh;
  capacity = new_capacity;
  for (size_t i = 0; i < old_capacity; ++i) {
    if (!old[i].data) continue;
    size_t j = slot_of(old[i].data, old[i].instance);
    while (table[j].data) j = (j + 1) & (capacity - 1);
    table[j] = old[i];
  }
  free(old);
  return 1;
}

void* vsc_registry_find(const void* data, int instance) {
  pthread_mutex_lock(&lock);
  entry* e = lookup(data, instance);
  void* cache = e ? e->cache : NULL;
  pthread_mutex_unlock(&lock);
  return cache;
}

void* vsc_registry_insert(const void* data, int instance, void* cache) {
  pthread_mutex_lock(&lock);
  void* replaced = NULL;
  entry* e = lookup(data, instance);
  if (e) {
    replaced = e->cache;
    e->cache = cache;
  } else if (2 * (count + 1) > capacity && !grow()) {
    replaced = cache;  // out of memory: not registered
  } else {
    size_t i = slot_of(data, instance);
    while (table[i].data) i = (i + 1) & (capacity - 1);
    table[i].data = data;
    table[i].instance = instance;
    table[i].cache = cache;
    ++count;
  }
  pthread_mutex_unlock(&lock);
  return replaced;
}

void* vsc_registry_remove(const void* data, int instance) {
  pthread_mutex_lock(&lock);
  void* cache = NULL;
  entry* e = lookup(data, instance);
  if (e) {
    cache = e->cache;
    // backward-shift deletion keeps every probe chain unbroken
    size_t hole = (size_t)(e - table);
    for (size_t i = (hole + 1) & (capacity - 1); table[i].data; i = (i + 1) & (capacity - 1)) {
      size_t home = slot_of(table[i].data, table[i].instance);
      int movable = (i > hole) ? (home <= hole || home > i) : (home <= hole && home > i);
      if (movable) {
        table[hole] = table[i];
        hole = i;
      }
    }
    table[hole].data = NULL;
    --count;
  }
  pthread_mutex_unlock(&lock);
  return cache;
}

int vsc_registry_visit(const void* cache, int instance, void (*visit)(void* cache, void* context), void* context) {
  pthread_mutex_lock(&lock);
  int found = 0;
  for (size_t i = 0; i < capacity && !found; ++i)
    if (table[i].data && table[i].cache == cache && table[i].instance == instance) {
      visit(table[i].cache, context);
      found = 1;
    }
  pthread_mutex_unlock(&lock);
  return found;
}

int vsc_registry_with(const void* data, int instance, void (*visit)(void* cache, void* context), void* context) {
  pthread_mutex_lock(&lock);
  entry* e = lookup(data, instance);
  if (e) visit(e->cache, context);
  pthread_mutex_unlock(&lock);
  return e != NULL;
}
