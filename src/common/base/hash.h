/* A 64-bit mixing function for the small open-addressing hash sets of the mesh code (node
 * pairs, sorted triples): splitmix64's finalizer, which spreads nearby keys over the table. */
#ifndef PM_HASH_H
#define PM_HASH_H

#include <stdint.h>

static inline uint64_t pm_mix64(uint64_t x) {
  x ^= x >> 33, x *= 0xff51afd7ed558ccdULL, x ^= x >> 33, x *= 0xc4ceb9fe1a85ec53ULL;
  return x ^ (x >> 33);
}

#endif /* PM_HASH_H */
