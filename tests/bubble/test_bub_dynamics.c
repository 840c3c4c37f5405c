/* The dynamics of papers/003 eq. 12-15: two bubbles relax to l0, a chain on a straight curve to
 * uniform spacing d, the step is the same for every k0 (stable over the thesis's [0.1, 150]),
 * RK2 works too, forces are thread-count independent, a clipped bubble stays in its face. */
#include "bub_test_util.h"

#include "common/sizing/sizing.h"

static pm_sizing *const_size(double d) {
  pm_sizing *s = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_sizing_constant(d, &s, &e), e);
  return s;
}

static double dist(const bub_state *s, int32_t i, int32_t j) {
  return pm_v3_dist(&s->x[3 * i], &s->x[3 * j]);
}

/* Two face bubbles at (a) and (b) on the square [0, 10]^2 with d = 1, compacted. */
static bub_state *pair_on_square(int integrator, double ax, double ay, double bx, double by,
                                 pm_model **m, pm_sizing **size) {
  *m = bt_square(0, 0, 10);
  *size = const_size(1.0);
  bub_params p = bt_params();
  p.integrator = integrator;
  bub_state *s = bt_state(*m, *size, &p, 1);
  bt_face_bubble(s, ax, ay);
  bt_face_bubble(s, bx, by);
  pm_error e = {0};
  PM_ASSERT_OK(bub_state_compact(s, &e), e);
  return s;
}

static void two_bubbles_with(int integrator) {
  pm_model *m = NULL;
  pm_sizing *size = NULL;
  bub_state *s = pair_on_square(integrator, 4.5, 5.0, 5.3, 5.1, &m, &size);
  assert_true(dist(s, 0, 1) < 0.9);
  bub_step_info info = bt_steps(s, 400);
  /* l0 = (d_i + d_j) / 2 = 1 (003 eq. 10). */
  PM_ASSERT_NEAR(dist(s, 0, 1), 1.0, 1e-7);
  assert_true(info.max_disp < 1e-8);
  /* Momentum: the pair's centre does not drift. */
  PM_ASSERT_NEAR(0.5 * (s->x[0] + s->x[3]), 4.9, 1e-9);
  PM_ASSERT_NEAR(0.5 * (s->x[1] + s->x[4]), 5.05, 1e-9);
  bub_state_destroy(s);
  pm_sizing_destroy(size);
  pm_model_destroy(m);
}

static void two_bubbles_rk4(void **state) {
  (void)state;
  two_bubbles_with(BUB_RK4);
}

static void two_bubbles_rk2(void **state) {
  (void)state;
  two_bubbles_with(BUB_RK2);
}

static void two_bubbles_symplectic(void **state) {
  (void)state;
  two_bubbles_with(BUB_SYMPLECTIC);
}

/* One symplectic step by hand: a pair 0.8 apart on a plane (d = 1, so l0 = 1), at rest. The step
 * is v' = h f / (m + h c), x' = x + h v' (bub_dynamics.c), f the force of bub_force.c at 0.8. */
static void symplectic_step_by_hand(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_sizing *size = NULL;
  bub_state *s = pair_on_square(BUB_SYMPLECTIC, 4.6, 5.0, 5.4, 5.0, &m, &size);
  const bub_params p = s->p;
  const double h = bub_time_step(&p), c = 2 * bub_zeta_now(s) * sqrt(p.mass * p.k0);
  const double f = bub_force(p.k0, 0.8, 1.0); /* repulsive: positive pushes apart */
  assert_true(f > 0);
  const double v = h * f / (p.mass + h * c);
  bt_steps(s, 1);
  PM_ASSERT_NEAR(s->x[0], 4.6 - h * v, 1e-12);
  PM_ASSERT_NEAR(s->x[3], 5.4 + h * v, 1e-12);
  PM_ASSERT_NEAR(s->v[0], -v, 1e-12);
  PM_ASSERT_NEAR(s->x[1], 5.0, 1e-12);
  bub_state_destroy(s);
  pm_sizing_destroy(size);
  pm_model_destroy(m);
}

