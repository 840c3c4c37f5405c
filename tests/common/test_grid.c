/* pm_grid: every query against a brute-force scan, on uniform and graded radii, planar and 3D
 * point sets, before and after long sequences of random moves, removals and insertions. */
#include "test_support.h"

#include <stdlib.h>
#include <string.h>

#include "common/sizing/grid.h"
#include "common/base/rng.h"

/* The reference set: the same points kept in plain arrays. */
typedef struct ref {
  int32_t cap;
  int *on;
  double *x, *r;
} ref;

static void ref_init(ref *f, int32_t cap) {
  f->cap = cap;
  f->on = calloc((size_t)cap, sizeof *f->on);
  f->x = calloc((size_t)cap * 3, sizeof *f->x);
  f->r = calloc((size_t)cap, sizeof *f->r);
  assert_non_null(f->on);
}

static void ref_free(ref *f) { free(f->on), free(f->x), free(f->r); }

static double d2_of(const double *a, const double *b) {
  double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
  return dx * dx + dy * dy + dz * dz;
}

/* Brute force for one query kind, ids in increasing order. */
static int32_t brute(const ref *f, const double x[3], double r, pm_grid_kind kind, int32_t *out) {
  int32_t n = 0;
  for (int32_t i = 0; i < f->cap; ++i) {
    if (!f->on[i]) continue;
    double d2 = d2_of(f->x + 3 * i, x), R;
    int ok;
    switch (kind) {
      case PM_GRID_MUTUAL: R = r > f->r[i] ? r : f->r[i], ok = d2 < R * R; break;
      case PM_GRID_OVERLAP: R = r + f->r[i], ok = d2 < R * R; break;
      default: ok = d2 <= r * r; break;
    }
    if (ok) out[n++] = i;
  }
  return n;
}

/* Brute-force k nearest by (d2, id), returned sorted by id. */
static int32_t brute_knn(const ref *f, const double x[3], int32_t k, int32_t *out) {
  int32_t n = 0;
  for (int32_t i = 0; i < f->cap; ++i)
    if (f->on[i]) out[n++] = i;
  /* selection of the k best */
  int32_t m = n < k ? n : k;
  for (int32_t a = 0; a < m; ++a) {
    int32_t best = a;
    for (int32_t b = a + 1; b < n; ++b) {
      double db = d2_of(f->x + 3 * out[b], x), dbest = d2_of(f->x + 3 * out[best], x);
      if (db < dbest || (db == dbest && out[b] < out[best])) best = b;
    }
    int32_t t = out[a];
    out[a] = out[best];
    out[best] = t;
  }
  /* sort the k by id */
  for (int32_t a = 1; a < m; ++a) {
    int32_t v = out[a], j = a;
    while (j > 0 && out[j - 1] > v) out[j] = out[j - 1], --j;
    out[j] = v;
  }
  return m;
}

static void assert_same(const int32_t *want, int32_t nwant, const pm_idbuf *got, const char *what,
                        int q) {
  for (int32_t i = 1; i < got->n; ++i)
    if (got->ids[i - 1] >= got->ids[i]) fail_msg("%s query %d: output not sorted", what, q);
  if (nwant != got->n) fail_msg("%s query %d: %d ids, brute force %d", what, q, got->n, nwant);
  for (int32_t i = 0; i < nwant; ++i)
    if (want[i] != got->ids[i]) fail_msg("%s query %d: id %d vs brute %d", what, q, got->ids[i], want[i]);
}

/* How radii are drawn. */
enum { RAD_UNIFORM, RAD_GRADED };

typedef struct setup {
  int planar;  /* z = 0 */
  int radii;   /* RAD_* */
  double base; /* typical radius */
} setup;

static void draw_point(pm_rng *g, const setup *s, double x[3], double *r) {
  x[0] = pm_rng_uniform(g), x[1] = pm_rng_uniform(g), x[2] = s->planar ? 0 : pm_rng_uniform(g);
  if (s->radii == RAD_UNIFORM) {
    *r = s->base * (0.9 + 0.2 * pm_rng_uniform(g));
  } else {
    /* Graded over three decades along x (as psys's sigma over a model), with a little noise. */
    *r = s->base * pow(10.0, -3.0 * x[0]) * (0.8 + 0.4 * pm_rng_uniform(g));
  }
}

