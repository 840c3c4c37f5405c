/* Cost of the TetGen adapter (tet_tetgen.h) on the unit cube: a surface grid of n x n squares
 * per face (two triangles each) and, in PM_TET_GIVEN_POINTS mode, (n-1)^3 interior lattice
 * points jittered by up to 0.25/n; in PM_TET_REFINE mode the surface alone with radius-edge 1.5
 * and volume bound 1/(6 n^3) (the volume of a lattice cell's corner tet). Prints points, tets and
 * seconds (the exact-predicate surface check, TetGen and the output checks together). */
#include "common/base/rng.h"
#include "common/backends/tet_tetgen.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

typedef struct cube {
  double *xyz;
  int32_t npts, nsurf, ntri;
  int32_t *tri;
} cube;

static int32_t *ids;

static int32_t point(cube *c, int n, int i, int j, int k) {
  size_t key = ((size_t)i * (n + 1) + j) * (n + 1) + k;
  if (ids[key] < 0) {
    c->xyz[3 * c->npts] = (double)i / n;
    c->xyz[3 * c->npts + 1] = (double)j / n;
    c->xyz[3 * c->npts + 2] = (double)k / n;
    ids[key] = c->npts++;
  }
  return ids[key];
}

static void build(cube *c, int n, int interior) {
  size_t lattice = (size_t)(n + 1) * (n + 1) * (n + 1);
  c->xyz = malloc(3 * lattice * sizeof *c->xyz);
  c->tri = malloc((size_t)12 * n * n * 3 * sizeof *c->tri);
  ids = malloc(lattice * sizeof *ids);
  for (size_t i = 0; i < lattice; ++i) ids[i] = -1;
  c->npts = c->ntri = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side)
      for (int a = 0; a < n; ++a)
        for (int b = 0; b < n; ++b) {
          int32_t q[4];
          const int du[4] = {0, 1, 1, 0}, dv[4] = {0, 0, 1, 1};
          for (int m = 0; m < 4; ++m) {
            int ijk[3];
            ijk[axis] = side * n;
            ijk[(axis + 1) % 3] = a + du[m];
            ijk[(axis + 2) % 3] = b + dv[m];
            q[m] = point(c, n, ijk[0], ijk[1], ijk[2]);
          }
          int32_t *t = c->tri + 3 * c->ntri;
          t[0] = q[0], t[1] = q[1], t[2] = q[2], t[3] = q[0], t[4] = q[2], t[5] = q[3];
          c->ntri += 2;
        }
  c->nsurf = c->npts;
  if (interior) {
    pm_rng rng;
    pm_rng_init(&rng, 3, 0);
    for (int i = 1; i < n; ++i)
      for (int j = 1; j < n; ++j)
        for (int k = 1; k < n; ++k) {
          double *p = c->xyz + 3 * c->npts++;
          p[0] = (i + pm_rng_range(&rng, -0.25, 0.25)) / n;
          p[1] = (j + pm_rng_range(&rng, -0.25, 0.25)) / n;
          p[2] = (k + pm_rng_range(&rng, -0.25, 0.25)) / n;
        }
  }
  free(ids);
}

int main(void) {
  const int sizes[] = {10, 20, 40};
  printf("%-12s %5s %9s %9s %10s %9s\n", "mode", "n", "points", "steiner", "tets", "seconds");
  for (int mode = 0; mode < 2; ++mode)
    for (int s = 0; s < 3; ++s) {
      int n = sizes[s];
      cube c;
      build(&c, n, mode == 0);
      pm_tet_input in;
      memset(&in, 0, sizeof in);
      in.npts = c.npts, in.xyz = c.xyz, in.nsurf = c.nsurf, in.ntri = c.ntri, in.tri = c.tri;
      in.mode = mode ? PM_TET_REFINE : PM_TET_GIVEN_POINTS;
      in.radius_edge = 1.5;
      in.max_volume = 1.0 / (6.0 * n * n * n);
      pm_tet_result r;
      pm_error err = {0};
      double t0 = now();
      pm_status st = pm_tet_tetrahedralize(&in, &r, &err);
      double dt = now() - t0;
      if (st != PM_OK) {
        fprintf(stderr, "bench_tet: n = %d: %s\n", n, err.msg);
        return 1;
      }
      printf("%-12s %5d %9d %9d %10d %9.3f\n", mode ? "refine" : "given_points", n, r.npts,
             r.nsteiner, r.ntet, dt);
      pm_tet_result_free(&r);
      free(c.xyz);
      free(c.tri);
    }
  return 0;
}
