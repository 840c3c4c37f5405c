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
 *   - over-relaxation in phase 3 (lambda_max_faces = 1.8, the default; 0 with move_tol_faces =
 *     1e-3 gives full steps): the faces' particles step up to 1.8 times their Newton step. The sweep is a
 *     Gauss-Seidel sweep, and over-relaxing one (SOR) speeds up the long waves of the packing,
 *     which full steps relax slowly: the tail of phase 3, where the count is fixed and sigma held, is all long waves. A step of omega times the
 *     Newton step still lowers a quadratic energy for omega < 2, so Algorithm 1's test keeps
 *     accepting them. The mean move of such a sweep is omega times the Newton step, so phase 3's
 *     tolerance goes with it (move_tol_faces = 1.8e-3 ends where 1e-3 ended full steps). With
 *     one thread (`packmesh mesh MODEL --method psys --threads 1 --stats`), phase-3 iterations
 *     and median / p75 R / l_min, full steps at 1e-3 against 1.8 at 1.8e-3: wrench.stp 208 ->
 *     161, 0.6036 / 0.6323 -> 0.5986 / 0.6260; base_interface.step 125 -> 99, 0.5951 / 0.6136 ->
 *     0.5888 / 0.6002; table.brep 115 -> 107, 0.6039 / 0.6328 -> 0.5976 / 0.6272;
 *     t20_component8.step 445 -> 234, 0.6165 / 0.6473 -> 0.6139 / 0.6460. At 1.8 with the old
 *     tolerance the quality gain was the same and the iterations more (wrench.stp 247,
 *     base_interface.step 178). Phases 1-2 keep lambda_max = 1: the curves' chains at 1.8 did not
 *     settle (wrench.stp's phase 2 ran to max_iter). It first left unforced needles where full
 *     steps left none: 9.6 degrees on step__SampleCrankshaft4A.stp, which went with the curve
 *     gaps of psys_population.c and the repeated needle steps of face_smooth.c, and two flat
 *     triangles on box_sides.step (161 degrees at a face node 0.10 from a boundary segment 1.28
 *     long), which went with face_smooth.c's flat move; then the robust folder and the shared
 *     models give none (bench_robust, one thread per run) and it became the default;
 *   - steps are capped at step_max sigma_i, and a trial point that lands farther from the
 *     particle than the neighbour lists are sure to cover, (psys_nbr_reach - 1) sigma_i (0.577
 *     sigma_i with the defaults), is not tried: it counts as a rejected step, and lambda_i
 *     shrinks by 10 at least, and by the ratio of that cover to the distance. The cap applies to
 *     the step in the tangent line or plane; the cell's map can stretch it where the
 *     parametrization's speed changes along the step (bottle.brep's curve 3, whose |C'| is about
 *     0.6 at t = 0.048 and 4.9 beyond: a step of 0.5 sigma in the tangent went 0.36 = 3.9 sigma
 *     along the curve). There the lists, made for the particle's old neighbourhood, held none of
 *     the particles around the trial point, so its energy was 0 and the step was accepted; the
 *     particle landed 0.008 from another, counted as hungry (E_i = 0 at the pass) and split, and
 *     the next passes did the same to its children: 23 curve particles 0.005 apart at the end of
 *     phase 2 where sigma was 0.094, and the faces beside them had triangles of 7 to 10 degrees.
 *     On wrench.stp 2 of 9.5 million trial points lie beyond the cover;
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
 *     and converged about twice as slowly.) A colour's particles step against the points of
 *     the colours before them; within a colour, in chunks of up to CHUNK particles in index
 *     order, every particle sees the same points, so the chunking, like the thread count, does
 *     not change a result.
 *   - two movable particles conflict when |x_i - x_j| < (1 + step_max) max(sigma_i, sigma_j):
 *     one may reach the other's ball in its step. The colours are a greedy colouring of that
 *     relation in index order, over the neighbour lists (psys_nbr.c), made with a margin (the
 *     pairs up to q max(sigma_i, sigma_j) apart get different colours, q = psys_nbr_reach, the
 *     farthest the lists are sure to reach: 1 + beta = 1.577 with the defaults, 5% beyond the
 *     conflict distance, so that a colouring outlives small moves) and kept from pass to pass
 *     while it holds: each pass first checks that every movable particle and no fixed one has
 *     a colour and that no two of one colour conflict -- from each particle's move and sigma
 *     growth since the colouring when that settles it (psys_colouring_surely_holds), else pair
 *     by pair in parallel from the particles that moved enough to conflict -- and colours again
 *     only when that fails or the particle count changed. Made at every pass,
 *     the serial colouring took 8% of a two-thread run (wrench.stp, perf) while phase 3's tail
 *     moves its particles by about 1e-3 sigma per pass. Every colouring that holds gives a
 *     Gauss-Seidel sweep of the same kind; which one a pass uses depends on the run's history
 *     only, never on the thread count.
 *
 * Frames (ours). A step's parameter displacement needs the derivatives Su, Sv of the surface at
 * the particle (eq. 7, 9). Closed-form cells evaluate them with the point at no extra cost. A
 * face evaluated by gmsh costs one call for the point and another for the derivatives, under a
 * lock: there the trial points are evaluated without derivatives, and an accepted particle keeps
 * the derivatives it had (its "frame") until it has moved frame_tol sigma from where they were
 * evaluated. The trial point itself is always exact, so every particle stays on its surface and
 * every energy is exact; only the direction of the parameter step is the one of a point up to
 * frame_tol sigma away. frame_tol = 0 evaluates the derivatives at every trial point, as
 * papers/001 eq. 7-9 do.
 *
 * Evaluation: a particle on a closed-form cell runs Algorithm 1 to its end in one go, its trial
 * points evaluated as they come. Particles on gmsh faces take their trials in rounds: the trial
 * points of a round are evaluated together, batched per face (pm_face_eval_many), since gmsh's
 * calls are serialized.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "common/base/clock.h"