/* Compare every kind of query at nq query points. */
static void compare_all(const pm_grid *g, const ref *f, pm_rng *rng, const setup *s, int nq) {
  pm_idbuf buf = PM_IDBUF_INIT;
  pm_error e = {0};
  int32_t *want = malloc((size_t)f->cap * sizeof *want);
  assert_non_null(want);
  for (int q = 0; q < nq; ++q) {
    double x[3], r;
    /* half the queries at stored points (the meshers' case), half anywhere near the box */
    int32_t at = (int32_t)pm_rng_below(rng, (uint64_t)f->cap);
    if (q % 2 == 0 && f->on[at]) {
      memcpy(x, f->x + 3 * at, sizeof x);
      r = f->r[at];
    } else {
      draw_point(rng, s, x, &r);
      for (int a = 0; a < 3; ++a) x[a] = x[a] * 1.2 - 0.1;
      if (s->planar && q % 3) x[2] = 0;
    }
    if (q % 7 == 3) r *= 10;  /* a wide query now and then */
    if (q % 11 == 5) r = 0;   /* and a zero radius */
    static const pm_grid_kind kinds[3] = {PM_GRID_BALL, PM_GRID_MUTUAL, PM_GRID_OVERLAP};
    static const char *names[3] = {"ball", "mutual", "overlap"};
    for (int kk = 0; kk < 3; ++kk) {
      int32_t nw = brute(f, x, r, kinds[kk], want);
      PM_ASSERT_OK(pm_grid_query(g, x, r, kinds[kk], &buf, &e), e);
      assert_same(want, nw, &buf, names[kk], q);
    }
    static const int32_t ks[3] = {1, 6, 23};
    int32_t k = ks[q % 3];
    int32_t nw = brute_knn(f, x, k, want);
    PM_ASSERT_OK(pm_grid_knearest(g, x, k, &buf, &e), e);
    assert_same(want, nw, &buf, "knearest", q);
    if (k == 1 && nw == 1) {
      double d;
      int32_t id = pm_grid_nearest(g, x, &d);
      assert_int_equal(id, want[0]);
      PM_ASSERT_NEAR(d, sqrt(d2_of(f->x + 3 * id, x)), 0);
    }
  }
  free(want);
  pm_idbuf_free(&buf);
}

static void random_history(const setup *s, uint64_t seed) {
  const int32_t cap = 1500;
  pm_rng rng;
  pm_rng_init(&rng, seed, 0);
  pm_grid *g = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_grid_create(s->base * 1e-4, &g, &e), e);
  ref f;
  ref_init(&f, cap);
  /* Fill ids 0..cap-1 except a few holes. */
  for (int32_t i = 0; i < cap; ++i) {
    if (i % 13 == 7) continue;
    draw_point(&rng, s, f.x + 3 * i, &f.r[i]);
    PM_ASSERT_OK(pm_grid_insert(g, i, f.x + 3 * i, f.r[i], &e), e);
    f.on[i] = 1;
  }
  PM_ASSERT_OK(pm_grid_validate(g, &e), e);
  compare_all(g, &f, &rng, s, 200);
  for (int round = 0; round < 6; ++round) {
    for (int op = 0; op < 2000; ++op) {
      int32_t i = (int32_t)pm_rng_below(&rng, (uint64_t)cap);
      double u = pm_rng_uniform(&rng);
      if (f.on[i] && u < 0.6) {
        /* mostly small steps with small radius changes (a relaxation step); sometimes a jump or a
         * radius change by 100x (psys's splits and sigma updates) */
        double *x = f.x + 3 * i;
        if (u < 0.45) {
          for (int a = 0; a < (s->planar ? 2 : 3); ++a) x[a] += (pm_rng_uniform(&rng) - 0.5) * f.r[i];
          f.r[i] *= 0.9 + 0.2 * pm_rng_uniform(&rng);
        } else if (u < 0.55) {
          draw_point(&rng, s, x, &f.r[i]);
        } else {
          f.r[i] *= pm_rng_uniform(&rng) < 0.5 ? 100 : 0.01;
        }
        PM_ASSERT_OK(pm_grid_move(g, i, x, f.r[i], &e), e);
      } else if (f.on[i] && u < 0.8) {
        PM_ASSERT_OK(pm_grid_remove(g, i, &e), e);
        f.on[i] = 0;
      } else if (!f.on[i]) {
        draw_point(&rng, s, f.x + 3 * i, &f.r[i]);
        PM_ASSERT_OK(pm_grid_insert(g, i, f.x + 3 * i, f.r[i], &e), e);
        f.on[i] = 1;
      }
    }
    PM_ASSERT_OK(pm_grid_validate(g, &e), e);
    int32_t n = 0;
    for (int32_t i = 0; i < cap; ++i) n += f.on[i];
    assert_int_equal(pm_grid_count(g), n);
    compare_all(g, &f, &rng, s, 120);
  }
  ref_free(&f);
  pm_grid_destroy(g);
}

