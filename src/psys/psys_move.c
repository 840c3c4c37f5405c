/* Algorithm 1 of papers/001 (position update): every movable particle takes one step down its
 * energy E_i, in the parameter space of its cell.
 *
 * For particle i: E_i, its gradient and Hessian from the neighbours (eq. 1-2); the world-space
 * velocity v_i = -dE_i/dx_i (eq. 8 with the sign that repels: dE/dr < 0 inside the ball); the
 * step dx = lambda_i n_i, n_i the Newton step of E_i in the tangent line or plane of the cell
 * (below); its parameter displacement M^-1 J dx (eq. 7, 9) and the move (eq. 10), both through
 * the shared pm_cell_param_delta / pm_cell_move (a step leaving the trimmed region stops just
 * inside it; curves clip at their ends; vertices do not move); the new point and E_i there. If
 * E_i did not decrease, lambda_i is divided by 10 and the step retried, until lambda_i <=
 * lambda_min, when the particle stays (Algorithm 1, lines 9-13).
 *
 * Choices where the paper is silent:
 *   - the "Newton-Raphson scheme" of section 3: v_i is a sum of dimensionless eq. 2
 *     derivatives, so it needs a length scale. We take the Newton step of E_i restricted to the
 *     cell's tangent space at x_i: n_i = H_t^-1 v_t, with H_t the Hessian of E_i (pairs:
 *     E'' u u^T + E'/r (I - u u^T)) and v_t the velocity in an orthonormal tangent basis. Where
 *     H_t is not positive definite (a particle pulled apart by sparse neighbours), n_i = v_t / k_i
 *     with k_i = sum_j d2E_ij/dr2 > 0 (the kernel is convex), which is the Newton step for a
 *     single neighbour. Without a Newton scale the energy test cannot stop a particle from
 *     overshooting: E_ij falls monotonically with r, so a step away from one neighbour is
 *     always accepted, however long;
 *   - lambda_i starts and is capped at 1 (a full Newton step);
 *   - growth: after an accepted step lambda_i is multiplied by lambda_grow (2), capped at
 *     lambda_max, so a particle that once met a steep neighbourhood is not slowed forever;
 *   - steps are capped at step_max sigma_i;
 *   - a face particle's step is also refused when it ends within 0.15 sigma_i of the face's
 *     boundary polyline (the frozen curve and vertex particles, psys_sizing.c) and closer to it
 *     than before: the curve particles repel face particles (section 4.3), but between two of
 *     them a face particle can settle on the curve itself, in line with them, and the
 *     connection then makes a needle triangle of the three;
 *   - order: Algorithm 1 updates the particles one after the other, each seeing the others'
 *     latest positions (Gauss-Seidel). Done literally, the result depends on how particles are
 *     shared between threads. We colour the movable particles greedily in index order so that no
 *     two particles of one colour are in each other's neighbour list, and sweep the colours in
 *     order: within a colour the particles step in parallel and independently (none sees
 *     another's move), every colour sees the moves of the colours before it. This is a
 *     Gauss-Seidel sweep in colour order, identical for any thread count. (Simultaneous steps,
 *     Jacobi, were tried first: they need lambda <= 0.5 against the zigzag mode of a chain,
 *     where two neighbours stepping towards each other double the stiffness each sees alone,
 *     and converged about twice as slowly.) The neighbour lists are gathered once per sweep with
 *     radius (1 + step_max) sigma_i, so that the energy at a trial point sees the particles it
 *     may reach.
 *
 * Evaluation: the trial points of all pending particles are evaluated together per round, in
 * parallel for closed-form cells and batched per face (pm_face_eval_many) for faces evaluated
 * by gmsh, whose calls are serialized.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "common/clock.h"
#include "common/vec3.h"
#include "psys/psys_private.h"

#define BLOCK 4096

enum { ST_DONE = 0, ST_PENDING = 1 };

typedef struct block {
  int32_t idx[BLOCK];    /* the particle in each slot */
  double e0[BLOCK], en[BLOCK], lam[BLOCK];
  double dir[3 * BLOCK]; /* the Newton step n_i (lambda = 1) */
  double bd[BLOCK];      /* boundary distance at the trial point (face particles, phase 3) */
  double tp[2 * BLOCK], tx[3 * BLOCK], td[6 * BLOCK];
  uint8_t st[BLOCK], acc[BLOCK], ready[BLOCK];
  int32_t order[BLOCK];
  double uv[2 * BLOCK];
  pm_face_point fp[BLOCK];
} block;

