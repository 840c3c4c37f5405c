/* The equation of motion of the bubbles (papers/003 eq. 12-15, papers/000 section 5.5,
 * papers/004 section 2.2):
 *     m x_i'' + c_i x_i' = f_i,   f_i = sum_j F(|x_i - x_j|, l0_ij) (x_i - x_j) / |x_i - x_j|,
 * for every curve and face bubble, over the bubbles it feels (bub_related); vertex bubbles are
 * fixed. Integrated by the classic fourth-order Runge-Kutta method (003 section 3.4), by Heun's
 * second-order scheme (the "second-order" scheme of 004 section 1 / its reference [23]), or by the
 * semi-implicit (symplectic) Euler scheme with implicit damping (our addition, integrator =
 * symplectic):
 *     v' = (v + h f(x) / m) / (1 + h c / m) = v + h (f - c v) / (m + h c),   x' = x + h v',
 * one force sum a step instead of RK4's four. The papers integrate a trajectory; what the mesh
 * keeps is where it ends, at rest (f = 0), and that rest point is the same for every scheme. The
 * slow part of the relaxation is the packing's long waves, whose h s is small, where every scheme
 * is accurate; the fast modes only need to be damped, not followed. On wrench.stp at 1e5 bubbles
 * the relaxation took 8.0 s against RK4's 12.5 s at the same step (dt 0.1), with the same
 * quality (mean radius ratio 0.9893 / 0.9892, median R / l_min 0.5962 both; `packmesh mesh
 * wrench.stp --method bubble --target-nodes 100000 --threads 1 --set integrator=I --stats`). Its
 * stability is the 2 x 2 map of a mode m s^2 + c s + k (bub_params.c). It is the default; the
 * papers' RK4 stays one parameter away (integrator = rk4). On the small planar cases the two
 * schemes end in different packings whose quality differs by as much as a 1% change of the size
 * does (bench_bubble compare, the mean over five sizes: qi1 rr_mean 0.9941 symplectic, 0.9946
 * RK4; qi3 0.9757 and 0.9753).
 *
 * Confinement. Positions live on the cells: every RK stage displaces the bubble from its
 * position at the start of the step by the stage's object-space displacement, through
 * pm_cell_param_delta and pm_cell_move (geom.h, the one shared routine: 003 eq. 15 for curves,
 * the first fundamental form for faces, periodic wrap, clip at the trimmed boundary). The stage
 * force is projected onto the tangent of the curve or the tangent plane of the face at the
 * stage point before it becomes an acceleration, and the velocity at the end of the step is
 * projected onto the new tangent space, so that no velocity builds up across the cell where the
 * bubble cannot move (a choice: 003 integrates in object space and corrects positions only,
 * which lets a normal velocity grow under the normal part of the forces on curved cells without
 * any effect but on the kinetic energy and the calm test). A bubble whose final move is clipped
 * at the boundary of its face or curve stops (velocity zero), the shared rule's "clip to the
 * boundary and stop".
 *
 * Volume bubbles (the volume phase, bub_volume.c) move freely in 3D: no projection, the RK
 * stages are free points (they only serve to evaluate forces), and the final step follows the
 * volumes' one rule, bub_volume_move: taken whole, else shortened, else not taken, so that the
 * bubble never crosses its volume's walls and ends at least BUB_VMARGIN of its diameter from
 * them; a bubble whose step was cut stops (velocity zero), as on faces.
 *
 * Parameters. c = 2 zeta sqrt(m k0) (003 eq. 14 with k = k0, 004 section 2.2). The step is
 * h = dt T0 with T0 = 2 pi sqrt(m / k0) the natural period of eq. 13 (our choice: 003 leaves the
 * step open). With the force of bub_force.c (spring constant k0 for every size) the equation
 * divided by k0 reads (m/k0) x'' + (c/k0) x' = l0 g(l/l0): in the time tau = t sqrt(k0/m) it is
 * x_tautau + 2 zeta x_tau = l0 g, independent of k0 and m. With h proportional to sqrt(m/k0) the
 * discrete steps are therefore the same for every k0 and m: the system is stable for all of
 * them, the thesis's range [0.1, 150] included (000 section 6.4 found k0 > 150 unstable at a fixed
 * step, which our step does not have). Stability itself: the linearized modes have stiffness up
 * to 12 k0 (bub_params.c), so frequencies up to 3.5 w0 (w0 = sqrt(k0/m)); the default h w0 = 2 pi 0.1
 * = 0.63 puts them at |h s| <= 2.2, inside RK4's region (2.6 to 2.8 along the damped directions),
 * and the overdamped fast root -2 zeta w0 stays inside for zeta <= 2.2; Heun's region is smaller
 * (it does not contain the imaginary axis), hence its default 0.05. The symplectic scheme at the
 * default 0.1 is stable for zeta >= 0.2933 (bub_params.c), final_zeta's 0.3 included. bub_params_check verifies
 * the chosen step and damping ratios against the exact stability polynomials.
 *
 * The diameter d(x) is constant within a step (l0 changes within a step by |grad d| |dx|, below
 * 1e-3 of l0 for the steps of a relaxing system) and is evaluated again once the bubble has
 * moved, in total since the last evaluation, more than BUB_DTOL of its diameter: the diameter in
 * use is then within BUB_DTOL L of d(x) for a field with Lipschitz constant L (<= 0.3% for the
 * fields of DESIGN.md's cases), while a relaxed bubble that hardly moves costs no evaluation.
 *
 * Two bubbles at the same point (distance below 1e-12 l0) repel along a direction drawn from
 * the run's seed and the pair, opposite for the two (003's force has no direction there).
 *
 * Frames (our addition, frame_tol > 0). An exact evaluation of a cell costs from a few
 * nanoseconds (a plane) to microseconds (a B-spline through gmsh, under its lock), and RK4 asks
 * for four per bubble and step. Each curve and face bubble therefore keeps a frame: the cell's
 * second-order Taylor model S + S_u du + S_v dv + (S_uu du^2 + 2 S_uv du dv + S_vv dv^2) / 2 (and
 * its derivatives for the tangents) around the parameters where it was last evaluated exactly.
 * A stage or end point whose first-order distance |S_u du + S_v dv| from the frame is at most
 * frame_r x d takes its position and tangents from the model; any other is evaluated exactly
 * (faces in one batch per chunk and face, pm_face_eval_many), and an end point so evaluated starts
 * a new frame. On planes and lines (bub_state.c checks which cells are affine) the model is exact
 * and no evaluation is ever needed. Elsewhere its error grows as the cube of the distance: each
 * new frame compares the old model with the exact point, scales that error to the frame radius
 * and sets the bubble's radius so that the error there is FRAME_ERR d (at most frame_tol, starting
 * from a quarter of it), and a point whose second-order term exceeds a tenth of its first-order
 * term (a parameter step too large for the model, as near a pole) is evaluated exactly. So a
 * relaxing bubble, which moves a thousandth of its diameter a step, is evaluated once in tens of
 * steps. The parameters are always exact (the shared displacement rule moves them); positions
 * are within about FRAME_ERR d of the cell during the relaxation and exactly on it at its end
 * (bub_state_refresh, before population control and the connection). frame_tol = 0 evaluates
 * every stage exactly.
 *
 * Neighbour lists (bub_neighbors.c) are used across stages and steps. Every point where forces
 * are about to be computed passes the lists' skin test first (each step's start points, and each
 * stage's points as they are computed); when it fails the lists are rebuilt there.
 *
 * Layout and threads. The positions the force sums gather are packed (x, y, z, d) per bubble in
 * three buffers (the step start and two alternating stage buffers: a stage reads one and writes
 * the other, so each stage is one pass), one cache line fetch per neighbour: measured against
 * separate x, y, z, d arrays with bench_bubble's bare-arithmetic kernel, packed was as fast or
 * faster. Everything else is one array per quantity. A stage is one parallel loop over chunks of
 * BUB_CHUNK bubbles, each thread taking one contiguous run of chunks, the same in every stage and
 * step (static schedule), so that the state a thread writes in one stage is in its own core's cache
 * when it reads it in the next. A dynamic schedule, which hands a chunk to whichever thread is free
 * and so moves most chunks between cores from stage to stage, ran two threads at 1.15 to 1.56
 * times one on a 1e5-bubble plane, the static one at 1.59 to 2.26 (bench_bubble throughput, three
 * alternating runs each on a noisy two-core machine); each bubble's force sums over its sorted neighbour list from the stage positions (Jacobi style),
 * and every sum over bubbles (energies, displacements) is formed per chunk in index order and the
 * chunks combined in chunk order, so no result depends on the thread count or the schedule. No
 * memory is allocated in a step once the scratch has grown to the bubble count.
 *
 * Stage times (bub_state.t): each chunk is timed in three parts -- the force sums, the RK
 * arithmetic, the confinement (parameter step, trimming, frames or evaluation) -- and the
 * thread-seconds are divided by the thread count.
 */
