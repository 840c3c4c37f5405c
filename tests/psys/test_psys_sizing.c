/* The inferred sizing field (papers/001 eq. 11-15, Algorithm 2): the Lipschitz closure, the
 * growth cap, and the curvature bound on a sphere with the limits of eq. 12-13 (the gap size is
 * tested on the thin flange in test_psys_flange.c). */
#include "test_psys_util.h"

#include "common/input/input.h"

/* After an update, no neighbour pair (|r_ij| < max(sigma_i, sigma_j)) violates
 * |sigma_i - sigma_j| <= L |r_ij|, every sigma lies within [sigma_min, its own bound], and each
 * one is tight: its own bound, or max(|r_ij|, sigma_j + L |r_ij|) for some particle j (the
 * closure is the largest field below the bounds whose neighbour pairs obey the bound). */
static void lipschitz_bound_holds_after_update(void **state) {
  (void)state;
  pm_model *m = psys_test_square(1);
  psys_params p;
  psys_params_init(&p);
  p.sigma_grow = 100; /* let the bounds, not the growth cap, decide */
  psys_sys *s = psys_test_system(m, &p, 2);
  pm_rng r;
  pm_rng_init(&r, 3, 0);
  pm_error e = {0};
  const int n = 800;
  for (int k = 0; k < n; ++k) {
    double uv[2] = {pm_rng_range(&r, 0.02, 0.98), pm_rng_range(&r, 0.02, 0.98)};
    PM_ASSERT_OK(psys_add(s, PM_FACE, 0, uv, 0.05, NULL, &e), e);
  }
  /* bounds spread over a factor 20: a field far from Lipschitz */
  double *bound = malloc(sizeof(double) * n);
  for (int i = 0; i < n; ++i) {
    bound[i] = exp(pm_rng_range(&r, log(0.01), log(0.2)));
    s->sig_curv[i] = bound[i];
    psys_set_sigma(s, i, bound[i]);
  }
  PM_ASSERT_OK(psys_sigma_update(s, &e), e);
  const double L = p.lipschitz;
  int pairs = 0, tight_lip = 0;
  for (int i = 0; i < n; ++i) {
    const double si = s->sigma[i];
    assert_true(si >= s->sigma_min);
    assert_true(si <= fmin(bound[i], s->sigma_max) * (1 + 1e-15));
    int tight = si == fmin(bound[i], s->sigma_max);
    for (int j = 0; j < n; ++j) {
      if (j == i) continue;
      double rij = pm_v3_dist(&s->xyz[3 * i], &s->xyz[3 * j]);
      if (rij < fmax(si, s->sigma[j])) {
        ++pairs;
        if (!(fabs(si - s->sigma[j]) <= L * rij * (1 + 1e-12)))
          fail_msg("pair %d-%d: |%g - %g| > L |r| = %g", i, j, si, s->sigma[j], L * rij);
      }
      if (fabs(si - fmax(rij, s->sigma[j] + L * rij)) <= 1e-12 * si) tight = 1, ++tight_lip;
    }
    if (!tight) fail_msg("particle %d: sigma %g is neither its bound nor Lipschitz-tight", i, si);
  }
  assert_true(pairs > 1000);
  assert_true(tight_lip > n / 4); /* the closure lowered many */
  free(bound);
  psys_sys_destroy(s);
  pm_model_destroy(m);
}

/* Growth: a sigma rises by at most sigma_grow per update; falls are immediate. */
static void sigma_rise_is_capped(void **state) {
  (void)state;
  pm_model *m = psys_test_square(1);
  psys_sys *s = psys_test_system(m, NULL, 1);
  pm_error e = {0};
  double uv[2] = {0.5, 0.5};
  int32_t i;
  PM_ASSERT_OK(psys_add(s, PM_FACE, 0, uv, 0.001, &i, &e), e);
  /* a plane: the curvature bound is sigma_max = diagonal / 10 */
  PM_ASSERT_NEAR(s->sig_curv[i], m->diagonal / 10, 1e-12);
  double prev = s->sigma[i];
  for (int it = 0; it < 40; ++it) {
    PM_ASSERT_OK(psys_sigma_update(s, &e), e);
    assert_true(s->sigma[i] <= prev * s->p.sigma_grow * (1 + 1e-15));
    prev = s->sigma[i];
  }
  PM_ASSERT_NEAR(s->sigma[i], s->sigma_max, 1e-15);
  s->sig_curv[i] = 0.003;
  PM_ASSERT_OK(psys_sigma_update(s, &e), e);
  PM_ASSERT_NEAR(s->sigma[i], 0.003, 1e-15);
  psys_sys_destroy(s);
  pm_model_destroy(m);
}

/* A particle added without a sigma starts at its curvature bound (sigma_max on a plane) and the
 * system counts as unsized until an update has run; phase 3 holds sigma only after that
 * (psys_phases.c), so a face seeded again in the last population pass is not held at sigma_max
 * among neighbours 14 times smaller. */
