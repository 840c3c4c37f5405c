/* The neighbour structure of the particle system: for every particle, the particles it may
 * interact with, and where the gap size applies, the particles that may bound its gap. Papers/001
 * section 5.2.1 asks for spatial structures "optimized for self-updates as the particle system
 * refines and coarsens"; these are Verlet lists whose particles carry a budget, so that an
 * iteration makes again only the lists of the particles that left theirs.
 *
 * Lists. For each kind of list (psys_vl), particle i records where its list was made, x0_i, and
 * its sigma then, s0_i; the list holds the j with |x0_i - x0_j| < f max(s0_i, s0_j) that the
 * kind admits: every j for the neighbour lists, the j whose cells can make a gap for i
 * (psys_gap_pair) for the gap lists, which only the particles the gap applies to hold
 * (psys_gap_active). The relation depends on (x0, s0) of the two particles only, and is
 * symmetric, so a list made again for i changes the lists of the others only where i enters or
 * leaves them, and the lists hold the same sets whatever the order in which they were made.
 *
 * Budget. A list stays while its particle lies within move s0_i of x0_i and its sigma below
 * (1 + grow) s0_i; psys_nbr_update makes again the others, and those of the particles added since.
 * With D_i = |x_i - x0_i| < move s0_i and sigma < (1 + grow) s0 for both particles of a pair,
 * and a use that needs the pairs with |y - x_j| < q max(sigma_i, sigma_j) around a point y within
 * a max(sigma_i, sigma_j) of x_i:
 *     |x0_i - x0_j| <= |y - x_j| + |y - x_i| + D_i + D_j < ((q + a)(1 + grow) + 2 move) max(s0),
 * so f = (q + a)(1 + grow) + 2 move covers it. The uses of the neighbour lists (q + a): the
 * energy at a trial point (1 + step_max: the point moves at most step_max sigma_i, a pair
 * interacts within sigma_ij), the colours of the sweep (the same), the Lipschitz pairs
 * (sigma_grow: psys_sizing.c), a split's probes (1 + beta: the child is placed at beta sigma_i,
 * papers/001 eq. 6), the particles around a split or delete (1) and the boundary distance of a
 * step (1 + step_max). The gap of i looks at the j within R_i = (sigma_grow / s_tau) sigma_i of
 * x_i. A relative margin of 1e-9 absorbs rounding.
 *
 * No use depends on how far a list reaches: each filters its candidates with the current points
 * and sigma (the energy takes the pairs with |x - x_j| < sigma_ij, the gap the j within R_i, and
 * so on). A run therefore gives the same particles, to the bit, whatever the budgets, and
 * whether lists are made again one by one or all at once.
 *
 * Cost. A list is made by one query of a grid that holds (x0_j, f s0_j) for every listed particle
 * (pm_grid, MUTUAL); the grid moves only when a list is made again. When more than BULK of the
 * lists are due (the first iterations of a phase) every list is made at once, each from its own
 * query, in parallel; otherwise the due lists are made in parallel, and the lists of the others
 * are mended in parallel where the difference between a due particle's old and new list says
 * that it left or entered them.
 *
 * Not done: shorter lists for the energy loops of phase 3's held tail (each particle's j within
 * 1.25 max(sigma_i, sigma_j) of a snapshot, 17 of its 41 neighbours on wrench.stp, kept while
 * no particle moved 0.05 sigma from its snapshot and the same sums to the bit): the energy step
 * of wrench.stp on two threads went from 6.9 / 6.0 s to 6.2 / 5.5 s in alternating runs and phase
 * 3 as a whole not at all, the lists' upkeep taking what the loops gave back: the loop's time is
 * in the pairs within reach, not in the candidates it skips.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "common/base/clock.h"
#include "psys/psys_private.h"

/* Budgets (see the file comment). The neighbour lists are read by every loop over a particle's
 * neighbours, so they are kept short and made again often; the gap lists reach twice as far and
 * are read by the sizing step only, so they are given a wider budget and made again rarely. */