/* Sort (cell, slot) pairs packed in 64 bits. */
static int cmp_u64(const void *a, const void *b) {
  uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
  return (x > y) - (x < y);
}

/* v^T H w for the packed symmetric H (xx, xy, xz, yy, yz, zz). */
static double hform(const double h[7], const double v[3], const double w[3]) {
  return v[0] * (h[0] * w[0] + h[1] * w[1] + h[2] * w[2]) +
         v[1] * (h[1] * w[0] + h[3] * w[1] + h[4] * w[2]) +
         v[2] * (h[2] * w[0] + h[4] * w[1] + h[5] * w[2]);
}

/* The Newton step n (lambda = 1) of particle i in its cell's tangent space from the velocity v
 * and the Hessian h; 0 when there is nothing to do. */
static int newton_step(const psys_sys *s, int32_t i, const double v[3], const double h[7],
                       double n[3]) {
  const double *d = &s->deriv[6 * i];
  double e1[3], e2[3] = {0, 0, 0}, nrm[3];
  int dims = 0;
  pm_v3_copy(e1, d);
  if (s->dim[i] == PM_CURVE) {
    if (pm_v3_normalize(e1) > 0) dims = 1;
  } else {
    pm_v3_cross(nrm, d, d + 3);
    if (pm_v3_normalize(nrm) > 0 && pm_v3_normalize(e1) > 0) {
      pm_v3_cross(e2, nrm, e1);
      dims = 2;
    }
  }
  const double k = h[6];
  if (!(k > 0)) return 0;
  if (dims == 0) {
    /* a singular chart (a pole): the plain scaled velocity, pm_cell_param_delta keeps what the
     * chart can express */
    pm_v3_scale(n, v, 1.0 / k);
    return pm_v3_dot(n, n) > 0;
  }
  double b1 = pm_v3_dot(e1, v), b2 = pm_v3_dot(e2, v);
  double a11 = hform(h, e1, e1);
  if (dims == 1) {
    double t = a11 > 0 ? b1 / a11 : b1 / k;
    pm_v3_scale(n, e1, t);
    return t != 0;
  }
  double a12 = hform(h, e1, e2), a22 = hform(h, e2, e2), det = a11 * a22 - a12 * a12;
  double t1, t2;
  if (a11 > 0 && det > 1e-12 * a11 * a22) {
    t1 = (a22 * b1 - a12 * b2) / det;
    t2 = (a11 * b2 - a12 * b1) / det;
  } else {
    t1 = b1 / k, t2 = b2 / k;
  }
  for (int c = 0; c < 3; ++c) n[c] = t1 * e1[c] + t2 * e2[c];
  return t1 != 0 || t2 != 0;
}

