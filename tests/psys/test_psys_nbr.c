/* The neighbour structure (psys_nbr.c): after random moves, sigma changes, additions, deletions
 * and reorderings, an update leaves every neighbour and gap list holding exactly the pairs of
 * its relation (psys_nbr_check, a brute-force scan over all pairs), whether it renewed a few lists
 * or all of them; a run's particles do not depend on how the lists were kept; the move pass's
 * quick test that its kept colouring still holds never passes a conflicting one; and a kept
 * colouring with a few conflicts is mended by colouring the particles in them alone. */
#include "test_psys_run_util.h"

/* Move each movable particle with probability `share` by up to `far` sigma along its cell, and
 * change its sigma by a random factor in [lo, hi]. */
static void stir(psys_sys *s, pm_rng *r, double share, double far, double lo, double hi) {
  for (int32_t i = 0; i < s->n; ++i) {
    if (pm_rng_uniform(r) > share) continue;
    if (!s->fixed[i]) {
      const pm_cell *c = pm_model_cell(s->model, s->dim[i], s->cell[i]);
      double dx[3], par[2] = {s->par[2 * i], s->par[2 * i + 1]}, x[3];
      for (int k = 0; k < 3; ++k) dx[k] = pm_rng_range(r, -far, far) * s->sigma[i];
      pm_cell_displace(c, &s->par[2 * i], dx, par);
      pm_cell_point(c, par, x);
      s->par[2 * i] = par[0], s->par[2 * i + 1] = par[1];
      psys_set_xyz(s, i, x);
    }
    if (!s->frozen[i]) psys_set_sigma(s, i, s->sigma[i] * pm_rng_range(r, lo, hi));
  }
}

static void check(psys_sys *s) {
  pm_error e = {0};
  PM_ASSERT_OK(psys_nbr_update(s, &e), e);
  PM_ASSERT_OK(psys_nbr_check(s, &e), e);
}

/* A two-thread system on case:boxhole (model m) after phases 1 to 3 of 20 iterations each. */
static psys_sys *boxhole_phase3(const pm_model *m) {
  psys_params p;
  psys_params_init(&p);
  p.max_iter = 20;
  psys_sys *s = psys_test_system(m, &p, 2);
  pm_error e = {0};
  psys_phase_report rep;
  for (int ph = 1; ph <= 3; ++ph) PM_ASSERT_OK(psys_run_phase(s, ph, NULL, NULL, &rep, &e), e);
  return s;
}

/* Phase 3 on a box with a hole: face particles hold neighbour and gap lists, the frozen curve and
 * vertex particles neighbour lists only. */
static void lists_follow_random_changes(void **state) {
  (void)state;
  pm_model *m = psys_test_open("case:boxhole");
  psys_sys *s = boxhole_phase3(m);
  pm_error e = {0};
  assert_true(s->nbr.gp.on);
  check(s);
  pm_rng r;
  pm_rng_init(&r, 5, 0);
  const int64_t renewed0 = s->nbr.nb.renewed + s->nbr.gp.renewed;
  for (int round = 0; round < 12; ++round) {
    /* few particles (lists mended one by one) or many (all made again) */
    stir(s, &r, round % 3 == 2 ? 0.6 : 0.05, 0.3, 0.8, 1.3);
    check(s);
    if (round % 4 == 1) {
      /* deletions (compaction: every index after the first deleted one shifts) */
      uint8_t *dead = calloc((size_t)s->n, 1);
      for (int32_t i = s->nfrozen; i < s->n; ++i) dead[i] = pm_rng_uniform(&r) < 0.1;
      PM_ASSERT_OK(psys_compact(s, dead, &e), e);
      free(dead);
      check(s);
    }
    if (round % 4 == 2) {
      /* additions, then a reordering of the movable particles */
      for (int k = 0; k < 30; ++k) {
        const int32_t f = (int32_t)(pm_rng_uniform(&r) * m->count[PM_FACE]);
        PM_ASSERT_OK(psys_seed_face(s, f, 1, &e), e);
      }
      check(s);
      PM_ASSERT_OK(psys_reorder(s, &e), e);
      check(s);
    }
  }
  /* most rounds mended lists one by one */
  assert_true(s->nbr.nb.renewed + s->nbr.gp.renewed > renewed0 + 100);
  psys_sys_destroy(s);
  pm_model_destroy(m);
}