#include "common/base/vec3.h"
#include "psys/psys_private.h"

#define CHUNK 16384 /* particles of a colour stepped together */
#define NEAR_MAX 48 /* near candidates kept per particle for its trial points */

enum { ST_DONE = 0, ST_PENDING = 1, ST_EVAL = 2 };

/* The work of one chunk, slot k for its k-th particle. */
typedef struct chunk {
  int32_t cap;
  int32_t *idx;    /* the particle in each slot */
  double *e0, *en, *lam;
  double *dir;     /* [3] the Newton step n_i (lambda = 1) */
  double *bd;      /* boundary distance at the trial point (face particles, phase 3) */
  double *tp;      /* [2] trial parameters */
  double *tx;      /* [3] trial point */
  double *td;      /* [6] derivatives at the trial point (when evaluated with it) */
  uint8_t *st, *acc, *tframe; /* state; accepted; td holds the trial point's frame */
  double *reach;   /* the longest trial step of the slot's particle (see near) */
  int32_t *noff;   /* [cap + 1] the slot's near candidates: near[noff[k] .. noff[k] + nn[k]) */
  int32_t *nn;     /* how many; -1 when they did not fit (the whole list is used) */
  int32_t *near;   /* [NEAR_MAX cap] */
  double *moved;   /* displacement of an accepted step */
  /* scratch of a batched evaluation */
  uint64_t *keys;
  double *uv;
  pm_face_point *fp;
} chunk;

static void chunk_free(chunk *B) {
  free(B->idx), free(B->e0), free(B->en), free(B->lam), free(B->dir), free(B->bd), free(B->tp);
  free(B->tx), free(B->td), free(B->st), free(B->acc), free(B->tframe), free(B->moved);
  free(B->keys), free(B->uv), free(B->fp);
  free(B->reach), free(B->noff), free(B->nn), free(B->near);
  memset(B, 0, sizeof *B);
}

static int chunk_alloc(chunk *B, int32_t cap) {
  memset(B, 0, sizeof *B);
  B->cap = cap;
  const size_t c = (size_t)cap + 1;
  B->idx = malloc(sizeof(int32_t) * c);
  B->e0 = malloc(sizeof(double) * c), B->en = malloc(sizeof(double) * c);
  B->lam = malloc(sizeof(double) * c), B->dir = malloc(sizeof(double) * 3 * c);
  B->bd = malloc(sizeof(double) * c), B->tp = malloc(sizeof(double) * 2 * c);
  B->tx = malloc(sizeof(double) * 3 * c), B->td = malloc(sizeof(double) * 6 * c);
  B->st = malloc(c), B->acc = malloc(c), B->tframe = malloc(c);
  B->moved = malloc(sizeof(double) * c);
  B->keys = malloc(sizeof(uint64_t) * c), B->uv = malloc(sizeof(double) * 2 * c);
  B->fp = malloc(sizeof(pm_face_point) * c);
  B->reach = malloc(sizeof(double) * c), B->nn = malloc(sizeof(int32_t) * c);
  B->noff = malloc(sizeof(int32_t) * c), B->near = malloc(sizeof(int32_t) * NEAR_MAX * c);
  if (!B->reach || !B->nn || !B->noff || !B->near ||!B->idx || !B->e0 || !B->en || !B->lam || !B->dir || !B->bd || !B->tp || !B->tx ||
      !B->td || !B->st || !B->acc || !B->tframe || !B->moved || !B->keys || !B->uv || !B->fp) {
    chunk_free(B);
    return -1;
  }
  return 0;
}

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

/* Whether particle i's cell is evaluated by gmsh (batched). */
static int slow_cell(const psys_sys *s, int32_t i) {
  return s->dim[i] == PM_FACE && s->slow_face[s->cell[i]];
}