/* Five curve bubbles between the two end vertices of a straight edge of length 6 with d = 1:
 * the chain relaxes to six gaps of exactly d. */
static void chain_uniform(void **state) {
  (void)state;
  pm_model *m = bt_square(0, 0, 6);
  pm_sizing *size = const_size(1.0);
  bub_params p = bt_params();
  bub_state *s = bt_state(m, size, &p, 1);
  const pm_cell *c = pm_model_cell(m, PM_CURVE, 0);
  pm_error e = {0};
  PM_ASSERT_OK(bub_state_add(s, BUB_KVERTEX, c->bound[0].cell, NULL, NULL, 0, NULL, &e), e);
  PM_ASSERT_OK(bub_state_add(s, BUB_KVERTEX, c->bound[1].cell, NULL, NULL, 0, NULL, &e), e);
  const double t0[5] = {0.4, 3.9, 1.1, 2.2, 5.5};
  for (int k = 0; k < 5; ++k) {
    double t = c->lo[0] + (c->hi[0] - c->lo[0]) * t0[k] / 6;
    PM_ASSERT_OK(bub_state_add(s, BUB_KCURVE, 0, &t, NULL, 0, NULL, &e), e);
  }
  PM_ASSERT_OK(bub_state_compact(s, &e), e);
  bt_steps(s, 800);
  /* Sort the x coordinates of all seven bubbles (they lie on y = 0). */
  double x[7];
  for (int i = 0; i < 7; ++i) {
    x[i] = s->x[3 * i];
    PM_ASSERT_NEAR(s->x[3 * i + 1], 0, 1e-12);
  }
  for (int i = 0; i < 7; ++i)
    for (int j = i + 1; j < 7; ++j)
      if (x[j] < x[i]) {
        double t = x[i];
        x[i] = x[j], x[j] = t;
      }
  for (int i = 0; i < 6; ++i) PM_ASSERT_NEAR(x[i + 1] - x[i], 1.0, 1e-6);
  bub_state_destroy(s);
  pm_sizing_destroy(size);
  pm_model_destroy(m);
}

/* The time step is h = dt 2 pi sqrt(m / k0) and c = 2 zeta sqrt(m k0): the discrete trajectory is
 * the same for every k0 and m (bub_dynamics.c), so k0 = 0.1 and k0 = 150 (the ends of the
 * thesis's stable range, 000 section 6.4) and beyond relax alike. */
static void k0_invariance(void **state) {
  (void)state;
  pm_model *m = bt_square(0, 0, 10);
  pm_sizing *size = const_size(0.5);
  const double k0s[4] = {0.1, 30, 150, 1e4}, masses[4] = {1, 1, 1, 7};
  double ref[6] = {0};
  for (int k = 0; k < 4; ++k) {
    bub_params p = bt_params();
    p.k0 = k0s[k], p.mass = masses[k];
    pm_error e = {0};
    PM_ASSERT_OK(bub_params_check(&p, &e), e);
    bub_state *s = bt_state(m, size, &p, 1);
    bt_face_bubble(s, 5.0, 5.0);
    bt_face_bubble(s, 5.1, 5.05);
    bt_face_bubble(s, 4.9, 5.2);
    PM_ASSERT_OK(bub_state_compact(s, &e), e);
    bt_steps(s, 30);
    for (int q = 0; q < 3; ++q) {
      if (k == 0)
        ref[2 * q] = s->x[3 * q], ref[2 * q + 1] = s->x[3 * q + 1];
      else {
        PM_ASSERT_NEAR(s->x[3 * q], ref[2 * q], 1e-9);
        PM_ASSERT_NEAR(s->x[3 * q + 1], ref[2 * q + 1], 1e-9);
      }
    }
    bt_steps(s, 400);
    /* Relaxed: all three pairs at l0 = 0.5 (an equilateral triangle). */
    for (int a = 0; a < 3; ++a)
      for (int b = a + 1; b < 3; ++b) PM_ASSERT_NEAR(dist(s, a, b), 0.5, 1e-6);
    bub_state_destroy(s);
  }
  pm_sizing_destroy(size);
  pm_model_destroy(m);
}