#define NB_MOVE 0.1    /* a neighbour list is made again once its particle moved 0.1 s0 */
#define NB_GROW 0.1    /* ... or its sigma rose above 1.1 s0 */
#define GP_MOVE 0.3    /* the same for gap lists */
#define GP_GROW 0.2
#define SHRINK 0.5     /* ... or its sigma fell below this share of s0 (the list is too long) */
/* Above this share of lists to renew, every list is made again. A list renewed costs its query,
 * the difference with its old list and the mending of the lists that difference names, about
 * twice a list made in a rebuild: the break-even is near one half. (At 0.125, screw.step with one
 * thread, callgrind: 681M instructions in psys_nbr_update, 2219M in psys_run_phase; at 0.5, 605M
 * and 2144M, the same mesh to the byte: the lists change costs only.) */
#define BULK 0.5
#define MARGIN (1 + 1e-9)

enum { KIND_NB = 0, KIND_GP = 1 };

/* ---- lists --------------------------------------------------------------------------------- */

static int list_reserve(psys_list *l, int32_t cap) {
  if (cap <= l->cap) return 0;
  int32_t c = l->cap ? 2 * l->cap : 16;
  if (c < cap) c = cap;
  int32_t *ids = realloc(l->ids, sizeof(int32_t) * (size_t)c);
  if (!ids) return -1;
  l->ids = ids, l->cap = c;
  return 0;
}

static void list_free(psys_list *l) {
  free(l->ids);
  l->ids = NULL, l->n = l->cap = 0;
}

/* ---- relations ------------------------------------------------------------------------------ */

int psys_gap_active(const psys_sys *s, int32_t i) {
  if (s->size || s->frozen[i]) return 0;
  return s->dim[i] <= PM_CURVE ? s->gap_curves : s->gap_faces;
}

int psys_gap_pair(const psys_sys *s, int32_t i, int32_t j) {
  const int32_t ki = psys_key(s, s->dim[i], s->cell[i]), kj = psys_key(s, s->dim[j], s->cell[j]);
  if (ki == kj) return 0;
  if (s->dim[i] <= PM_CURVE) return !psys_adjacent(s, ki, kj); /* curves and vertices */
  /* a face particle: its own boundary (the width through the face), or a cell that shares no
   * vertex with the face */
  if (s->dim[j] < PM_FACE && psys_in_closure(s, ki, kj)) return 1;
  return !psys_touch(s, ki, kj);
}

static psys_vl *vl_of(psys_sys *s, int kind) { return kind == KIND_NB ? &s->nbr.nb : &s->nbr.gp; }

/* Whether particle i holds a list of this kind. */
static int holds(const psys_sys *s, int kind, int32_t i) {
  return kind == KIND_NB || psys_gap_active(s, i);
}

/* Whether j belongs in the list of i (a holder). */
static int admits(const psys_sys *s, const psys_vl *V, int kind, int32_t i, int32_t j) {
  const double m = V->f * (V->s0[i] > V->s0[j] ? V->s0[i] : V->s0[j]);
  return psys_d2(&V->x0[3 * i], &V->x0[3 * j]) < m * m && (kind == KIND_NB || psys_gap_pair(s, i, j));
}

/* The list radii and budgets of the current phase (see the file comment). */
double psys_nbr_reach(const psys_params *p) {
  return fmax(fmax(1 + p->step_max, p->sigma_grow), 1 + PSYS_BETA);
}

/* While sigma is held (psys_nbr_hold) it does not grow, so the neighbour lists need no budget
 * for it: f = q + 2 move instead of q (1 + grow) + 2 move, 1.78 instead of 1.94 sigma, and the
 * lists a sixth shorter ((1.78 / 1.94)^2 of the area). Every loop over a particle's list reads
 * its neighbours' points, which is most of the energy's time (perf, table.brep: the load of the
 * neighbour's point takes a third of psys_energy_at's samples), and most of phase 3 runs held
 * (box_sides.step: the last 200 of its 232 iterations). */