/* The trial parameters of particle i (slot k) at lam[k]; 0 when the step is clipped to where the
 * particle stands (nothing to try). */
static int trial_par(const psys_sys *s, chunk *B, int32_t k, int32_t i) {
  const pm_cell *c = pm_model_cell(s->model, s->dim[i], s->cell[i]);
  double dx[3];
  pm_v3_scale(dx, &B->dir[3 * k], B->lam[k]);
  double len = pm_v3_norm(dx), cap = s->p.step_max * s->sigma[i];
  if (len > cap) pm_v3_scale(dx, dx, cap / len);
  double dpar[2] = {0, 0}, *tp = &B->tp[2 * k];
  const double *par = &s->par[2 * i];
  pm_cell_param_delta(c, par, &s->deriv[6 * i], dx, dpar); /* eq. 7, 9 */
  pm_cell_move(c, par, dpar, tp);                          /* eq. 10, shared clip rule */
  return !(tp[0] == par[0] && (c->dim == PM_CURVE || tp[1] == par[1]));
}

/* Evaluate the trial point of slot k on a closed-form cell, with its derivatives. */
static void trial_eval(const psys_sys *s, chunk *B, int32_t k, int32_t i) {
  const pm_cell *c = pm_model_cell(s->model, s->dim[i], s->cell[i]);
  double *tx = &B->tx[3 * k], *td = &B->td[6 * k];
  if (c->dim == PM_CURVE) {
    pm_curve_point cp;
    pm_curve_eval(c, B->tp[2 * k], 1, &cp);
    pm_v3_copy(tx, cp.p), pm_v3_copy(td, cp.d1);
    memset(td + 3, 0, 3 * sizeof(double));
  } else {
    pm_face_point fp;
    pm_face_eval(c, &B->tp[2 * k], 1, &fp);
    pm_v3_copy(tx, fp.p), pm_v3_copy(td, fp.su), pm_v3_copy(td + 3, fp.sv);
  }
  B->tframe[k] = 1;
}

/* Algorithm 1's test of the evaluated trial point of slot k: accept (ST_DONE, acc), give up
 * (ST_DONE) or shrink lambda (ST_PENDING). */
static void trial_check(const psys_sys *s, chunk *B, int32_t k, int32_t i) {
  const psys_list *l = psys_nb(s, i);
  const double d2 = psys_d2(&B->tx[3 * k], &s->xyz[3 * i]);
  /* a point beyond what the lists cover is rejected untried (see the file comment) */
  const double cover = (psys_nbr_reach(&s->p) - 1) * s->sigma[i];
  const int beyond = d2 > cover * cover;
  int better = 0;
  if (!beyond) {
    /* the near candidates serve a trial point within the reach they were chosen for (the point
     * of a curved cell is not always within its 3D step of the particle: then the whole list) */
    const double rr = B->reach[k];
    if (B->nn[k] >= 0 && d2 <= rr * rr)
      B->en[k] = psys_particle_energy(s, i, &B->tx[3 * k], B->near + B->noff[k], B->nn[k], NULL,
                                      NULL);
    else
      B->en[k] = psys_particle_energy(s, i, &B->tx[3 * k], l->ids, l->n, NULL, NULL);
    better = B->en[k] < B->e0[k];
    if (better && s->dim[i] == PM_FACE && s->chain_off) {
      /* a face particle does not step onto its face's boundary (see the file comment) */
      B->bd[k] = psys_boundary_distance(s, i, &B->tx[3 * k], l->ids, l->n);
      if (B->bd[k] < PSYS_BOUNDARY_CLEARANCE * s->sigma[i] && B->bd[k] < s->bdist[i])
        better = 0;
    }
  }
  if (better) {
    B->acc[k] = 1, B->st[k] = ST_DONE; /* Algorithm 1: accept */
  } else if (B->lam[k] <= s->p.lambda_min) {
    B->st[k] = ST_DONE; /* lines 10-11: skip */
  } else {
    /* line 13; beyond the cover, also by the ratio of the cover to the distance, since a capped
     * step divided by 10 can still be capped to the same point */
    const double dn = pm_v3_norm(&B->dir[3 * k]);
    const double step = fmin(B->lam[k] * dn, s->p.step_max * s->sigma[i]);
    B->lam[k] /= 10;
    if (beyond) B->lam[k] = fmin(B->lam[k], step * (cover / sqrt(d2)) / dn);
    B->st[k] = ST_PENDING;
  }
}

/* The candidates a trial point of slot k can meet: its trial steps are at most
 * min(lambda_i |n_i|, step_max sigma_i) long (reach[k]), so a trial point within that of x_i
 * interacts only with the j that have |x_i - x_j| < sigma_ij + reach[k] (a few more than the
 * neighbours at x_i itself; the list reaches (1 + step_max) sigma_ij). Choosing them once per
 * pass makes each trial's energy a short loop. The same sums: the near candidates are the
 * list's, in its order, less ones that contribute nothing at the trial point. */
