/* The equation of motion of the bubbles (papers/003 eq. 12-15, papers/000 section 5.5,
 * papers/004 section 2.2):
 *     m x_i'' + c_i x_i' = f_i,   f_i = sum_j F(|x_i - x_j|, l0_ij) (x_i - x_j) / |x_i - x_j|,
 * for every curve and face bubble, over the bubbles it feels (bub_related); vertex bubbles are
 * fixed. Integrated by the classic fourth-order Runge-Kutta method (003 section 3.4) or by Heun's
 * second-order scheme (the "second-order" scheme of 004 section 1 / its reference [23]).
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
 * (it does not contain the imaginary axis), hence its default 0.05. bub_params_check verifies
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
 * Threads: every stage computes all forces from the stage positions (Jacobi style) and each
 * bubble's force sums over its sorted neighbour list, so the result does not depend on the thread
 * count.
 */
#include "bubble/bub_private.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/rng.h"
#include "common/vec3.h"

/* Re-evaluate d(x) after a bubble moved this fraction of its diameter (see above). */
#define BUB_DTOL 0.01

double bub_time_step(const bub_params *p) {
  double frac = p->dt > 0 ? p->dt : (p->integrator == BUB_RK4 ? 0.1 : 0.05);
  return frac * 2 * M_PI * sqrt(p->mass / p->k0);
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
  if (s->scratch_cap >= s->n) return PM_OK;
  int32_t nc = s->n + s->n / 4 + 64;
#define R(ptr, per)                                                                   \
  do {                                                                                \
    void *np = realloc(s->ptr, sizeof(*s->ptr) * (size_t)(per) * (size_t)nc);        \
    if (!np) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");                \
    s->ptr = np;                                                                      \
  } while (0)
  R(xs, 3);
  R(vs, 3);
  R(as, 3);
  R(ders, 6);
  R(pars, 2);
  R(sumv, 3);
  R(suma, 3);
  R(x0, 3);
  R(pot, 1);
  R(disp, 1);
  R(deg, 1);
#undef R
  s->scratch_cap = nc;
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

/* A unit direction for a coincident pair, from (seed, pair), pointing from j to i. */
static void pair_direction(uint64_t seed, int32_t i, int32_t j, double u[3]) {
  int32_t a = i < j ? i : j, b = i < j ? j : i;
  pm_rng r;
  pm_rng_init(&r, seed, ((uint64_t)(uint32_t)a << 32) | (uint32_t)b);
  double z = pm_rng_range(&r, -1, 1), phi = pm_rng_range(&r, 0, 2 * M_PI), q = sqrt(1 - z * z);
  u[0] = q * cos(phi), u[1] = q * sin(phi), u[2] = z;
  if (i > j) pm_v3_scale(u, u, -1);
}

/* Force on bubble i at the stage positions xs (object space, before projection). */
static void force_on(const bub_state *s, int32_t i, const double *xs, double f[3], double *pot,
                     int32_t *deg) {
  const double k0 = s->p.k0, di = s->d[i];
  const double *xi = &xs[3 * i];
  pm_v3_zero(f);
  double u = 0;
  int32_t nd = 0;
  for (int32_t k = s->nb_off[i]; k < s->nb_off[i + 1]; ++k) {
    int32_t j = s->nb[k];
    double r[3];
    pm_v3_sub(r, xi, &xs[3 * j]);
    double l = pm_v3_norm(r), l0 = 0.5 * (di + s->d[j]);
    if (l >= 1.5 * l0) continue;
    if (l < 1.3 * l0) ++nd;
    double F = bub_force(k0, l, l0);
    if (pot) u += 0.5 * bub_potential(k0, l, l0);
    if (l > 1e-12 * l0) {
      pm_v3_axpy(f, f, F / l, r);
    } else {
      double dir[3];
      pair_direction(s->seed, i, j, dir);
      pm_v3_axpy(f, f, F, dir);
    }
  }
  if (pot) *pot = u;
  if (deg) *deg = nd;
}

/* Displace bubble i from its step-start state by dx; writes the stage parameters and position
 * and derivatives there. Returns PM_MOVE_FREE / PM_MOVE_CLIPPED. */
static int stage_move(const bub_state *s, int32_t i, const double dx[3], double *par_out,
                      double *x_out, double *der_out) {
  if (s->kind[i] == BUB_KVOLUME) { /* a free stage point */
    pm_v3_add(x_out, &s->x[3 * i], dx);
    for (int k = 0; k < 6; ++k) der_out[k] = 0;
    par_out[0] = par_out[1] = 0;
    return PM_MOVE_FREE;
  }
  const pm_cell *c = pm_model_cell(s->model, s->kind[i], s->cell[i]);
  double dpar[3] = {0, 0, 0};
  pm_cell_param_delta(c, &s->par[2 * i], &s->der[6 * i], dx, dpar);
  int r = pm_cell_move(c, &s->par[2 * i], dpar, par_out);
  if (s->kind[i] == BUB_KCURVE) {
    pm_curve_point cp;
    pm_curve_eval(c, par_out[0], 1, &cp);
    pm_v3_copy(x_out, cp.p);
    pm_v3_copy(der_out, cp.d1);
    pm_v3_zero(der_out + 3);
  } else {
    pm_face_point fp;
    pm_face_eval(c, par_out, 1, &fp);
    pm_v3_copy(x_out, fp.p);
    pm_v3_copy(der_out, fp.su);
    pm_v3_copy(der_out + 3, fp.sv);
  }
  return r;
}

pm_status bub_dynamics_step(bub_state *s, bub_step_info *info, pm_error *err) {
  memset(info, 0, sizeof *info);
  pm_status st = scratch(s, err);
  if (!st) st = bub_neighbors_update(s, err);
  if (st) return st;
  const int32_t n = s->n;
  int32_t a, b;
  bub_moving(s, &a, &b);
  const double m = s->p.mass, h = bub_time_step(&s->p), sq = sqrt(s->p.mass * s->p.k0);
  const double c_norm = 2 * bub_zeta_now(s) * sq, c_odd = 2 * s->p.zeta_odd * sq;
  const int rk4 = s->p.integrator == BUB_RK4, nstage = rk4 ? 4 : 2;
  static const double w4[4] = {1.0 / 6, 1.0 / 3, 1.0 / 3, 1.0 / 6}, off4[4] = {0, 0.5, 0.5, 1};
  static const double w2[2] = {0.5, 0.5}, off2[2] = {0, 1};
  const double *w = rk4 ? w4 : w2, *off = rk4 ? off4 : off2;

  memcpy(s->xs, s->x, sizeof(double) * 3 * (size_t)n);
  memcpy(s->x0, s->x, sizeof(double) * 3 * (size_t)n);
  memcpy(s->vs, s->v, sizeof(double) * 3 * (size_t)n);
  memcpy(s->ders, s->der, sizeof(double) * 6 * (size_t)n);
  memcpy(s->pars, s->par, sizeof(double) * 2 * (size_t)n);
  memset(s->sumv, 0, sizeof(double) * 3 * (size_t)n);
  memset(s->suma, 0, sizeof(double) * 3 * (size_t)n);
  const int T = bub_threads_for(s, b - a);

  for (int stg = 0; stg < nstage; ++stg) {
    /* Accelerations at the stage positions. */
#pragma omp parallel for num_threads(T) schedule(static)
    for (int32_t i = a; i < b; ++i) {
      double f[3];
      force_on(s, i, s->xs, f, stg == 0 ? &s->pot[i] : NULL, stg == 0 ? &s->deg[i] : NULL);
      tangent_project(s->kind[i], &s->ders[6 * i], f);
      double c = (s->flags[i] & BUB_FODD) ? c_odd : c_norm;
      for (int k = 0; k < 3; ++k) s->as[3 * i + k] = (f[k] - c * s->vs[3 * i + k]) / m;
    }
    /* Accumulate, and move to the next stage's point (from the step start). */
#pragma omp parallel for num_threads(T) schedule(static)
    for (int32_t i = a; i < b; ++i) {
      double *sv = &s->sumv[3 * i], *sa = &s->suma[3 * i], *vs = &s->vs[3 * i];
      pm_v3_axpy(sv, sv, w[stg], vs);
      pm_v3_axpy(sa, sa, w[stg], &s->as[3 * i]);
      if (stg + 1 < nstage) {
        double hc = off[stg + 1] * h, dx[3];
        pm_v3_scale(dx, vs, hc);
        stage_move(s, i, dx, &s->pars[2 * i], &s->xs[3 * i], &s->ders[6 * i]);
        pm_v3_axpy(vs, &s->v[3 * i], hc, &s->as[3 * i]);
      }
    }
  }

  /* Energies at the step start (from the first stage). */
  double kin = 0, pot = 0, edev = 0;
  int32_t nface = 0;
  for (int32_t i = a; i < b; ++i) {
    kin += 0.5 * m * pm_v3_dot(&s->v[3 * i], &s->v[3 * i]);
    pot += s->pot[i];
    if (s->kind[i] == BUB_KFACE) edev += fabs(s->deg[i] - 6.0), ++nface;
    if (s->kind[i] == BUB_KVOLUME) edev += fabs(s->deg[i] - 12.0), ++nface;
  }

  /* The step. */
  int bad = 0;
#pragma omp parallel for num_threads(T) schedule(static) reduction(| : bad)
  for (int32_t i = a; i < b; ++i) {
    double dx[3], npar[2] = {0, 0}, nx[3], nder[6];
    pm_v3_scale(dx, &s->sumv[3 * i], h);
    int r;
    if (s->kind[i] == BUB_KVOLUME) {
      r = bub_volume_move(s, i, &s->x0[3 * i], dx, nx);
      for (int k = 0; k < 6; ++k) nder[k] = 0;
    } else {
      r = stage_move(s, i, dx, npar, nx, nder);
    }
    double *v = &s->v[3 * i];
    pm_v3_axpy(v, v, h, &s->suma[3 * i]);
    tangent_project(s->kind[i], nder, v);
    if (r == PM_MOVE_CLIPPED) pm_v3_zero(v);
    s->disp[i] = pm_v3_dist(nx, &s->x0[3 * i]);
    s->par[2 * i] = npar[0], s->par[2 * i + 1] = npar[1];
    pm_v3_copy(&s->x[3 * i], nx);
    memcpy(&s->der[6 * i], nder, sizeof nder);
    s->dmoved[i] += s->disp[i];
    if (s->dmoved[i] > BUB_DTOL * s->d[i]) {
      s->dmoved[i] = 0;
      double d = pm_sizing_eval(s->size, nx);
      if (d > 0 && isfinite(d))
        s->d[i] = d;
      else
        bad = 1;
    }
  }
  if (bad)
    for (int32_t i = a; i < b; ++i) {
      double d;
      if ((st = bub_size_at(s, &s->x[3 * i], &d, err))) return st;
    }

  double sum = 0, mx = 0, mrel = 0;
  for (int32_t i = a; i < b; ++i) {
    sum += s->disp[i];
    if (s->disp[i] > mx) mx = s->disp[i];
    double rel = s->disp[i] / s->d[i];
    if (rel > mrel) mrel = rel;
  }
  info->kinetic = kin, info->potential = pot;
  info->mean_disp = b > a ? sum / (b - a) : 0;
  info->max_disp = mx;
  info->max_rel_disp = mrel;
  info->eps_t = nface ? edev / nface : 0;
  s->step++;
  s->steps_in_round++;
  return PM_OK;
}