/* A disordered patch (more bubbles than BUB_PARALLEL_MIN, so that 2 threads are used): positions
 * after 30 steps are bitwise identical with 1 and 2 threads. */
static void thread_independence_with(int integrator) {
  pm_model *m = bt_square(0, 0, 10);
  pm_sizing *size = const_size(0.12);
  double *xs[2] = {NULL, NULL};
  int32_t n = 0;
  for (int T = 1; T <= 2; ++T) {
    bub_params p = bt_params();
    p.integrator = integrator;
    bub_state *s = bt_state(m, size, &p, T);
    pm_rng r;
    pm_rng_init(&r, 3, 0);
    for (int k = 0; k < 2 * BUB_PARALLEL_MIN; ++k)
      bt_face_bubble(s, pm_rng_range(&r, 2, 8), pm_rng_range(&r, 2, 8));
    pm_error e = {0};
    PM_ASSERT_OK(bub_state_compact(s, &e), e);
    bt_steps(s, 30);
    n = s->n;
    xs[T - 1] = malloc(sizeof(double) * 3 * (size_t)n);
    memcpy(xs[T - 1], s->x, sizeof(double) * 3 * (size_t)n);
    bub_state_destroy(s);
  }
  assert_memory_equal(xs[0], xs[1], sizeof(double) * 3 * (size_t)n);
  free(xs[0]), free(xs[1]);
  pm_sizing_destroy(size);
  pm_model_destroy(m);
}

static void thread_independence(void **state) {
  (void)state;
  thread_independence_with(BUB_RK4);
  thread_independence_with(BUB_SYMPLECTIC);
}

/* The forces from the lists against a fresh search: every pair of related bubbles within 1.5 l0
 * (bub_force), found by a sweep over the bubbles sorted by x (every pair whose x differ by less
 * than 1.5 times the largest l0: the brute-force set, without its n^2 cost), at the bubbles'
 * current positions; the largest difference relative to k0 d. */
static const bub_state *sweep_state;
static int by_x(const void *pa, const void *pb) {
  double xa = sweep_state->x[3 * *(const int32_t *)pa], xb = sweep_state->x[3 * *(const int32_t *)pb];
  return xa < xb ? -1 : xa > xb ? 1 : (*(const int32_t *)pa > *(const int32_t *)pb) - (*(const int32_t *)pa < *(const int32_t *)pb);
}

static double force_mismatch(const bub_state *s) {
  double *pos = malloc(sizeof(double) * 4 * (size_t)s->n), worst = 0, dmax = 0;
  int32_t *ord = malloc(sizeof(int32_t) * (size_t)s->n), *rank = malloc(sizeof(int32_t) * (size_t)s->n);
  for (int32_t i = 0; i < s->n; ++i) {
    memcpy(&pos[4 * i], &s->x[3 * i], sizeof(double) * 3);
    pos[4 * i + 3] = s->d[i];
    dmax = fmax(dmax, s->d[i]);
    ord[i] = i;
  }
  sweep_state = s;
  qsort(ord, (size_t)s->n, sizeof(int32_t), by_x);
  for (int32_t k = 0; k < s->n; ++k) rank[ord[k]] = k;
  int32_t a, b;
  bub_moving(s, &a, &b);
  for (int32_t i = a; i < b; ++i) {
    double f[3], g[3] = {0, 0, 0};
    bub_force_on(s, pos, i, f, NULL, NULL);
    const double span = 0.75 * (s->d[i] + dmax) * (1 + 1e-9);
    for (int dir = -1; dir <= 1; dir += 2)
      for (int32_t k = rank[i] + (dir > 0); k >= 0 && k < s->n; k += dir) {
        const int32_t j = ord[k];
        if (fabs(s->x[3 * j] - s->x[3 * i]) > span) break;
        if (j == i || !bub_related(s, i, j)) continue;
        double r[3], l0 = 0.5 * (s->d[i] + s->d[j]);
        pm_v3_sub(r, &s->x[3 * i], &s->x[3 * j]);
        double l = pm_v3_norm(r);
        if (l < 1.5 * l0 && l > 0) pm_v3_axpy(g, g, bub_force(s->p.k0, l, l0) / l, r);
      }
    worst = fmax(worst, pm_v3_dist(f, g) / (s->p.k0 * s->d[i]));
  }
  free(pos), free(ord), free(rank);
  return worst;
}