static void near_candidates(const psys_sys *s, chunk *B, int32_t k, int32_t i,
                            const psys_list *l) {
  const double step = B->lam[k] * pm_v3_norm(&B->dir[3 * k]);
  const double cap = s->p.step_max * s->sigma[i];
  const double reach = (step < cap ? step : cap) * (1 + 1e-9);
  const double *xi = &s->xs[4 * i];
  int32_t *out = B->near + (size_t)NEAR_MAX * (size_t)k, m = 0;
  B->reach[k] = reach;
  B->noff[k] = NEAR_MAX * k;
  for (int32_t q = 0; q < l->n; ++q) {
    const double *xj = &s->xs[4 * l->ids[q]];
    const double r = (xi[3] > xj[3] ? xi[3] : xj[3]) + reach;
    if (psys_d2(xi, xj) < r * r) {
      if (m == NEAR_MAX) {
        B->nn[k] = -1;
        return;
      }
      out[m++] = l->ids[q];
    }
  }
  B->nn[k] = m;
}

/* Evaluate the trial points of the slots in ST_EVAL, face by face (gmsh: batched), with
 * derivatives when `order` is 1. Returns how many; B->keys then holds (face, slot) of each,
 * sorted. */
static int32_t batch_eval(const psys_sys *s, chunk *B, int32_t m, int order) {
  int32_t nk = 0;
  for (int32_t k = 0; k < m; ++k)
    if (B->st[k] == ST_EVAL)
      B->keys[nk++] = ((uint64_t)(uint32_t)s->cell[B->idx[k]] << 32) | (uint32_t)k;
  if (!nk) return 0;
  qsort(B->keys, (size_t)nk, sizeof(uint64_t), cmp_u64);
  for (int32_t a = 0; a < nk;) {
    int32_t f = (int32_t)(B->keys[a] >> 32), e = a;
    while (e < nk && (int32_t)(B->keys[e] >> 32) == f) {
      int32_t k = (int32_t)(B->keys[e] & 0xffffffffu);
      B->uv[2 * (e - a)] = B->tp[2 * k], B->uv[2 * (e - a) + 1] = B->tp[2 * k + 1];
      ++e;
    }
    pm_face_eval_many(pm_model_cell(s->model, PM_FACE, f), e - a, B->uv, order, B->fp);
    for (int32_t q = a; q < e; ++q) {
      int32_t k = (int32_t)(B->keys[q] & 0xffffffffu);
      const pm_face_point *fp = &B->fp[q - a];
      pm_v3_copy(&B->tx[3 * k], fp->p);
      if (order >= 1) pm_v3_copy(&B->td[6 * k], fp->su), pm_v3_copy(&B->td[6 * k + 3], fp->sv);
      B->tframe[k] = order >= 1;
      B->st[k] = ST_PENDING;
    }
    a = e;
  }
  return nk;
}

/* The particle's sampled timing (see step_chunk): every TSAMPLE-th slot reads the clock. */
#define TSAMPLE 8

/* Algorithm 1 for the m particles in B->idx against the current points; the accepted steps are
 * written to the system at the end (the particles of one colour never see each other). */