/* The trial point of pending particle i (slot k) at lam[k]; slow faces are left for the batch. */
static void trial(const psys_sys *s, block *B, int32_t k, int32_t i) {
  const pm_cell *c = pm_model_cell(s->model, s->dim[i], s->cell[i]);
  double dx[3];
  pm_v3_scale(dx, &B->dir[3 * k], B->lam[k]);
  double len = pm_v3_norm(dx), cap = s->p.step_max * s->sigma[i];
  if (len > cap) pm_v3_scale(dx, dx, cap / len);
  double dpar[2] = {0, 0}, *tp = &B->tp[2 * k];
  const double *par = &s->par[2 * i];
  pm_cell_param_delta(c, par, &s->deriv[6 * i], dx, dpar); /* eq. 7, 9 */
  pm_cell_move(c, par, dpar, tp);                          /* eq. 10, shared clip rule */
  B->ready[k] = 0;
  if (tp[0] == par[0] && (c->dim == PM_CURVE || tp[1] == par[1])) {
    B->st[k] = ST_DONE; /* clipped to where it stands: nothing to try */
    return;
  }
  double *tx = &B->tx[3 * k], *td = &B->td[6 * k];
  if (c->dim == PM_CURVE) {
    pm_curve_point cp;
    pm_curve_eval(c, tp[0], 1, &cp);
    pm_v3_copy(tx, cp.p), pm_v3_copy(td, cp.d1);
    memset(td + 3, 0, 3 * sizeof(double));
    B->ready[k] = 1;
  } else if (!s->slow_face[c->index]) {
    pm_face_point fp;
    pm_face_eval(c, tp, 1, &fp);
    pm_v3_copy(tx, fp.p), pm_v3_copy(td, fp.su), pm_v3_copy(td + 3, fp.sv);
    B->ready[k] = 1;
  }
}

/* Evaluate the trial points left for the batch, face by face. */
static void batch_eval(const psys_sys *s, block *B, int32_t m) {
  uint64_t keys[BLOCK];
  int32_t nk = 0;
  for (int32_t k = 0; k < m; ++k)
    if (B->st[k] == ST_PENDING && !B->ready[k])
      keys[nk++] = ((uint64_t)(uint32_t)s->cell[B->idx[k]] << 32) | (uint32_t)k;
  if (!nk) return;
  qsort(keys, (size_t)nk, sizeof(uint64_t), cmp_u64);
  for (int32_t a = 0; a < nk;) {
    int32_t f = (int32_t)(keys[a] >> 32), e = a;
    while (e < nk && (int32_t)(keys[e] >> 32) == f) {
      int32_t k = (int32_t)(keys[e] & 0xffffffffu);
      B->uv[2 * (e - a)] = B->tp[2 * k], B->uv[2 * (e - a) + 1] = B->tp[2 * k + 1];
      ++e;
    }
    pm_face_eval_many(pm_model_cell(s->model, PM_FACE, f), e - a, B->uv, 1, B->fp);
    for (int32_t q = a; q < e; ++q) {
      int32_t k = (int32_t)(keys[q] & 0xffffffffu);
      const pm_face_point *fp = &B->fp[q - a];
      pm_v3_copy(&B->tx[3 * k], fp->p), pm_v3_copy(&B->td[6 * k], fp->su);
      pm_v3_copy(&B->td[6 * k + 3], fp->sv);
      B->ready[k] = 1;
    }
    a = e;
  }
}

/* Neighbour lists of every particle, as CSR: the ids of particle i are ids[off[i] .. off[i+1]). */
typedef struct nblist {
  int64_t *off;
  int32_t *ids;
} nblist;

static void nblist_free(nblist *L) {
  free(L->off), free(L->ids);
  L->off = NULL, L->ids = NULL;
}

/* The search radius around particle i: its ball, widened by the longest step it may take. */
static double search_radius(const psys_sys *s, int32_t i) {
  return s->fixed[i] ? s->sigma[i] : (1 + s->p.step_max) * s->sigma[i];
}

