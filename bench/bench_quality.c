/* Quality measures and the validity checker on large meshes: a structured grid of triangles
 * (n x n squares, 2 n^2 triangles) with jittered interior nodes, and its tetrahedral
 * counterpart (a grid of cubes, 6 tets each). Prints wall-clock times.
 *   bench_quality [n_tri_side] [n_tet_side]   (defaults 708 -> 1.0e6 triangles, 55 -> 1.0e6 tets) */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "common/mesh/mesh.h"
#include "common/mesh/mesh_check.h"
#include "common/measure/quality.h"
#include "common/base/rng.h"

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static double size_fn(const double *x, void *u) {
  (void)u;
  return 0.001 * (1.0 + 0.5 * x[0]);
}

int main(int argc, char **argv) {
  int n = argc > 1 ? atoi(argv[1]) : 708;
  int k = argc > 2 ? atoi(argv[2]) : 55;
  pm_error e = {0};
  pm_rng rng;
  pm_rng_init(&rng, 42, 0);

  pm_mesh *m = pm_mesh_create();
  pm_mesh_reserve(m, (n + 1) * (n + 1), 0, 2 * n * n, 0, &e);
  double h = 1.0 / n;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      int inner = i > 0 && i < n && j > 0 && j < n;
      double p[3] = {i * h + (inner ? 0.2 * h * (pm_rng_uniform(&rng) - 0.5) : 0),
                     j * h + (inner ? 0.2 * h * (pm_rng_uniform(&rng) - 0.5) : 0), 0};
      pm_mesh_add_node(m, p, inner ? 2 : 1, 0, NULL, NULL, &e);
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      int32_t a = i + (n + 1) * j, b = a + 1, c = a + n + 2, d = a + n + 1;
      pm_mesh_add_tri(m, a, b, c, 0, &e);
      pm_mesh_add_tri(m, a, c, d, 0, &e);
    }
  printf("triangles: %d nodes, %d triangles\n", m->nnode, m->ntri);
  pm_quality q;
  double t0 = now();
  if (pm_quality_compute_fn(m, NULL, NULL, &q, &e)) return printf("%s\n", e.msg), 1;
  double t1 = now();
  printf("  quality (no size field)   %.3f s  (radius ratio mean %.6f, eps_t %.4f)\n", t1 - t0,
         q.tri.s_radius_ratio.mean, q.tri.eps_t);
  pm_quality_clear(&q);
  t0 = now();
  if (pm_quality_compute_fn(m, size_fn, NULL, &q, &e)) return printf("%s\n", e.msg), 1;
  t1 = now();
  printf("  quality (with size field) %.3f s  (size ratio mean %.4f over %lld edges)\n", t1 - t0,
         q.tri.size_ratio.mean, (long long)q.tri.nedge);
  pm_quality_clear(&q);
  pm_check_report r;
  t0 = now();
  if (pm_mesh_check(m, NULL, &r, &e)) return printf("%s\n", e.msg), 1;
  t1 = now();
  printf("  check                     %.3f s  (valid %d, V-E+F %lld)\n", t1 - t0, r.valid,
         (long long)r.shell[0].euler);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);

  /* k^3 cubes, each split into 6 tets around its main diagonal (Kuhn subdivision). */
  m = pm_mesh_create();
  int s = k + 1;
  for (int z = 0; z <= k; ++z)
    for (int y = 0; y <= k; ++y)
      for (int x = 0; x <= k; ++x) {
        double p[3] = {x, y, z};
        pm_mesh_add_node(m, p, -1, -1, NULL, NULL, &e);
      }
  static const int perm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int z = 0; z < k; ++z)
    for (int y = 0; y < k; ++y)
      for (int x = 0; x < k; ++x)
        for (int t = 0; t < 6; ++t) {
          int c[3] = {x, y, z}, v[4];
          v[0] = c[0] + s * (c[1] + s * c[2]);
          for (int j = 0; j < 3; ++j) {
            c[perm[t][j]]++;
            v[j + 1] = c[0] + s * (c[1] + s * c[2]);
          }
          /* orientation alternates with the permutation's parity */
          if (t == 1 || t == 2 || t == 5)
            pm_mesh_add_tet(m, v[0], v[2], v[1], v[3], 0, &e);
          else
            pm_mesh_add_tet(m, v[0], v[1], v[2], v[3], 0, &e);
        }
  printf("tetrahedra: %d nodes, %d tets\n", m->nnode, m->ntet);
  t0 = now();
  if (pm_quality_compute_fn(m, NULL, NULL, &q, &e)) return printf("%s\n", e.msg), 1;
  t1 = now();
  printf("  quality                   %.3f s  (radius ratio mean %.6f, eps_t %.4f)\n", t1 - t0,
         q.tet.s_radius_ratio.mean, q.tet.eps_t);
  pm_quality_clear(&q);
  t0 = now();
  if (pm_mesh_check(m, NULL, &r, &e)) return printf("%s\n", e.msg), 1;
  t1 = now();
  printf("  check                     %.3f s  (valid %d%s%s)\n", t1 - t0, r.valid,
         r.nproblem ? ": " : "", r.nproblem ? r.problem[0] : "");
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);
  return 0;
}