#include "bubble/bub_private.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/clock.h"
#include "common/base/rng.h"
#include "common/geom/trim.h"
#include "common/base/vec3.h"

#ifdef _OPENMP
#include <omp.h>
#endif

/* Re-evaluate d(x) after a bubble moved this fraction of its diameter (see above). */
#define BUB_DTOL 0.01

/* The model error a frame's radius aims at, relative to d (see "Frames" above). */
#define FRAME_ERR 1e-6

/* Frame layout (BUB_FRAME_LEN doubles): par, S, S_u, S_v, S_uu, S_uv, S_vv. */
enum { F_PAR = 0, F_S = 2, F_U = 5, F_V = 8, F_UU = 11, F_UV = 14, F_VV = 17 };

double bub_time_step(const bub_params *p) {
  double frac = p->dt > 0 ? p->dt : (p->integrator == BUB_RK2 ? 0.05 : 0.1);
  return frac * 2 * M_PI * sqrt(p->mass / p->k0);
}

double bub_final_zeta(const bub_params *p) {
  if (p->final_zeta != 0) return p->final_zeta > 0 ? p->final_zeta : 0;
  return p->integrator == BUB_RK2 ? 0 : 0.3;
}

double bub_zeta_curved(const bub_state *s) {
  /* (the surface phase's final steps only: the volume phase was not measured with it) */
  if (s->final_phase && !s->volume_phase && bub_final_zeta(&s->p) > 0) return bub_final_zeta(&s->p);
  return bub_zeta_now(s);
}

double bub_zeta_now(const bub_state *s) {
  if (s->p.viscosity == BUB_VISC_CONSTANT) return s->p.zeta;
  /* 004 section 2.2: c = c0 + k1 (steps into the round) + k2 (rounds done), saw-tooth shaped,
   * rising within a round and from round to round; capped for stability. */
  /* The volume phase restarts the rise (its rounds count from round0). */
  double z = s->p.zeta + s->p.zeta_k1 * s->steps_in_round + s->p.zeta_k2 * (double)(s->round - s->round0);
  return fmin(z, fmax(s->p.zeta_max, s->p.zeta));
}

