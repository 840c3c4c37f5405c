/* Splitting and deleting (papers/001 eq. 3-6): a sparse patch splits, a crowded one deletes, the
 * annealed bias stops both, and the random choices follow the seed only. */
#include "test_psys_util.h"

/* A hexagonal patch of spacing x sigma; energies refreshed. */
static psys_sys *patch(pm_model *m, double x, uint64_t seed, int threads) {
  psys_params p;
  psys_params_init(&p);
  psys_sys *s = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(psys_sys_create(m, &p, NULL, seed, threads, 1000000, &s, &e), e);
  const double sigma = 0.1;
  psys_test_hex(s, x * sigma, sigma, 0.5, 0.5, 1.5, 1.5);
  psys_test_energies(s);
  return s;
}

static void sparse_patch_splits(void **state) {
  (void)state;
  pm_model *m = psys_test_square(2);
  /* spacing 0.9 sigma: E_i = 6 E(0.9) sigma = 0.011 E_ideal, far below 0.35 E_ideal / (1 + eps) */
  psys_sys *s = patch(m, 0.9, 1, 1);
  const int32_t n0 = s->n;
  for (int32_t i = 0; i < n0; ++i)
    assert_true(s->energy[i] < 0.35 / 2 * psys_ideal_energy(s->sigma[i]));
  int32_t sp, de;
  pm_error e = {0};
  PM_ASSERT_OK(psys_population_pass(s, 1.0, &sp, &de, &e), e);
  assert_int_equal(de, 0);
  assert_true(sp > 0);
  assert_int_equal(s->n, n0 + sp);
  /* A split marks its neighbourhood for this pass: no two neighbours split together, so at most
   * about one particle in seven (a particle and its one-ring) splits. */
  assert_true(sp <= n0 / 3);
  assert_true(sp >= n0 / 12);
  /* children lie on the face, beta sigma from a parent */
  for (int32_t i = n0; i < s->n; ++i) {
    assert_int_equal(s->dim[i], PM_FACE);
    double best = INFINITY;
    for (int32_t j = 0; j < n0; ++j) best = fmin(best, pm_v3_dist(&s->xyz[3 * i], &s->xyz[3 * j]));
    assert_true(best <= PSYS_BETA * 0.1 * (1 + 1e-9));
    assert_true(pm_face_inside(pm_model_cell(m, PM_FACE, 0), &s->par[2 * i]));
  }
  /* the neighbour lists, mended for the children, hold exactly the pairs they must */
  PM_ASSERT_OK(psys_nbr_update(s, &e), e);
  PM_ASSERT_OK(psys_nbr_check(s, &e), e);
  psys_sys_destroy(s);
  pm_model_destroy(m);
}

static void crowded_patch_deletes(void **state) {
  (void)state;
  pm_model *m = psys_test_square(2);
  /* spacing 0.4 sigma: E_i = 3.66 E_ideal > 1.75 E_ideal */
  psys_sys *s = patch(m, 0.4, 1, 1);
  const int32_t n0 = s->n;
  int interior_crowded = 0;
  for (int32_t i = 0; i < n0; ++i) interior_crowded += s->energy[i] > 1.75 * psys_ideal_energy(0.1);
  assert_true(interior_crowded > n0 / 2);
  int32_t sp, de;
  pm_error e = {0};
  PM_ASSERT_OK(psys_population_pass(s, 1.0, &sp, &de, &e), e);
  assert_int_equal(sp, 0);
  assert_true(de > 0);
  assert_int_equal(s->n, n0 - de);
  assert_true(de <= n0 / 3); /* never a particle and its neighbour in one pass */
  /* the neighbour lists follow the compaction */
  PM_ASSERT_OK(psys_nbr_update(s, &e), e);
  PM_ASSERT_OK(psys_nbr_check(s, &e), e);
  psys_sys_destroy(s);
  pm_model_destroy(m);
}

/* Gaps along a curve (phases 1-2): a chain of particles in the middle of one side of the square,
 * the side's vertices far from it. Each population pass puts a particle in the middle of every
 * stretch longer than 1.2 sigma between consecutive particles (vertices included), so the gaps
 * halve pass after pass instead of waiting for the chain's ends to split outward one particle
 * at a time; an almost annealed bias (a = 0.005) leaves eq. 4 out of it. */
