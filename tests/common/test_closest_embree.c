/* Tests of closest_embree.c: the Embree BVH closest-point queries against brute force, the
 * point-triangle routine against hand-computed answers, the radius limit, the visitor, the
 * overlapping-pairs broad phase against brute-force box tests, concurrent queries, bad input. */
#include "test_support.h"

#include <float.h>
#include <stdlib.h>
#include <string.h>

#include "common/backends/closest_embree.h"
#include "common/base/rng.h"

/* ---- helpers ------------------------------------------------------------------------------- */

/* A random triangle soup: nnode nodes uniform in [-1, 1]^3, ntri triangles of random nodes,
 * every fifth one shrunk to a small triangle near its first node (so that sizes vary). */
static void random_soup(pm_rng *r, int32_t nnode, int32_t ntri, double **xyz, int32_t **tri) {
  *xyz = malloc(sizeof(double) * 3 * (size_t)nnode);
  *tri = malloc(sizeof(int32_t) * 3 * (size_t)ntri);
  for (int32_t i = 0; i < 3 * nnode; ++i) (*xyz)[i] = pm_rng_range(r, -1, 1);
  for (int32_t t = 0; t < 3 * ntri; ++t) (*tri)[t] = (int32_t)pm_rng_below(r, (uint64_t)nnode);
}

/* A bumpy open surface z = 0.2 sin(3x) cos(2y) over [0,1]^2, n x n cells, two triangles each. */
static void bumpy_grid(int n, double **xyz, int32_t *nnode, int32_t **tri, int32_t *ntri) {
  *nnode = (n + 1) * (n + 1);
  *ntri = 2 * n * n;
  *xyz = malloc(sizeof(double) * 3 * (size_t)*nnode);
  *tri = malloc(sizeof(int32_t) * 3 * (size_t)*ntri);
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      double x = (double)i / n, y = (double)j / n;
      double *p = &(*xyz)[3 * (j * (n + 1) + i)];
      p[0] = x, p[1] = y, p[2] = 0.2 * sin(3 * x) * cos(2 * y);
    }
  int32_t k = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      int32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      int32_t *t = &(*tri)[3 * k];
      t[0] = a, t[1] = b, t[2] = d, t[3] = a, t[4] = d, t[5] = c;
      k += 2;
    }
}

static double brute_closest(const double *xyz, const int32_t *tri, int32_t ntri, const double p[3],
                            int32_t *best_tri) {
  double best = INFINITY;
  *best_tri = -1;
  for (int32_t t = 0; t < ntri; ++t) {
    const int32_t *v = &tri[3 * t];
    double q[3];
    double d = pm_point_triangle_closest(p, &xyz[3 * v[0]], &xyz[3 * v[1]], &xyz[3 * v[2]], q, NULL);
    if (d < best) best = d, *best_tri = t;
  }
  return best;
}

/* ---- point-triangle distance ------------------------------------------------------------------ */

