/* Neighbour lists of the moving bubbles (Verlet lists), two levels, found through the shared grid
 * (grid.h).
 *
 * The force acts within 1.5 l0 (003 eq. 11). Querying the grid at every one of RK4's four stages
 * would cost four queries per bubble and step; instead each moving bubble keeps the list of the
 * bubbles it feels (bub_related) within the reach 0.75 (1 + skin)(d_i + d_j) at build time
 * (skin = list_skin), and the lists are used, across RK stages and steps, for as long as no pair
 * missing from them can have come within 1.5 l0. A short skin keeps the lists short (the force sums
 * are most of a step's cost: with skin 0.15 a hexagonal packing lists its 6 neighbours, with 0.6
 * 18), but needs rebuilds more often; a grid query costs about as much as a bubble's whole step.
 * So the lists are rebuilt from outer lists of skin list_outer (0.6), by filtering their distances,
 * and only the outer lists come from the grid, as rarely as their longer skin allows.
 *
 * The skin test. A pair missing from the lists was at least 0.75 (1 + s)(db_i + db_j) apart at
 * the build (db: diameters then). After bubble i moved by delta_i from its build position and its
 * diameter changed by Delta_i, the pair is at least that minus delta_i + delta_j apart, while its
 * force range 0.75 (d_i + d_j) is at most 0.75 (db_i + db_j) + 0.75 (|Delta_i| + |Delta_j|). It
 * stays out of range while e_i + e_j <= 0, with e_i = delta_i + 0.75 |Delta_i| - 0.75 s db_i
 * (bub_skin_excess). For every pair at once: while the two largest e over all moving bubbles sum
 * to at most 0. (No assumption on the size field's gradient: the diameters in use enter the test
 * directly.) The dynamics (bub_dynamics.c) evaluates e at every point where forces are about to
 * be computed -- each RK stage's points and the step's end -- and rebuilds the lists there when
 * the test fails, so the lists are exact for every force evaluated: a bubble that crosses the
 * skin forces a rebuild before its force is summed.
 *
 * The outer test. Filtering the outer lists (skin S, built at positions po with diameters do)
 * gives complete lists (skin s) at the current positions when every pair missing from the outer
 * lists is still beyond 0.75 (1 + s)(d_i + d_j): by the same argument, when the two largest
 * e'_i = |x_i - po_i| + 0.75 (1 + s) |d_i - do_i| - 0.75 (S - s) do_i sum to at most 0. When they
 * do not, the outer lists are built again from the grid first.
 *
 * Partial builds (list_partial > 0). The argument above holds pair by pair with build positions
 * that differ from bubble to bubble: a pair missing from the lists of i and j is safe while
 * e_i + e_j <= 0, each e measured from that bubble's own build position, as long as the pair's
 * membership was decided from those two positions, |xb_i - xb_j| < 0.75 (1 + s)(db_i + db_j). So
 * when the test fails and only a few bubbles are responsible (a defect gliding through a packing
 * at rest), only the bubbles H whose e is above half their skin (-0.375 s db) get a new build
 * position; every other bubble keeps e <= -0.375 s db, so pairs of them stay safe, and pairs with a
 * bubble of H too. The lists of H and of their outer neighbours are then filtered again from the
 * (unchanged) build positions of everyone else. The outer lists the same way, one level up: the
 * bubbles whose outer excess e' is above half the gap (from their new build position) get a new
 * outer build position, the grid is moved there (it holds the outer build positions), their outer
 * lists come from the grid, and each of their old and new outer neighbours has them removed from
 * or inserted into its outer list (kept sorted; each region has room for BUB_OUTER_SLACK more
 * entries). When H is more than list_partial of the moving bubbles, when a region is full or the
 * grid was changed meanwhile, every list is built again instead. Which bubbles are rebuilt depends
 * only on positions, never on threads, and the lists are sets kept in id order, so the forces do
 * not depend on the thread count either.
 *
 * Only the moving bubbles (bub_moving) have lists: curve and face bubbles, or volume bubbles in the
 * volume phase.
 *
 * Lists are sorted by id (a grid query returns sorted ids; filtering keeps the order), so every
 * per-bubble sum runs in the same order whatever the thread count (the determinism rule of
 * STYLE.md). An outer build runs in parallel over chunks of bubbles, each thread appending to its
 * own buffer (kept across builds: no allocation once the buffers have grown to their size) and
 * noting where each chunk went; the pieces are then copied to the outer lists in chunk order. A
 * list is stored at the start of its bubble's outer list (it is a subset), so the lists need no
 * offsets of their own and their build is one parallel pass.
 */
