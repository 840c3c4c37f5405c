/* Wall-clock seconds from a monotonic clock, for the time_s figures of --stats. */
#ifndef PM_CLOCK_H
#define PM_CLOCK_H

#include <time.h>

static inline double pm_seconds(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

#endif /* PM_CLOCK_H */