/* The particles of a run on model m (all three phases), with lists kept incrementally or made
 * again at every update, and with or without the held radii of phase 3's end. */
static psys_sys *optimize(const pm_model *m, int always, int never_hold) {
  psys_sys *s = psys_test_system(m, NULL, 1);
  s->nbr.always = always;
  s->nbr.never_hold = never_hold;
  pm_error e = {0};
  psys_phase_report rep[3];
  PM_ASSERT_OK(psys_optimize(s, NULL, rep, &e), e);
  return s;
}

/* The lists only choose candidates: every use filters them with the current points and sigma,
 * so a run whose lists are made again at every update gives the same particles, to the bit, and
 * so does one that keeps the growth budget and the gap lists while sigma is held. */
static void lists_do_not_change_results(void **state) {
  (void)state;
  pm_model *m = psys_test_open("case:boxhole");
  psys_sys *a = optimize(m, 0, 0), *b = optimize(m, 1, 0), *c = optimize(m, 0, 1);
  assert_true(a->nbr.nb.renewed > 1000);
  assert_int_equal(b->nbr.nb.renewed, 0);
  /* a ended held: neighbour lists without the growth budget, no gap lists */
  assert_true(a->nbr.held && !a->nbr.gp.on && a->nbr.nb.f < c->nbr.nb.f);
  assert_true(!c->nbr.held && c->nbr.gp.on);
  for (const psys_sys *o = b; o; o = o == b ? c : NULL) {
    assert_int_equal(a->n, o->n);
    assert_memory_equal(a->xyz, o->xyz, sizeof(double) * 3 * (size_t)a->n);
    assert_memory_equal(a->sigma, o->sigma, sizeof(double) * (size_t)a->n);
  }
  /* the held lists hold every pair of their relation; a sigma update takes the gap lists back */
  check(a);
  assert_true(a->nbr.held);
  pm_error e = {0};
  PM_ASSERT_OK(psys_sigma_update(a, &e), e);
  assert_true(!a->nbr.held && a->nbr.gp.on);
  check(a);
  psys_sys_destroy(a), psys_sys_destroy(b), psys_sys_destroy(c);
  pm_model_destroy(m);
}

/* The kept colouring's quick test (psys_colouring_surely_holds) never passes a colouring with two
 * movable particles of one colour in conflict, |x_i - x_j| < (1 + step_max) max(sigma_i,
 * sigma_j), found here by a scan over all pairs, after random moves and sigma changes small
 * (most rounds pass) and large (none does). */
static void colouring_test_is_sufficient(void **state) {
  (void)state;
  pm_model *m = psys_test_open("case:boxhole");
  psys_sys *s = boxhole_phase3(m);
  pm_error e = {0};
  /* Passes that barely move anything (lambda at most 1e-4): the colouring made at a pass's start
   * then stands for the points the stirring starts from. */
  s->p.lambda_max = 1e-4;
  for (int32_t i = 0; i < s->n; ++i) s->lambda[i] = fmin(s->lambda[i], 1e-4);
  pm_rng r;
  pm_rng_init(&r, 9, 0);
  const double reach = 1 + s->p.step_max;
  int passed[2] = {0, 0}, rounds[2] = {0, 0};
  for (int round = 0; round < 40; ++round) {
    psys_move_info info;
    PM_ASSERT_OK(psys_move_pass(s, &info, &e), e); /* colours again when the colouring fails */
    const int large = round % 2;
    stir(s, &r, 0.3, large ? 0.2 : 0.01, large ? 0.9 : 0.995, large ? 1.2 : 1.01);
    const int surely = psys_colouring_surely_holds(s);
    int conflict = 0;
    for (int32_t i = 0; i < s->n && !conflict; ++i)
      for (int32_t j = i + 1; j < s->n && !conflict; ++j) {
        if (s->colour[i] < 0 || s->colour[i] != s->colour[j]) continue;
        const double d = reach * fmax(s->sigma[i], s->sigma[j]);
        conflict = pm_v3_dist2(&s->xyz[3 * i], &s->xyz[3 * j]) < d * d;
      }
    if (surely && conflict) fail_msg("round %d: the quick test passed a conflicting colouring", round);
    passed[large] += surely, rounds[large]++;
    check(s); /* the lists follow the moves for the next pass */
  }
  print_message("colouring quick test: passed %d of %d small rounds, %d of %d large ones\n",
                passed[0], rounds[0], passed[1], rounds[1]);
  assert_true(passed[0] > 0);
  assert_int_equal(passed[1], 0);
  psys_sys_destroy(s);
  pm_model_destroy(m);
}

