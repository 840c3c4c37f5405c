/* pm_rng: the one seeded random generator of packmesh (xoshiro256**, seeded by splitmix64).
 *
 * Every random choice in the library draws from a pm_rng that the caller seeds; nothing uses
 * rand() or the clock. Streams derived from (seed, stream) let per-particle or per-face
 * choices be independent of the order in which threads reach them, so the thread count
 * never changes a result.
 */
#ifndef PM_RNG_H
#define PM_RNG_H

#include <stdint.h>

typedef struct pm_rng {
  uint64_t s[4]; /* generator state; never all zero */
} pm_rng;

/* Seed stream `stream` of `seed`. Equal (seed, stream) give equal sequences. */
void pm_rng_init(pm_rng *r, uint64_t seed, uint64_t stream);

/* Next 64 random bits. */
uint64_t pm_rng_next(pm_rng *r);

/* Uniform double in [0, 1) with 53 random bits. */
double pm_rng_uniform(pm_rng *r);

/* Uniform double in [lo, hi). */
double pm_rng_range(pm_rng *r, double lo, double hi);

/* Uniform integer in [0, n), n > 0, without modulo bias. */
uint64_t pm_rng_below(pm_rng *r, uint64_t n);

#endif /* PM_RNG_H */
