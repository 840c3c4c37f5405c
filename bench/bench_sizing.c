/* bench_sizing: evaluations per second of size fields, one thread and all OpenMP threads.
 *
 * Fields: a constant; DESIGN.md's qi3 and shimada expressions (muparser, one parser per
 * thread); qi4's longer expression; the same expression scaled; a callback computing qi3 in C
 * (the floor any expression could reach); a field sampled on a 100 x 100 triangle grid of the
 * unit square (query points on the mesh) and the same queried beside the mesh, in its plane
 * (the inverse-distance fallback).
 *
 * usage: bench_sizing [N]   (evaluations per field, default 2000000)
 */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "common/mesh/mesh.h"
#include "common/base/rng.h"
#include "common/sizing/sizing.h"

/* Serial figures use this thread's CPU time (robust on a shared machine); the multi-threaded
 * figure uses wall time. */
static double cpu_now(void) {
  struct timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

static double qi3_fn(const double p[3], void *user) {
  (void)user;
  return 0.2 * fabs(sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) - 2) + 0.15;
}

static void run(const char *name, const pm_sizing *s, const double *pts, int n) {
  double sum = 0, t0 = cpu_now();
  for (int i = 0; i < n; ++i) sum += pm_sizing_eval(s, pts + 3 * i);
  double t1 = cpu_now() - t0;
  double psum = 0, w0 = omp_get_wtime();
#pragma omp parallel for reduction(+ : psum) schedule(static)
  for (int i = 0; i < n; ++i) psum += pm_sizing_eval(s, pts + 3 * i);
  double t2 = omp_get_wtime() - w0;
  printf("%-34s %10.3g eval/s   x%d threads %10.3g eval/s   (%.1f ns/eval; mean %.6g)\n", name,
         n / t1, omp_get_max_threads(), n / t2, 1e9 * t1 / n, sum / n);
  if (fabs(psum - sum) > 1e-9 * fabs(sum)) printf("  parallel sum differs: %.17g vs %.17g\n", psum, sum);
}

int main(int argc, char **argv) {
  int n = argc > 1 ? atoi(argv[1]) : 2000000;
  if (n < 1) {
    fprintf(stderr, "usage: bench_sizing [N]\n");
    return 2;
  }
  pm_rng g;
  pm_rng_init(&g, 5, 0);
  double *pts = malloc(sizeof(double) * 3 * (size_t)n), *off = malloc(sizeof(double) * 3 * (size_t)n);
  for (int i = 0; i < n; ++i) {
    pts[3 * i] = pm_rng_uniform(&g), pts[3 * i + 1] = pm_rng_uniform(&g), pts[3 * i + 2] = 0;
    /* beyond the square's right side, in its plane: the inverse-distance fallback */
    off[3 * i] = 1.05 + pts[3 * i], off[3 * i + 1] = pts[3 * i + 1], off[3 * i + 2] = 0;
  }
  pm_error e = {0};
  pm_sizing *s = NULL, *sc = NULL;
  const char *exprs[][2] = {
      {"constant 0.1", "0.1"},
      {"expression qi3", "0.2*abs(r-2)+0.15"},
      {"expression shimada", "0.04/(1.5+sin(3+4*x*y))"},
      {"expression qi4",
       "min(0.25-0.15*(r-1), min(0.05+0.08*(sqrt((x+0.4)^2+y^2)-0.5), "
       "((sqrt((x+0.4)^2+y^2)-0.5)-(r-1))/2))"},
  };
  for (int k = 0; k < 4; ++k) {
    if (pm_sizing_parse(exprs[k][1], &s, &e)) {
      fprintf(stderr, "%s\n", e.msg);
      return 1;
    }
    run(exprs[k][0], s, pts, n);
    if (k == 1) {
      pm_sizing_scaled(s, 1.07, &sc, &e);
      run("scaled 1.07 x qi3", sc, pts, n);
      pm_sizing_destroy(sc);
    }
    pm_sizing_destroy(s);
  }
  pm_sizing_callback(qi3_fn, NULL, "qi3 in C", &s, &e);
  run("callback qi3 (C)", s, pts, n);
  pm_sizing_destroy(s);

  const int m = 101;
  pm_mesh *mesh = pm_mesh_create();
  double *val = malloc(sizeof(double) * m * m);
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < m; ++i) {
      double p[3] = {(double)i / (m - 1), (double)j / (m - 1), 0};
      pm_mesh_add_node(mesh, p, -1, -1, NULL, NULL, &e);
      val[j * m + i] = qi3_fn(p, NULL);
    }
  for (int j = 0; j + 1 < m; ++j)
    for (int i = 0; i + 1 < m; ++i) {
      int32_t a = j * m + i;
      pm_mesh_add_tri(mesh, a, a + 1, a + m + 1, -1, &e);
      pm_mesh_add_tri(mesh, a, a + m + 1, a + m, -1, &e);
    }
  if (pm_sizing_sampled(mesh, val, &s, &e)) {
    fprintf(stderr, "%s\n", e.msg);
    return 1;
  }
  run("sampled 20000 triangles, on mesh", s, pts, n / 4);
  run("sampled, beside the mesh (IDW)", s, off, n / 4);
  pm_sizing_destroy(s);
  pm_mesh_destroy(mesh);
  free(val), free(pts), free(off);
  return 0;
}