static void set_radii(psys_sys *s) {
  const psys_params *p = &s->p;
  psys_vl *nb = &s->nbr.nb, *gp = &s->nbr.gp;
  const double q = psys_nbr_reach(p), grow = s->nbr.held ? 0 : NB_GROW;
  nb->move = NB_MOVE, nb->grow = grow, nb->on = 1;
  nb->f = (q * (1 + grow) + 2 * NB_MOVE) * MARGIN;
  gp->move = GP_MOVE, gp->grow = GP_GROW;
  gp->on = !s->nbr.held && !s->size && (s->gap_curves || s->gap_faces);
  gp->f = (p->sigma_grow / p->s_tau * (1 + GP_GROW) + 2 * GP_MOVE) * MARGIN;
}

/* ---- life cycle ----------------------------------------------------------------------------- */

pm_status psys_nbr_init(psys_sys *s, pm_error *err) {
  memset(&s->nbr, 0, sizeof s->nbr);
  s->nbr.rebuild = 1;
  /* the grids' smallest distinguished radius: a hundredth of the smallest sigma expected */
  double hmin = s->size ? 1e-6 * s->model->diagonal : 1e-2 * s->sigma_min;
  pm_status st = pm_grid_create(hmin, &s->nbr.nb.grid, err);
  if (!st) st = pm_grid_create(hmin, &s->nbr.gp.grid, err);
  return st;
}

static void vl_free(psys_vl *V, int32_t cap) {
  if (V->l)
    for (int32_t i = 0; i < cap; ++i) list_free(&V->l[i]);
  free(V->x0), free(V->s0), free(V->l), free(V->mark);
  pm_grid_destroy(V->grid);
  memset(V, 0, sizeof *V);
}

void psys_nbr_free(psys_sys *s) {
  vl_free(&s->nbr.nb, s->cap);
  vl_free(&s->nbr.gp, s->cap);
}

static pm_status vl_reserve(psys_vl *V, int32_t old, int32_t cap, pm_error *err) {
  double *x0 = realloc(V->x0, sizeof(double) * 3 * (size_t)cap);
  if (x0) V->x0 = x0;
  double *s0 = realloc(V->s0, sizeof(double) * (size_t)cap);
  if (s0) V->s0 = s0;
  psys_list *l = realloc(V->l, sizeof(psys_list) * (size_t)cap);
  if (l) V->l = l;
  uint8_t *mark = realloc(V->mark, (size_t)cap);
  if (mark) V->mark = mark;
  if (!x0 || !s0 || !l || !mark)
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory for the neighbour lists");
  memset(V->l + old, 0, sizeof(psys_list) * (size_t)(cap - old));
  memset(V->mark + old, 0, (size_t)(cap - old));
  return pm_grid_reserve(V->grid, cap - 1, err);
}

pm_status psys_nbr_reserve(psys_sys *s, int32_t cap, pm_error *err) {
  pm_status st = vl_reserve(&s->nbr.nb, s->cap, cap, err);
  if (!st) st = vl_reserve(&s->nbr.gp, s->cap, cap, err);
  return st;
}

void psys_nbr_reset(psys_sys *s) { s->nbr.rebuild = 1, s->nbr.held = 0; }

void psys_nbr_hold(psys_sys *s) {
  if (!s->nbr.held && !s->nbr.never_hold) s->nbr.held = 1, s->nbr.rebuild = 1;
}

/* ---- making lists ---------------------------------------------------------------------------- */

/* A visit of the grid that keeps the candidates of a gap list: most particles around a face
 * particle lie on its own face, which makes no gap, so they are dropped before anything else. */