/* Neighbour lists reused across steps: a packing at rest keeps its lists; a bubble moved across
 * the skin forces a rebuild from the outer lists at the next step, one moved across the outer
 * skin a rebuild of those from the grid; the forces from the lists match a fresh search (every
 * pair, brute force) to 1e-12 throughout. With list_partial = 0 every list is built again; by
 * default only the moved bubble's and its neighbours' (a partial build). */
static void lists_reuse_and_skin_with(double list_partial) {
  pm_model *m = bt_square(0, 0, 10);
  pm_sizing *size = const_size(0.5);
  bub_params p = bt_params();
  p.list_partial = list_partial;
  bub_state *s = bt_state(m, size, &p, 1);
  int32_t c = bt_hex_patch(s, 5, 5, 0.5, 6);
  pm_error e = {0};
  PM_ASSERT_OK(bub_state_compact(s, &e), e);
  bt_steps(s, 3);
  assert_true(force_mismatch(s) <= 1e-12);
  int64_t b0 = s->list_builds, o0 = s->outer_builds, pb0 = s->partial_builds, po0 = s->partial_outer;
  bt_steps(s, 5); /* a relaxed lattice: nothing moves, nothing is rebuilt */
  assert_int_equal(s->list_builds, b0);
  assert_int_equal(s->outer_builds, o0);
  assert_int_equal(s->partial_builds, pb0);
  /* Across the skin, not the outer one. The test sums the excesses of the pair: a bubble moving
   * alone among bubbles at rest crosses the skin after 2 x 0.75 x 0.15 d = 0.225 d, the outer skin
   * after 2 x 0.75 x (0.6 - 0.15) d = 0.675 d. 0.25 d towards the second ring's bubble at 30
   * degrees, at sqrt3 d, beyond the lists' reach 1.725 d: it comes within 1.5 d. The lists are
   * filtered again from the outer ones. */
  const double dx = 0.25 * 0.5 * cos(M_PI / 6), dy = 0.25 * 0.5 * sin(M_PI / 6);
  s->x[3 * c] += dx, s->par[2 * c] += dx, s->x[3 * c + 1] += dy, s->par[2 * c + 1] += dy;
  assert_true(force_mismatch(s) > 1e-3); /* the stale lists miss that pair: the check can fail */
  bt_steps(s, 1);
  if (list_partial > 0) { /* its own list and its neighbours' only */
    assert_int_equal(s->list_builds, b0);
    assert_int_equal(s->partial_builds, pb0 + 1);
    assert_int_equal(s->partial_outer, po0 + 1); /* its outer excess passed half the gap too */
    assert_int_equal(s->nb_nmoved, 1);
    assert_int_equal(s->nb_moved[0], c);
  } else {
    assert_int_equal(s->list_builds, b0 + 1);
    assert_int_equal(s->partial_builds, pb0);
  }
  assert_int_equal(s->outer_builds, o0);
  assert_true(force_mismatch(s) <= 1e-12);
  /* Across the outer skin: the outer lists from the grid as well. */
  s->x[3 * c + 1] -= 0.9 * 0.5, s->par[2 * c + 1] -= 0.9 * 0.5;
  bt_steps(s, 1);
  if (list_partial > 0) {
    assert_int_equal(s->list_builds, b0);
    assert_int_equal(s->outer_builds, o0);
    assert_int_equal(s->partial_outer, po0 + 2);
  } else {
    assert_int_equal(s->list_builds, b0 + 2);
    assert_int_equal(s->outer_builds, o0 + 1);
  }
  assert_true(force_mismatch(s) <= 1e-12);
  for (int k = 0; k < 20; ++k) {
    bt_steps(s, 1);
    assert_true(force_mismatch(s) <= 1e-12);
  }
  bub_state_destroy(s);
  pm_sizing_destroy(size);
  pm_model_destroy(m);
}

