/* An index from 64-bit keys to int32 ids: open addressing with linear probing, at most half
 * full. For lattices whose points are numbered as they are first reached (the bubble method's
 * quadtree and octree): the key is the point's packed lattice coordinates. */
#ifndef PM_KEYINDEX_H
#define PM_KEYINDEX_H

#include <stdint.h>

typedef struct pm_keyindex {
  uint64_t *key;  /* [mask + 1] */
  int32_t *id;    /* [mask + 1], -1 empty */
  uint64_t mask;  /* table size - 1 (a power of two) */
  int32_t n;      /* ids held */
} pm_keyindex;

#define PM_KEYINDEX_INIT {NULL, NULL, 0, 0}

/* Room for n ids in all (the table grows, keeping what it holds); 0 when out of memory. */
int pm_keyindex_reserve(pm_keyindex *t, int32_t n);

/* The id of key, or -1. */
int32_t pm_keyindex_get(const pm_keyindex *t, uint64_t key);

/* Add key -> id; the key must be absent and room reserved. */
void pm_keyindex_put(pm_keyindex *t, uint64_t key, int32_t id);

/* Release (the index is left empty and reusable). */
void pm_keyindex_free(pm_keyindex *t);

#endif /* PM_KEYINDEX_H */