static void test_point_triangle_regions(void **state) {
  (void)state;
  const double a[3] = {0, 0, 0}, b[3] = {2, 0, 0}, c[3] = {0, 2, 0};
  double q[3], w[3];
  /* Above the interior: the foot point, distance = height. */
  double p1[3] = {0.5, 0.5, 3};
  PM_ASSERT_NEAR(pm_point_triangle_closest(p1, a, b, c, q, w), 3.0, 1e-15);
  PM_ASSERT_NEAR(q[0], 0.5, 1e-15);
  PM_ASSERT_NEAR(q[1], 0.5, 1e-15);
  PM_ASSERT_NEAR(q[2], 0.0, 1e-15);
  PM_ASSERT_NEAR(w[0], 0.5, 1e-15);
  PM_ASSERT_NEAR(w[1], 0.25, 1e-15);
  PM_ASSERT_NEAR(w[2], 0.25, 1e-15);
  /* Beyond vertex a. */
  double p2[3] = {-1, -2, 2};
  PM_ASSERT_NEAR(pm_point_triangle_closest(p2, a, b, c, q, w), 3.0, 1e-15);
  PM_ASSERT_NEAR(w[0], 1.0, 0);
  /* Beyond the hypotenuse bc, in its region: distance to the line x + y = 2 in the plane. */
  double p3[3] = {2, 2, 1};
  PM_ASSERT_NEAR(pm_point_triangle_closest(p3, a, b, c, q, w), sqrt(2.0 + 1.0), 1e-15);
  PM_ASSERT_NEAR(q[0], 1.0, 1e-15);
  PM_ASSERT_NEAR(q[1], 1.0, 1e-15);
  PM_ASSERT_NEAR(w[1], 0.5, 1e-15);
  PM_ASSERT_NEAR(w[2], 0.5, 1e-15);
  /* Beyond edge ab (y < 0), between its ends. */
  double p4[3] = {1.5, -4, 0};
  PM_ASSERT_NEAR(pm_point_triangle_closest(p4, a, b, c, q, w), 4.0, 1e-15);
  PM_ASSERT_NEAR(w[1], 0.75, 1e-15);
  /* A degenerate triangle (a segment a-b with c = b) and a point triangle. */
  double p5[3] = {1, 3, 4};
  PM_ASSERT_NEAR(pm_point_triangle_closest(p5, a, b, b, q, w), 5.0, 1e-15);
  PM_ASSERT_NEAR(w[0] + w[1] + w[2], 1.0, 1e-15);
  PM_ASSERT_NEAR(q[0], 1.0, 1e-15);
  PM_ASSERT_NEAR(pm_point_triangle_closest(p5, b, b, b, q, w), sqrt(1.0 + 9 + 16), 1e-15);
  /* The closest point always reproduces from the barycentrics. */
  pm_rng r;
  pm_rng_init(&r, 7, 0);
  for (int it = 0; it < 1000; ++it) {
    double A[3], B[3], C[3], P[3];
    for (int k = 0; k < 3; ++k)
      A[k] = pm_rng_range(&r, -1, 1), B[k] = pm_rng_range(&r, -1, 1), C[k] = pm_rng_range(&r, -1, 1),
      P[k] = pm_rng_range(&r, -2, 2);
    double d = pm_point_triangle_closest(P, A, B, C, q, w);
    for (int k = 0; k < 3; ++k) {
      PM_ASSERT_NEAR(q[k], w[0] * A[k] + w[1] * B[k] + w[2] * C[k], 1e-12);
      assert_true(w[k] >= -1e-12 && w[k] <= 1 + 1e-12);
    }
    /* No point of a fine barycentric lattice on the triangle is closer than q. */
    for (int i = 0; i <= 20; ++i)
      for (int j = 0; i + j <= 20; ++j) {
        double s = i / 20.0, t = j / 20.0, x[3];
        for (int k = 0; k < 3; ++k) x[k] = (1 - s - t) * A[k] + s * B[k] + t * C[k];
        double dx = sqrt((x[0] - P[0]) * (x[0] - P[0]) + (x[1] - P[1]) * (x[1] - P[1]) +
                         (x[2] - P[2]) * (x[2] - P[2]));
        assert_true(dx >= d - 1e-12);
      }
  }
}

/* ---- BVH against brute force -------------------------------------------------------------------- */