static pm_status step_chunk(psys_sys *s, chunk *B, int32_t m, pm_error *err) {
  (void)err;
  const int nthr = s->threads;
  const int frames = s->p.frame_tol > 0;
  double *cpu = calloc((size_t)nthr * 3, sizeof(double)); /* energy, surface, step (sampled) */
  if (!cpu) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  /* For each particle, in one parallel loop (one barrier): E_i, its gradient and Hessian, the
   * Newton step, then Algorithm 1's trials -- a particle on a closed-form cell to the end at
   * once, the others up to their next point to evaluate. A slot reads only its own particle and
   * the points of other colours, which no slot of this chunk writes. */
  double t0 = pm_seconds();
  int slow = 0;
#pragma omp parallel num_threads(nthr) if (m > 256) reduction(| : slow)
  {
#ifdef _OPENMP
    const int tid = omp_get_thread_num();
#else
    const int tid = 0;
#endif
    /* Static: each thread takes the same share of every colour (the particles of a colour are
     * in index order, which is spatial order), so the neighbourhoods it reads stay in its own
     * core's cache from colour to colour. table.brep --size 0.5 on two threads, three runs
     * each: phase-3 energy 1.06-1.6 s against 1.42-1.5 s with dynamic chunks of 32. */
#pragma omp for schedule(static)
    for (int32_t k = 0; k < m; ++k) {
      const int32_t i = B->idx[k];
      const int timed = k % TSAMPLE == 0, is_slow = slow_cell(s, i);
      double te = timed ? pm_seconds() : 0;
      const psys_list *l = psys_nb(s, i);
      double grad[3], hess[7];
      B->e0[k] = psys_particle_energy(s, i, &s->xyz[3 * i], l->ids, l->n, grad, hess);
      pm_v3_scale(&s->force[3 * i], grad, -1.0); /* eq. 8: the velocity that repels */
      B->lam[k] = s->lambda[i];
      B->acc[k] = 0, B->tframe[k] = 0;
      B->st[k] = ST_DONE;
      if (s->dim[i] == PM_FACE && s->chain_off)
        s->bdist[i] = psys_boundary_distance(s, i, &s->xyz[3 * i], l->ids, l->n);
      if (B->e0[k] > 0 && newton_step(s, i, &s->force[3 * i], hess, &B->dir[3 * k])) {
        B->st[k] = ST_PENDING;
        near_candidates(s, B, k, i, l);
      }
      if (timed) cpu[3 * tid] += pm_seconds() - te;
      while (B->st[k] == ST_PENDING) {
        double ta = timed ? pm_seconds() : 0;
        if (!trial_par(s, B, k, i)) {
          B->st[k] = ST_DONE; /* clipped to where it stands: nothing to try */
          break;
        }
        if (is_slow) {
          B->st[k] = ST_EVAL, slow = 1;
          if (timed) cpu[3 * tid + 1] += pm_seconds() - ta;
          break;
        }
        trial_eval(s, B, k, i);
        double tb = timed ? pm_seconds() : 0;
        trial_check(s, B, k, i);
        if (timed) cpu[3 * tid + 1] += tb - ta, cpu[3 * tid + 2] += pm_seconds() - tb;
      }
    }
  }
  double t1;
  {
    const psys_step ks[3] = {PSYS_T_ENERGY, PSYS_T_SURFACE, PSYS_T_STEP};
    double sum[3] = {0, 0, 0};
    for (int t = 0; t < nthr; ++t)
      for (int q = 0; q < 3; ++q) sum[q] += cpu[3 * t + q];
    t1 = pm_seconds();
    psys_clock_split(s, t1 - t0, 3, ks, sum);
  }
  /* the particles on gmsh faces, in rounds */
  for (int round = 0; slow && round < 64; ++round) {
    t0 = pm_seconds();
    const int32_t ne = batch_eval(s, B, m, frames ? 0 : 1);
    t1 = pm_seconds();
    psys_clock_add(s, PSYS_T_SURFACE, t1 - t0);
    slow = 0;
    /* only the slots just evaluated (a round's evaluation is serial under gmsh's lock; later
     * rounds hold few slots, too few to pay for waking the threads) */
#pragma omp parallel for num_threads(nthr) schedule(dynamic, 32) if (ne > 2048) reduction(| : slow)
    for (int32_t q = 0; q < ne; ++q) {
      const int32_t k = (int32_t)(B->keys[q] & 0xffffffffu);
      const int32_t i = B->idx[k];
      trial_check(s, B, k, i);
      if (B->st[k] != ST_PENDING) continue;
      if (trial_par(s, B, k, i))
        B->st[k] = ST_EVAL, slow = 1;
      else
        B->st[k] = ST_DONE;
    }
    psys_clock_add(s, PSYS_T_STEP, pm_seconds() - t1);
  }
  /* new frames where an accepted particle on a gmsh face has moved frame_tol sigma from its
   * last one */
  t0 = pm_seconds();
  int refresh = 0;
  for (int32_t k = 0; k < m; ++k) {
    const int32_t i = B->idx[k];
    if (!B->acc[k] || B->tframe[k]) continue;
    const double lim = s->p.frame_tol * s->sigma[i];
    if (!(psys_d2(&B->tx[3 * k], &s->fxyz[3 * i]) < lim * lim)) B->st[k] = ST_EVAL, refresh = 1;
  }
  if (refresh) batch_eval(s, B, m, 1);
  /* write the accepted steps */
  const double lmax =
      s->phase == 3 && s->p.lambda_max_faces > 0 ? s->p.lambda_max_faces : s->p.lambda_max;
#pragma omp parallel for num_threads(nthr) schedule(static) if (m > 4096)
  for (int32_t k = 0; k < m; ++k) {
    const int32_t i = B->idx[k];
    B->moved[k] = 0;
    if (B->acc[k]) {
      B->moved[k] = sqrt(psys_d2(&B->tx[3 * k], &s->xyz[3 * i]));
      memcpy(&s->par[2 * i], &B->tp[2 * k], 2 * sizeof(double));
      psys_set_xyz(s, i, &B->tx[3 * k]);
      if (B->tframe[k]) {
        memcpy(&s->deriv[6 * i], &B->td[6 * k], 6 * sizeof(double));
        memcpy(&s->fxyz[3 * i], &B->tx[3 * k], 3 * sizeof(double));
      }
      s->energy[i] = B->en[k];
      if (s->dim[i] == PM_FACE && s->chain_off) s->bdist[i] = B->bd[k];
      double l = B->lam[k] * s->p.lambda_grow;
      s->lambda[i] = l < lmax ? l : lmax;
    } else {
      s->energy[i] = B->e0[k];
      s->lambda[i] = B->lam[k];
    }
  }
  psys_clock_add(s, PSYS_T_SURFACE, pm_seconds() - t0);
  free(cpu);
  return PM_OK;
}