typedef struct gvisit {
  const psys_sys *s;
  const psys_vl *V;
  int32_t i, ki;
  int32_t last_k; /* the cell of the last candidate that reached the relation, and ... */
  int last_gap;   /* ... whether it makes a gap for i: the grid hands out the particles of one
                     cell together, and the relation of two cells costs a merge of their vertex
                     lists (psys_touch: 4% of box_sides.step on two threads, perf) */
  psys_list *l;
  int oom;
} gvisit;

static int gap_candidate(int32_t j, double d2, void *user) {
  (void)d2;
  gvisit *g = user;
  const psys_sys *s = g->s;
  const int32_t kj = psys_key(s, s->dim[j], s->cell[j]);
  if (j == g->i || kj == g->ki) return 0;
  const psys_vl *V = g->V;
  const double m = V->f * (V->s0[g->i] > V->s0[j] ? V->s0[g->i] : V->s0[j]);
  if (!(psys_d2(&V->x0[3 * g->i], &V->x0[3 * j]) < m * m)) return 0; /* admits(), in two parts */
  if (kj != g->last_k) g->last_k = kj, g->last_gap = psys_gap_pair(s, g->i, j);
  if (!g->last_gap) return 0;
  if (list_reserve(g->l, g->l->n + 1)) {
    g->oom = 1;
    return 1;
  }
  g->l->ids[g->l->n++] = j;
  return 0;
}

/* The list of holder i, made from a query around x0_i (q: scratch). */
static int make_list(const psys_sys *s, const psys_vl *V, int kind, int32_t i, pm_idbuf *q,
                     psys_list *l) {
  const double r = V->f * V->s0[i];
  l->n = 0;
  if (kind == KIND_GP) {
    gvisit g = {s, V, i, psys_key(s, s->dim[i], s->cell[i]), -1, 0, l, 0};
    pm_grid_visit(V->grid, &V->x0[3 * i], r, PM_GRID_MUTUAL, gap_candidate, &g);
    if (g.oom) return -1;
    pm_sort_ids(l->ids, l->n); /* a gap list holds a few hundred */
    return 0;
  }
  if (pm_grid_query_mutual(V->grid, &V->x0[3 * i], r, q, NULL)) return -1;
  if (list_reserve(l, q->n)) return -1;
  for (int32_t k = 0; k < q->n; ++k) {
    const int32_t j = q->ids[k];
    if (j != i && admits(s, V, kind, i, j)) l->ids[l->n++] = j;
  }
  return 0;
}

static pm_status rebuild_all(psys_sys *s, int kind, pm_error *err) {
  psys_vl *V = vl_of(s, kind);
  const int32_t n = s->n;
  pm_grid_clear(V->grid);
  for (int32_t i = 0; i < n; ++i) {
    memcpy(&V->x0[3 * i], &s->xyz[3 * i], 3 * sizeof(double));
    V->s0[i] = s->sigma[i];
    pm_status st = pm_grid_insert(V->grid, i, &V->x0[3 * i], V->f * V->s0[i], err);
    if (st) return st;
  }
  int fail = 0;
#pragma omp parallel num_threads(s->threads) if (n > 512)
  {
    pm_idbuf q = PM_IDBUF_INIT;
#pragma omp for schedule(dynamic, 64)
    for (int32_t i = 0; i < n; ++i) {
      if (!holds(s, kind, i)) {
        list_free(&V->l[i]);
        continue;
      }
      if (make_list(s, V, kind, i, &q, &V->l[i])) {
#pragma omp atomic write
        fail = 1;
      }
    }
    pm_idbuf_free(&q);
  }
  if (fail) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory for the neighbour lists");
  V->n = n;
  V->rebuilds++;
  return PM_OK;
}

/* What a renewed list changes for the others: the holders (outside S) it dropped and gained. */
typedef struct delta {
  psys_list rem, add;
} delta;