/* Movable particles of one colour closer than `factor` (1 + step_max) max(sigma_i, sigma_j), by a
 * scan over all pairs. */
static int colour_conflicts(const psys_sys *s, double factor) {
  const double reach = factor * (1 + s->p.step_max);
  int n = 0;
  for (int32_t i = 0; i < s->n; ++i)
    for (int32_t j = i + 1; j < s->n; ++j) {
      if (s->colour[i] < 0 || s->colour[i] != s->colour[j]) continue;
      const double d = reach * fmax(s->sigma[i], s->sigma[j]);
      n += pm_v3_dist2(&s->xyz[3 * i], &s->xyz[3 * j]) < d * d;
    }
  return n;
}

/* A few particles moved by up to 0.3 sigma into particles of their colour: with colour_mend the
 * next pass gives them new colours alone (no colouring of all), and the sweep's colouring has no
 * conflict; without it, every particle is coloured again. The particles hardly move in a pass
 * (lambda at most 1e-4), so a conflict after the pass would have been one at its start. */
static void colouring_mends_conflicts_alone(void **state) {
  (void)state;
  pm_model *m = psys_test_open("case:boxhole");
  for (int mend = 1; mend >= 0; --mend) {
    psys_sys *s = boxhole_phase3(m);
    pm_error e = {0};
    s->p.colour_mend = mend;
    s->p.lambda_max = 1e-4;
    for (int32_t i = 0; i < s->n; ++i) s->lambda[i] = fmin(s->lambda[i], 1e-4);
    psys_move_info info;
    PM_ASSERT_OK(psys_move_pass(s, &info, &e), e);
    pm_rng r;
    pm_rng_init(&r, 17, 0);
    int conflicted = 0;
    for (int round = 0; round < 10; ++round) {
      stir(s, &r, 0.01, 0.3, 1, 1);
      check(s);
      const int before = colour_conflicts(s, 1);
      const int64_t recolours = s->recolours, mends = s->colour_mends;
      PM_ASSERT_OK(psys_move_pass(s, &info, &e), e);
      assert_int_equal(colour_conflicts(s, 0.999), 0);
      if (before == 0) continue;
      conflicted++;
      if (mend) {
        /* within the share mended alone: the particles in conflict, no colouring of all */
        assert_int_equal(s->recolours, recolours);
        assert_true(s->colour_mends >= mends + 1);
        assert_true(s->colour_nmended > 0);
        assert_int_equal(psys_colouring_surely_holds(s), 0);
      } else {
        assert_int_equal(s->recolours, recolours + 1);
        assert_int_equal(s->colour_mends, mends);
      }
      check(s);
    }
    assert_true(conflicted >= 3);
    psys_sys_destroy(s);
  }
  pm_model_destroy(m);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(lists_follow_random_changes),
      cmocka_unit_test(lists_do_not_change_results),
      cmocka_unit_test(colouring_test_is_sufficient),
      cmocka_unit_test(colouring_mends_conflicts_alone),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