static void brute_3d_uniform(void **state) {
  (void)state;
  setup s = {0, RAD_UNIFORM, 0.06};
  random_history(&s, 11);
}

static void brute_3d_graded(void **state) {
  (void)state;
  setup s = {0, RAD_GRADED, 0.2};
  random_history(&s, 12);
}

static void brute_2d_uniform(void **state) {
  (void)state;
  setup s = {1, RAD_UNIFORM, 0.03};
  random_history(&s, 13);
}

static void brute_2d_graded(void **state) {
  (void)state;
  setup s = {1, RAD_GRADED, 0.1};
  random_history(&s, 14);
}

static void empty_grid(void **state) {
  (void)state;
  pm_grid *g = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_grid_create(1e-3, &g, &e), e);
  pm_idbuf b = PM_IDBUF_INIT;
  double x[3] = {0.5, 0.5, 0.5}, d = -1;
  assert_int_equal(pm_grid_count(g), 0);
  PM_ASSERT_OK(pm_grid_query_ball(g, x, 10, &b, &e), e);
  assert_int_equal(b.n, 0);
  PM_ASSERT_OK(pm_grid_query_mutual(g, x, 10, &b, &e), e);
  assert_int_equal(b.n, 0);
  PM_ASSERT_OK(pm_grid_knearest(g, x, 4, &b, &e), e);
  assert_int_equal(b.n, 0);
  assert_int_equal(pm_grid_nearest(g, x, &d), -1);
  /* empty again after inserting and removing, and after clear */
  PM_ASSERT_OK(pm_grid_insert(g, 3, x, 0.1, &e), e);
  PM_ASSERT_OK(pm_grid_remove(g, 3, &e), e);
  PM_ASSERT_OK(pm_grid_validate(g, &e), e);
  assert_int_equal(pm_grid_nearest(g, x, &d), -1);
  PM_ASSERT_OK(pm_grid_insert(g, 3, x, 0.1, &e), e);
  PM_ASSERT_OK(pm_grid_insert(g, 4, x, 5.0, &e), e);
  pm_grid_clear(g);
  assert_int_equal(pm_grid_count(g), 0);
  PM_ASSERT_OK(pm_grid_validate(g, &e), e);
  PM_ASSERT_OK(pm_grid_query_ball(g, x, 10, &b, &e), e);
  assert_int_equal(b.n, 0);
  PM_ASSERT_OK(pm_grid_insert(g, 3, x, 0.1, &e), e); /* usable after clear */
  assert_int_equal(pm_grid_nearest(g, x, &d), 3);
  PM_ASSERT_NEAR(d, 0, 0);
  pm_idbuf_free(&b);
  pm_grid_destroy(g);
  pm_grid_destroy(NULL);
  pm_idbuf_free(NULL);
}