static void lists_reuse_and_skin(void **state) {
  (void)state;
  lists_reuse_and_skin_with(0);
  lists_reuse_and_skin_with(0.125);
}

/* Partial builds (bub_neighbors.c) on a packing at rest of more than BUB_PARALLEL_MIN bubbles, in
 * which three bubbles at a time are thrown 0.2 to 0.6 d (across the skin, often the outer one):
 * after every step the forces from the lists match a fresh search to 1e-12, only partial builds
 * happen, and the positions are bitwise the same with 1 and 2 threads. */
static void partial_builds_exact(void **state) {
  (void)state;
  pm_model *m = bt_square(0, 0, 80);
  pm_sizing *size = const_size(0.5);
  double *xs[2] = {NULL, NULL};
  int32_t n = 0;
  for (int T = 1; T <= 2; ++T) {
    bub_params p = bt_params();
    bub_state *s = bt_state(m, size, &p, T);
    bt_hex_patch(s, 40, 40, 0.5, 55);
    pm_error e = {0};
    PM_ASSERT_OK(bub_state_compact(s, &e), e);
    assert_true(s->n > BUB_PARALLEL_MIN);
    bt_steps(s, 3);
    const int64_t b0 = s->list_builds, o0 = s->outer_builds, pb0 = s->partial_builds;
    pm_rng r;
    pm_rng_init(&r, 11, 0);
    for (int it = 0; it < 12; ++it) {
      for (int k = 0; k < 3; ++k) {
        int32_t i = (int32_t)(pm_rng_range(&r, 0, 1) * (s->nf - s->nv)) + s->nv;
        double ang = pm_rng_range(&r, 0, 2 * M_PI), len = pm_rng_range(&r, 0.2, 0.6) * 0.5;
        s->x[3 * i] += len * cos(ang), s->par[2 * i] += len * cos(ang);
        s->x[3 * i + 1] += len * sin(ang), s->par[2 * i + 1] += len * sin(ang);
      }
      bt_steps(s, 1);
      assert_true(force_mismatch(s) <= 1e-12);
    }
    assert_int_equal(s->list_builds, b0);
    assert_int_equal(s->outer_builds, o0);
    assert_true(s->partial_builds >= pb0 + 12);
    assert_true(s->partial_outer > 0);
    n = s->n;
    xs[T - 1] = malloc(sizeof(double) * 3 * (size_t)n);
    memcpy(xs[T - 1], s->x, sizeof(double) * 3 * (size_t)n);
    bub_state_destroy(s);
  }
  assert_memory_equal(xs[0], xs[1], sizeof(double) * 3 * (size_t)n);
  free(xs[0]), free(xs[1]);
  pm_sizing_destroy(size);
  pm_model_destroy(m);
}

/* The force kernel's two implementations (bub_kernel.c, plain and AVX2) give the same bits: on
 * a disordered patch with a graded size field and a coincident pair, every bubble's force,
 * potential and degree. (Where the processor has no AVX2 both calls use the plain one.) */