static pm_status nblist_build(const psys_sys *s, nblist *L, pm_error *err) {
  const int32_t n = s->n;
  const int nthr = s->threads;
  L->off = calloc((size_t)n + 1, sizeof(int64_t));
  int32_t *tstart = malloc(sizeof(int32_t) * ((size_t)n + 1)); /* offset in its thread's buffer */
  int8_t *towner = malloc((size_t)n + 1);
  pm_idbuf *tb = calloc((size_t)nthr, sizeof(pm_idbuf));
  int fail = 0;
  if (!L->off || !tstart || !towner || !tb) fail = 1;
  if (!fail) {
#pragma omp parallel num_threads(nthr) if (n > 512)
    {
#ifdef _OPENMP
      int t = omp_get_thread_num();
#else
      int t = 0;
#endif
      pm_idbuf q = PM_IDBUF_INIT;
#pragma omp for schedule(dynamic, 64)
      for (int32_t i = 0; i < n; ++i) {
        if (fail) continue;
        if (pm_grid_query_mutual(s->grid, &s->xyz[3 * i], search_radius(s, i), &q, NULL) ||
            pm_idbuf_reserve(&tb[t], tb[t].n + q.n, NULL)) {
#pragma omp atomic write
          fail = 1;
          continue;
        }
        tstart[i] = tb[t].n, towner[i] = (int8_t)t;
        memcpy(tb[t].ids + tb[t].n, q.ids, sizeof(int32_t) * (size_t)q.n);
        tb[t].n += q.n;
        L->off[i + 1] = q.n;
      }
      pm_idbuf_free(&q);
    }
  }
  if (!fail) {
    for (int32_t i = 0; i < n; ++i) L->off[i + 1] += L->off[i];
    L->ids = malloc(sizeof(int32_t) * (size_t)(L->off[n] + 1));
    if (!L->ids) fail = 1;
  }
  if (!fail)
    for (int32_t i = 0; i < n; ++i)
      memcpy(L->ids + L->off[i], tb[towner[i]].ids + tstart[i],
             sizeof(int32_t) * (size_t)(L->off[i + 1] - L->off[i]));
  if (tb)
    for (int t = 0; t < nthr; ++t) pm_idbuf_free(&tb[t]);
  free(tb), free(tstart), free(towner);
  if (fail) {
    nblist_free(L);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  return PM_OK;
}

/* Greedy colouring of the movable particles in index order: two movable particles get different
 * colours when either lies in the other's list. Returns the number of colours (or -1 when out
 * of memory); colour[i] = -1 for fixed particles. */
static int32_t colour_particles(const psys_sys *s, const nblist *L, int32_t *colour) {
  const int32_t n = s->n;
  /* the transpose: who lists i */
  int64_t *roff = calloc((size_t)n + 1, sizeof(int64_t));
  int32_t *rids = malloc(sizeof(int32_t) * (size_t)(L->off[n] + 1));
  int32_t *stamp = NULL;
  int32_t ncol = 0, cap = 64;
  if (!roff || !rids) goto oom;
  for (int32_t i = 0; i < n; ++i)
    for (int64_t q = L->off[i]; q < L->off[i + 1]; ++q) roff[L->ids[q] + 1]++;
  for (int32_t i = 0; i < n; ++i) roff[i + 1] += roff[i];
  {
    int64_t *fill = malloc(sizeof(int64_t) * ((size_t)n + 1));
    if (!fill) goto oom;
    memcpy(fill, roff, sizeof(int64_t) * ((size_t)n + 1));
    for (int32_t i = 0; i < n; ++i)
      for (int64_t q = L->off[i]; q < L->off[i + 1]; ++q) rids[fill[L->ids[q]]++] = i;
    free(fill);
  }
  stamp = malloc(sizeof(int32_t) * (size_t)cap);
  if (!stamp) goto oom;
  for (int32_t c = 0; c < cap; ++c) stamp[c] = -1;
  for (int32_t i = 0; i < n; ++i) {
    colour[i] = -1;
    if (s->fixed[i]) continue;
    for (int64_t q = L->off[i]; q < L->off[i + 1]; ++q) {
      int32_t c = L->ids[q] < i ? colour[L->ids[q]] : -1;
      if (c >= 0) stamp[c] = i;
    }
    for (int64_t q = roff[i]; q < roff[i + 1]; ++q) {
      int32_t c = rids[q] < i ? colour[rids[q]] : -1;
      if (c >= 0) stamp[c] = i;
    }
    int32_t c = 0;
    while (c < cap && stamp[c] == i) ++c;
    if (c == cap) {
      int32_t *ns = realloc(stamp, sizeof(int32_t) * 2 * (size_t)cap);
      if (!ns) goto oom;
      stamp = ns;
      for (int32_t k = cap; k < 2 * cap; ++k) stamp[k] = -1;
      cap *= 2;
    }
    colour[i] = c;
    if (c + 1 > ncol) ncol = c + 1;
  }
  free(roff), free(rids), free(stamp);
  return ncol;
oom:
  free(roff), free(rids), free(stamp);
  return -1;
}

/* Algorithm 1 for the m particles in B->idx against the current positions; the accepted steps
 * are written to the system at once (the particles of one colour never see each other). */
static pm_status step_block(psys_sys *s, const nblist *L, block *B, int32_t m, double *moved,
                            pm_error *err) {
  double t0 = pm_seconds();
#pragma omp parallel for num_threads(s->threads) schedule(dynamic, 32) if (m > 256)
  for (int32_t k = 0; k < m; ++k) {
    const int32_t i = B->idx[k];
    const double *xi = &s->xyz[3 * i];
    const int32_t *ids = L->ids + L->off[i];
    const int32_t nn = (int32_t)(L->off[i + 1] - L->off[i]);
    double grad[3], hess[7];
    B->e0[k] = psys_particle_energy(s, i, xi, ids, nn, grad, hess);
    pm_v3_scale(&s->force[3 * i], grad, -1.0); /* eq. 8: the velocity that repels */
    B->lam[k] = s->lambda[i];
    B->acc[k] = 0;
    B->st[k] = ST_DONE;
    if (s->dim[i] == PM_FACE && s->chain_off)
      s->bdist[i] = psys_boundary_distance(s, i, xi, ids, nn);
    if (B->e0[k] > 0 && newton_step(s, i, &s->force[3 * i], hess, &B->dir[3 * k]))
      B->st[k] = ST_PENDING;
  }
  double t1 = pm_seconds();
  psys_clock_add(s, PSYS_T_ENERGY, t1 - t0);
  /* Algorithm 1's retries, all pending particles of the block per round. */
  for (int round = 0; round < 64; ++round) {
    int any = 0;
    for (int32_t k = 0; k < m && !any; ++k) any = B->st[k] == ST_PENDING;
    if (!any) break;
    t0 = pm_seconds();
#pragma omp parallel for num_threads(s->threads) schedule(dynamic, 32) if (m > 256)
    for (int32_t k = 0; k < m; ++k)
      if (B->st[k] == ST_PENDING) trial(s, B, k, B->idx[k]);
    batch_eval(s, B, m);
    t1 = pm_seconds();
    psys_clock_add(s, PSYS_T_SURFACE, t1 - t0);
#pragma omp parallel for num_threads(s->threads) schedule(dynamic, 32) if (m > 256)
    for (int32_t k = 0; k < m; ++k) {
      if (B->st[k] != ST_PENDING) continue;
      const int32_t i = B->idx[k];
      const int32_t *ids = L->ids + L->off[i];
      const int32_t nn = (int32_t)(L->off[i + 1] - L->off[i]);
      B->en[k] = psys_particle_energy(s, i, &B->tx[3 * k], ids, nn, NULL, NULL);
      int off_boundary = 1;
      if (s->dim[i] == PM_FACE && s->chain_off) {
        /* a face particle does not step onto its face's boundary (see the file comment) */
        B->bd[k] = psys_boundary_distance(s, i, &B->tx[3 * k], ids, nn);
        if (B->bd[k] < PSYS_BOUNDARY_CLEARANCE * s->sigma[i] && B->bd[k] < s->bdist[i])
          off_boundary = 0;
      }
      if (B->en[k] < B->e0[k] && off_boundary) {
        B->acc[k] = 1, B->st[k] = ST_DONE; /* Algorithm 1: accept */
      } else if (B->lam[k] <= s->p.lambda_min) {
        B->st[k] = ST_DONE; /* lines 10-11: skip */
      } else {
        B->lam[k] /= 10; /* line 13 */
      }
    }
    psys_clock_add(s, PSYS_T_STEP, pm_seconds() - t1);
  }
  t0 = pm_seconds();
  for (int32_t k = 0; k < m; ++k) {
    const int32_t i = B->idx[k];
    if (B->acc[k]) {
      moved[i] = pm_v3_dist(&B->tx[3 * k], &s->xyz[3 * i]);
      memcpy(&s->par[2 * i], &B->tp[2 * k], 2 * sizeof(double));
      memcpy(&s->xyz[3 * i], &B->tx[3 * k], 3 * sizeof(double));
      memcpy(&s->deriv[6 * i], &B->td[6 * k], 6 * sizeof(double));
      s->energy[i] = B->en[k];
      if (s->dim[i] == PM_FACE && s->chain_off) s->bdist[i] = B->bd[k];
      double l = B->lam[k] * s->p.lambda_grow;
      s->lambda[i] = l < s->p.lambda_max ? l : s->p.lambda_max;
      pm_status st = pm_grid_move(s->grid, i, &s->xyz[3 * i], s->sigma[i], err);
      if (st) return st;
    } else {
      s->energy[i] = B->e0[k];
      s->lambda[i] = B->lam[k];
    }
  }
  psys_clock_add(s, PSYS_T_NEIGHBOURS, pm_seconds() - t0);
  return PM_OK;
}

pm_status psys_move_pass(psys_sys *s, psys_move_info *info, pm_error *err) {
  const int32_t n = s->n;
  memset(info, 0, sizeof *info);
  nblist L = {0};
  int32_t *colour = malloc(sizeof(int32_t) * ((size_t)n + 1));
  double *moved = calloc((size_t)n + 1, sizeof(double));
  block *B = malloc(sizeof *B);
  pm_status st = PM_OK;
  if (!colour || !moved || !B) {
    st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto out;
  }
  double t0 = pm_seconds();
  if ((st = nblist_build(s, &L, err))) goto out;
  int32_t ncol = colour_particles(s, &L, colour);
  if (ncol < 0) {
    st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto out;
  }
  psys_clock_add(s, PSYS_T_NEIGHBOURS, pm_seconds() - t0);
  /* Colour by colour, in index order within a colour, blocks of BLOCK particles. */
  for (int32_t c = 0; c < ncol; ++c) {
    int32_t m = 0;
    for (int32_t i = 0; i <= n; ++i) {
      if (i < n && colour[i] == c) B->idx[m++] = i;
      if (m == BLOCK || (i == n && m > 0)) {
        if ((st = step_block(s, &L, B, m, moved, err))) goto out;
        m = 0;
      }
    }
  }
  /* The fixed particles' energies, for the trace and the population rules. */
  t0 = pm_seconds();
#pragma omp parallel for num_threads(s->threads) schedule(dynamic, 64) if (n > 512)
  for (int32_t i = 0; i < n; ++i) {
    if (!s->fixed[i]) continue;
    double grad[3];
    s->energy[i] = psys_particle_energy(s, i, &s->xyz[3 * i], L.ids + L.off[i],
                                        (int32_t)(L.off[i + 1] - L.off[i]), grad, NULL);
    pm_v3_scale(&s->force[3 * i], grad, -1.0);
  }
  psys_clock_add(s, PSYS_T_ENERGY, pm_seconds() - t0);
  double sum_move = 0, sum_rel = 0, sum_e = 0;
  for (int32_t i = 0; i < n; ++i) {
    sum_e += s->energy[i];
    if (s->fixed[i]) continue;
    info->movable++;
    sum_move += moved[i];
    sum_rel += moved[i] / s->sigma[i];
    if (moved[i] > info->max_move) info->max_move = moved[i];
  }
  info->energy = sum_e;
  info->colours = ncol;
  if (info->movable) {
    info->mean_move = sum_move / info->movable;
    info->mean_rel = sum_rel / info->movable;
  }
out:
  nblist_free(&L);
  free(B), free(colour), free(moved);
  return st;
}
