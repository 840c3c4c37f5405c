/* pm_rng: xoshiro256** (Blackman & Vigna, 2018), state filled by splitmix64. */
#include "common/base/rng.h"

static uint64_t splitmix64(uint64_t *x) {
  uint64_t z = (*x += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

static inline uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

void pm_rng_init(pm_rng *r, uint64_t seed, uint64_t stream) {
  /* Mix the stream through splitmix before combining so that neighbouring stream ids
   * (particle 7 and particle 8) start from unrelated states. */
  uint64_t t = stream;
  uint64_t x = seed ^ splitmix64(&t);
  for (int i = 0; i < 4; ++i) r->s[i] = splitmix64(&x);
  if (!(r->s[0] | r->s[1] | r->s[2] | r->s[3])) r->s[0] = 1;
}

uint64_t pm_rng_next(pm_rng *r) {
  uint64_t *s = r->s;
  const uint64_t result = rotl(s[1] * 5, 7) * 9;
  const uint64_t t = s[1] << 17;
  s[2] ^= s[0];
  s[3] ^= s[1];
  s[1] ^= s[2];
  s[0] ^= s[3];
  s[2] ^= t;
  s[3] = rotl(s[3], 45);
  return result;
}

double pm_rng_uniform(pm_rng *r) { return (double)(pm_rng_next(r) >> 11) * 0x1.0p-53; }

double pm_rng_range(pm_rng *r, double lo, double hi) { return lo + (hi - lo) * pm_rng_uniform(r); }

uint64_t pm_rng_below(pm_rng *r, uint64_t n) {
  /* Rejection sampling on the top of the range removes the modulo bias. */
  uint64_t limit = UINT64_MAX - UINT64_MAX % n;
  uint64_t x;
  do x = pm_rng_next(r);
  while (x >= limit);
  return x % n;
}