/* Many points at one position: every query sees all of them, k nearest breaks ties by id. */
static void duplicate_positions(void **state) {
  (void)state;
  pm_grid *g = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_grid_create(1e-3, &g, &e), e);
  double x[3] = {0.25, -0.5, 1.0};
  for (int32_t i = 40; i > 0; --i) PM_ASSERT_OK(pm_grid_insert(g, 2 * i, x, 0.01 * i, &e), e);
  pm_idbuf b = PM_IDBUF_INIT;
  PM_ASSERT_OK(pm_grid_query_ball(g, x, 0, &b, &e), e); /* closed ball of radius 0 */
  assert_int_equal(b.n, 40);
  for (int32_t i = 0; i < 40; ++i) assert_int_equal(b.ids[i], 2 * (i + 1));
  PM_ASSERT_OK(pm_grid_query_mutual(g, x, 0, &b, &e), e); /* 0 < max(0, r_j) for all */
  assert_int_equal(b.n, 40);
  PM_ASSERT_OK(pm_grid_knearest(g, x, 5, &b, &e), e);
  assert_int_equal(b.n, 5);
  for (int32_t i = 0; i < 5; ++i) assert_int_equal(b.ids[i], 2 * (i + 1));
  assert_int_equal(pm_grid_nearest(g, x, NULL), 2);
  /* a point just off: mutual finds those whose radius exceeds the offset */
  double y[3] = {0.25 + 0.105, -0.5, 1.0};
  PM_ASSERT_OK(pm_grid_query_mutual(g, y, 0, &b, &e), e);
  assert_int_equal(b.n, 30); /* radii 0.11 .. 0.40 */
  assert_int_equal(b.ids[0], 22);
  PM_ASSERT_OK(pm_grid_query_overlap(g, y, 0.1, &b, &e), e);
  assert_int_equal(b.n, 40); /* 0.105 < 0.1 + r_j for r_j >= 0.01 */
  PM_ASSERT_OK(pm_grid_validate(g, &e), e);
  pm_idbuf_free(&b);
  pm_grid_destroy(g);
}

/* Exact values on a tiny hand-made set, including the strict / closed boundaries. */
static void known_answers(void **state) {
  (void)state;
  pm_grid *g = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_grid_create(1e-6, &g, &e), e);
  double p0[3] = {0, 0, 0}, p1[3] = {1, 0, 0}, p2[3] = {0, 2, 0}, p3[3] = {0, 0, 4};
  PM_ASSERT_OK(pm_grid_insert(g, 0, p0, 0.5, &e), e);
  PM_ASSERT_OK(pm_grid_insert(g, 1, p1, 1.0, &e), e);
  PM_ASSERT_OK(pm_grid_insert(g, 2, p2, 3.0, &e), e);
  PM_ASSERT_OK(pm_grid_insert(g, 3, p3, 0.0, &e), e);
  pm_idbuf b = PM_IDBUF_INIT;
  PM_ASSERT_OK(pm_grid_query_ball(g, p0, 1.0, &b, &e), e); /* closed: includes id 1 at 1.0 */
  assert_int_equal(b.n, 2);
  assert_int_equal(b.ids[0], 0);
  assert_int_equal(b.ids[1], 1);
  PM_ASSERT_OK(pm_grid_query_mutual(g, p0, 0.5, &b, &e), e); /* 1 < max(.5, 1) is false; 2 < 3 */
  assert_int_equal(b.n, 2);
  assert_int_equal(b.ids[0], 0);
  assert_int_equal(b.ids[1], 2);
  PM_ASSERT_OK(pm_grid_query_overlap(g, p0, 0.5, &b, &e), e); /* 1 < 1.5, 2 < 3.5, 4 !< 0.5 */
  assert_int_equal(b.n, 3);
  assert_int_equal(b.ids[2], 2);
  PM_ASSERT_OK(pm_grid_knearest(g, p3, 2, &b, &e), e); /* 3 itself and 0 at distance 4 */
  assert_int_equal(b.n, 2);
  assert_int_equal(b.ids[0], 0);
  assert_int_equal(b.ids[1], 3);
  int32_t ids[4];
  double d2[4];
  assert_int_equal(pm_grid_knearest_fixed(g, p1, 10, ids, d2), 4);
  assert_int_equal(ids[0], 1);
  assert_int_equal(ids[1], 0);
  assert_int_equal(ids[2], 2);
  assert_int_equal(ids[3], 3);
  PM_ASSERT_NEAR(d2[3], 17, 0);
  /* a far-away nearest query */
  double far[3] = {1e9, -1e9, 3};
  assert_int_equal(pm_grid_nearest(g, far, NULL), 1);
  double got[3], r;
  assert_int_equal(pm_grid_get(g, 2, got, &r), 1);
  PM_ASSERT_NEAR(got[1], 2, 0);
  PM_ASSERT_NEAR(r, 3, 0);
  assert_int_equal(pm_grid_get(g, 7, got, &r), 0);
  pm_idbuf_free(&b);
  pm_grid_destroy(g);
}