/* rem := old \ new, add := new \ old, both restricted to the holders outside S. */
static int diff(const psys_sys *s, const psys_vl *V, int kind, const psys_list *old,
                const psys_list *neu, delta *d) {
  d->rem.n = d->add.n = 0;
  if (list_reserve(&d->rem, old->n) || list_reserve(&d->add, neu->n)) return -1;
  int32_t a = 0, b = 0;
  while (a < old->n || b < neu->n) {
    const int32_t x = a < old->n ? old->ids[a] : INT32_MAX;
    const int32_t y = b < neu->n ? neu->ids[b] : INT32_MAX;
    if (x == y) {
      ++a, ++b;
      continue;
    }
    const int32_t j = x < y ? x : y;
    const int keep = !V->mark[j] && holds(s, kind, j);
    if (x < y) {
      if (keep) d->rem.ids[d->rem.n++] = j;
      ++a;
    } else {
      if (keep) d->add.ids[d->add.n++] = j;
      ++b;
    }
  }
  return 0;
}

/* The changes of the members of S (ascending) as CSR per particle j: off[j] .. off[j + 1] in ids,
 * sorted (which = 0: drops, 1: gains). */
typedef struct csr {
  int32_t *off, *ids;
} csr;

static int to_csr(int32_t n, const int32_t *S, int32_t ns, const delta *D, int which, csr *C) {
  C->off = calloc((size_t)n + 2, sizeof(int32_t));
  if (!C->off) return -1;
  int64_t total = 0;
  for (int32_t k = 0; k < ns; ++k) {
    const psys_list *l = which ? &D[k].add : &D[k].rem;
    for (int32_t q = 0; q < l->n; ++q) C->off[l->ids[q] + 2]++, total++;
  }
  for (int32_t j = 0; j < n; ++j) C->off[j + 2] += C->off[j + 1];
  C->ids = malloc(sizeof(int32_t) * (size_t)(total + 1));
  if (!C->ids) return -1;
  for (int32_t k = 0; k < ns; ++k) {
    const psys_list *l = which ? &D[k].add : &D[k].rem;
    for (int32_t q = 0; q < l->n; ++q) C->ids[C->off[l->ids[q] + 1]++] = S[k];
  }
  return 0; /* now off[j] .. off[j + 1] is j's range */
}

/* l := (l minus rem[nr]) merged with add[na]; rem is a sorted subset of l, add sorted and
 * disjoint from it. */
static int mend(psys_list *l, const int32_t *rem, int32_t nr, const int32_t *add, int32_t na) {
  if (list_reserve(l, l->n - nr + na)) return -1;
  int32_t m = 0, r = 0;
  for (int32_t q = 0; q < l->n; ++q) {
    if (r < nr && l->ids[q] == rem[r]) {
      ++r;
      continue;
    }
    l->ids[m++] = l->ids[q];
  }
  /* merge from the back, in place */
  int32_t a = m - 1, b = na - 1, w = m + na - 1;
  while (b >= 0) {
    if (a >= 0 && l->ids[a] > add[b])
      l->ids[w--] = l->ids[a--];
    else
      l->ids[w--] = add[b--];
  }
  l->n = m + na;
  return 0;
}

/* Renew the lists of the members of S (V->mark set), and mend the others where a renewed list
 * dropped or gained them. The relation is symmetric between holders: j enters or leaves the
 * list of i exactly when i enters or leaves the list of j (for gap lists: between two curve or
 * vertex particles in phase 2, two face particles in phase 3). A member of S that holds no list
 * may be named in the lists of others without naming them; it cannot be mended from, and every
 * list is made again instead (it does not happen: the particles that hold no gap list are the
 * frozen ones, which never move). */