/* Greedy colouring of the movable particles in index order: two movable particles get different
 * colours when they are closer than psys_nbr_reach times the larger sigma (see the file
 * comment). Returns the number of colours (-1: out of memory); colour[i] = -1 for fixed
 * particles. */
static int32_t colour_particles(const psys_sys *s, int32_t *colour) {
  const int32_t n = s->n;
  const double reach = psys_nbr_reach(&s->p);
  int32_t ncol = 0, cap = 64;
  int32_t *stamp = malloc(sizeof(int32_t) * (size_t)cap);
  if (!stamp) return -1;
  for (int32_t c = 0; c < cap; ++c) stamp[c] = -1;
  for (int32_t i = 0; i < n; ++i) {
    colour[i] = -1;
    if (s->fixed[i]) continue;
    const psys_list *l = psys_nb(s, i);
    const double *xi = &s->xs[4 * i];
    for (int32_t q = 0; q < l->n && l->ids[q] < i; ++q) {
      const int32_t j = l->ids[q];
      const int32_t c = colour[j];
      if (c < 0 || stamp[c] == i) continue; /* (a colour already taken needs no distance) */
      const double *xj = &s->xs[4 * j];
      const double r = reach * (xi[3] > xj[3] ? xi[3] : xj[3]);
      if (psys_d2(xi, xj) < r * r) stamp[c] = i;
    }
    int32_t c = 0;
    while (c < cap && stamp[c] == i) ++c;
    if (c == cap) {
      int32_t *ns = realloc(stamp, sizeof(int32_t) * 2 * (size_t)cap);
      if (!ns) {
        free(stamp);
        return -1;
      }
      stamp = ns;
      for (int32_t q = cap; q < 2 * cap; ++q) stamp[q] = -1;
      cap *= 2;
    }
    colour[i] = c;
    if (c + 1 > ncol) ncol = c + 1;
  }
  free(stamp);
  return ncol;
}

/* e_i of psys_colouring_surely_holds (r = 1 + step_max, slack = (q - r) / 2 less a rounding
 * margin). */
static inline double colour_excess(const psys_sys *s, int32_t i, double r, double slack) {
  const double *x = &s->xs[4 * i], *x0 = &s->colour_x0[4 * i];
  const double g = x[3] > x0[3] ? x[3] - x0[3] : 0;
  return sqrt(psys_d2(x, x0)) * (1 + 1e-9) + r * g - slack * x0[3];
}

static double colour_slack(const psys_sys *s) {
  const double r = 1 + s->p.step_max, q = psys_nbr_reach(&s->p);
  /* (1 - 1e-9): room for the rounding of the distances the pair check compares */
  return 0.5 * (q - r) * (1 - 1e-9);
}

/* Whether no two movable particles of one colour can be in conflict, judged from how far each
 * moved and how much its sigma grew since the colouring, without looking at pairs. Two particles
 * of one colour were at least d0 = q m0 apart then (q = psys_nbr_reach, m0 the larger of their
 * sigma then: the lists hold every pair within that, and the colouring separated them); they
 * conflict when closer than r m (r = 1 + step_max, m the larger sigma now). With delta the
 * distance a particle moved and g its sigma's growth (0 when it shrank), they are at least
 * q m0 - delta_i - delta_j apart and m <= m0 + g_i + g_j, so they cannot conflict while
 * e_i + e_j <= 0, e = delta + r g - (q - r) sigma0 / 2 (as m0 >= (sigma0_i + sigma0_j) / 2): for
 * every pair at once while the two largest e sum to at most 0. A sufficient test only: when it
 * fails, the pairs are checked. Runs of phase 3's tail pass it at most passes; the pair check
 * took 6% of a one-thread run (wrench.stp, perf). */
int psys_colouring_surely_holds(const psys_sys *s) {
  const int32_t n = s->n;
  if (s->colour_nmended > 0) return 0; /* their pairs are checked at every pass (colour_mend) */
  const double r = 1 + s->p.step_max, slack = colour_slack(s);
  double e1 = -INFINITY, e2 = -INFINITY; /* the two largest */
  for (int32_t i = 0; i < n; ++i) {
    if (s->colour[i] < 0) continue;
    const double e = colour_excess(s, i, r, slack);
    if (e > e1) e2 = e1, e1 = e;
    else if (e > e2) e2 = e;
  }
  return !(e1 + e2 > 0);
}