/* Renumbering: ids shift as when an array is compacted; queries and validation follow; a bad
 * map (a point without a new id, two points with the same) is refused and changes nothing. */
static void renumber(void **state) {
  (void)state;
  pm_grid *g = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_grid_create(1e-6, &g, &e), e);
  for (int32_t i = 0; i < 6; ++i) {
    double x[3] = {(double)i, 0, 0};
    PM_ASSERT_OK(pm_grid_insert(g, i, x, 0.5 + 0.1 * i, &e), e);
  }
  PM_ASSERT_OK(pm_grid_remove(g, 1, &e), e);
  PM_ASSERT_OK(pm_grid_remove(g, 4, &e), e);
  const int32_t bad1[6] = {0, -1, 1, -1, -1, 3}; /* point 3 has none */
  assert_int_equal(pm_grid_renumber(g, 6, bad1, &e), PM_ERR_ARG);
  const int32_t bad2[6] = {0, -1, 1, 1, -1, 3}; /* 2 and 3 both become 1 */
  assert_int_equal(pm_grid_renumber(g, 6, bad2, &e), PM_ERR_ARG);
  PM_ASSERT_OK(pm_grid_validate(g, &e), e);
  const int32_t map[6] = {0, -1, 1, 2, -1, 3};
  PM_ASSERT_OK(pm_grid_renumber(g, 6, map, &e), e);
  PM_ASSERT_OK(pm_grid_validate(g, &e), e);
  assert_int_equal(pm_grid_count(g), 4);
  double got[3], r;
  assert_int_equal(pm_grid_get(g, 3, got, &r), 1); /* the old point 5 */
  PM_ASSERT_NEAR(got[0], 5, 0);
  PM_ASSERT_NEAR(r, 1.0, 1e-15);
  assert_int_equal(pm_grid_get(g, 4, got, &r), 0);
  pm_idbuf b = PM_IDBUF_INIT;
  double x[3] = {2.5, 0, 0};
  PM_ASSERT_OK(pm_grid_query_ball(g, x, 0.6, &b, &e), e); /* old 2 and 3 */
  assert_int_equal(b.n, 2);
  assert_int_equal(b.ids[0], 1);
  assert_int_equal(b.ids[1], 2);
  /* a new point at a freed id, then one beyond the old ids */
  PM_ASSERT_OK(pm_grid_insert(g, 4, x, 0.1, &e), e);
  const int32_t up[5] = {10, 11, 12, 13, 14};
  PM_ASSERT_OK(pm_grid_renumber(g, 5, up, &e), e);
  PM_ASSERT_OK(pm_grid_validate(g, &e), e);
  assert_int_equal(pm_grid_get(g, 14, got, &r), 1);
  PM_ASSERT_NEAR(r, 0.1, 0);
  pm_idbuf_free(&b);
  pm_grid_destroy(g);
}

static int count_fn(int32_t id, double d2, void *user) {
  (void)d2;
  int32_t *c = user;
  c[0]++;
  c[1] += id;
  return c[0] >= c[2]; /* stop after c[2] calls */
}

