/* See keyindex.h. */
#include "common/base/keyindex.h"

#include <stdlib.h>

#include "common/base/hash.h"

static void insert(uint64_t *keys, int32_t *ids, uint64_t mask, uint64_t key, int32_t id) {
  uint64_t h = pm_mix64(key) & mask;
  while (ids[h] >= 0) h = (h + 1) & mask;
  keys[h] = key, ids[h] = id;
}

int pm_keyindex_reserve(pm_keyindex *t, int32_t n) {
  if (t->id && 2 * (uint64_t)n <= t->mask + 1) return 1;
  uint64_t size = t->id ? t->mask + 1 : 1024;
  while (2 * (uint64_t)n > size) size *= 2;
  uint64_t *keys = malloc(sizeof(uint64_t) * size);
  int32_t *ids = malloc(sizeof(int32_t) * size);
  if (!keys || !ids) {
    free(keys), free(ids);
    return 0;
  }
  for (uint64_t k = 0; k < size; ++k) ids[k] = -1;
  if (t->id)
    for (uint64_t k = 0; k <= t->mask; ++k)
      if (t->id[k] >= 0) insert(keys, ids, size - 1, t->key[k], t->id[k]);
  free(t->key), free(t->id);
  t->key = keys, t->id = ids, t->mask = size - 1;
  return 1;
}

int32_t pm_keyindex_get(const pm_keyindex *t, uint64_t key) {
  if (!t->id) return -1;
  for (uint64_t h = pm_mix64(key) & t->mask; t->id[h] >= 0; h = (h + 1) & t->mask)
    if (t->key[h] == key) return t->id[h];
  return -1;
}

void pm_keyindex_put(pm_keyindex *t, uint64_t key, int32_t id) {
  insert(t->key, t->id, t->mask, key, id);
  ++t->n;
}

void pm_keyindex_free(pm_keyindex *t) {
  free(t->key), free(t->id);
  t->key = NULL, t->id = NULL, t->mask = 0, t->n = 0;
}