#include "bubble/bub_private.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/clock.h"
#include "common/base/vec3.h"

#ifdef _OPENMP
#include <omp.h>
#endif

/* Bubbles per work item of a build. */
#define NB_CHUNK 1024

/* Room left in each outer list's region at a full build, for partial builds (header). */
#define BUB_OUTER_SLACK 6

/* A thread's buffers (kept in the state across builds). */
typedef struct bub_nbscratch {
  int32_t *v;     /* neighbour ids appended by this thread */
  int64_t n, cap;
  pm_idbuf q;     /* grid query results */
  pm_status st;
} bub_nbscratch;

/* Where a chunk's lists went: thread, offset in its buffer. */
typedef struct bub_nbpiece {
  int32_t thread;
  int64_t at;
} nb_piece;

static pm_status ensure(bub_state *s, pm_error *err) {
  if (!s->nbs) {
    s->nbs = calloc((size_t)s->threads, sizeof(bub_nbscratch));
    if (!s->nbs) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  return PM_OK;
}

void bub_neighbors_free(bub_state *s) {
  if (!s->nbs) return;
  for (int t = 0; t < s->threads; ++t) {
    free(s->nbs[t].v);
    pm_idbuf_free(&s->nbs[t].q);
  }
  free(s->nbs);
  s->nbs = NULL;
  free(s->nb_piece);
  s->nb_piece = NULL;
  s->nb_piece_cap = 0;
}

static int push(bub_nbscratch *b, int32_t x) {
  if (b->n == b->cap) {
    int64_t nc = b->cap ? 2 * b->cap : 4096;
    int32_t *nv = realloc(b->v, sizeof(int32_t) * (size_t)nc);
    if (!nv) return 0;
    b->v = nv, b->cap = nc;
  }
  b->v[b->n++] = x;
  return 1;
}

/* Position and diameter of bubble i at the build. */
static inline const double *at(const bub_state *s, const double *pos4, int32_t i, double *d) {
  if (pos4) {
    *d = pos4[4 * i + 3];
    return &pos4[4 * i];
  }
  *d = s->d[i];
  return &s->x[3 * i];
}

/* The outer lists at pos4 (or x, d), from the grid. */
static pm_status build_outer(bub_state *s, const double *pos4, pm_error *err) {
  pm_status st = ensure(s, err);
  if (st) return st;
  int32_t a, b;
  bub_moving(s, &a, &b);
  /* The grid at the build positions: every bubble after a change of the set, else the moving
   * ones (the others do not move). */
  if (!s->grid_valid) {
    pm_grid_clear(s->grid);
    st = pm_grid_reserve(s->grid, s->n, err);
    for (int32_t i = 0; i < s->n && !st; ++i) {
      if (s->flags[i] & BUB_FDEAD) continue;
      double d;
      const double *x = at(s, pos4, i, &d);
      st = pm_grid_insert(s->grid, i, x, s->grid_factor * d, err);
    }
    s->grid_valid = !st;
  } else {
    for (int32_t i = a; i < b && !st; ++i) {
      if (s->flags[i] & BUB_FDEAD) continue;
      double d;
      const double *x = at(s, pos4, i, &d);
      st = pm_grid_move(s->grid, i, x, s->grid_factor * d, err);
    }
  }
  if (st) return st;

  const int64_t nchunk = ((int64_t)(b - a) + NB_CHUNK - 1) / NB_CHUNK;
  if (nchunk + 1 > s->nb_piece_cap) {
    int64_t nc = nchunk + nchunk / 4 + 16;
    nb_piece *np = realloc(s->nb_piece, sizeof(nb_piece) * (size_t)nc);
    if (!np) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    s->nb_piece = np, s->nb_piece_cap = nc;
  }
  nb_piece *piece = s->nb_piece;
  for (int32_t i = 0; i < s->n; ++i) {
    double d;
    const double *x = at(s, pos4, i, &d);
    pm_v3_copy(&s->xo_build[3 * i], x);
    s->do_build[i] = d;
  }
  const double reach = bub_outer_reach(&s->p);
  for (int32_t i = 0; i <= s->n; ++i) s->nb_off[i] = 0;
  for (int32_t i = 0; i < s->n; ++i) s->nbo_cnt[i] = 0;
  const int T = bub_threads_for(s, b - a);
  for (int t = 0; t < T; ++t) s->nbs[t].n = 0, s->nbs[t].st = PM_OK;
#pragma omp parallel for num_threads(T) schedule(dynamic, 1) if (T > 1)
  for (int64_t c = 0; c < nchunk; ++c) {
#ifdef _OPENMP
    const int t = omp_get_thread_num();
#else
    const int t = 0;
#endif
    bub_nbscratch *buf = &s->nbs[t];
    piece[c].thread = t, piece[c].at = buf->n;
    const int32_t lo = a + (int32_t)(c * NB_CHUNK), hi = lo + NB_CHUNK < b ? lo + NB_CHUNK : b;
    pm_error e = {0};
    for (int32_t i = lo; i < hi && !buf->st; ++i) {
      /* Grid radius grid_factor d_j >= reach d_j: the query returns dist < reach d_i +
       * grid_factor d_j, a superset of the outer list's dist < reach (d_i + d_j). */
      const double *xi = &s->xo_build[3 * i], di = s->do_build[i];
      buf->st = pm_grid_query_overlap(s->grid, xi, reach * di, &buf->q, &e);
      int32_t cnt = 0;
      for (int32_t k = 0; k < buf->q.n && !buf->st; ++k) {
        int32_t j = buf->q.ids[k];
        if (!bub_related(s, i, j)) continue;
        if (pm_v3_dist(xi, &s->xo_build[3 * j]) >= reach * (di + s->do_build[j])) continue;
        if (!push(buf, j)) buf->st = PM_ERR_NOMEM;
        ++cnt;
      }
      s->nb_off[i + 1] = cnt;
      s->nbo_cnt[i] = cnt;
    }
  }
  for (int t = 0; t < T; ++t)
    if (s->nbs[t].st) st = s->nbs[t].st;
  if (st)
    return st == PM_ERR_NOMEM ? pm_error_setf(err, PM_ERR_NOMEM, "out of memory")
                              : pm_error_setf(err, st, "neighbour query failed");
  /* Regions: each moving bubble's outer list with room for BUB_OUTER_SLACK more. */
  const int slack = s->p.list_partial > 0 ? BUB_OUTER_SLACK : 0;
  for (int32_t i = 0; i < s->n; ++i) s->nb_off[i + 1] += s->nb_off[i] + (i >= a && i < b ? slack : 0);
  int64_t total = s->nb_off[s->n];
  if (total + 1 > s->nb_cap) {
    int64_t nc = total + total / 4 + 1024;
    int32_t *no = realloc(s->nbo, sizeof(int32_t) * (size_t)nc);
    if (no) s->nbo = no;
    int32_t *ni = realloc(s->nb, sizeof(int32_t) * (size_t)nc);
    if (ni) s->nb = ni;
    if (!no || !ni) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    s->nb_cap = nc;
  }
  /* Chunk c's lists are contiguous in its thread's buffer: they go at the offset of its first
   * bubble. */
  for (int64_t c = 0; c < nchunk; ++c) {
    const int32_t lo = a + (int32_t)(c * NB_CHUNK), hi = lo + NB_CHUNK < b ? lo + NB_CHUNK : b;
    const int32_t *from = &s->nbs[piece[c].thread].v[piece[c].at];
    for (int32_t i = lo; i < hi; ++i) {
      if (s->nbo_cnt[i]) memcpy(&s->nbo[s->nb_off[i]], from, sizeof(int32_t) * (size_t)s->nbo_cnt[i]);
      from += s->nbo_cnt[i];
    }
  }
  s->outer_builds++;
  return PM_OK;
}

/* The outer test at pos4 (or x, d): 1 when filtering the outer lists gives complete lists. */
static int outer_holds(const bub_state *s, const double *pos4) {
  int32_t a, b;
  bub_moving(s, &a, &b);
  const double reach = bub_list_reach(&s->p), gap = 0.75 * (s->p.list_outer - s->p.list_skin);
  bub_top2 t = {-INFINITY, -INFINITY};
  for (int32_t i = a; i < b; ++i) {
    double d;
    const double *x = at(s, pos4, i, &d);
    const double *xo = &s->xo_build[3 * i];
    double dx = x[0] - xo[0], dy = x[1] - xo[1], dz = x[2] - xo[2], dd = fabs(d - s->do_build[i]);
    bub_top2_add(&t, sqrt(dx * dx + dy * dy + dz * dz) + reach * dd - gap * (1 - 1e-9) * s->do_build[i]);
  }
  return t.e1 + t.e2 <= 0;
}

/* The outer excess of bubble i at position x, diameter d (header, "The outer test"). */
static inline double outer_excess(const bub_state *s, int32_t i, const double *x, double d) {
  const double reach = bub_list_reach(&s->p), gap = 0.75 * (s->p.list_outer - s->p.list_skin);
  const double *xo = &s->xo_build[3 * i];
  double dx = x[0] - xo[0], dy = x[1] - xo[1], dz = x[2] - xo[2], dd = fabs(d - s->do_build[i]);
  return sqrt(dx * dx + dy * dy + dz * dz) + reach * dd - gap * (1 - 1e-9) * s->do_build[i];
}

/* Bubble i's list filtered from its outer list at the build positions x_build, d_build. */
static inline void filter_list(bub_state *s, int32_t i, double reach) {
  const double *xi = &s->x_build[3 * i], di = s->d_build[i];
  int32_t cnt = 0;
  const int32_t o = s->nb_off[i];
  for (int32_t k = o; k < o + s->nbo_cnt[i]; ++k) {
    int32_t j = s->nbo[k];
    const double *xj = &s->x_build[3 * j];
    double dx = xi[0] - xj[0], dy = xi[1] - xj[1], dz = xi[2] - xj[2], r = reach * (di + s->d_build[j]);
    if (dx * dx + dy * dy + dz * dz < r * r) s->nb[o + cnt++] = j;
  }
  s->nb_cnt[i] = cnt;
}

/* The lists at pos4 (or x, d), filtered from the outer lists. */
static void build_lists(bub_state *s, const double *pos4) {
  int32_t a, b;
  bub_moving(s, &a, &b);
  const double reach = bub_list_reach(&s->p);
  for (int32_t i = 0; i < s->n; ++i) {
    double d;
    const double *x = at(s, pos4, i, &d);
    pm_v3_copy(&s->x_build[3 * i], x);
    s->d_build[i] = d;
  }
  const int T = bub_threads_for(s, b - a);
  for (int32_t i = 0; i < a; ++i) s->nb_cnt[i] = 0;
  for (int32_t i = b; i < s->n; ++i) s->nb_cnt[i] = 0;
#pragma omp parallel for num_threads(T) schedule(static) if (T > 1)
  for (int32_t i = a; i < b; ++i) filter_list(s, i, reach);
  s->list_builds++;
  s->nb_nmoved = -1;
}

/* Remove id j from bubble i's outer list (sorted) if it is there. */
static void outer_remove(bub_state *s, int32_t i, int32_t j) {
  int32_t *L = &s->nbo[s->nb_off[i]], n = s->nbo_cnt[i], k = 0;
  while (k < n && L[k] < j) ++k;
  if (k == n || L[k] != j) return;
  memmove(&L[k], &L[k + 1], sizeof(int32_t) * (size_t)(n - k - 1));
  s->nbo_cnt[i] = n - 1;
}

/* Insert id j into bubble i's outer list (sorted) if it is not there; 0 when its region is full. */
static int outer_insert(bub_state *s, int32_t i, int32_t j) {
  int32_t *L = &s->nbo[s->nb_off[i]], n = s->nbo_cnt[i], k = 0;
  while (k < n && L[k] < j) ++k;
  if (k < n && L[k] == j) return 1;
  if (s->nb_off[i] + n + 1 > s->nb_off[i + 1]) return 0;
  memmove(&L[k + 1], &L[k], sizeof(int32_t) * (size_t)(n - k));
  L[k] = j;
  s->nbo_cnt[i] = n + 1;
  return 1;
}

/* A partial build at pos4 (header, "Partial builds"): 1 when done, 0 when every list must be built
 * again instead (nothing has been changed then but build positions the full build overwrites). */
static int partial_build(bub_state *s, const double *pos4, pm_error *err, pm_status *st) {
  int32_t a, b;
  bub_moving(s, &a, &b);
  const int32_t nmov = b - a;
  const double limit = s->p.list_partial * nmov;
  const double half = 0.5 * 0.75 * s->p.list_skin, ohalf = 0.5 * 0.75 * (s->p.list_outer - s->p.list_skin);
  if (!(limit >= 1) || !s->grid_valid) return 0;
  /* H: the bubbles past half their skin. */
  int32_t nh = 0;
  for (int32_t i = a; i < b; ++i) {
    double d;
    const double *x = at(s, pos4, i, &d);
    if (bub_skin_excess(s, i, x, d) > -half * s->d_build[i]) {
      if (nh + 1 > limit) return 0;
      s->nb_moved[nh++] = i;
    }
  }
  /* New build positions for H. */
  for (int32_t k = 0; k < nh; ++k) {
    const int32_t i = s->nb_moved[k];
    double d;
    const double *x = at(s, pos4, i, &d);
    pm_v3_copy(&s->x_build[3 * i], x);
    s->d_build[i] = d;
  }
  /* The outer test at the build positions, bubble by bubble: those past half the gap (H's, and
   * any an earlier full filtering left there) get new outer lists at their build position; every
   * other has e' <= -half the gap, so the outer lists stay complete for the pairs of them. The
   * grid follows (it holds the outer build positions). Marks: 1 list to filter, 2 new outer list,
   * 3 outer list changed. */
  int32_t no = 0;
  for (int32_t i = a; i < b; ++i) {
    s->nb_mark[i] = 0;
    if (outer_excess(s, i, &s->x_build[3 * i], s->d_build[i]) > -ohalf * s->do_build[i]) {
      if (no + 1 > limit) return 0;
      s->nb_mark[i] = 2, ++no;
    }
  }
  for (int32_t k = 0; k < nh; ++k)
    if (!s->nb_mark[s->nb_moved[k]]) s->nb_mark[s->nb_moved[k]] = 1;
  for (int32_t i = a; i < b && no; ++i) {
    if (s->nb_mark[i] != 2) continue;
    pm_v3_copy(&s->xo_build[3 * i], &s->x_build[3 * i]);
    s->do_build[i] = s->d_build[i];
    if ((*st = pm_grid_move(s->grid, i, &s->xo_build[3 * i], s->grid_factor * s->do_build[i], err))) return 1;
  }
  if (no) {
    /* Outer lists of the marked-2 bubbles from the grid (every grid point at its outer build
     * position now), and each old or new outer neighbour updated. */
    const double reach = bub_outer_reach(&s->p);
    pm_idbuf *q = &s->nbs[0].q;
    for (int32_t i = a; i < b; ++i) {
      if (s->nb_mark[i] != 2) continue;
      const double *xi = &s->xo_build[3 * i], di = s->do_build[i];
      if ((*st = pm_grid_query_overlap(s->grid, xi, reach * di, q, err))) return 1;
      int32_t *L = &s->nbo[s->nb_off[i]], n = s->nbo_cnt[i], cap = s->nb_off[i + 1] - s->nb_off[i];
      /* The old list goes to the inner-list storage of i meanwhile (the region is i's alone). */
      int32_t *old = &s->nb[s->nb_off[i]];
      memcpy(old, L, sizeof(int32_t) * (size_t)n);
      int32_t m = 0;
      for (int32_t t = 0; t < q->n; ++t) {
        int32_t j = q->ids[t];
        if (!bub_related(s, i, j)) continue;
        if (pm_v3_dist(xi, &s->xo_build[3 * j]) >= reach * (di + s->do_build[j])) continue;
        if (m == cap) { /* no room: every list again */
          s->lists_valid = 0;
          return 0;
        }
        L[m++] = j;
      }
      s->nbo_cnt[i] = m;
      /* Old and new lists are sorted: walk them together. */
      int32_t u = 0, w = 0;
      while (u < n || w < m) {
        int32_t jo = u < n ? old[u] : INT32_MAX, jn = w < m ? L[w] : INT32_MAX;
        int32_t j = jo < jn ? jo : jn;
        int in_old = jo == j, in_new = jn == j;
        u += in_old, w += in_new;
        if (j < a || j >= b) continue; /* a fixed bubble: no list */
        if (in_old && !in_new) outer_remove(s, j, i);
        if (in_new && !in_old && !outer_insert(s, j, i)) {
          s->lists_valid = 0;
          return 0;
        }
        if (in_old != in_new && !s->nb_mark[j]) s->nb_mark[j] = 3;
      }
    }
    s->partial_outer++;
  }
  /* The lists to filter again: H, the outer neighbours of H, the bubbles whose outer list changed. */
  const double reach = bub_list_reach(&s->p);
  for (int32_t k = 0; k < nh; ++k) {
    const int32_t i = s->nb_moved[k];
    for (int32_t t = s->nb_off[i]; t < s->nb_off[i] + s->nbo_cnt[i]; ++t) {
      int32_t j = s->nbo[t];
      if (j >= a && j < b && !s->nb_mark[j]) s->nb_mark[j] = 3;
    }
  }
  for (int32_t i = a; i < b; ++i)
    if (s->nb_mark[i]) filter_list(s, i, reach);
  s->nb_nmoved = nh;
  s->partial_builds++;
  return 1;
}

pm_status bub_neighbors_update(bub_state *s, const double *pos4, pm_error *err) {
  if (s->lists_valid && !s->lists_stale) return PM_OK;
  const double t0 = pm_seconds();
  if (s->n + 1 > s->nb_build_cap) {
    int32_t nc = s->n + s->n / 4 + 64;
#define R(ptr, per)                                                                   \
  do {                                                                                \
    void *np = realloc(s->ptr, sizeof(*s->ptr) * (size_t)(per) * ((size_t)nc + 1));  \
    if (!np) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");                \
    s->ptr = np;                                                                      \
  } while (0)
    R(nb_off, 1);
    R(nb_cnt, 1);
    R(x_build, 3);
    R(d_build, 1);
    R(xo_build, 3);
    R(do_build, 1);
    R(nbo_cnt, 1);
    R(nb_mark, 1);
    R(nb_moved, 1);
#undef R
    s->nb_build_cap = nc;
  }
  pm_status st = PM_OK;
  if (s->lists_valid && s->p.list_partial > 0 && partial_build(s, pos4, err, &st)) {
    if (!st) s->lists_stale = 0;
    s->t.neighbors += pm_seconds() - t0;
    return st;
  }
  if (st) return st;
  if (!s->lists_valid || !outer_holds(s, pos4)) st = build_outer(s, pos4, err);
  if (st) return st;
  build_lists(s, pos4);
  s->lists_valid = 1;
  s->lists_stale = 0;
  s->t.neighbors += pm_seconds() - t0;
  return PM_OK;
}
