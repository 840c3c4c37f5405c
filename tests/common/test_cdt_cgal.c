/* Constrained Delaunay triangulation through CGAL (cdt_cgal.h): exact triangle counts from
 * Euler's formula, orientation, area, hole removal by nesting parity, constraint edges kept,
 * the constrained Delaunay property, crossing constraints, duplicates and degenerate input. */
#include "test_support.h"

#include "common/backends/cdt_cgal.h"
#include "common/backends/predicates.h"
#include "common/base/rng.h"

#include <stdlib.h>
#include <string.h>

/* ---- helpers ---------------------------------------------------------------------------- */

static double tri_area(const double *xy, const int32_t *t) {
  const double *a = xy + 2 * t[0], *b = xy + 2 * t[1], *c = xy + 2 * t[2];
  return 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]));
}

/* How many triangles have the undirected edge (a, b). */
static int edge_count(const pm_cdt_result *r, int32_t a, int32_t b) {
  int n = 0;
  for (int32_t t = 0; t < r->ntri; ++t)
    for (int i = 0; i < 3; ++i) {
      int32_t u = r->tri[3 * t + i], v = r->tri[3 * t + (i + 1) % 3];
      if ((u == a && v == b) || (u == b && v == a)) ++n;
    }
  return n;
}

static int is_constraint(const int32_t *cons, int32_t ncons, int32_t a, int32_t b) {
  for (int32_t k = 0; k < ncons; ++k)
    if ((cons[2 * k] == a && cons[2 * k + 1] == b) || (cons[2 * k] == b && cons[2 * k + 1] == a))
      return 1;
  return 0;
}

/* ---- a square [0,4]^2 with a square hole [1.5,2.5]^2 -------------------------------------- */

typedef struct domain {
  double xy[2 * 512];
  int32_t npts;
  int32_t cons[2 * 128];
  int32_t ncons;
  int32_t nboundary, ninterior; /* vertices of the domain (the hole's and outside's excluded) */
  int32_t dangling;             /* index of the dangling constraint in cons */
} domain;

static int32_t add_pt(domain *d, double x, double y) {
  d->xy[2 * d->npts] = x;
  d->xy[2 * d->npts + 1] = y;
  return d->npts++;
}

/* A closed loop of 4*m points on the square [lo,hi]^2, constrained edge by edge. */
static void add_square_loop(domain *d, double lo, double hi, int m) {
  int32_t first = d->npts;
  double h = (hi - lo) / m;
  for (int i = 0; i < m; ++i) add_pt(d, lo + i * h, lo);
  for (int i = 0; i < m; ++i) add_pt(d, hi, lo + i * h);
  for (int i = 0; i < m; ++i) add_pt(d, hi - i * h, hi);
  for (int i = 0; i < m; ++i) add_pt(d, lo, hi - i * h);
  int32_t n = 4 * m;
  for (int32_t i = 0; i < n; ++i) {
    d->cons[2 * d->ncons] = first + i;
    d->cons[2 * d->ncons + 1] = first + (i + 1) % n;
    d->ncons++;
  }
  d->nboundary += n;
}

static void build_domain(domain *d) {
  memset(d, 0, sizeof *d);
  add_square_loop(d, 0.0, 4.0, 8); /* 32 points, spacing 0.5 */
  add_square_loop(d, 1.5, 2.5, 4); /* 16 points, spacing 0.25 */
  /* Interior points: a jittered grid of spacing 0.4 at 0.2 + 0.4 k; the jitter (< 0.05) keeps
   * them off the boundaries, and points that fall in the hole stay in the input (they must
   * vanish with the hole) but are not counted as domain vertices. */
  pm_rng rng;
  pm_rng_init(&rng, 7, 0);
  int32_t pa = -1, pb = -1;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) {
      double x = 0.2 + 0.4 * i + pm_rng_range(&rng, -0.05, 0.05);
      double y = 0.2 + 0.4 * j + pm_rng_range(&rng, -0.05, 0.05);
      int in_hole = x > 1.5 && x < 2.5 && y > 1.5 && y < 2.5;
      int32_t id = add_pt(d, x, y);
      if (!in_hole) d->ninterior++;
      if (i == 1 && j == 1) pa = id;
      if (i == 2 && j == 2) pb = id;
    }
  /* Points outside the outer square: triangulated, then removed with the exterior. */
  add_pt(d, -1.0, 2.0);
  add_pt(d, 5.0, 5.5);
  /* A dangling constraint inside the domain between two interior points: it keeps the nesting
   * parity and must be an edge of two triangles. */
  d->dangling = d->ncons;
  d->cons[2 * d->ncons] = pa;
  d->cons[2 * d->ncons + 1] = pb;
  d->ncons++;
}