static void a_new_seed_is_sized_before_sigma_is_held(void **state) {
  (void)state;
  pm_model *m = psys_test_square(1);
  psys_sys *s = psys_test_system(m, NULL, 1);
  pm_error e = {0};
  const double sigma = 0.01;
  psys_test_hex(s, PSYS_BETA * sigma, sigma, 0.3, 0.3, 0.7, 0.7);
  assert_int_equal(s->unsized, 0);
  double uv[2] = {0.5, 0.5 + 0.25 * PSYS_BETA * sigma};
  int32_t i;
  PM_ASSERT_OK(psys_add(s, PM_FACE, 0, uv, 0, &i, &e), e);
  assert_int_equal(s->unsized, 1);
  PM_ASSERT_NEAR(s->sigma[i], s->sigma_max, 1e-15);
  PM_ASSERT_OK(psys_sigma_update(s, &e), e);
  assert_int_equal(s->unsized, 0);
  /* the Lipschitz closure from its neighbours, which grew by at most sigma_grow = 1.5:
   * sigma_i <= 1.5 sigma + L r, far below sigma_max = 14 sigma */
  assert_true(s->sigma[i] <= (1.5 + 0.3 * PSYS_BETA) * sigma * (1 + 1e-12));
  psys_sys_destroy(s);
  pm_model_destroy(m);
}

/* Phases 1-3 of the inferred field on case:sphere (radius 1); returns the system. */
static psys_sys *sphere(pm_model **mp, double kappa_min, double kappa_max, double s_kappa) {
  pm_error e = {0};
  PM_ASSERT_OK(pm_input_open("case:sphere", mp, NULL, &e), e);
  psys_params p;
  psys_params_init(&p);
  p.kappa_min = kappa_min, p.kappa_max = kappa_max, p.s_kappa = s_kappa;
  psys_sys *s = NULL;
  PM_ASSERT_OK(psys_sys_create(*mp, &p, NULL, 1, 2, 1000000, &s, &e), e);
  psys_phase_report rep[3];
  PM_ASSERT_OK(psys_optimize(s, NULL, rep, &e), e);
  assert_true(rep[2].converged);
  return s;
}

/* Curvature alone (a sphere has no gap): sigma settles at R / s_kappa everywhere, unless
 * eq. 12-13 bound it. */
static void sphere_sigma_is_radius_over_s_kappa(void **state) {
  (void)state;
  pm_model *m = NULL;
  /* limits far away: sigma = 1 / (2 x 1) */
  psys_sys *s = sphere(&m, 0.01, 100, 2);
  int faces = 0;
  for (int32_t i = 0; i < s->n; ++i) {
    faces += s->dim[i] == PM_FACE;
    PM_ASSERT_NEAR(s->sigma[i], 0.5, 1e-6);
  }
  assert_true(faces > 30);
  psys_sys_destroy(s);
  pm_model_destroy(m);
  /* s_kappa = 4: R / 4 */
  s = sphere(&m, 0.01, 100, 4);
  for (int32_t i = 0; i < s->n; ++i) PM_ASSERT_NEAR(s->sigma[i], 0.25, 1e-6);
  int32_t n4 = s->n;
  psys_sys_destroy(s);
  pm_model_destroy(m);
  assert_true(n4 > 3 * faces); /* half the sigma, four times the particles, roughly */
  /* eq. 13: kappa_min = 2.5 > 1 caps sigma at sigma_max = 1 / (2 x 2.5) = 0.2 */
  s = sphere(&m, 2.5, 100, 2);
  PM_ASSERT_NEAR(s->sigma_max, 0.2, 1e-15);
  for (int32_t i = 0; i < s->n; ++i) PM_ASSERT_NEAR(s->sigma[i], 0.2, 1e-12);
  psys_sys_destroy(s);
  pm_model_destroy(m);
  /* eq. 12: kappa_max = 0.8 < 1 raises sigma to sigma_min = 1 / (2 x 0.8) = 0.625 */
  s = sphere(&m, 0.01, 0.8, 2);
  PM_ASSERT_NEAR(s->sigma_min, 0.625, 1e-15);
  for (int32_t i = 0; i < s->n; ++i) PM_ASSERT_NEAR(s->sigma[i], 0.625, 1e-12);
  psys_sys_destroy(s);
  pm_model_destroy(m);
  /* the defaults: kappa_min = 5 / diagonal, sigma_max = diagonal / 10 = 0.346 < R / 2 */
  s = sphere(&m, 0, 0, 2);
  PM_ASSERT_NEAR(s->sigma_max, m->diagonal / 10, 1e-12);
  for (int32_t i = 0; i < s->n; ++i) PM_ASSERT_NEAR(s->sigma[i], m->diagonal / 10, 1e-12);
  psys_sys_destroy(s);
  pm_model_destroy(m);
}