static pm_status renew(psys_sys *s, int kind, int32_t ns, pm_error *err) {
  psys_vl *V = vl_of(s, kind);
  const int32_t n = s->n, nlisted = V->n;
  uint8_t *mark = V->mark;
  int32_t *S = malloc(sizeof(int32_t) * (size_t)ns);
  psys_list *nl = calloc((size_t)ns, sizeof(psys_list));
  delta *D = calloc((size_t)ns, sizeof(delta));
  csr rc = {0}, ac = {0};
  pm_status st = PM_OK;
  int fail = 0;
  if (!S || !nl || !D) goto oom;
  for (int32_t i = 0, k = 0; i < n; ++i)
    if (mark[i]) S[k++] = i;
  for (int32_t k = 0; k < ns; ++k)
    if (!holds(s, kind, S[k])) {
      free(S), free(nl), free(D);
      memset(mark, 0, (size_t)n);
      return rebuild_all(s, kind, err);
    }
  for (int32_t k = 0; k < ns; ++k) {
    const int32_t i = S[k];
    memcpy(&V->x0[3 * i], &s->xyz[3 * i], 3 * sizeof(double));
    V->s0[i] = s->sigma[i];
    st = i < nlisted ? pm_grid_move(V->grid, i, &V->x0[3 * i], V->f * V->s0[i], err)
                     : pm_grid_insert(V->grid, i, &V->x0[3 * i], V->f * V->s0[i], err);
    if (st) goto out;
  }
#pragma omp parallel num_threads(s->threads) if (ns > 256)
  {
    pm_idbuf q = PM_IDBUF_INIT;
#pragma omp for schedule(dynamic, 32)
    for (int32_t k = 0; k < ns; ++k) {
      const int32_t i = S[k];
      if (make_list(s, V, kind, i, &q, &nl[k]) || diff(s, V, kind, &V->l[i], &nl[k], &D[k])) {
#pragma omp atomic write
        fail = 1;
      }
    }
    pm_idbuf_free(&q);
  }
  if (fail) goto oom;
  for (int32_t k = 0; k < ns; ++k) {
    list_free(&V->l[S[k]]);
    V->l[S[k]] = nl[k];
    memset(&nl[k], 0, sizeof(psys_list));
  }
  if (to_csr(n, S, ns, D, 0, &rc) || to_csr(n, S, ns, D, 1, &ac)) goto oom;
#pragma omp parallel for num_threads(s->threads) schedule(dynamic, 256) if (n > 4096)
  for (int32_t j = 0; j < n; ++j) {
    const int32_t nr = rc.off[j + 1] - rc.off[j], na = ac.off[j + 1] - ac.off[j];
    if ((nr || na) && mend(&V->l[j], rc.ids + rc.off[j], nr, ac.ids + ac.off[j], na)) {
#pragma omp atomic write
      fail = 1;
    }
  }
  if (fail) goto oom;
  V->n = n;
  V->renewed += ns;
  goto out;
oom:
  st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory for the neighbour lists");
out:
  for (int32_t k = 0; k < ns; ++k) {
    if (nl) list_free(&nl[k]);
    if (D) list_free(&D[k].rem), list_free(&D[k].add);
  }
  free(S), free(nl), free(D);
  free(rc.off), free(rc.ids), free(ac.off), free(ac.ids);
  memset(mark, 0, (size_t)n);
  return st;
}

static pm_status vl_update(psys_sys *s, int kind, pm_error *err) {
  psys_vl *V = vl_of(s, kind);
  const int32_t n = s->n;
  int32_t ns = 0;
  const double g = 1 + V->grow;
#pragma omp parallel for num_threads(s->threads) reduction(+ : ns) schedule(static) if (n > 4096)
  for (int32_t i = 0; i < n; ++i) {
    int due = i >= V->n;
    if (!due) {
      const double lim = V->move * V->s0[i], sg = s->sigma[i];
      due = !(psys_d2(&s->xyz[3 * i], &V->x0[3 * i]) < lim * lim) || !(sg <= g * V->s0[i]) ||
            sg < SHRINK * V->s0[i];
    }
    V->mark[i] = (uint8_t)due;
    ns += due;
  }
  if (!ns) return PM_OK;
  if (ns > BULK * n) {
    memset(V->mark, 0, (size_t)n);
    return rebuild_all(s, kind, err);
  }
  return renew(s, kind, ns, err);
}