static void kernel_implementations_agree(void **state) {
  (void)state;
  pm_model *m = bt_square(0, 0, 10);
  pm_sizing *size = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_sizing_expression("0.2 + 0.05 * x", &size, &e), e);
  bub_params p = bt_params();
  bub_state *s = bt_state(m, size, &p, 1);
  pm_rng r;
  pm_rng_init(&r, 8, 0);
  for (int k = 0; k < 3000; ++k) bt_face_bubble(s, pm_rng_range(&r, 1, 9), pm_rng_range(&r, 1, 9));
  bt_face_bubble(s, 5, 5);
  bt_face_bubble(s, 5, 5); /* coincident */
  PM_ASSERT_OK(bub_state_compact(s, &e), e);
  bt_steps(s, 2);
  double *pos = malloc(sizeof(double) * 4 * (size_t)s->n);
  for (int32_t i = 0; i < s->n; ++i) memcpy(&pos[4 * i], &s->x[3 * i], 24), pos[4 * i + 3] = s->d[i];
  int32_t listed = 0;
  for (int32_t i = s->nc; i < s->nf; ++i) {
    double f0[3], f1[3], u0, u1;
    int32_t d0, d1;
    bub_force_sum(s, pos, i, 0, f0, &u0, &d0);
    bub_force_sum(s, pos, i, bub_kernel_simd(), f1, &u1, &d1);
    assert_memory_equal(f0, f1, sizeof f0);
    assert_memory_equal(&u0, &u1, sizeof u0);
    assert_int_equal(d0, d1);
    double g0[3];
    bub_force_sum(s, pos, i, bub_kernel_simd(), g0, NULL, NULL); /* without the extras */
    assert_memory_equal(f0, g0, sizeof f0);
    listed += s->nb_cnt[i];
  }
  assert_true(listed > 10 * (s->nf - s->nc));
  print_message("force kernel: %s\n", bub_kernel_simd() ? "AVX2 against plain C" : "plain C only");
  free(pos);
  bub_state_destroy(s);
  pm_sizing_destroy(size);
  pm_model_destroy(m);
}

/* Two bubbles on top of each other (distance 0) separate along a seeded direction. */
static void coincident_pair(void **state) {
  (void)state;
  pm_model *m = bt_square(0, 0, 10);
  pm_sizing *size = const_size(1.0);
  bub_params p = bt_params();
  bub_state *s = bt_state(m, size, &p, 1);
  bt_face_bubble(s, 5, 5);
  bt_face_bubble(s, 5, 5);
  pm_error e = {0};
  PM_ASSERT_OK(bub_state_compact(s, &e), e);
  bt_steps(s, 400);
  PM_ASSERT_NEAR(dist(s, 0, 1), 1.0, 1e-6);
  bub_state_destroy(s);
  pm_sizing_destroy(size);
  pm_model_destroy(m);
}

/* A face bubble squeezed against the border by a dense patch never leaves the face (the shared
 * clip rule), and the vertex bubbles never move. */
static void stays_in_face(void **state) {
  (void)state;
  pm_model *m = bt_square(0, 0, 2);
  pm_sizing *size = const_size(1.0);
  bub_params p = bt_params();
  bub_state *s = bt_state(m, size, &p, 1);
  pm_error e = {0};
  for (int32_t v = 0; v < 4; ++v) PM_ASSERT_OK(bub_state_add(s, BUB_KVERTEX, v, NULL, NULL, 0, NULL, &e), e);
  for (int k = 0; k < 12; ++k) bt_face_bubble(s, 0.6 + 0.07 * k, 0.4 + 0.09 * (k % 5));
  PM_ASSERT_OK(bub_state_compact(s, &e), e);
  double vx[12];
  memcpy(vx, s->x, sizeof vx);
  for (int k = 0; k < 300; ++k) {
    bt_steps(s, 1);
    for (int32_t i = s->nc; i < s->nf; ++i) assert_true(pm_face_inside(pm_model_cell(m, PM_FACE, 0), &s->par[2 * i]));
  }
  assert_memory_equal(vx, s->x, sizeof vx);
  bub_state_destroy(s);
  pm_sizing_destroy(size);
  pm_model_destroy(m);
}