static void visit_and_stop(void **state) {
  (void)state;
  pm_grid *g = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_grid_create(1e-3, &g, &e), e);
  for (int32_t i = 0; i < 100; ++i) {
    double x[3] = {0.01 * i, 0, 0};
    PM_ASSERT_OK(pm_grid_insert(g, i, x, 0.02, &e), e);
  }
  double x[3] = {0.5, 0, 0};
  int32_t c[3] = {0, 0, 1000};
  assert_int_equal(pm_grid_visit(g, x, 0.1, PM_GRID_BALL, count_fn, c), 21); /* 0.40 .. 0.60 */
  assert_int_equal(c[0], 21);
  assert_int_equal(c[1], 50 * 21);
  int32_t s[3] = {0, 0, 5};
  assert_int_equal(pm_grid_visit(g, x, 0.1, PM_GRID_BALL, count_fn, s), 5);
  pm_grid_destroy(g);
}

static void bad_input(void **state) {
  (void)state;
  pm_grid *g = NULL;
  pm_error e = {0};
  assert_int_equal(pm_grid_create(0, &g, &e), PM_ERR_ARG);
  assert_null(g);
  assert_int_equal(pm_grid_create(NAN, &g, &e), PM_ERR_ARG);
  PM_ASSERT_OK(pm_grid_create(1e-3, &g, &e), e);
  double x[3] = {0, 0, 0}, bad[3] = {0, NAN, 0}, huge[3] = {1e200, 0, 0};
  PM_ASSERT_OK(pm_grid_insert(g, 0, x, 1, &e), e);
  assert_int_equal(pm_grid_insert(g, 0, x, 1, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "already"));
  assert_int_equal(pm_grid_insert(g, -1, x, 1, &e), PM_ERR_ARG);
  assert_int_equal(pm_grid_insert(g, 1, bad, 1, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "coordinate"));
  assert_int_equal(pm_grid_insert(g, 1, huge, 1, &e), PM_ERR_ARG);
  assert_int_equal(pm_grid_insert(g, 1, x, -1, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "radius"));
  assert_int_equal(pm_grid_insert(g, 1, x, INFINITY, &e), PM_ERR_ARG);
  assert_int_equal(pm_grid_remove(g, 5, &e), PM_ERR_ARG);
  assert_int_equal(pm_grid_remove(g, 1 << 30, &e), PM_ERR_ARG);
  assert_int_equal(pm_grid_move(g, 5, x, 1, &e), PM_ERR_ARG);
  assert_int_equal(pm_grid_move(g, 0, bad, 1, &e), PM_ERR_ARG);
  pm_idbuf b = PM_IDBUF_INIT;
  assert_int_equal(pm_grid_query_ball(g, bad, 1, &b, &e), PM_ERR_ARG);
  assert_int_equal(pm_grid_query_ball(g, x, -1, &b, &e), PM_ERR_ARG);
  assert_int_equal(pm_grid_query_ball(g, x, NAN, &b, &e), PM_ERR_ARG);
  assert_int_equal(pm_grid_knearest(g, x, 0, &b, &e), PM_ERR_ARG);
  /* an infinite ball takes everything */
  PM_ASSERT_OK(pm_grid_query_ball(g, x, INFINITY, &b, &e), e);
  assert_int_equal(b.n, 1);
  /* the failed calls left the grid as it was */
  PM_ASSERT_OK(pm_grid_validate(g, &e), e);
  assert_int_equal(pm_grid_count(g), 1);
  pm_idbuf_free(&b);
  pm_grid_destroy(g);
}

/* Far from the origin with tiny radii (the coordinate-precision floor), and radius changes that
 * raise and lower the top level many times. */