static pm_status nbr_update(psys_sys *s, pm_error *err) {
  psys_nbr *N = &s->nbr;
  pm_status st = PM_OK;
  if (N->rebuild || N->always) {
    set_radii(s);
    st = rebuild_all(s, KIND_NB, err);
    if (!st && N->gp.on) st = rebuild_all(s, KIND_GP, err);
    if (!st && !N->gp.on) {
      for (int32_t i = 0; i < s->n; ++i) list_free(&N->gp.l[i]);
      pm_grid_clear(N->gp.grid);
      N->gp.n = 0;
    }
    if (!st) N->rebuild = 0;
    return st;
  }
  st = vl_update(s, KIND_NB, err);
  if (!st && N->gp.on) st = vl_update(s, KIND_GP, err);
  return st;
}

pm_status psys_nbr_update(psys_sys *s, pm_error *err) {
  const double t0 = pm_seconds();
  pm_status st = nbr_update(s, err);
  psys_clock_add(s, PSYS_T_NEIGHBOURS, pm_seconds() - t0);
  return st;
}

static pm_status vl_compact(psys_sys *s, psys_vl *V, const int32_t *map, int32_t n_old,
                            pm_error *err) {
  const int32_t nlisted = V->n;
  /* the entries, in place: the map keeps the order, so the lists stay sorted */
#pragma omp parallel for num_threads(s->threads) schedule(dynamic, 256) if (nlisted > 4096)
  for (int32_t i = 0; i < nlisted; ++i) {
    if (map[i] < 0) continue;
    psys_list *l = &V->l[i];
    int32_t m = 0;
    for (int32_t q = 0; q < l->n; ++q)
      if (map[l->ids[q]] >= 0) l->ids[m++] = map[l->ids[q]];
    l->n = m;
  }
  int32_t listed = 0;
  for (int32_t i = 0; i < n_old; ++i) {
    const int32_t to = map[i];
    if (to < 0) {
      list_free(&V->l[i]);
      if (i < nlisted) {
        pm_status st = pm_grid_remove(V->grid, i, err);
        if (st) return st;
      }
      continue;
    }
    if (i < nlisted) ++listed;
    if (to == i) continue;
    V->l[to] = V->l[i];
    memset(&V->l[i], 0, sizeof(psys_list));
    memcpy(&V->x0[3 * to], &V->x0[3 * i], 3 * sizeof(double));
    V->s0[to] = V->s0[i];
  }
  V->n = listed;
  return pm_grid_renumber(V->grid, n_old, map, err);
}

pm_status psys_nbr_compact(psys_sys *s, const int32_t *map, int32_t n_old, pm_error *err) {
  const double t0 = pm_seconds();
  pm_status st = vl_compact(s, &s->nbr.nb, map, n_old, err);
  if (!st) st = vl_compact(s, &s->nbr.gp, map, n_old, err);
  psys_clock_add(s, PSYS_T_NEIGHBOURS, pm_seconds() - t0);
  return st;
}