static void check_against_brute(const double *xyz, int32_t nnode, const int32_t *tri, int32_t ntri,
                                uint64_t seed, int npts, double box) {
  pm_error e = {0};
  pm_bvh *bvh = NULL;
  PM_ASSERT_OK(pm_bvh_create(xyz, nnode, tri, ntri, &bvh, &e), e);
  assert_int_equal(pm_bvh_ntri(bvh), ntri);
  pm_rng r;
  pm_rng_init(&r, seed, 1);
  for (int i = 0; i < npts; ++i) {
    double p[3] = {pm_rng_range(&r, -box, box), pm_rng_range(&r, -box, box),
                   pm_rng_range(&r, -box, box)};
    int32_t bt;
    double bd = brute_closest(xyz, tri, ntri, p, &bt);
    pm_bvh_hit h;
    assert_int_equal(pm_bvh_closest(bvh, p, INFINITY, &h), 1);
    PM_ASSERT_NEAR(h.dist, bd, 1e-12);
    /* The reported point is on the reported triangle, at the reported distance. */
    const int32_t *v = &tri[3 * h.tri];
    for (int k = 0; k < 3; ++k)
      PM_ASSERT_NEAR(h.point[k],
                     h.bary[0] * xyz[3 * v[0] + k] + h.bary[1] * xyz[3 * v[1] + k] +
                         h.bary[2] * xyz[3 * v[2] + k],
                     1e-12);
    PM_ASSERT_NEAR(sqrt((h.point[0] - p[0]) * (h.point[0] - p[0]) +
                        (h.point[1] - p[1]) * (h.point[1] - p[1]) +
                        (h.point[2] - p[2]) * (h.point[2] - p[2])),
                   h.dist, 1e-12);
    /* A radius just below the distance finds nothing; just above finds the same distance. */
    pm_bvh_hit h2;
    if (bd > 1e-9) {
      assert_int_equal(pm_bvh_closest(bvh, p, bd * (1 - 1e-9), &h2), 0);
      assert_int_equal(h2.tri, -1);
      assert_true(isinf(h2.dist));
    }
    assert_int_equal(pm_bvh_closest(bvh, p, bd * (1 + 1e-9) + 1e-300, &h2), 1);
    PM_ASSERT_NEAR(h2.dist, bd, 1e-12);
  }
  pm_bvh_destroy(bvh);
}

static void test_bvh_random_soup(void **state) {
  (void)state;
  pm_rng r;
  pm_rng_init(&r, 11, 0);
  double *xyz;
  int32_t *tri;
  random_soup(&r, 300, 500, &xyz, &tri);
  check_against_brute(xyz, 300, tri, 500, 12, 2000, 1.5);
  free(xyz), free(tri);
}

static void test_bvh_bumpy_surface(void **state) {
  (void)state;
  double *xyz;
  int32_t *tri, nnode, ntri;
  bumpy_grid(40, &xyz, &nnode, &tri, &ntri);
  /* Points near the surface (the hard case for pruning: many boxes nearly tie). */
  check_against_brute(xyz, nnode, tri, ntri, 13, 2000, 1.2);
  free(xyz), free(tri);
}

/* Ties go to the lowest index, as in brute_closest's search in index order: a bumpy surface
 * whose every triangle appears three times, at indices spread over the array (so the copies sit
 * in different places of the tree), and points over the grid's nodes, where the closest point
 * is a node shared by up to six triangles. Every query's triangle is brute force's. */
static void test_bvh_ties_lowest_index(void **state) {
  (void)state;
  double *xyz;
  int32_t *tri, nnode, ntri;
  bumpy_grid(20, &xyz, &nnode, &tri, &ntri);
  const int32_t n3 = 3 * ntri;
  int32_t *tri3 = malloc(sizeof(int32_t) * 3 * (size_t)n3);
  pm_rng r;
  pm_rng_init(&r, 21, 0);
  int32_t *slot = malloc(sizeof(int32_t) * (size_t)n3);
  for (int32_t k = 0; k < n3; ++k) slot[k] = k;
  for (int32_t k = n3 - 1; k > 0; --k) { /* a random placement of the copies */
    int32_t j = (int32_t)pm_rng_below(&r, (uint64_t)k + 1), x = slot[k];
    slot[k] = slot[j], slot[j] = x;
  }
  for (int32_t k = 0; k < n3; ++k) memcpy(&tri3[3 * slot[k]], &tri[3 * (k % ntri)], 3 * sizeof(int32_t));
  pm_error e = {0};
  pm_bvh *bvh = NULL;
  PM_ASSERT_OK(pm_bvh_create(xyz, nnode, tri3, n3, &bvh, &e), e);
  for (int32_t i = 0; i < nnode; ++i) {
    const double *x = &xyz[3 * i];
    double p[3] = {x[0] + pm_rng_range(&r, -1e-3, 1e-3), x[1], x[2] + 0.05};
    if (i % 2) p[0] = x[0]; /* right above the node: up to six triangles tie, three times */
    int32_t bt;
    double bd = brute_closest(xyz, tri3, n3, p, &bt);
    pm_bvh_hit h;
    assert_int_equal(pm_bvh_closest(bvh, p, INFINITY, &h), 1);
    assert_true(h.dist == bd);
    assert_int_equal(h.tri, bt);
  }
  pm_bvh_destroy(bvh);
  free(slot), free(tri3), free(xyz), free(tri);
}