static void square_with_hole(void **state) {
  (void)state;
  domain d;
  build_domain(&d);
  pm_cdt_result r;
  pm_error e = {0};
  PM_ASSERT_OK(pm_cdt_triangulate(d.xy, d.npts, d.cons, d.ncons, 1, 1, &r, &e), e);

  /* Euler's formula for a triangulated polygonal region with b boundary vertices, i interior
   * vertices and h holes: V - E + F = 1 - h (F counts triangles), 3T + b = 2E, V = b + i give
   * T = 2i + b - 2 + 2h. */
  int32_t expect = 2 * d.ninterior + d.nboundary - 2 + 2 * 1;
  assert_int_equal(d.ninterior, 96); /* 4 of the 100 grid points fall in the hole */
  assert_int_equal(r.ntri, expect);
  assert_int_equal(r.nmerged, 0);
  assert_non_null(r.merged_into);
  for (int32_t i = 0; i < d.npts; ++i) assert_int_equal(r.merged_into[i], i);

  double area = 0;
  for (int32_t t = 0; t < r.ntri; ++t) {
    const int32_t *v = r.tri + 3 * t;
    for (int i = 0; i < 3; ++i) assert_true(v[i] >= 0 && v[i] < d.npts);
    assert_int_equal(pm_orient2d(d.xy + 2 * v[0], d.xy + 2 * v[1], d.xy + 2 * v[2]), 1);
    area += tri_area(d.xy, v);
    double cx = (d.xy[2 * v[0]] + d.xy[2 * v[1]] + d.xy[2 * v[2]]) / 3;
    double cy = (d.xy[2 * v[0] + 1] + d.xy[2 * v[1] + 1] + d.xy[2 * v[2] + 1]) / 3;
    assert_false(cx > 1.5 && cx < 2.5 && cy > 1.5 && cy < 2.5); /* nothing in the hole */
    assert_true(cx > 0 && cx < 4 && cy > 0 && cy < 4);           /* nothing outside */
  }
  PM_ASSERT_NEAR(area, 16.0 - 1.0, 1e-12);

  /* Loop constraints bound the domain: one triangle each; the dangling one: two. */
  for (int32_t k = 0; k < d.ncons; ++k)
    assert_int_equal(edge_count(&r, d.cons[2 * k], d.cons[2 * k + 1]), k == d.dangling ? 2 : 1);

  /* Constrained Delaunay: across every interior unconstrained edge, the opposite vertex of the
   * neighbour is not strictly inside the circumcircle (exact incircle). */
  int checked = 0;
  for (int32_t t = 0; t < r.ntri; ++t)
    for (int i = 0; i < 3; ++i) {
      int32_t a = r.tri[3 * t + i], b = r.tri[3 * t + (i + 1) % 3], c = r.tri[3 * t + (i + 2) % 3];
      if (is_constraint(d.cons, d.ncons, a, b)) continue;
      for (int32_t s = 0; s < r.ntri; ++s) {
        if (s == t) continue;
        for (int j = 0; j < 3; ++j)
          if (r.tri[3 * s + j] == b && r.tri[3 * s + (j + 1) % 3] == a) {
            int32_t dv = r.tri[3 * s + (j + 2) % 3];
            assert_true(pm_incircle(d.xy + 2 * a, d.xy + 2 * b, d.xy + 2 * c, d.xy + 2 * dv) <= 0);
            ++checked;
          }
      }
    }
  assert_true(checked > 2 * r.ntri); /* each interior edge is seen from both sides */
  pm_cdt_result_free(&r);
  assert_null(r.tri);
  assert_int_equal(r.ntri, 0);
}

/* Without exterior removal: the Delaunay triangulation of the convex hull, 2n - 2 - k
 * triangles for n points of which k on the hull; points the constraints do not touch remain. */
static void keep_exterior(void **state) {
  (void)state;
  /* The unit square's corners and 5 interior points, no constraint. */
  double xy[] = {0, 0, 1, 0, 1, 1, 0, 1, 0.5, 0.5, 0.2, 0.3, 0.7, 0.2, 0.8, 0.7, 0.3, 0.8};
  pm_cdt_result r;
  pm_error e = {0};
  PM_ASSERT_OK(pm_cdt_triangulate(xy, 9, NULL, 0, 0, 0, &r, &e), e);
  assert_int_equal(r.ntri, 2 * 9 - 2 - 4);
  assert_null(r.merged_into);
  double area = 0;
  for (int32_t t = 0; t < r.ntri; ++t) area += tri_area(xy, r.tri + 3 * t);
  PM_ASSERT_NEAR(area, 1.0, 1e-15);
  pm_cdt_result_free(&r);
  /* remove_exterior with no constraint at all: nothing is enclosed, nothing is kept. */
  PM_ASSERT_OK(pm_cdt_triangulate(xy, 9, NULL, 0, 1, 0, &r, &e), e);
  assert_int_equal(r.ntri, 0);
  pm_cdt_result_free(&r);
}