/* A random displacement of every movable particle along its cell (up to `far` sigma) and a
 * random factor on every free sigma, so that neither the lists nor the last field fit. */
static void shake(psys_sys *s, pm_rng *r, double far) {
  pm_error e = {0};
  for (int32_t i = 0; i < s->n; ++i) {
    if (!s->fixed[i]) {
      const pm_cell *c = pm_model_cell(s->model, s->dim[i], s->cell[i]);
      double dx[3] = {pm_rng_range(r, -far, far) * s->sigma[i],
                      pm_rng_range(r, -far, far) * s->sigma[i],
                      pm_rng_range(r, -far, far) * s->sigma[i]};
      double par[2] = {s->par[2 * i], s->par[2 * i + 1]}, x[3];
      pm_cell_displace(c, &s->par[2 * i], dx, par);
      pm_cell_point(c, par, x);
      s->par[2 * i] = par[0], s->par[2 * i + 1] = par[1];
      psys_set_xyz(s, i, x);
    }
    if (!s->frozen[i]) psys_set_sigma(s, i, s->sigma[i] * exp(pm_rng_range(r, -0.7, 0.35)));
  }
  (void)e;
}

/* Compare the incremental update with the field computed from scratch (psys_sigma_reference):
 * equal to 1e-12 relative. Returns how many particles the gap bounds (s_tau x gap is their
 * bound before the closure). */
static int32_t compare_with_reference(psys_sys *s) {
  pm_error e = {0};
  double *ref = malloc(sizeof(double) * (size_t)s->n);
  PM_ASSERT_OK(psys_sigma_reference(s, ref, &e), e);
  /* how many gaps bind, from the lists the update will use */
  PM_ASSERT_OK(psys_nbr_update(s, &e), e);
  int32_t gaps = 0;
  for (int32_t i = 0; i < s->n; ++i)
    if (psys_gap_active(s, i))
      gaps += s->p.s_tau * psys_gap_distance(s, i) < fmin(s->sig_curv[i], s->p.sigma_grow * s->sigma[i]);
  PM_ASSERT_OK(psys_sigma_update(s, &e), e);
  for (int32_t i = 0; i < s->n; ++i)
    if (!(fabs(s->sigma[i] - ref[i]) <= 1e-12 * ref[i]))
      fail_msg("particle %d: incremental sigma %.17g, from scratch %.17g", (int)i, s->sigma[i],
               ref[i]);
  free(ref);
  return gaps;
}

/* The incremental gap and Lipschitz updates (neighbour and gap lists kept from update to update,
 * the closure settled from the particles their neighbours' bounds lower) give the sigma that a
 * computation from scratch gives (a fresh grid, Dijkstra over every particle), to 1e-12, on
 * random states of phase 2 (curves and vertices, the gap between non-adjacent cells) and phase 3
 * (faces: the width through a face, the cells across a wall) of a box with a hole. */
static void incremental_sigma_matches_full_recomputation(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_input_open("case:boxhole", &m, NULL, &e), e);
  psys_params p;
  psys_params_init(&p);
  p.max_iter = 25; /* a state on the way, not a converged one */
  psys_sys *s = psys_test_system(m, &p, 2);
  psys_phase_report rep;
  PM_ASSERT_OK(psys_run_phase(s, 1, NULL, NULL, &rep, &e), e);
  PM_ASSERT_OK(psys_run_phase(s, 2, NULL, NULL, &rep, &e), e);
  pm_rng r;
  pm_rng_init(&r, 11, 0);
  int32_t gaps2 = 0;
  for (int round = 0; round < 4; ++round) {
    shake(s, &r, 0.3);
    gaps2 += compare_with_reference(s);
  }
  assert_true(gaps2 > 10);
  PM_ASSERT_OK(psys_run_phase(s, 3, NULL, NULL, &rep, &e), e);
  assert_true(s->n > s->nfrozen + 200);
  int32_t gaps3 = 0;
  for (int round = 0; round < 4; ++round) {
    shake(s, &r, round == 0 ? 0.05 : 0.4);
    gaps3 += compare_with_reference(s);
    /* a population pass between rounds: lists follow splits, deletes and compaction */
    int32_t sp, de;
    PM_ASSERT_OK(psys_population_pass(s, 1.0, &sp, &de, &e), e);
  }
  assert_true(gaps3 > 10);
  psys_sys_destroy(s);
  pm_model_destroy(m);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(incremental_sigma_matches_full_recomputation),
      cmocka_unit_test(lipschitz_bound_holds_after_update),
      cmocka_unit_test(sigma_rise_is_capped),
      cmocka_unit_test(a_new_seed_is_sized_before_sigma_is_held),
      cmocka_unit_test(sphere_sigma_is_radius_over_s_kappa),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