static pm_status vl_permute(psys_sys *s, psys_vl *V, int32_t lo, int32_t m, const int32_t *perm,
                            const int32_t *inv, pm_error *err) {
  const int32_t n = s->n;
  if (V->n != n) return PM_OK; /* not listed yet: made at the next update */
  psys_list *l = malloc(sizeof(psys_list) * (size_t)m);
  double *x0 = malloc(sizeof(double) * 3 * (size_t)m), *s0 = malloc(sizeof(double) * (size_t)m);
  if (!l || !x0 || !s0) {
    free(l), free(x0), free(s0);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory for the neighbour lists");
  }
  for (int32_t k = 0; k < m; ++k) {
    l[k] = V->l[perm[k]];
    memcpy(&x0[3 * k], &V->x0[3 * perm[k]], 3 * sizeof(double));
    s0[k] = V->s0[perm[k]];
  }
  memcpy(V->l + lo, l, sizeof(psys_list) * (size_t)m);
  memcpy(V->x0 + 3 * lo, x0, sizeof(double) * 3 * (size_t)m);
  memcpy(V->s0 + lo, s0, sizeof(double) * (size_t)m);
  free(l), free(x0), free(s0);
#pragma omp parallel for num_threads(s->threads) schedule(dynamic, 256) if (n > 4096)
  for (int32_t i = 0; i < n; ++i) {
    psys_list *li = &V->l[i];
    for (int32_t q = 0; q < li->n; ++q) li->ids[q] = inv[li->ids[q]];
    pm_sort_ids(li->ids, li->n);
  }
  return pm_grid_renumber(V->grid, n, inv, err);
}

pm_status psys_nbr_permute(psys_sys *s, int32_t lo, int32_t m, const int32_t *perm,
                           pm_error *err) {
  const double t0 = pm_seconds();
  const int32_t n = s->n;
  int32_t *inv = malloc(sizeof(int32_t) * ((size_t)n + 1));
  if (!inv) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory for the neighbour lists");
  for (int32_t i = 0; i < n; ++i) inv[i] = i;
  for (int32_t k = 0; k < m; ++k) inv[perm[k]] = lo + k;
  pm_status st = vl_permute(s, &s->nbr.nb, lo, m, perm, inv, err);
  if (!st && s->nbr.gp.on) st = vl_permute(s, &s->nbr.gp, lo, m, perm, inv, err);
  free(inv);
  psys_clock_add(s, PSYS_T_NEIGHBOURS, pm_seconds() - t0);
  return st;
}

/* ---- checking ------------------------------------------------------------------------------- */

static pm_status vl_check(const psys_sys *s, const psys_vl *V, int kind, pm_error *err) {
  static const char *const names[2] = {"neighbour", "gap"};
  if (V->n != s->n)
    return pm_error_setf(err, PM_ERR_INTERNAL, "%s lists: %d of %d particles listed",
                         names[kind], (int)V->n, (int)s->n);
  for (int32_t i = 0; i < s->n; ++i) {
    const double lim = V->move * V->s0[i];
    if (!(psys_d2(&s->xyz[3 * i], &V->x0[3 * i]) < lim * lim) ||
        !(s->sigma[i] <= (1 + V->grow) * V->s0[i]))
      return pm_error_setf(err, PM_ERR_INTERNAL, "%s lists: particle %d out of budget",
                           names[kind], (int)i);
    const int h = holds(s, kind, i);
    const psys_list *l = &V->l[i];
    int32_t a = 0;
    for (int32_t j = 0; j < s->n; ++j) {
      if (j == i) continue;
      const int want = h && admits(s, V, kind, i, j), has = a < l->n && l->ids[a] == j;
      if (want != has)
        return pm_error_setf(err, PM_ERR_INTERNAL, "%s lists: pair (%d, %d) %s the list of %d",
                             names[kind], (int)i, (int)j, has ? "wrongly in" : "missing from",
                             (int)i);
      a += has;
    }
    if (a != l->n)
      return pm_error_setf(err, PM_ERR_INTERNAL, "%s lists: list of %d not sorted", names[kind],
                           (int)i);
  }
  return PM_OK;
}

pm_status psys_nbr_check(const psys_sys *s, pm_error *err) {
  if (s->nbr.rebuild)
    return pm_error_setf(err, PM_ERR_INTERNAL, "neighbour lists: rebuild pending");
  pm_status st = vl_check(s, &s->nbr.nb, KIND_NB, err);
  if (!st && s->nbr.gp.on) st = vl_check(s, &s->nbr.gp, KIND_GP, err);
  return st;
}