static void crossing_constraints(void **state) {
  (void)state;
  /* A square with both diagonals constrained: they cross at (0.5, 0.5), which is no input
   * point, so the triangulation must fail rather than add it. */
  double xy[] = {0, 0, 1, 0, 1, 1, 0, 1};
  int32_t cons[] = {0, 1, 1, 2, 2, 3, 3, 0, 0, 2, 1, 3};
  pm_cdt_result r;
  pm_error e = {0};
  assert_int_equal(pm_cdt_triangulate(xy, 4, cons, 6, 1, 1, &r, &e), PM_ERR_GEOM);
  assert_int_equal(e.code, PM_ERR_GEOM);
  assert_non_null(strstr(e.msg, "constraint edges 4 (points 0-2) and 5 (points 1-3)"));
  assert_int_equal(r.ntri, 0);
  assert_null(r.tri);
  assert_null(r.merged_into);

  /* The same diagonals with the crossing point given as input: both are split there. */
  double xy2[] = {0, 0, 1, 0, 1, 1, 0, 1, 0.5, 0.5};
  pm_error e2 = {0};
  PM_ASSERT_OK(pm_cdt_triangulate(xy2, 5, cons, 6, 1, 0, &r, &e2), e2);
  assert_int_equal(r.ntri, 4);
  for (int32_t c = 0; c < 4; ++c) assert_int_equal(edge_count(&r, c, 4), 2);
  pm_cdt_result_free(&r);

  /* A T: the end point of one constraint on the interior of another is an input point. */
  double xy3[] = {0, 0, 2, 0, 1, 1, 1, 0, 0, -1};
  int32_t cons3[] = {0, 1, 3, 2};
  PM_ASSERT_OK(pm_cdt_triangulate(xy3, 5, cons3, 2, 0, 0, &r, &e2), e2);
  assert_int_equal(edge_count(&r, 0, 3), 2);
  assert_int_equal(edge_count(&r, 3, 1), 2);
  assert_int_equal(edge_count(&r, 3, 2), 2);
  pm_cdt_result_free(&r);
}

/* A constraint through an input point is split there; no point is added. */
static void collinear_constraint_through_point(void **state) {
  (void)state;
  double xy[] = {0, 0, 2, 0, 1, 0, 1, 1, 1, -1};
  int32_t cons[] = {0, 1};
  pm_cdt_result r;
  pm_error e = {0};
  PM_ASSERT_OK(pm_cdt_triangulate(xy, 5, cons, 1, 0, 0, &r, &e), e);
  assert_int_equal(r.ntri, 4);
  assert_int_equal(edge_count(&r, 0, 2), 2);
  assert_int_equal(edge_count(&r, 2, 1), 2);
  assert_int_equal(edge_count(&r, 0, 1), 0);
  for (int32_t i = 0; i < 3 * r.ntri; ++i) assert_true(r.tri[i] >= 0 && r.tri[i] < 5);
  pm_cdt_result_free(&r);
}

static void duplicates_merged(void **state) {
  (void)state;
  /* The unit square with point 0 repeated as 4 and 6, point 2 as 5; the constraint loop uses
   * the copies, and one constraint joins two copies of the same point. */
  double xy[] = {0, 0, 1, 0, 1, 1, 0, 1, 0, 0, 1, 1, 0, 0, 0.4, 0.6};
  int32_t cons[] = {4, 1, 1, 5, 5, 3, 3, 6, 0, 6};
  pm_cdt_result r;
  pm_error e = {0};
  PM_ASSERT_OK(pm_cdt_triangulate(xy, 8, cons, 5, 1, 1, &r, &e), e);
  assert_int_equal(r.nmerged, 3);
  const int32_t expect[] = {0, 1, 2, 3, 0, 2, 0, 7};
  for (int i = 0; i < 8; ++i) assert_int_equal(r.merged_into[i], expect[i]);
  /* T = 2i + b - 2 = 2 + 4 - 2. */
  assert_int_equal(r.ntri, 4);
  for (int32_t i = 0; i < 3 * r.ntri; ++i) assert_true(r.tri[i] < 4 || r.tri[i] == 7);
  double area = 0;
  for (int32_t t = 0; t < r.ntri; ++t) area += tri_area(xy, r.tri + 3 * t);
  PM_ASSERT_NEAR(area, 1.0, 1e-15);
  pm_cdt_result_free(&r);
}