/* Bad parameters: one-line errors. */
static void bad_parameters(void **state) {
  (void)state;
  bub_params p;
  bub_params_init(&p);
  pm_error e = {0};
  assert_int_equal(pm_params_set(&bub_params_table, &p, "k0", "0", &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "k0"));
  assert_int_equal(pm_params_set(&bub_params_table, &p, "k0", "-3", &e), PM_ERR_ARG);
  assert_int_equal(pm_params_set(&bub_params_table, &p, "zeta", "0", &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "zeta"));
  assert_int_equal(pm_params_set(&bub_params_table, &p, "w2", "1.5", &e), PM_ERR_ARG);
  assert_int_equal(pm_params_set(&bub_params_table, &p, "w2", "0", &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "w2"));
  assert_int_equal(pm_params_set(&bub_params_table, &p, "w2", "1", &e), PM_OK);
  assert_int_equal(pm_params_set(&bub_params_table, &p, "nonsense", "1", &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "unknown"));
  assert_null(strchr(e.msg, '\n'));
  assert_int_equal(pm_params_set(&bub_params_table, &p, "integrator", "euler", &e), PM_ERR_ARG);
  /* Relations between fields. */
  bub_params_init(&p);
  p.face_open = 9;
  assert_int_equal(bub_params_check(&p, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "face_open"));
  bub_params_init(&p);
  p.integrator = BUB_RK2, p.dt = 0.15;
  assert_int_equal(bub_params_check(&p, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "unstable"));
  p.dt = 0; /* automatic: stable */
  PM_ASSERT_OK(bub_params_check(&p, &e), e);
  /* Symplectic at its default step 0.1: b = 12 (0.2 pi)^2 = 4.737 <= 4 + 2 a, a = 0.4 pi zeta, for
   * zeta >= 0.2933 (final_zeta's automatic 0.3 included). */
  bub_params_init(&p);
  p.integrator = BUB_SYMPLECTIC;
  PM_ASSERT_OK(bub_params_check(&p, &e), e);
  p.final_zeta = 0.29;
  assert_int_equal(bub_params_check(&p, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "final_zeta"));
  assert_non_null(strstr(e.msg, "symplectic"));
  p.final_zeta = 0.2935;
  PM_ASSERT_OK(bub_params_check(&p, &e), e);
  p.dt = 0.12;
  assert_int_equal(bub_params_check(&p, &e), PM_ERR_ARG);
  PM_ASSERT_OK(pm_params_set(&bub_params_table, &p, "integrator", "symplectic", &e), e);
  /* A damping ratio whose overdamped fast root leaves RK4's region is refused; the symplectic
   * step, whose damping is implicit, takes any damping. */
  bub_params_init(&p);
  p.integrator = BUB_RK4, p.zeta_max = 6;
  assert_int_equal(bub_params_check(&p, &e), PM_ERR_ARG);
  p.integrator = BUB_SYMPLECTIC;
  PM_ASSERT_OK(bub_params_check(&p, &e), e);
  bub_params_init(&p);
  assert_int_equal(p.integrator, BUB_SYMPLECTIC); /* the default */
  PM_ASSERT_OK(bub_params_check(&p, &e), e);
  /* The defaults are in the table. */
  const pm_param_desc *d = pm_params_find(&bub_params_table, "k0");
  assert_non_null(d);
  PM_ASSERT_NEAR(d->def, 30, 0);
  PM_ASSERT_NEAR(p.face_excess, 7, 0); /* 000 sec. 4.1.2: 8 and 5 (for its quadtree start) */
  PM_ASSERT_NEAR(p.face_open, 5.6, 0);
  PM_ASSERT_NEAR(p.zeta, 0.7, 0);
  assert_int_equal(p.control_steps, 20);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(two_bubbles_rk4),  cmocka_unit_test(two_bubbles_rk2),
      cmocka_unit_test(two_bubbles_symplectic), cmocka_unit_test(symplectic_step_by_hand),
      cmocka_unit_test(chain_uniform),    cmocka_unit_test(k0_invariance),
      cmocka_unit_test(thread_independence), cmocka_unit_test(lists_reuse_and_skin),
      cmocka_unit_test(partial_builds_exact),
      cmocka_unit_test(kernel_implementations_agree), cmocka_unit_test(coincident_pair),
      cmocka_unit_test(stays_in_face),    cmocka_unit_test(bad_parameters),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