static pm_status scratch(bub_state *s, pm_error *err) {
  if (s->scratch_cap >= s->n && s->chunks) return PM_OK;
  int32_t nc = s->n + s->n / 4 + 64;
#define R(ptr, per)                                                                   \
  do {                                                                                \
    void *np = realloc(s->ptr, sizeof(*s->ptr) * (size_t)(per) * (size_t)nc);        \
    if (!np) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");                \
    s->ptr = np;                                                                      \
  } while (0)
  R(pos[0], 4);
  R(pos[1], 4);
  R(pos[2], 4);
  R(vs, 3);
  R(sumv, 3);
  R(suma, 3);
  R(ders, 6);
  R(pot, 1);
  R(disp, 1);
  R(deg, 1);
  R(skin0, 1);
  R(room, 1);
#undef R
  if (!s->hist) {
    s->hist = calloc((size_t)BUB_HBINS * (size_t)s->threads, sizeof(int32_t));
    s->timers = calloc(3 * (size_t)s->threads, sizeof(double));
    if (!s->hist || !s->timers) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  bub_chunk *ch = realloc(s->chunks, sizeof(bub_chunk) * ((size_t)nc / BUB_CHUNK + 2));
  if (!ch) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  s->chunks = ch;
  s->scratch_cap = nc;
  s->lists_valid = 0; /* the fixed bubbles' entries of the stage buffers are refilled with them */
  return PM_OK;
}

/* Remove the part of w across the cell at a point with derivatives der (curve: keep the part
 * along C'; face: remove the part along Su x Sv). */
static void tangent_project(int kind, const double *der, double w[3]) {
  if (kind == BUB_KVOLUME) return; /* free in 3D */
  if (kind == BUB_KCURVE) {
    double g = pm_v3_dot(der, der);
    if (g > 0) {
      double k = pm_v3_dot(w, der) / g;
      pm_v3_scale(w, der, k);
    }
  } else {
    double nrm[3];
    pm_v3_cross(nrm, der, der + 3);
    double g = pm_v3_dot(nrm, nrm);
    if (g > 0) pm_v3_axpy(w, w, -pm_v3_dot(w, nrm) / g, nrm);
  }
}

void bub_pair_direction(uint64_t seed, int32_t i, int32_t j, double u[3]) {
  int32_t a = i < j ? i : j, b = i < j ? j : i;
  pm_rng r;
  pm_rng_init(&r, seed, ((uint64_t)(uint32_t)a << 32) | (uint32_t)b);
  double z = pm_rng_range(&r, -1, 1), phi = pm_rng_range(&r, 0, 2 * M_PI), q = sqrt(1 - z * z);
  u[0] = q * cos(phi), u[1] = q * sin(phi), u[2] = z;
  if (i > j) pm_v3_scale(u, u, -1);
}

void bub_force_on(const bub_state *s, const double *pos4, int32_t i, double f[3], double *pot,
                  int32_t *deg) {
  bub_force_sum(s, pos4, i, bub_kernel_simd(), f, pot, deg);
}

/* ---- frames ------------------------------------------------------------------------------- */

static inline int is_affine(const bub_state *s, int kind, int32_t cell) {
  return kind == BUB_KFACE ? s->affine[cell] : s->affine[s->model->count[PM_FACE] + cell];
}

/* The parameter offset from the frame's origin (periodic parameters: the nearest copy). */
static inline void frame_delta(const pm_cell *c, const double *F, const double *par, int np, double dp[2]) {
  dp[1] = 0;
  for (int k = 0; k < np; ++k) {
    dp[k] = par[k] - F[F_PAR + k];
    if (c->periodic[k] && c->period[k] > 0) dp[k] -= c->period[k] * nearbyint(dp[k] / c->period[k]);
  }
}

/* The Taylor model of frame F at parameter offset (du, dv): position, tangents, the size of the
 * first- and second-order terms. */
static inline void frame_eval(const double *F, const double dp[2], double x[3], double der[6],
                              double *first, double *second) {
  const double du = dp[0], dv = dp[1];
  double t1[3], t2[3];
  for (int k = 0; k < 3; ++k) {
    t1[k] = F[F_U + k] * du + F[F_V + k] * dv;
    t2[k] = 0.5 * (F[F_UU + k] * du * du + 2 * F[F_UV + k] * du * dv + F[F_VV + k] * dv * dv);
    x[k] = F[F_S + k] + t1[k] + t2[k];
    der[k] = F[F_U + k] + F[F_UU + k] * du + F[F_UV + k] * dv;
    der[3 + k] = F[F_V + k] + F[F_UV + k] * du + F[F_VV + k] * dv;
  }
  *first = pm_v3_norm(t1), *second = pm_v3_norm(t2);
}

/* Position and tangents of bubble i at par from its frame, when the frame covers par. */
static int frame_covers(const bub_state *s, int32_t i, const pm_cell *c, const double *par,
                        double x[3], double der[6]) {
  const double fr = s->frame_r[i];
  if (!(fr > 0)) return 0;
  const double *F = &s->frame[(size_t)BUB_FRAME_LEN * i];
  double dp[2], first, second;
  frame_delta(c, F, par, s->kind[i] == BUB_KFACE ? 2 : 1, dp);
  if (is_affine(s, s->kind[i], s->cell[i])) { /* a plane or a line: the first-order model is the cell */
    for (int k = 0; k < 3; ++k) {
      x[k] = F[F_S + k] + F[F_U + k] * dp[0] + F[F_V + k] * dp[1];
      der[k] = F[F_U + k], der[3 + k] = F[F_V + k];
    }
    return 1;
  }
  frame_eval(F, dp, x, der, &first, &second);
  return first <= fr * s->d[i] && second <= 0.1 * first;
}

/* A new frame at an exact evaluation (p, d1, d2 as a face point; curves: su = C', suu = C''),
 * its radius set from the old frame's error there (see "Frames"). */
static void frame_start(bub_state *s, int32_t i, const pm_cell *c, const double *par,
                        const pm_face_point *fp) {
  double *F = &s->frame[(size_t)BUB_FRAME_LEN * i];
  const double tol = s->p.frame_tol, d = s->d[i];
  double r = s->frame_r[i];
  if (is_affine(s, s->kind[i], s->cell[i])) {
    r = tol;
  } else if (r > 0) {
    double dp[2], x[3], der[6], first, second;
    frame_delta(c, F, par, s->kind[i] == BUB_KFACE ? 2 : 1, dp);
    frame_eval(F, dp, x, der, &first, &second);
    double err = pm_v3_dist(x, fp->p), dist = first / d; /* error at distance dist x d */
    if (dist > 0 && err > 0) {
      /* error ~ dist^3: the radius where it would be FRAME_ERR d, with a 0.8 margin. */
      double at = 0.8 * dist * cbrt(FRAME_ERR * d / err);
      r = fmin(fmin(at, 2 * r), tol);
    } else if (err == 0) {
      r = fmin(2 * r, tol);
    }
  } else {
    r = 0.25 * tol;
  }
  s->frame_r[i] = r;
  F[F_PAR] = par[0], F[F_PAR + 1] = s->kind[i] == BUB_KFACE ? par[1] : 0;
  for (int k = 0; k < 3; ++k) {
    F[F_S + k] = fp->p[k];
    F[F_U + k] = fp->su[k], F[F_V + k] = fp->sv[k];
    F[F_UU + k] = fp->suu[k], F[F_UV + k] = fp->suv[k], F[F_VV + k] = fp->svv[k];
  }
}

/* Exact evaluation of a curve as a face point (sv and the mixed terms zero). */
static void curve_as_face(const pm_cell *c, double t, int order, pm_face_point *fp) {
  pm_curve_point cp;
  pm_curve_eval(c, t, order, &cp);
  memset(fp, 0, sizeof *fp);
  pm_v3_copy(fp->p, cp.p);
  if (order >= 1) pm_v3_copy(fp->su, cp.d1);
  if (order >= 2) pm_v3_copy(fp->suu, cp.d2);
}

void bub_state_refresh(bub_state *s) {
  for (int32_t i = 0; i < s->n; ++i) {
    int k = s->kind[i];
    if (k != BUB_KCURVE && k != BUB_KFACE) continue;
    const pm_cell *c = pm_model_cell(s->model, k, s->cell[i]);
    pm_face_point fp;
    if (k == BUB_KFACE)
      pm_face_eval(c, &s->par[2 * i], s->p.frame_tol > 0 ? 2 : 1, &fp);
    else
      curve_as_face(c, s->par[2 * i], s->p.frame_tol > 0 ? 2 : 1, &fp);
    pm_v3_copy(&s->x[3 * i], fp.p);
    pm_v3_copy(&s->der[6 * i], fp.su);
    pm_v3_copy(&s->der[6 * i + 3], fp.sv);
    if (s->p.frame_tol > 0) frame_start(s, i, c, &s->par[2 * i], &fp);
  }
  s->evals += s->n;
}

/* A new clearance for face bubble i at its new parameters par (trim.h): up to about 2 d in
 * object space (the parameter radius 2 d / sqrt(|S_u|^2 + |S_v|^2)). */
static void clear_at(bub_state *s, int32_t i, const pm_cell *c, const double *par) {
  const double *su = &s->der[6 * i], *sv = &s->der[6 * i + 3];
  double g = pm_v3_dot(su, su) + pm_v3_dot(sv, sv), *cl = &s->clear[3 * i];
  cl[0] = par[0], cl[1] = par[1];
  cl[2] = g > 0 ? pm_trim_clearance(c, par, 2 * s->d[i] / sqrt(g)) : 0;
}

/* ---- one chunk of a stage --------------------------------------------------------------------- */

typedef struct stage_ctx {
  double m, h, c_norm, c_odd, c_curved; /* c_curved: bubbles of curved faces (bub_zeta_curved) */
  const double *w, *off;
  int stg, nstage;
  int symplectic; /* one stage: semi-implicit Euler, damping implicit (the header) */
  const double *src; /* positions the forces are computed at */
  double *dst;       /* the next stage's positions (NULL: the step's end) */
  double *timers;    /* [3 * threads] */
  int simd;          /* the force kernel (bub_kernel.c) */
} stage_ctx;

/* Confine the points par0 + M^-1 J dx of the chunk's curve and face bubbles (given in par, with the
 * clip results in r): position and tangents from the frame, or by exact evaluation (faces batched
 * per face); a final point evaluated exactly starts a new frame. */
static int32_t confine(bub_state *s, int32_t lo, int32_t hi, const uint8_t *need, const double *par,
                       double *x, double *der, int final) {
  pm_face_point fp[BUB_CHUNK];
  double uv[2 * BUB_CHUNK];
  int32_t who[BUB_CHUNK];
  const int order = final && s->p.frame_tol > 0 ? 2 : 1;
  int32_t nneed = 0, nexact = 0;
  for (int32_t i = lo; i < hi; ++i) {
    const int k = s->kind[i];
    const int32_t q = i - lo;
    if (!need[q]) continue;
    const pm_cell *c = pm_model_cell(s->model, k, s->cell[i]);
    if (frame_covers(s, i, c, &par[2 * q], &x[3 * q], &der[6 * q])) continue;
    ++nexact;
    if (k == BUB_KCURVE) {
      curve_as_face(c, par[2 * q], order, &fp[0]);
      pm_v3_copy(&x[3 * q], fp[0].p), pm_v3_copy(&der[6 * q], fp[0].su), pm_v3_zero(&der[6 * q + 3]);
      if (final && s->p.frame_tol > 0) frame_start(s, i, c, &par[2 * q], &fp[0]);
      continue;
    }
    who[nneed] = i, uv[2 * nneed] = par[2 * q], uv[2 * nneed + 1] = par[2 * q + 1], ++nneed;
  }
  for (int32_t a = 0; a < nneed;) {
    int32_t b = a + 1;
    while (b < nneed && s->cell[who[b]] == s->cell[who[a]]) ++b;
    const pm_cell *c = pm_model_cell(s->model, BUB_KFACE, s->cell[who[a]]);
    pm_face_eval_many(c, b - a, &uv[2 * a], order, &fp[a]);
    for (int32_t e = a; e < b; ++e) {
      const int32_t i = who[e], q = i - lo;
      pm_v3_copy(&x[3 * q], fp[e].p), pm_v3_copy(&der[6 * q], fp[e].su), pm_v3_copy(&der[6 * q + 3], fp[e].sv);
      if (final && s->p.frame_tol > 0) frame_start(s, i, c, &par[2 * q], &fp[e]);
    }
    a = b;
  }
  return nexact;
}

/* The histogram bin of a relative displacement (BUB_HBINS). */
static inline int hist_bin(double rel) {
  if (!(rel > 0x1p-60)) return 0;
  if (!(rel < 0x1p4)) return BUB_HBINS - 1;
  int e;
  double m = frexp(rel, &e); /* rel = m 2^e, m in [0.5, 1) */
  int b = (e + 60) * 8 + (int)((m - 0.5) * 16);
  return b < 1 ? 1 : (b > BUB_HBINS - 2 ? BUB_HBINS - 2 : b);
}

/* The upper end of bin b. */
static double hist_top(int b) {
  if (b <= 0) return 0x1p-60;
  return ldexp(0.5 + (b % 8 + 1) / 16.0, b / 8 - 60);
}

/* 1 when bubble i lives on a plane and frames are on: its position follows from the step start
 * x0 + S_u du + S_v dv exactly, its tangents never change, and its normal is the face's. */
static inline int on_plane(const bub_state *s, int32_t i) {
  return s->kind[i] == BUB_KFACE && s->affine[s->cell[i]] && s->p.frame_tol > 0;
}

/* The room of plane bubble i at its parameters: the clearance disk (u, v, r) leaves r - |par - (u, v)|
 * in parameter space, at least that over pgain in object space (0 outside the disk). */
static inline double plane_room(const bub_state *s, int32_t i) {
  const double *cl = &s->clear[3 * i], *par = &s->par[2 * i];
  const double du = par[0] - cl[0], dv = par[1] - cl[1];
  const double left = cl[2] - sqrt(du * du + dv * dv);
  return left > 0 ? left / s->pgain[s->cell[i]] : 0;
}

/* Stage `stg` for bubbles [lo, hi): forces at ctx->src, the RK sums, the next stage's points (or
 * the step's end). The chunk's sums are formed in a local copy and stored once at the end: the
 * chunks' records share cache lines, and a store per bubble into them from two threads working
 * on neighbouring chunks made each thread's stage 30% slower (bench_bubble throughput). */
static void stage_chunk(bub_state *s, const stage_ctx *cx, int32_t lo, int32_t hi, bub_chunk *chunk,
                        double *tm, int32_t *hist) {
  bub_chunk local = *chunk, *out = &local;
  double acc[3 * BUB_CHUNK], dxc[3 * BUB_CHUNK], par[2 * BUB_CHUNK], x[3 * BUB_CHUNK], der[6 * BUB_CHUNK];
  int8_t rc[BUB_CHUNK];
  uint8_t need[BUB_CHUNK], plane[BUB_CHUNK];
  const int stg = cx->stg, last = stg + 1 == cx->nstage;
  const double m = cx->m, inv_m = 1 / cx->m, h = cx->h;
  for (int32_t i = lo; i < hi; ++i) plane[i - lo] = (uint8_t)on_plane(s, i);
  double t0 = pm_seconds();
  /* Forces, projected onto the cell at the stage point, and accelerations. */
  for (int32_t i = lo; i < hi; ++i) {
    double f[3];
    const int32_t q = i - lo;
    if (stg == 0)
      bub_force_sum(s, cx->src, i, cx->simd, f, &s->pot[i], &s->deg[i]);
    else
      bub_force_sum(s, cx->src, i, cx->simd, f, NULL, NULL);
    if (plane[q]) {
      const double *nrm = &s->normal[3 * s->cell[i]];
      pm_v3_axpy(f, f, -pm_v3_dot(f, nrm), nrm);
    } else {
      tangent_project(s->kind[i], stg == 0 ? &s->der[6 * i] : &s->ders[6 * i], f);
    }
    const double c = (s->flags[i] & BUB_FODD)                                ? cx->c_odd
                     : s->kind[i] == BUB_KFACE && !s->affine[s->cell[i]] ? cx->c_curved
                                                                          : cx->c_norm;
    const double *vs = stg == 0 ? &s->v[3 * i] : &s->vs[3 * i]; /* (stage 0's velocity is v) */
    if (cx->symplectic) { /* v' = v + h acc is (v + h f / m) / (1 + h c / m) */
      const double inv = 1 / (m + h * c);
      for (int k = 0; k < 3; ++k) acc[3 * q + k] = (f[k] - c * vs[k]) * inv;
    } else {
      for (int k = 0; k < 3; ++k) acc[3 * q + k] = (f[k] - c * vs[k]) * inv_m;
    }
    if (s->flags[i] & BUB_FHOLD) pm_v3_zero(&acc[3 * q]); /* (and v stays 0: it never moves) */
  }
  double t1 = pm_seconds();
  /* The RK sums and the displacement from the step start to the next point. */
  for (int32_t i = lo; i < hi; ++i) {
    const int32_t q = i - lo;
    double *sv = &s->sumv[3 * i], *sa = &s->suma[3 * i], *vs = &s->vs[3 * i];
    const double *v = &s->v[3 * i];
    const double *vst = stg == 0 ? v : vs; /* the stage's velocity */
    if (stg == 0) {
      out->kinetic += 0.5 * m * pm_v3_dot(v, v);
      out->potential += s->pot[i];
      if (s->kind[i] == BUB_KFACE) out->edev += fabs(s->deg[i] - 6.0), ++out->nface;
      if (s->kind[i] == BUB_KVOLUME) out->edev += fabs(s->deg[i] - 12.0), ++out->nface;
    }
    if (cx->symplectic) { /* the step moves with the new velocity: x' = x + h v' */
      for (int k = 0; k < 3; ++k) sa[k] = acc[3 * q + k], sv[k] = v[k] + h * acc[3 * q + k];
    } else if (stg == 0) { /* the sums start here (nothing to clear at the step's start) */
      for (int k = 0; k < 3; ++k) sv[k] = cx->w[0] * v[k], sa[k] = cx->w[0] * acc[3 * q + k];
    } else {
      for (int k = 0; k < 3; ++k) sv[k] += cx->w[stg] * vs[k], sa[k] += cx->w[stg] * acc[3 * q + k];
    }
    if (!last) {
      const double hc = cx->off[stg + 1] * h;
      for (int k = 0; k < 3; ++k) dxc[3 * q + k] = hc * vst[k], vs[k] = v[k] + hc * acc[3 * q + k];
    } else {
      for (int k = 0; k < 3; ++k) dxc[3 * q + k] = h * sv[k];
    }
  }
  double t2 = pm_seconds();
  /* Confinement: the parameter step (003 eq. 15, 001 eq. 7-9) and the shared clip rule. */
  for (int32_t i = lo; i < hi; ++i) {
    const int32_t q = i - lo;
    const double *x0 = &s->pos[0][4 * i];
    need[q] = 0;
    if (s->kind[i] == BUB_KVOLUME) {
      if (last) {
        rc[q] = (int8_t)bub_volume_move(s, i, x0, &dxc[3 * q], &x[3 * q]);
      } else {
        pm_v3_add(&x[3 * q], x0, &dxc[3 * q]);
        rc[q] = PM_MOVE_FREE;
      }
      for (int k = 0; k < 6; ++k) der[6 * q + k] = 0;
      par[2 * q] = par[2 * q + 1] = 0;
      continue;
    }
    if (plane[q]) {
      /* Within the room (the step start's clearance as an object-space ball): the point is
       * x0 + dx (dx is tangent) and inside; the parameters only at the step's end. */
      const double *dx = &dxc[3 * q], room = s->room[i];
      if (dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2] < room * room) {
        for (int k = 0; k < 3; ++k) x[3 * q + k] = x0[k] + dx[k];
        if (last) {
          const double *P = &s->pinv[6 * s->cell[i]], *par0 = &s->par[2 * i];
          par[2 * q] = par0[0] + (P[0] * dx[0] + P[1] * dx[1] + P[2] * dx[2]);
          par[2 * q + 1] = par0[1] + (P[3] * dx[0] + P[4] * dx[1] + P[5] * dx[2]);
        }
        rc[q] = PM_MOVE_FREE;
        continue;
      }
    }
    const pm_cell *c = pm_model_cell(s->model, s->kind[i], s->cell[i]);
    const double *par0 = &s->par[2 * i], *der0 = &s->der[6 * i];
    double dpar[3] = {0, 0, 0};
    if (plane[q]) { /* M^-1 J of the face, a constant (bub_state.c) */
      const double *P = &s->pinv[6 * s->cell[i]], *dx = &dxc[3 * q];
      dpar[0] = P[0] * dx[0] + P[1] * dx[1] + P[2] * dx[2];
      dpar[1] = P[3] * dx[0] + P[4] * dx[1] + P[5] * dx[2];
    } else {
      pm_cell_param_delta(c, par0, der0, &dxc[3 * q], dpar);
    }
    par[2 * q + 1] = 0;
    if (s->kind[i] == BUB_KFACE) {
      const double *cl = &s->clear[3 * i];
      const double u = par0[0] + dpar[0], v = par0[1] + dpar[1];
      if ((u - cl[0]) * (u - cl[0]) + (v - cl[1]) * (v - cl[1]) < cl[2] * cl[2]) {
        /* within the bubble's clearance: inside, no test, no wrap */
        par[2 * q] = u, par[2 * q + 1] = v, rc[q] = PM_MOVE_FREE;
      } else {
        rc[q] = (int8_t)pm_cell_move(c, par0, dpar, &par[2 * q]);
        if (last) clear_at(s, i, c, &par[2 * q]);
      }
    } else {
      rc[q] = (int8_t)pm_cell_move(c, par0, dpar, &par[2 * q]);
    }
    if (plane[q]) { /* (the tangents never change: der[] is not read for planes) */
      const double du = par[2 * q] - par0[0], dv = par[2 * q + 1] - par0[1];
      for (int k = 0; k < 3; ++k) x[3 * q + k] = x0[k] + der0[k] * du + der0[3 + k] * dv;
    } else {
      need[q] = 1;
    }
  }
  out->evals += confine(s, lo, hi, need, par, x, der, last);
  if (!last) {
    for (int32_t i = lo; i < hi; ++i) {
      const int32_t q = i - lo;
      double *P = &cx->dst[4 * i];
      P[0] = x[3 * q], P[1] = x[3 * q + 1], P[2] = x[3 * q + 2], P[3] = s->d[i];
      if (!plane[q]) memcpy(&s->ders[6 * i], &der[6 * q], sizeof(double) * 6);
      /* The skin test at the stage point, bounded from the step start's (the diameter is the
       * step's): |x - x_build| <= |x0 - x_build| + |x - x0|. */
      const double *x0 = &s->pos[0][4 * i];
      const double ex = x[3 * q] - x0[0], ey = x[3 * q + 1] - x0[1], ez = x[3 * q + 2] - x0[2];
      bub_top2_add(&out->skin, s->skin0[i] + sqrt(ex * ex + ey * ey + ez * ez));
    }
    double t3 = pm_seconds();
    tm[0] += t1 - t0, tm[1] += t2 - t1, tm[2] += t3 - t2;
    *chunk = local;
    return;
  }
  /* The step's end: velocity (tangent there; zero after a clip), state, displacement. */
  for (int32_t i = lo; i < hi; ++i) {
    const int32_t q = i - lo;
    double *v = &s->v[3 * i];
    pm_v3_axpy(v, v, h, &s->suma[3 * i]);
    if (plane[q]) {
      const double *nrm = &s->normal[3 * s->cell[i]];
      pm_v3_axpy(v, v, -pm_v3_dot(v, nrm), nrm);
    } else {
      tangent_project(s->kind[i], &der[6 * q], v);
      memcpy(&s->der[6 * i], &der[6 * q], sizeof(double) * 6);
    }
    if (rc[q] == PM_MOVE_CLIPPED) pm_v3_zero(v);
    s->disp[i] = pm_v3_dist(&x[3 * q], &s->pos[0][4 * i]);
    s->par[2 * i] = par[2 * q], s->par[2 * i + 1] = par[2 * q + 1];
    pm_v3_copy(&s->x[3 * i], &x[3 * q]);
  }
  double t3 = pm_seconds();
  /* The diameter where the bubble moved far enough, the sums, the skin test. */
  for (int32_t i = lo; i < hi; ++i) {
    s->dmoved[i] += s->disp[i];
    if (s->dmoved[i] > BUB_DTOL * s->d[i]) {
      s->dmoved[i] = 0;
      double d = pm_sizing_eval(s->size, &s->x[3 * i]);
      if (d > 0 && isfinite(d))
        s->d[i] = d;
      else
        out->bad_size = 1;
    }
    out->sum_disp += s->disp[i];
    if (s->disp[i] > out->max_disp) out->max_disp = s->disp[i];
    double rel = s->disp[i] / s->d[i];
    if (rel > out->max_rel) out->max_rel = rel;
    if (s->flags[i] & BUB_FHOLD) /* the quantile is the moving bubbles' */
      ++out->held;
    else
      hist[hist_bin(rel)]++;
  }
  double t4 = pm_seconds();
  tm[0] += t1 - t0, tm[1] += (t2 - t1) + (t4 - t3), tm[2] += t3 - t2;
  *chunk = local;
}

/* The skin test's excess of the step's start points after a build: every bubble's after a full
 * build, the bubbles whose build position changed after a partial one (bub_neighbors.c). */
static void renew_skin0(bub_state *s, int32_t a, int32_t b) {
  if (s->nb_nmoved < 0) {
    for (int32_t i = a; i < b; ++i) s->skin0[i] = bub_skin_excess(s, i, &s->pos[0][4 * i], s->d[i]);
  } else {
    for (int32_t k = 0; k < s->nb_nmoved; ++k) {
      const int32_t i = s->nb_moved[k];
      s->skin0[i] = bub_skin_excess(s, i, &s->pos[0][4 * i], s->d[i]);
    }
  }
}

/* The skin test over the chunks (fixed order). */
static int skin_failed(const bub_state *s, int64_t nchunk) {
  bub_top2 t = {-INFINITY, -INFINITY};
  for (int64_t c = 0; c < nchunk; ++c) bub_top2_add(&t, s->chunks[c].skin.e1), bub_top2_add(&t, s->chunks[c].skin.e2);
  return t.e1 + t.e2 > 0;
}

pm_status bub_dynamics_step(bub_state *s, bub_step_info *info, pm_error *err) {
  memset(info, 0, sizeof *info);
  pm_status st = scratch(s, err);
  if (st) return st;
  const int32_t n = s->n;
  int32_t a, b;
  bub_moving(s, &a, &b);
  const int T = bub_threads_for(s, b - a);
  double *timers = s->timers;
  for (int k = 0; k < 3 * T; ++k) timers[k] = 0;
  double t0 = pm_seconds();
  /* The step start, packed; the fixed bubbles' entries of the stage buffers with it when the set
   * of bubbles changed. */
  const int refill = !s->lists_valid;
  const int64_t nchunk = ((int64_t)(b - a) + BUB_CHUNK - 1) / BUB_CHUNK;
  memset(s->hist, 0, sizeof(int32_t) * BUB_HBINS * (size_t)s->threads);
  for (int32_t i = 0; i < n; i = (i + 1 == a) ? b : i + 1) { /* the fixed bubbles */
    if (i >= a && i < b) continue; /* only when a == 0 */
    double *P = &s->pos[0][4 * i];
    P[0] = s->x[3 * i], P[1] = s->x[3 * i + 1], P[2] = s->x[3 * i + 2], P[3] = s->d[i];
    if (refill) memcpy(&s->pos[1][4 * i], P, 32), memcpy(&s->pos[2][4 * i], P, 32);
  }
  /* The moving bubbles, with the skin test of the step's start points (a step ends with the same
   * points, but they may have been changed since: population control, a caller). */
#pragma omp parallel for num_threads(T) schedule(static) if (T > 1)
  for (int64_t c = 0; c < nchunk; ++c) {
    const int32_t lo = a + (int32_t)(c * BUB_CHUNK), hi = lo + BUB_CHUNK < b ? lo + BUB_CHUNK : b;
    bub_top2 t = {-INFINITY, -INFINITY};
    for (int32_t i = lo; i < hi; ++i) {
      double *P = &s->pos[0][4 * i];
      P[0] = s->x[3 * i], P[1] = s->x[3 * i + 1], P[2] = s->x[3 * i + 2], P[3] = s->d[i];
      s->room[i] = on_plane(s, i) ? plane_room(s, i) : 0;
      if (s->lists_valid) {
        s->skin0[i] = bub_skin_excess(s, i, P, P[3]);
        bub_top2_add(&t, s->skin0[i]);
      }
    }
    s->chunks[c].skin = t;
  }
  s->t.integrate += pm_seconds() - t0;
  if (s->lists_valid && skin_failed(s, nchunk)) s->lists_stale = 1;
  if (s->lists_stale || !s->lists_valid) {
    if ((st = bub_neighbors_update(s, s->pos[0], err))) return st;
    renew_skin0(s, a, b);
  }

  const double sq = sqrt(s->p.mass * s->p.k0);
  static const double w4[4] = {1.0 / 6, 1.0 / 3, 1.0 / 3, 1.0 / 6}, off4[4] = {0, 0.5, 0.5, 1};
  static const double w2[2] = {0.5, 0.5}, off2[2] = {0, 1};
  static const double w1[1] = {1}, off1[1] = {0};
  const int rk4 = s->p.integrator == BUB_RK4, sy = s->p.integrator == BUB_SYMPLECTIC;
  stage_ctx cx = {s->p.mass, bub_time_step(&s->p), 2 * bub_zeta_now(s) * sq, 2 * s->p.zeta_odd * sq,
                  2 * bub_zeta_curved(s) * sq, rk4 ? w4 : sy ? w1 : w2, rk4 ? off4 : sy ? off1 : off2, 0,
                  rk4 ? 4 : sy ? 1 : 2, sy, NULL, NULL, timers, bub_kernel_simd()};
  for (int stg = 0; stg < cx.nstage; ++stg) {
    cx.stg = stg;
    cx.src = stg == 0 ? s->pos[0] : s->pos[1 + ((stg - 1) & 1)];
    cx.dst = stg + 1 < cx.nstage ? s->pos[1 + (stg & 1)] : NULL;
    for (int64_t c = 0; c < nchunk; ++c) {
      memset(&s->chunks[c], 0, sizeof(bub_chunk));
      s->chunks[c].skin.e1 = s->chunks[c].skin.e2 = -INFINITY;
    }
#pragma omp parallel for num_threads(T) schedule(static) if (T > 1)
    for (int64_t c = 0; c < nchunk; ++c) {
#ifdef _OPENMP
      const int t = omp_get_thread_num();
#else
      const int t = 0;
#endif
      const int32_t lo = a + (int32_t)(c * BUB_CHUNK), hi = lo + BUB_CHUNK < b ? lo + BUB_CHUNK : b;
      stage_chunk(s, &cx, lo, hi, &s->chunks[c], &timers[3 * t], &s->hist[(size_t)BUB_HBINS * t]);
    }
    /* The next stage's points must pass the skin test before their forces are summed. */
    if (cx.dst && skin_failed(s, nchunk)) {
      s->lists_stale = 1;
      if ((st = bub_neighbors_update(s, cx.dst, err))) return st;
      renew_skin0(s, a, b); /* the step start against the new build, for the next stages' bounds */
    }
    int64_t nface = 0;
    for (int64_t c = 0; c < nchunk; ++c) {
      s->evals += s->chunks[c].evals;
      if (stg > 0) continue;
      info->kinetic += s->chunks[c].kinetic, info->potential += s->chunks[c].potential;
      info->eps_t += s->chunks[c].edev, nface += s->chunks[c].nface;
    }
    if (stg == 0) info->eps_t = nface > 0 ? info->eps_t / (double)nface : 0;
  }
  for (int t = 0; t < T; ++t) {
    s->t.force += timers[3 * t] / T;
    s->t.integrate += timers[3 * t + 1] / T;
    s->t.project += timers[3 * t + 2] / T;
  }
  /* The step's end: sums in chunk order, the skin test for the next step. */
  double sum = 0, mx = 0, mrel = 0;
  int bad = 0;
  int64_t held = 0;
  for (int64_t c = 0; c < nchunk; ++c) {
    const bub_chunk *ch = &s->chunks[c];
    sum += ch->sum_disp, mx = fmax(mx, ch->max_disp), mrel = fmax(mrel, ch->max_rel);
    bad |= ch->bad_size, held += ch->held;
  }
  if (bad)
    for (int32_t i = a; i < b; ++i) {
      double d;
      if ((st = bub_size_at(s, &s->x[3 * i], &d, err))) return st;
    }
  info->mean_disp = b > a ? sum / (b - a) : 0;
  info->max_disp = mx;
  info->max_rel_disp = mrel;
  /* The quantile from the threads' histograms (integer counts: the same sums in any order). */
  info->q_rel_disp = mrel;
  if (s->p.disp_quantile < 1 && b - a > held) {
    const int64_t want = (int64_t)ceil(s->p.disp_quantile * (double)(b - a - held));
    int64_t cum = 0;
    for (int k = 0; k < BUB_HBINS; ++k) {
      for (int t = 0; t < s->threads; ++t) cum += s->hist[(size_t)BUB_HBINS * t + k];
      if (cum >= want) {
        info->q_rel_disp = fmin(hist_top(k), mrel);
        break;
      }
    }
  }
  s->step++;
  s->steps_in_round++;
  s->bubble_steps += b - a;
  return PM_OK;
}
