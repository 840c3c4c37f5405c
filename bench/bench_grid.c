/* bench_grid: build, update and query throughput of pm_grid at 10^4, 10^5 and 10^6 points.
 *
 * Two point sets in the unit cube (or square with --2d), each point's radius about its spacing
 * so that a mutual query finds ~30 neighbours in 3D (~12 in 2D), as in both meshers:
 *   uniform  one radius everywhere;
 *   graded   radius r(x) = rmin 1000^x along x (three decades, psys's range), points spaced
 *            accordingly (density ~ r^-3), so most points sit at the fine end.
 * Reported per set: inserts/s, small moves/s (a relaxation step: 0.1 r displacement, +-5%
 * radius), mutual / overlap / ball queries/s at every point with its own radius, 8-nearest
 * queries/s, and mutual queries/s with all OpenMP threads. Flat queries/s as n grows means a
 * step of the meshers costs O(n).
 *
 * usage: bench_grid [--2d] [--max N]     (N: largest size, default 1000000)
 */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "common/sizing/grid.h"
#include "common/base/rng.h"

/* Serial figures use this thread's CPU time, so that other programs sharing the machine do not
 * distort them; the multi-threaded figure uses wall time. */
static double now(void) {
  struct timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

typedef struct pts {
  int32_t n;
  double *x, *r;
} pts;

/* Radius that gives `nb` expected neighbours within the ball at density n per unit volume. */
static double radius_for(double density, double nb, int dim) {
  return dim == 3 ? cbrt(nb * 3 / (4 * M_PI * density)) : sqrt(nb / (M_PI * density));
}

static void make_points(pts *p, int32_t n, int graded, int dim, uint64_t seed) {
  pm_rng g;
  pm_rng_init(&g, seed, 0);
  p->n = n;
  p->x = malloc(sizeof(double) * 3 * (size_t)n);
  p->r = malloc(sizeof(double) * (size_t)n);
  const double nb = dim == 3 ? 30 : 12;
  const double span = log(1000.0); /* r(x) = rmin exp(span x) */
  for (int32_t i = 0; i < n; ++i) {
    double *x = p->x + 3 * i;
    x[1] = pm_rng_uniform(&g);
    x[2] = dim == 3 ? pm_rng_uniform(&g) : 0;
    if (!graded) {
      x[0] = pm_rng_uniform(&g);
      p->r[i] = radius_for(n, nb, dim);
    } else {
      /* density ~ exp(-dim span x): inverse CDF along x */
      double a = dim * span, u = pm_rng_uniform(&g);
      x[0] = -log(1 - u * (1 - exp(-a))) / a;
      /* local density n * a exp(-a x) / (1 - exp(-a)) points per unit volume */
      double rho = n * a * exp(-a * x[0]) / (1 - exp(-a));
      p->r[i] = radius_for(rho, nb, dim);
    }
  }
}

static void shuffle(int32_t *ids, int32_t n, uint64_t seed) {
  pm_rng g;
  pm_rng_init(&g, seed, 1);
  for (int32_t i = n - 1; i > 0; --i) {
    int32_t j = (int32_t)pm_rng_below(&g, (uint64_t)i + 1), t = ids[i];
    ids[i] = ids[j], ids[j] = t;
  }
}

/* Morton code of a point of the unit cube quantized to 2^21 per axis. */
static uint64_t morton(const double *x) {
  uint64_t code = 0;
  uint32_t q[3];
  for (int a = 0; a < 3; ++a) {
    double v = x[a] < 0 ? 0 : (x[a] >= 1 ? 0.9999999 : x[a]);
    q[a] = (uint32_t)(v * (1u << 21));
  }
  for (int b = 20; b >= 0; --b)
    for (int a = 2; a >= 0; --a) code = code << 1 | ((q[a] >> b) & 1);
  return code;
}

typedef struct keyed {
  uint64_t key;
  int32_t id;
} keyed;

static int cmp_keyed(const void *a, const void *b) {
  const keyed *x = a, *y = b;
  return (x->key > y->key) - (x->key < y->key);
}

static void run(int32_t n, int graded, int dim) {
  pts p;
  make_points(&p, n, graded, dim, 1234 + (uint64_t)n);
  double rmin = INFINITY, rmax = 0;
  for (int32_t i = 0; i < n; ++i) rmin = fmin(rmin, p.r[i]), rmax = fmax(rmax, p.r[i]);
  /* ids in random order: neighbouring points have unrelated ids (the worst case for caches) */
  int32_t *order = malloc(sizeof(int32_t) * (size_t)n);
  for (int32_t i = 0; i < n; ++i) order[i] = i;
  shuffle(order, n, 7);
  pm_grid *g = NULL;
  pm_error e = {0};
  if (pm_grid_create(rmin * 0.5, &g, &e)) {
    fprintf(stderr, "%s\n", e.msg);
    exit(1);
  }
  double t0 = now();
  for (int32_t k = 0; k < n; ++k) {
    int32_t i = order[k];
    if (pm_grid_insert(g, i, p.x + 3 * i, p.r[i], &e)) {
      fprintf(stderr, "%s\n", e.msg);
      exit(1);
    }
  }
  double t_ins = now() - t0;

  pm_idbuf b = PM_IDBUF_INIT;
  double nbsum = 0;
  t0 = now();
  for (int32_t i = 0; i < n; ++i) {
    pm_grid_query_mutual(g, p.x + 3 * i, p.r[i], &b, NULL);
    nbsum += b.n;
  }
  double t_mut = now() - t0;
  /* The same queries in space-filling-curve order (a mesher whose ids follow space): the
   * neighbourhood of one query is still in cache for the next. */
  keyed *kq = malloc(sizeof(keyed) * (size_t)n);
  for (int32_t i = 0; i < n; ++i) kq[i].key = morton(p.x + 3 * i), kq[i].id = i;
  qsort(kq, (size_t)n, sizeof *kq, cmp_keyed);
  t0 = now();
  for (int32_t k = 0; k < n; ++k) {
    int32_t i = kq[k].id;
    pm_grid_query_mutual(g, p.x + 3 * i, p.r[i], &b, NULL);
  }
  double t_mut_sp = now() - t0;
  free(kq);
  double ovsum = 0;
  t0 = now();
  for (int32_t i = 0; i < n; ++i) {
    pm_grid_query_overlap(g, p.x + 3 * i, 0.75 * p.r[i], &b, NULL);
    ovsum += b.n;
  }
  double t_ov = now() - t0;
  t0 = now();
  for (int32_t i = 0; i < n; ++i) pm_grid_query_ball(g, p.x + 3 * i, p.r[i], &b, NULL);
  double t_ball = now() - t0;
  int32_t nk = n < 200000 ? n : 200000, ids[8];
  t0 = now();
  for (int32_t i = 0; i < nk; ++i) pm_grid_knearest_fixed(g, p.x + 3 * i, 8, ids, NULL);
  double t_knn = now() - t0;

  int nth = omp_get_max_threads();
  t0 = omp_get_wtime();
#pragma omp parallel
  {
    pm_idbuf tb = PM_IDBUF_INIT;
#pragma omp for schedule(static, 1024)
    for (int32_t i = 0; i < n; ++i) pm_grid_query_mutual(g, p.x + 3 * i, p.r[i], &tb, NULL);
    pm_idbuf_free(&tb);
  }
  double t_par = omp_get_wtime() - t0;

  pm_rng rg;
  pm_rng_init(&rg, 99, 0);
  t0 = now();
  for (int32_t i = 0; i < n; ++i) {
    double *x = p.x + 3 * i;
    for (int a = 0; a < dim; ++a) x[a] += 0.1 * p.r[i] * (pm_rng_uniform(&rg) - 0.5);
    p.r[i] *= 0.95 + 0.1 * pm_rng_uniform(&rg);
    pm_grid_move(g, i, x, p.r[i], NULL);
  }
  double t_mov = now() - t0;

  printf("%-7s %dD n=%-8d r %.2g..%.2g  nb %.1f/%.1f  insert %.3g/s  move %.3g/s  mutual %.3g q/s  "
         "(space order %.3g q/s)  overlap %.3g q/s  ball %.3g q/s  knn8 %.3g q/s  "
         "mutual x%d threads %.3g q/s\n",
         graded ? "graded" : "uniform", dim, n, rmin, rmax, nbsum / n, ovsum / n, n / t_ins,
         n / t_mov, n / t_mut, n / t_mut_sp, n / t_ov, n / t_ball, nk / t_knn, nth, n / t_par);
  fflush(stdout);
  pm_idbuf_free(&b);
  pm_grid_destroy(g);
  free(order), free(p.x), free(p.r);
}

int main(int argc, char **argv) {
  int dim = 3;
  int32_t nmax = 1000000;
  for (int i = 1; i < argc; ++i) {
    if (!strcmp(argv[i], "--2d"))
      dim = 2;
    else if (!strcmp(argv[i], "--max") && i + 1 < argc)
      nmax = atoi(argv[++i]);
    else {
      fprintf(stderr, "usage: bench_grid [--2d] [--max N]\n");
      return 2;
    }
  }
  printf("pm_grid throughput (nb = mean neighbours: mutual / overlap at 0.75 r)\n");
  for (int graded = 0; graded < 2; ++graded)
    for (int32_t n = 10000; n <= nmax; n *= 10) run(n, graded, dim);
  return 0;
}