/* Coordinates far from the origin: the float rounding of the query point and of Embree's boxes is
 * then large compared with the mesh's features, the case the sphere margin exists for. */
static void test_bvh_offset_coordinates(void **state) {
  (void)state;
  double *xyz;
  int32_t *tri, nnode, ntri;
  bumpy_grid(30, &xyz, &nnode, &tri, &ntri);
  for (int32_t i = 0; i < nnode; ++i) {
    xyz[3 * i] = 1e4 + 1e-3 * xyz[3 * i];
    xyz[3 * i + 1] = -2e4 + 1e-3 * xyz[3 * i + 1];
    xyz[3 * i + 2] = 3e4 + 1e-3 * xyz[3 * i + 2];
  }
  pm_error e = {0};
  pm_bvh *bvh = NULL;
  PM_ASSERT_OK(pm_bvh_create(xyz, nnode, tri, ntri, &bvh, &e), e);
  pm_rng r;
  pm_rng_init(&r, 5, 0);
  for (int i = 0; i < 2000; ++i) {
    double p[3] = {1e4 + pm_rng_range(&r, -2e-4, 1.2e-3), -2e4 + pm_rng_range(&r, -2e-4, 1.2e-3),
                   3e4 + pm_rng_range(&r, -3e-4, 3e-4)};
    int32_t bt;
    double bd = brute_closest(xyz, tri, ntri, p, &bt);
    pm_bvh_hit h;
    assert_int_equal(pm_bvh_closest(bvh, p, INFINITY, &h), 1);
    PM_ASSERT_NEAR(h.dist, bd, 1e-12);
  }
  pm_bvh_destroy(bvh);
  free(xyz), free(tri);
}

/* Segments (a, b, b) and points (a, a, a) are primitives like any other. */
static void test_bvh_degenerate_primitives(void **state) {
  (void)state;
  const double xyz[] = {0, 0, 0, 1, 0, 0, 5, 5, 5};
  const int32_t tri[] = {0, 1, 1, 2, 2, 2};
  pm_error e = {0};
  pm_bvh *bvh = NULL;
  PM_ASSERT_OK(pm_bvh_create(xyz, 3, tri, 2, &bvh, &e), e);
  pm_bvh_hit h;
  const double p[3] = {0.25, 3, 4};
  assert_int_equal(pm_bvh_closest(bvh, p, INFINITY, &h), 1);
  assert_int_equal(h.tri, 0);
  PM_ASSERT_NEAR(h.dist, 5.0, 1e-15);
  PM_ASSERT_NEAR(h.point[0], 0.25, 1e-15);
  const double p2[3] = {5, 5, 6.5};
  assert_int_equal(pm_bvh_closest(bvh, p2, INFINITY, &h), 1);
  assert_int_equal(h.tri, 1);
  PM_ASSERT_NEAR(h.dist, 1.5, 1e-15);
  pm_bvh_destroy(bvh);
}

/* The visitor sees every triangle within the radius (and may see more). */
typedef struct visit_rec {
  const double *xyz;
  const int32_t *tri;
  double p[3];
  char *seen;
} visit_rec;

static double visit_mark(void *user, int32_t t, double radius) {
  visit_rec *v = user;
  v->seen[t] = 1;
  return radius;
}

static void test_bvh_visit(void **state) {
  (void)state;
  double *xyz;
  int32_t *tri, nnode, ntri;
  bumpy_grid(20, &xyz, &nnode, &tri, &ntri);
  pm_error e = {0};
  pm_bvh *bvh = NULL;
  PM_ASSERT_OK(pm_bvh_create(xyz, nnode, tri, ntri, &bvh, &e), e);
  visit_rec v = {xyz, tri, {0.4, 0.6, 0.1}, calloc((size_t)ntri, 1)};
  double rad = 0.15;
  PM_ASSERT_NEAR(pm_bvh_visit(bvh, v.p, rad, visit_mark, &v), rad, 0);
  int within = 0, seen = 0;
  for (int32_t t = 0; t < ntri; ++t) {
    const int32_t *k = &tri[3 * t];
    double d = pm_point_triangle_closest(v.p, &xyz[3 * k[0]], &xyz[3 * k[1]], &xyz[3 * k[2]], NULL,
                                         NULL);
    if (d <= rad) {
      ++within;
      assert_true(v.seen[t]);
    }
    seen += v.seen[t];
  }
  assert_true(within > 10);
  assert_true(seen < ntri); /* it pruned something */
  free(v.seen);
  pm_bvh_destroy(bvh);
  free(xyz), free(tri);
}