/* The kept colouring against the current particles: -1 when it must be made again (another
 * count, or a colour on other particles than the movable ones), else the number of movable
 * particles in conflict with one of their colour, each marked in s->colour_mark (0: it holds).
 * The pairs are checked from the particles whose e (above) is positive, and from those coloured
 * alone since the colouring (colour_mend), whose e says nothing: a pair of two others with
 * e_i + e_j <= 0 cannot conflict, so every conflict is found, and both of its particles are marked
 * when both are checked. Those checked are few when the sufficient test fails (table.brep with
 * one thread, 103 checks: 0.006% to 24% of the movable particles, median 0.8%), and the check of
 * all pairs took 47 s of box_sides.step's 706 s on two threads. */
static int32_t colouring_check(psys_sys *s) {
  const int32_t n = s->n;
  if (n == 0 || s->colour_n != n) return -1;
  int consistent = 1;
  for (int32_t i = 0; i < n && consistent; ++i) consistent = (s->colour[i] < 0) == (s->fixed[i] != 0);
  if (!consistent) return -1;
  if (psys_colouring_surely_holds(s)) return 0;
  const double reach = 1 + s->p.step_max, slack = colour_slack(s);
  int32_t nbad = 0;
  uint8_t *mark = s->colour_mark;
#pragma omp parallel for num_threads(s->threads) schedule(static) reduction(+ : nbad) if (n > 4096)
  for (int32_t i = 0; i < n; ++i) {
    mark[i] = 0;
    const int32_t ci = s->colour[i];
    if (ci < 0 || (!s->colour_mended[i] && !(colour_excess(s, i, reach, slack) > 0))) continue;
    const psys_list *l = psys_nb(s, i);
    const double *xi = &s->xs[4 * i];
    for (int32_t q = 0; q < l->n && !mark[i]; ++q) {
      const int32_t j = l->ids[q];
      if (j == i || s->colour[j] != ci) continue;
      const double *xj = &s->xs[4 * j];
      const double r = reach * (xi[3] > xj[3] ? xi[3] : xj[3]);
      if (psys_d2(xi, xj) < r * r) mark[i] = 1;
    }
    nbad += mark[i];
  }
  return nbad;
}

/* List the movable particles colour by colour, in index order within a colour (a counting sort
 * of s->colour over its s->ncolour colours). */
static void order_colours(psys_sys *s) {
  const int32_t n = s->n, ncol = s->ncolour;
  int32_t *start = s->colour_start;
  memset(start, 0, sizeof(int32_t) * ((size_t)ncol + 2));
  for (int32_t i = 0; i < n; ++i)
    if (s->colour[i] >= 0) start[s->colour[i] + 2]++;
  for (int32_t c = 0; c < ncol; ++c) start[c + 2] += start[c + 1];
  for (int32_t i = 0; i < n; ++i)
    if (s->colour[i] >= 0) s->colour_order[start[s->colour[i] + 1]++] = i;
}

/* colour_mend: the particles marked by colouring_check get, one after the other in index order,
 * the lowest colour that no movable particle within psys_nbr_reach times the larger sigma has
 * (the separation of the greedy colouring; the lists hold every such pair). Each then keeps its
 * pairs checked at every pass until the next colouring, since its colouring point says nothing
 * about the others'. On a packing at rest the conflicts come a few at a time, where a lattice
 * defect glides (wrench.stp on two threads: 1 to 6 particles of 48371, every 4 to 10 passes of
 * phase 3's last 120), and colouring all again for them took a tenth of box_sides.step's run
 * (64 of 602 s, 205 colourings in 322 passes). Above MEND_MAX of the movable particles, and
 * above MEND_MIN (in conflict now, or coloured alone before), everything is coloured again
 * instead: each particle coloured alone is checked at every pass. */
#define MEND_MAX (1.0 / 64)
#define MEND_MIN 32

static pm_status colour_mend(psys_sys *s, int32_t nmark, pm_error *err) {
  const int32_t n = s->n;
  const double q = psys_nbr_reach(&s->p);
  /* each particle coloured alone adds at most one colour */
  uint8_t *used = calloc((size_t)s->ncolour + (size_t)nmark + 1, 1);
  if (!used) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  int32_t ncol = s->ncolour;
  for (int32_t i = 0; i < n; ++i) {
    if (!s->colour_mark[i]) continue;
    const psys_list *l = psys_nb(s, i);
    const double *xi = &s->xs[4 * i];
    memset(used, 0, (size_t)ncol + 1);
    for (int32_t k = 0; k < l->n; ++k) {
      const int32_t j = l->ids[k], c = s->colour[j];
      if (j == i || c < 0) continue;
      const double *xj = &s->xs[4 * j];
      const double r = q * (xi[3] > xj[3] ? xi[3] : xj[3]);
      if (psys_d2(xi, xj) < r * r) used[c] = 1;
    }
    int32_t c = 0;
    while (used[c]) ++c;
    s->colour[i] = c;
    if (c + 1 > ncol) ncol = c + 1;
    if (!s->colour_mended[i]) s->colour_mended[i] = 1, s->colour_nmended++;
    s->colour_mends++;
  }
  free(used);
  s->ncolour = ncol;
  order_colours(s);
  return PM_OK;
}