static void offsets_and_levels(void **state) {
  (void)state;
  setup s = {0, RAD_UNIFORM, 1e-3};
  pm_rng rng;
  pm_rng_init(&rng, 5, 0);
  pm_grid *g = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_grid_create(1e-12, &g, &e), e);
  ref f;
  ref_init(&f, 300);
  for (int32_t i = 0; i < 300; ++i) {
    draw_point(&rng, &s, f.x + 3 * i, &f.r[i]);
    f.x[3 * i] += 1e6; /* 2^-50 * 1e6 ~ 1e-9: radii 1e-12 are filed at the precision floor */
    f.r[i] = i % 3 ? 1e-12 : f.r[i];
    PM_ASSERT_OK(pm_grid_insert(g, i, f.x + 3 * i, f.r[i], &e), e);
    f.on[i] = 1;
  }
  PM_ASSERT_OK(pm_grid_validate(g, &e), e);
  pm_idbuf b = PM_IDBUF_INIT;
  int32_t want[300];
  for (int step = 0; step < 200; ++step) {
    int32_t i = (int32_t)pm_rng_below(&rng, 300);
    f.r[i] = step % 2 ? 1e-3 : 50.0; /* jumps of many levels, up and down */
    PM_ASSERT_OK(pm_grid_move(g, i, f.x + 3 * i, f.r[i], &e), e);
    if (step % 20 == 0) PM_ASSERT_OK(pm_grid_validate(g, &e), e);
    double *x = f.x + 3 * (int32_t)pm_rng_below(&rng, 300);
    int32_t nw = brute(&f, x, 2e-3, PM_GRID_MUTUAL, want);
    PM_ASSERT_OK(pm_grid_query_mutual(g, x, 2e-3, &b, &e), e);
    assert_same(want, nw, &b, "offset mutual", step);
    nw = brute_knn(&f, x, 4, want);
    PM_ASSERT_OK(pm_grid_knearest(g, x, 4, &b, &e), e);
    assert_same(want, nw, &b, "offset knn", step);
  }
  PM_ASSERT_OK(pm_grid_validate(g, &e), e);
  pm_idbuf_free(&b);
  ref_free(&f);
  pm_grid_destroy(g);
}

/* A far outlier raises the apex; queries from far away (the sampled size field's fallback)
 * stay exact; removing the outlier leaves a valid grid. */
static void far_points(void **state) {
  (void)state;
  setup s = {0, RAD_UNIFORM, 0.05};
  pm_rng rng;
  pm_rng_init(&rng, 21, 0);
  pm_grid *g = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_grid_create(1e-4, &g, &e), e);
  ref f;
  ref_init(&f, 801);
  for (int32_t i = 0; i < 800; ++i) {
    draw_point(&rng, &s, f.x + 3 * i, &f.r[i]);
    PM_ASSERT_OK(pm_grid_insert(g, i, f.x + 3 * i, f.r[i], &e), e);
    f.on[i] = 1;
  }
  double out[3] = {1e6, -3e5, 42};
  memcpy(f.x + 3 * 800, out, sizeof out);
  f.r[800] = 0.05;
  f.on[800] = 1;
  PM_ASSERT_OK(pm_grid_insert(g, 800, out, 0.05, &e), e);
  PM_ASSERT_OK(pm_grid_validate(g, &e), e);
  pm_idbuf b = PM_IDBUF_INIT;
  int32_t want[801];
  double qs[4][3] = {{0.5, 0.5, 0.5}, {0.5, 0.5, 3.0}, {5e5, -1e5, 0}, {-2e6, 7e6, 1e3}};
  for (int round = 0; round < 2; ++round) {
    for (int q = 0; q < 4; ++q) {
      for (int32_t k = 1; k <= 12; k += 11) {
        int32_t nw = brute_knn(&f, qs[q], k, want);
        PM_ASSERT_OK(pm_grid_knearest(g, qs[q], k, &b, &e), e);
        assert_same(want, nw, &b, "far knn", q);
      }
      int32_t nw = brute(&f, qs[q], 3.0, PM_GRID_BALL, want);
      PM_ASSERT_OK(pm_grid_query_ball(g, qs[q], 3.0, &b, &e), e);
      assert_same(want, nw, &b, "far ball", q);
    }
    if (round == 0) { /* then without the outlier */
      PM_ASSERT_OK(pm_grid_remove(g, 800, &e), e);
      f.on[800] = 0;
      PM_ASSERT_OK(pm_grid_validate(g, &e), e);
    }
  }
  pm_idbuf_free(&b);
  ref_free(&f);
  pm_grid_destroy(g);
}