/* ---- concurrent queries -------------------------------------------------------------------------- */

static void test_bvh_concurrent(void **state) {
  (void)state;
  double *xyz;
  int32_t *tri, nnode, ntri;
  bumpy_grid(60, &xyz, &nnode, &tri, &ntri);
  pm_error e = {0};
  pm_bvh *bvh = NULL;
  PM_ASSERT_OK(pm_bvh_create(xyz, nnode, tri, ntri, &bvh, &e), e);
  enum { N = 20000 };
  double *pts = malloc(sizeof(double) * 3 * N), *d1 = malloc(sizeof(double) * N),
         *d2 = malloc(sizeof(double) * N);
  pm_rng r;
  pm_rng_init(&r, 3, 0);
  for (int i = 0; i < 3 * N; ++i) pts[i] = pm_rng_range(&r, -0.2, 1.2);
  for (int i = 0; i < N; ++i) {
    pm_bvh_hit h;
    pm_bvh_closest(bvh, &pts[3 * i], INFINITY, &h);
    d1[i] = h.dist;
  }
#pragma omp parallel for num_threads(4) schedule(dynamic, 64)
  for (int i = 0; i < N; ++i) {
    pm_bvh_hit h;
    pm_bvh_closest(bvh, &pts[3 * i], INFINITY, &h);
    d2[i] = h.dist;
  }
  for (int i = 0; i < N; ++i) assert_true(d1[i] == d2[i]);
  free(pts), free(d1), free(d2);
  pm_bvh_destroy(bvh);
  free(xyz), free(tri);
}

/* ---- overlapping pairs ------------------------------------------------------------------------------ */

typedef struct pair_rec {
  int32_t ntri;
  uint8_t *count; /* [ntri*ntri] how often each ordered pair was reported */
  int bad_order;
} pair_rec;

static void pair_collect(void *user, const int32_t *pairs, int32_t npair) {
  pair_rec *p = user;
  for (int32_t k = 0; k < npair; ++k) {
    int32_t s = pairs[2 * k], t = pairs[2 * k + 1];
    if (s >= t) p->bad_order = 1;
    p->count[(size_t)s * p->ntri + t]++;
  }
}

