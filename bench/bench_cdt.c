/* Throughput of the constrained Delaunay adapter (cdt_cgal.h): n random points in the unit
 * square plus a constrained loop of 4 sqrt(n) points on its boundary, exterior removal on.
 * Prints points per second for n = 10^4, 10^5, 10^6 (best of a few runs for the small sizes). */
#include "common/backends/cdt_cgal.h"
#include "common/base/rng.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int main(void) {
  const int32_t sizes[] = {10000, 100000, 1000000};
  printf("%10s %10s %12s %10s %14s\n", "points", "boundary", "triangles", "seconds", "points/s");
  for (int s = 0; s < 3; ++s) {
    int32_t n = sizes[s];
    int32_t m = (int32_t)sqrt((double)n);
    int32_t nb = 4 * m, npts = n + nb;
    double *xy = malloc(2 * (size_t)npts * sizeof *xy);
    int32_t *cons = malloc(2 * (size_t)nb * sizeof *cons);
    if (!xy || !cons) return 1;
    for (int32_t i = 0; i < m; ++i) {
      double t = (double)i / m;
      xy[2 * i] = t, xy[2 * i + 1] = 0;
      xy[2 * (m + i)] = 1, xy[2 * (m + i) + 1] = t;
      xy[2 * (2 * m + i)] = 1 - t, xy[2 * (2 * m + i) + 1] = 1;
      xy[2 * (3 * m + i)] = 0, xy[2 * (3 * m + i) + 1] = 1 - t;
    }
    for (int32_t i = 0; i < nb; ++i) cons[2 * i] = i, cons[2 * i + 1] = (i + 1) % nb;
    pm_rng rng;
    pm_rng_init(&rng, 1, 0);
    for (int32_t i = nb; i < npts; ++i) {
      /* Keep random points strictly inside so none lands on a boundary edge. */
      xy[2 * i] = pm_rng_range(&rng, 1e-6, 1 - 1e-6);
      xy[2 * i + 1] = pm_rng_range(&rng, 1e-6, 1 - 1e-6);
    }
    int reps = n >= 1000000 ? 1 : 3;
    double best = INFINITY;
    int32_t ntri = 0;
    for (int r = 0; r < reps; ++r) {
      pm_cdt_result res;
      pm_error err = {0};
      double t0 = now();
      pm_status st = pm_cdt_triangulate(xy, npts, cons, nb, 1, 0, &res, &err);
      double dt = now() - t0;
      if (st != PM_OK) {
        fprintf(stderr, "bench_cdt: %s\n", err.msg);
        return 1;
      }
      ntri = res.ntri;
      pm_cdt_result_free(&res);
      if (dt < best) best = dt;
    }
    printf("%10d %10d %12d %10.3f %14.0f\n", n, nb, ntri, best, npts / best);
    free(xy);
    free(cons);
  }
  return 0;
}