/* Queries from several threads give what a serial loop gives. */
static void concurrent_queries(void **state) {
  (void)state;
  setup s = {0, RAD_GRADED, 0.2};
  pm_rng rng;
  pm_rng_init(&rng, 9, 0);
  pm_grid *g = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_grid_create(1e-5, &g, &e), e);
  const int32_t n = 3000;
  double *x = malloc(sizeof(double) * 3 * n), *r = malloc(sizeof(double) * n);
  for (int32_t i = 0; i < n; ++i) {
    draw_point(&rng, &s, x + 3 * i, &r[i]);
    PM_ASSERT_OK(pm_grid_insert(g, i, x + 3 * i, r[i], &e), e);
  }
  /* serial: a checksum of every neighbour list, position-weighted so order matters */
  double *serial = calloc((size_t)n, sizeof *serial), *par = calloc((size_t)n, sizeof *par);
  pm_idbuf b = PM_IDBUF_INIT;
  for (int32_t i = 0; i < n; ++i) {
    PM_ASSERT_OK(pm_grid_query_mutual(g, x + 3 * i, r[i], &b, &e), e);
    for (int32_t j = 0; j < b.n; ++j) serial[i] += (j + 1) * (double)b.ids[j];
  }
  int failures = 0;
#pragma omp parallel num_threads(4) reduction(+ : failures)
  {
    pm_idbuf tb = PM_IDBUF_INIT;
#pragma omp for schedule(dynamic, 7)
    for (int32_t i = 0; i < n; ++i) {
      if (pm_grid_query_mutual(g, x + 3 * i, r[i], &tb, NULL)) failures++;
      for (int32_t j = 0; j < tb.n; ++j) par[i] += (j + 1) * (double)tb.ids[j];
    }
    pm_idbuf_free(&tb);
  }
  assert_int_equal(failures, 0);
  for (int32_t i = 0; i < n; ++i)
    if (serial[i] != par[i]) fail_msg("point %d: parallel neighbours differ", i);
  pm_idbuf_free(&b);
  free(x), free(r), free(serial), free(par);
  pm_grid_destroy(g);
}

static int cmp_i32(const void *a, const void *b) {
  int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
  return (x > y) - (x < y);
}

/* pm_sort_ids against qsort on both sides of its insertion-sort cut-over, with duplicates, and
 * on the inputs that break a naive quicksort: sorted, reversed, all equal. */
static void sort_ids(void **state) {
  (void)state;
  pm_rng g;
  pm_rng_init(&g, 7, 0);
  const int32_t sizes[] = {0, 1, 2, 47, 48, 49, 97, 1000, 100000};
  for (size_t k = 0; k < sizeof sizes / sizeof *sizes; ++k) {
    int32_t n = sizes[k];
    int32_t *a = malloc((size_t)(n ? n : 1) * sizeof *a), *b = malloc((size_t)(n ? n : 1) * sizeof *b);
    assert_non_null(a), assert_non_null(b);
    for (int shape = 0; shape < 4; ++shape) {
      for (int32_t i = 0; i < n; ++i)
        a[i] = shape == 0   ? (int32_t)pm_rng_below(&g, (uint64_t)(n / 3 + 1))
               : shape == 1 ? i
               : shape == 2 ? n - i
                            : 5;
      memcpy(b, a, (size_t)n * sizeof *a);
      pm_sort_ids(a, n);
      qsort(b, (size_t)n, sizeof *b, cmp_i32);
      if (n && memcmp(a, b, (size_t)n * sizeof *a)) fail_msg("n %d shape %d: order differs", n, shape);
    }
    free(a), free(b);
  }
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(empty_grid),
      cmocka_unit_test(known_answers),
      cmocka_unit_test(renumber),
      cmocka_unit_test(duplicate_positions),
      cmocka_unit_test(visit_and_stop),
      cmocka_unit_test(bad_input),
      cmocka_unit_test(brute_3d_uniform),
      cmocka_unit_test(brute_3d_graded),
      cmocka_unit_test(brute_2d_uniform),
      cmocka_unit_test(brute_2d_graded),
      cmocka_unit_test(offsets_and_levels),
      cmocka_unit_test(far_points),
      cmocka_unit_test(concurrent_queries),
      cmocka_unit_test(sort_ids),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