static void test_bvh_overlapping_pairs(void **state) {
  (void)state;
  pm_rng r;
  pm_rng_init(&r, 21, 0);
  /* Small random triangles scattered in a box: a few overlaps each. */
  const int32_t ntri = 700, nnode = 3 * ntri;
  double *xyz = malloc(sizeof(double) * 3 * nnode);
  int32_t *tri = malloc(sizeof(int32_t) * 3 * ntri);
  for (int32_t t = 0; t < ntri; ++t) {
    double c[3] = {pm_rng_range(&r, 0, 1), pm_rng_range(&r, 0, 1), pm_rng_range(&r, 0, 1)};
    for (int v = 0; v < 3; ++v) {
      for (int k = 0; k < 3; ++k) xyz[3 * (3 * t + v) + k] = c[k] + pm_rng_range(&r, -0.06, 0.06);
      tri[3 * t + v] = 3 * t + v;
    }
  }
  /* Two triangles sharing exactly one corner value along x: their boxes touch. */
  xyz[3 * 0 + 0] = 0.5, xyz[3 * 1 + 0] = 0.4, xyz[3 * 2 + 0] = 0.45;
  xyz[3 * 3 + 0] = 0.5, xyz[3 * 4 + 0] = 0.6, xyz[3 * 5 + 0] = 0.55;
  for (int v = 0; v < 6; ++v) xyz[3 * v + 1] = 0.3 + 0.01 * (v % 3), xyz[3 * v + 2] = 0.7 + 0.01 * (v % 2);
  pm_error e = {0};
  pm_bvh *bvh = NULL;
  PM_ASSERT_OK(pm_bvh_create(xyz, nnode, tri, ntri, &bvh, &e), e);
  pair_rec p = {ntri, calloc((size_t)ntri * ntri, 1), 0};
  PM_ASSERT_OK(pm_bvh_overlapping_pairs(bvh, pair_collect, &p, &e), e);
  assert_int_equal(p.bad_order, 0);
  int npairs = 0;
  for (int32_t s = 0; s < ntri; ++s)
    for (int32_t t = s + 1; t < ntri; ++t) {
      int touch = 1;
      for (int k = 0; k < 3; ++k) {
        double lo0 = INFINITY, hi0 = -INFINITY, lo1 = INFINITY, hi1 = -INFINITY;
        for (int v = 0; v < 3; ++v) {
          lo0 = fmin(lo0, xyz[3 * tri[3 * s + v] + k]), hi0 = fmax(hi0, xyz[3 * tri[3 * s + v] + k]);
          lo1 = fmin(lo1, xyz[3 * tri[3 * t + v] + k]), hi1 = fmax(hi1, xyz[3 * tri[3 * t + v] + k]);
        }
        if (lo0 > hi1 || lo1 > hi0) touch = 0;
      }
      if (p.count[(size_t)s * ntri + t] != touch)
        fail_msg("pair (%d, %d): reported %d times, boxes %s", (int)s, (int)t,
                 p.count[(size_t)s * ntri + t], touch ? "touch" : "apart");
      npairs += touch;
    }
  assert_int_equal(p.count[0 * ntri + 1], 1); /* the touching pair */
  assert_true(npairs > 100);
  free(p.count);
  pm_bvh_destroy(bvh);
  free(xyz), free(tri);
}

/* ---- bad input, empty input -------------------------------------------------------------------------- */

static void test_bvh_bad_input(void **state) {
  (void)state;
  double xyz[] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  int32_t tri[] = {0, 1, 3};
  pm_error e = {0};
  pm_bvh *bvh = NULL;
  assert_int_equal(pm_bvh_create(xyz, 3, tri, 1, &bvh, &e), PM_ERR_ARG);
  assert_null(bvh);
  assert_non_null(strstr(e.msg, "triangle 0 uses node 3"));
  tri[2] = 2;
  xyz[4] = NAN;
  assert_int_equal(pm_bvh_create(xyz, 3, tri, 1, &bvh, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "node 1"));
  assert_int_equal(pm_bvh_create(xyz, -1, tri, 1, &bvh, &e), PM_ERR_ARG);
  xyz[4] = 0;
  /* Empty: builds, finds nothing. */
  PM_ASSERT_OK(pm_bvh_create(NULL, 0, NULL, 0, &bvh, &e), e);
  pm_bvh_hit h;
  const double p[3] = {0, 0, 0};
  assert_int_equal(pm_bvh_closest(bvh, p, INFINITY, &h), 0);
  assert_int_equal(h.tri, -1);
  pm_bvh_destroy(bvh);
  /* A non-finite query point finds nothing (no crash). */
  PM_ASSERT_OK(pm_bvh_create(xyz, 3, tri, 1, &bvh, &e), e);
  const double q[3] = {NAN, 0, 0};
  assert_int_equal(pm_bvh_closest(bvh, q, INFINITY, &h), 0);
  pm_bvh_destroy(bvh);
  pm_bvh_destroy(NULL);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_point_triangle_regions),
      cmocka_unit_test(test_bvh_random_soup),
      cmocka_unit_test(test_bvh_bumpy_surface),
      cmocka_unit_test(test_bvh_offset_coordinates),
      cmocka_unit_test(test_bvh_ties_lowest_index),
      cmocka_unit_test(test_bvh_degenerate_primitives),
      cmocka_unit_test(test_bvh_visit),
      cmocka_unit_test(test_bvh_concurrent),
      cmocka_unit_test(test_bvh_overlapping_pairs),
      cmocka_unit_test(test_bvh_bad_input),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
