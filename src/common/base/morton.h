/* Morton (Z-order) codes: interleaving the bits of integer coordinates, so that sorting by the
 * code keeps points that are near in space near in the order. */
#ifndef PM_MORTON_H
#define PM_MORTON_H

#include <stdint.h>

/* The low 21 bits of v spread to every third bit: the code of (x, y, z) is
 * pm_morton_spread3(x) | pm_morton_spread3(y) << 1 | pm_morton_spread3(z) << 2 (and of (x, y),
 * the same without z). */
static inline uint64_t pm_morton_spread3(uint64_t v) {
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffffULL;
  v = (v | v << 16) & 0x1f0000ff0000ffULL;
  v = (v | v << 8) & 0x100f00f00f00f00fULL;
  v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
  v = (v | v << 2) & 0x1249249249249249ULL;
  return v;
}

#endif /* PM_MORTON_H */