static void degenerate_input(void **state) {
  (void)state;
  pm_cdt_result r;
  pm_error e = {0};
  PM_ASSERT_OK(pm_cdt_triangulate(NULL, 0, NULL, 0, 1, 1, &r, &e), e);
  assert_int_equal(r.ntri, 0);
  assert_null(r.merged_into);
  pm_cdt_result_free(&r);

  double two[] = {0, 0, 1, 1};
  int32_t c01[] = {0, 1};
  PM_ASSERT_OK(pm_cdt_triangulate(two, 2, c01, 1, 1, 1, &r, &e), e);
  assert_int_equal(r.ntri, 0);
  assert_int_equal(r.merged_into[1], 1);
  pm_cdt_result_free(&r);

  /* Collinear points, constrained or not: no triangle, no failure. */
  double line[] = {0, 0, 3, 3, 1, 1, 2, 2, 4, 4};
  int32_t cl[] = {0, 1, 4, 3};
  PM_ASSERT_OK(pm_cdt_triangulate(line, 5, cl, 2, 0, 0, &r, &e), e);
  assert_int_equal(r.ntri, 0);
  pm_cdt_result_free(&r);
  PM_ASSERT_OK(pm_cdt_triangulate(line, 5, cl, 2, 1, 0, &r, &e), e);
  assert_int_equal(r.ntri, 0);
  pm_cdt_result_free(&r);

  /* All points equal: one vertex. */
  double same[] = {1, 2, 1, 2, 1, 2};
  PM_ASSERT_OK(pm_cdt_triangulate(same, 3, NULL, 0, 0, 1, &r, &e), e);
  assert_int_equal(r.ntri, 0);
  assert_int_equal(r.nmerged, 2);
  assert_int_equal(r.merged_into[2], 0);
  pm_cdt_result_free(&r);
  pm_cdt_result_free(NULL);
}

static void bad_arguments(void **state) {
  (void)state;
  double xy[] = {0, 0, 1, 0, 0, 1};
  int32_t good[] = {0, 1, 1, 2, 2, 0};
  pm_cdt_result r;
  pm_error e = {0};

  double nan_xy[] = {0, 0, 1, 0, 0, NAN};
  assert_int_equal(pm_cdt_triangulate(nan_xy, 3, good, 3, 1, 0, &r, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "point 2"));
  assert_null(r.tri);
  double inf_xy[] = {INFINITY, 0, 1, 0, 0, 1};
  assert_int_equal(pm_cdt_triangulate(inf_xy, 3, good, 3, 1, 0, &r, &e), PM_ERR_ARG);

  int32_t out_of_range[] = {0, 1, 1, 3};
  assert_int_equal(pm_cdt_triangulate(xy, 3, out_of_range, 2, 1, 0, &r, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "constraint 1"));
  int32_t negative[] = {-1, 1};
  assert_int_equal(pm_cdt_triangulate(xy, 3, negative, 1, 1, 0, &r, &e), PM_ERR_ARG);
  int32_t self[] = {0, 1, 2, 2};
  assert_int_equal(pm_cdt_triangulate(xy, 3, self, 2, 1, 0, &r, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "itself"));

  assert_int_equal(pm_cdt_triangulate(NULL, 3, NULL, 0, 1, 0, &r, &e), PM_ERR_ARG);
  assert_int_equal(pm_cdt_triangulate(xy, 3, NULL, 2, 1, 0, &r, &e), PM_ERR_ARG);
  assert_int_equal(pm_cdt_triangulate(xy, -1, NULL, 0, 1, 0, &r, &e), PM_ERR_ARG);
  assert_int_equal(pm_cdt_triangulate(xy, 3, good, -2, 1, 0, &r, &e), PM_ERR_ARG);
  assert_int_equal(pm_cdt_triangulate(xy, 3, good, 3, 1, 0, NULL, &e), PM_ERR_ARG);

  /* The good input works and is the one triangle. */
  PM_ASSERT_OK(pm_cdt_triangulate(xy, 3, good, 3, 1, 0, &r, &e), e);
  assert_int_equal(r.ntri, 1);
  pm_cdt_result_free(&r);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(square_with_hole),
      cmocka_unit_test(keep_exterior),
      cmocka_unit_test(crossing_constraints),
      cmocka_unit_test(collinear_constraint_through_point),
      cmocka_unit_test(duplicates_merged),
      cmocka_unit_test(degenerate_input),
      cmocka_unit_test(bad_arguments),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