/* Colour the particles again into s->colour, and list the movable ones colour by colour, in
 * index order within a colour (a counting sort). */
static pm_status colour_again(psys_sys *s, pm_error *err) {
  const int32_t n = s->n;
  if (n + 2 > s->colour_cap) {
    int32_t cap = s->colour_cap ? s->colour_cap : 256;
    while (cap < n + 2) cap = cap > INT32_MAX / 2 ? INT32_MAX : 2 * cap;
    free(s->colour), free(s->colour_order), free(s->colour_start), free(s->colour_x0);
    free(s->colour_mark), free(s->colour_mended);
    s->colour = malloc(sizeof(int32_t) * (size_t)cap);
    s->colour_order = malloc(sizeof(int32_t) * (size_t)cap);
    s->colour_start = malloc(sizeof(int32_t) * (size_t)cap);
    s->colour_x0 = malloc(sizeof(double) * 4 * (size_t)cap);
    s->colour_mark = malloc((size_t)cap);
    s->colour_mended = malloc((size_t)cap);
    s->colour_cap = s->colour && s->colour_order && s->colour_start && s->colour_x0 &&
                            s->colour_mark && s->colour_mended
                        ? cap
                        : 0;
    s->colour_n = 0;
    if (!s->colour_cap) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  s->colour_n = 0;
  const int32_t ncol = colour_particles(s, s->colour);
  if (ncol < 0) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  s->ncolour = ncol;
  order_colours(s);
  memcpy(s->colour_x0, s->xs, sizeof(double) * 4 * (size_t)n);
  memset(s->colour_mended, 0, (size_t)n);
  s->colour_nmended = 0;
  s->colour_n = n;
  s->recolours++;
  return PM_OK;
}

pm_status psys_move_pass(psys_sys *s, psys_move_info *info, pm_error *err) {
  const int32_t n = s->n;
  memset(info, 0, sizeof *info);
  double *moved = calloc((size_t)n + 1, sizeof(double));
  chunk B;
  memset(&B, 0, sizeof B);
  pm_status st = PM_OK;
  if (!moved) {
    st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto out;
  }
  if ((st = psys_nbr_update(s, err))) goto out; /* timed as the neighbour structure's */
  double t0 = pm_seconds();
  {
    const int32_t nbad = colouring_check(s);
    const int32_t movable = s->colour_n == n ? s->colour_start[s->ncolour] : 0;
    if (nbad > 0 && s->p.colour_mend &&
        (double)(nbad + s->colour_nmended) <= fmax(MEND_MIN, MEND_MAX * (double)movable)) {
      if ((st = colour_mend(s, nbad, err))) goto out;
    } else if (nbad != 0 && (st = colour_again(s, err))) {
      goto out;
    }
  }
  const int32_t ncol = s->ncolour, *start = s->colour_start, *order = s->colour_order;
  int32_t largest = 0;
  for (int32_t c = 0; c < ncol; ++c)
    if (start[c + 1] - start[c] > largest) largest = start[c + 1] - start[c];
  psys_clock_add(s, PSYS_T_COLOURING, pm_seconds() - t0);
  if (largest > 0 && chunk_alloc(&B, largest < CHUNK ? largest : CHUNK)) {
    st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto out;
  }
  for (int32_t c = 0; c < ncol && !st; ++c)
    for (int32_t a = start[c]; a < start[c + 1] && !st; a += B.cap) {
      const int32_t m = start[c + 1] - a < B.cap ? start[c + 1] - a : B.cap;
      memcpy(B.idx, order + a, sizeof(int32_t) * (size_t)m);
      st = step_chunk(s, &B, m, err);
      for (int32_t k = 0; k < m; ++k) moved[B.idx[k]] = B.moved[k];
    }
  if (st) goto out;
  /* The fixed particles' energies, for the trace and the population rules. */
  t0 = pm_seconds();
#pragma omp parallel for num_threads(s->threads) schedule(dynamic, 64) if (n > 512)
  for (int32_t i = 0; i < n; ++i) {
    if (!s->fixed[i]) continue;
    double grad[3];
    const psys_list *l = psys_nb(s, i);
    s->energy[i] = psys_particle_energy(s, i, &s->xyz[3 * i], l->ids, l->n, grad, NULL);
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
  chunk_free(&B);
  free(moved);
  return st;
}