static void curve_gaps_are_halved(void **state) {
  (void)state;
  pm_model *m = psys_test_square(2);
  psys_sys *s = psys_test_system(m, NULL, 1);
  pm_error e = {0};
  const double sigma = 0.1;
  for (int32_t v = 0; v < m->count[PM_VERTEX]; ++v)
    PM_ASSERT_OK(psys_add(s, PM_VERTEX, v, NULL, sigma, NULL, &e), e);
  const pm_cell *c = pm_model_cell(m, PM_CURVE, 0);
  const double lo = c->lo[0], hi = c->hi[0], len = 2;
  for (int k = -2; k <= 2; ++k) {
    double t = 0.5 * (lo + hi) + k * 0.06 * (hi - lo) / len;
    PM_ASSERT_OK(psys_add(s, PM_CURVE, 0, &t, sigma, NULL, &e), e);
  }
  psys_test_energies(s);
  int32_t sp, de;
  const int32_t n0 = s->n;
  PM_ASSERT_OK(psys_population_pass(s, 0.005, &sp, &de, &e), e);
  assert_int_equal(de, 0);
  /* the two stretches of 0.88 between the chain and the vertices: one particle each, at the
   * middle (the three empty sides get theirs from the empty-cell rule) */
  int32_t added = 0;
  for (int32_t i = n0; i < s->n; ++i) {
    if (s->dim[i] != PM_CURVE || s->cell[i] != 0) continue;
    double from_mid = fabs(s->par[2 * i] - 0.5 * (lo + hi)) * len / (hi - lo);
    PM_ASSERT_NEAR(from_mid, 0.12 + 0.44, 1e-9);
    ++added;
  }
  assert_int_equal(added, 2);
  /* log2(0.88 / 0.12) = 3 halvings: after three more passes no stretch of the side is longer
   * than 1.2 sigma (the isolated children, E_i = 0, also split by eq. 4 meanwhile) */
  for (int pass = 0; pass < 3; ++pass) {
    psys_test_energies(s);
    PM_ASSERT_OK(psys_population_pass(s, 0.005, &sp, &de, &e), e);
  }
  double t[64];
  int nt = 0;
  t[nt++] = 0, t[nt++] = len;
  for (int32_t i = 0; i < s->n && nt < 64; ++i)
    if (s->dim[i] == PM_CURVE && s->cell[i] == 0) t[nt++] = (s->par[2 * i] - lo) * len / (hi - lo);
  for (int i = 1; i < nt; ++i)
    for (int j = i; j > 0 && t[j] < t[j - 1]; --j) {
      double x = t[j];
      t[j] = t[j - 1], t[j - 1] = x;
    }
  double widest = 0;
  for (int i = 0; i + 1 < nt; ++i) widest = fmax(widest, t[i + 1] - t[i]);
  assert_true(widest <= 1.2 * sigma);
  psys_sys_destroy(s);
  pm_model_destroy(m);
}

/* The annealing weight a: E* = E (1 + a eps); split below 0.35 a E_ideal, delete above
 * 1.75 E_ideal / a. As a falls both stop. */
static void annealing_stops_splits_and_deletes(void **state) {
  (void)state;
  pm_model *m = psys_test_square(2);
  pm_error e = {0};
  int32_t sp, de;
  psys_sys *s = patch(m, 0.9, 1, 1);
  PM_ASSERT_OK(psys_population_pass(s, 0.005, &sp, &de, &e), e);
  assert_int_equal(sp, 0);
  assert_int_equal(de, 0);
  psys_sys_destroy(s);
  s = patch(m, 0.4, 1, 1);
  PM_ASSERT_OK(psys_population_pass(s, 0.3, &sp, &de, &e), e);
  assert_int_equal(sp + de, 0);
  psys_sys_destroy(s);
  /* a = 0 is "population control off" */
  s = patch(m, 0.9, 1, 1);
  PM_ASSERT_OK(psys_population_pass(s, 0, &sp, &de, &e), e);
  assert_int_equal(sp + de, 0);
  psys_sys_destroy(s);
  pm_model_destroy(m);
}

/* The ideal lattice (beta sigma) neither splits nor deletes at its exact ideal energy unless the
 * bias eps pushes E* above 1.75 E_ideal: with E = E_ideal that needs eps > 0.75, about a quarter
 * of the particles, and only the interior has E = E_ideal. */
static void bias_draws_follow_the_seed(void **state) {
  (void)state;
  pm_model *m = psys_test_square(2);
  pm_error e = {0};
  int32_t sp1, de1, sp2, de2, sp3, de3;
  psys_sys *a = patch(m, PSYS_BETA, 7, 1);
  psys_sys *b = patch(m, PSYS_BETA, 7, 2);
  psys_sys *c = patch(m, PSYS_BETA, 8, 1);
  const int32_t n0 = a->n;
  PM_ASSERT_OK(psys_population_pass(a, 1, &sp1, &de1, &e), e);
  PM_ASSERT_OK(psys_population_pass(b, 1, &sp2, &de2, &e), e);
  PM_ASSERT_OK(psys_population_pass(c, 1, &sp3, &de3, &e), e);
  /* interior particles sit at E_ideal: some are deleted by the bias, none split */
  assert_true(de1 > 0 && de1 < n0 / 3);
  /* same seed, any thread count: the same particles, to the bit */
  assert_int_equal(sp1, sp2);
  assert_int_equal(de1, de2);
  assert_int_equal(a->n, b->n);
  assert_memory_equal(a->xyz, b->xyz, sizeof(double) * 3 * (size_t)a->n);
  /* another seed draws other eps */
  assert_true(de3 != de1 || memcmp(a->xyz, c->xyz, sizeof(double) * 3 * (size_t)a->n) != 0);
  psys_sys_destroy(a), psys_sys_destroy(b), psys_sys_destroy(c);
  pm_model_destroy(m);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(sparse_patch_splits),
      cmocka_unit_test(crowded_patch_deletes),
      cmocka_unit_test(curve_gaps_are_halved),
      cmocka_unit_test(annealing_stops_splits_and_deletes),
      cmocka_unit_test(bias_draws_follow_the_seed),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
