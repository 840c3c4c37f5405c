/* Neighbour lists of the moving bubbles, found through the shared grid (grid.h), O(n) per build.
 *
 * The force acts within 1.5 l0 (003 eq. 11). Querying the grid at every one of RK4's four stages
 * would cost four queries per bubble and step; instead each curve and face bubble keeps the list
 * of the bubbles it feels (bub_related) within (1 + skin) 1.5 l0 at build time, and the lists are
 * rebuilt when some bubble has moved far enough that a pair outside the list could have come
 * within 1.5 l0 (a Verlet list). With skin s, a pair missing from the list was at least
 * 0.75 (1 + s)(d_i + d_j) apart; after moves delta_i, delta_j its distance is at least that minus
 * delta_i + delta_j, while its new range 0.75 (d_i' + d_j') grew by at most 0.75 (delta_i +
 * delta_j) (a size field with Lipschitz constant <= 1). The pair stays out of range while
 * 1.75 (delta_i + delta_j) <= 0.75 s (d_i + d_j), which holds when every bubble moved less than
 * 0.75 s / 1.75 of its diameter: the rebuild threshold below.
 *
 * Only the moving bubbles (bub_moving) have lists: curve and face bubbles, or volume bubbles in the
 * volume phase.
 *
 * Lists are sorted by id, so every per-bubble sum runs in the same order whatever the thread
 * count (the determinism rule of STYLE.md). The build runs in parallel over contiguous ranges of
 * bubbles, each thread filling its own buffer; the buffers are then concatenated in order.
 */
#include "bubble/bub_private.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/vec3.h"

#ifdef _OPENMP
#include <omp.h>
#endif

#define REBUILD_FRACTION (0.75 * BUB_SKIN / 1.75)

static int need_rebuild(const bub_state *s) {
  if (!s->lists_valid) return 1;
  int32_t a, b;
  bub_moving(s, &a, &b);
  for (int32_t i = a; i < b; ++i)
    if (pm_v3_dist(&s->x[3 * i], &s->x_build[3 * i]) > REBUILD_FRACTION * s->d_build[i]) {
      return 1;
    }
  return 0;
}

typedef struct ibuf {
  int32_t *v;
  int64_t n, cap;
} ibuf;

static int ibuf_push(ibuf *b, int32_t x) {
  if (b->n == b->cap) {
    int64_t nc = b->cap ? 2 * b->cap : 1024;
    int32_t *nv = realloc(b->v, sizeof(int32_t) * (size_t)nc);
    if (!nv) return 0;
    b->v = nv, b->cap = nc;
  }
  b->v[b->n++] = x;
  return 1;
}

pm_status bub_neighbors_update(bub_state *s, pm_error *err) {
  if (!need_rebuild(s)) return PM_OK;
  pm_status st = PM_OK;
  /* The grid at the current positions and diameters. */
  if (!s->grid_valid) {
    st = bub_state_grid_rebuild(s, err);
  } else {
    for (int32_t i = 0; i < s->n && !st; ++i)
      if (!(s->flags[i] & BUB_FDEAD)) st = pm_grid_move(s->grid, i, &s->x[3 * i], BUB_GRID_FACTOR * s->d[i], err);
  }
  if (st) return st;

  int32_t *off = realloc(s->nb_off, sizeof(int32_t) * ((size_t)s->n + 1));
  double *xb = realloc(s->x_build, sizeof(double) * 3 * ((size_t)s->n + 1));
  double *db = realloc(s->d_build, sizeof(double) * ((size_t)s->n + 1));
  if (off) s->nb_off = off;
  if (xb) s->x_build = xb;
  if (db) s->d_build = db;
  if (!off || !xb || !db) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  memcpy(s->x_build, s->x, sizeof(double) * 3 * (size_t)s->n);
  memcpy(s->d_build, s->d, sizeof(double) * (size_t)s->n);

  int32_t a, b;
  bub_moving(s, &a, &b);
  int T = bub_threads_for(s, b - a);
  ibuf *tb = calloc((size_t)T, sizeof(ibuf));
  pm_status *tst = calloc((size_t)T, sizeof(pm_status));
  int32_t *tlo = calloc((size_t)T, sizeof(int32_t));
  if (!tb || !tst || !tlo) {
    free(tb), free(tst), free(tlo);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  const double reach = 0.75 * (1 + BUB_SKIN);
  for (int32_t i = 0; i <= s->n; ++i) s->nb_off[i] = 0;
#pragma omp parallel num_threads(T)
  {
#ifdef _OPENMP
    int t = omp_get_thread_num(), nt = omp_get_num_threads();
#else
    int t = 0, nt = 1;
#endif
    int32_t lo = a + (int32_t)((int64_t)(b - a) * t / nt);
    int32_t hi = a + (int32_t)((int64_t)(b - a) * (t + 1) / nt);
    tlo[t] = lo;
    pm_idbuf q = PM_IDBUF_INIT;
    pm_error e = {0};
    for (int32_t i = lo; i < hi && !tst[t]; ++i) {
      /* grid radius BUB_GRID_FACTOR d_j >= reach d_j: the query returns
       * dist < reach d_i + BUB_GRID_FACTOR d_j, a superset of the list radius reach (d_i + d_j). */
      tst[t] = pm_grid_query_overlap(s->grid, &s->x[3 * i], reach * s->d[i], &q, &e);
      int32_t cnt = 0;
      for (int32_t k = 0; k < q.n && !tst[t]; ++k) {
        int32_t j = q.ids[k];
        if (!bub_related(s, i, j)) continue;
        if (pm_v3_dist(&s->x[3 * i], &s->x[3 * j]) >= reach * (s->d[i] + s->d[j])) continue;
        if (!ibuf_push(&tb[t], j)) tst[t] = PM_ERR_NOMEM;
        ++cnt;
      }
      s->nb_off[i + 1] = cnt;
    }
    pm_idbuf_free(&q);
  }
  for (int t = 0; t < T; ++t)
    if (tst[t]) st = tst[t];
  if (st) {
    for (int t = 0; t < T; ++t) free(tb[t].v);
    free(tb), free(tst), free(tlo);
    return st == PM_ERR_NOMEM ? pm_error_setf(err, PM_ERR_NOMEM, "out of memory")
                              : pm_error_setf(err, st, "neighbour query failed");
  }
  for (int32_t i = 0; i < s->n; ++i) s->nb_off[i + 1] += s->nb_off[i];
  int64_t total = s->nb_off[s->n];
  if (total > s->nb_cap) {
    int32_t *nn = realloc(s->nb, sizeof(int32_t) * (size_t)(total + 1));
    if (!nn) {
      for (int t = 0; t < T; ++t) free(tb[t].v);
      free(tb), free(tst), free(tlo);
      return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    }
    s->nb = nn, s->nb_cap = total + 1;
  }
  /* Thread t's bubbles are contiguous and in order: its buffer goes at the offset of its first. */
  for (int t = 0; t < T; ++t) {
    if (tb[t].n) memcpy(&s->nb[s->nb_off[tlo[t]]], tb[t].v, sizeof(int32_t) * (size_t)tb[t].n);
    free(tb[t].v);
  }
  free(tb), free(tst), free(tlo);
  s->lists_valid = 1;
  s->list_builds++;
  return PM_OK;
}
