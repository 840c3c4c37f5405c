/* Quality measures against exact answers: single elements, percentiles, eps_t / eps_g on
 * hand-built meshes, size conformity and angle counts. */
#include "test_support.h"

#include <stdlib.h>
#include <string.h>

#include "common/mesh/mesh.h"
#include "common/measure/quality.h"
#include "common/sizing/sizing.h"

#define DEG(x) ((x) * 57.295779513082320876798154814105)

static void equilateral_triangle(void **state) {
  (void)state;
  double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0.5, sqrt(3.0) / 2, 0};
  pm_tri_measure q;
  pm_tri_measure_eval(a, b, c, &q);
  assert_false(q.degenerate);
  PM_ASSERT_NEAR(q.radius_ratio, 1.0, 1e-14);
  PM_ASSERT_NEAR(q.aspect_ratio, 1.0 / sqrt(3.0), 1e-14);
  PM_ASSERT_NEAR(q.min_angle, 60.0, 1e-12);
  PM_ASSERT_NEAR(q.max_angle, 60.0, 1e-12);
  PM_ASSERT_NEAR(q.area, sqrt(3.0) / 4, 1e-15);
  PM_ASSERT_NEAR(q.rr, 0.5, 1e-14);
  /* Scale and rotation invariance, any plane. */
  double s = 1e-3, a2[3] = {5, 5, 5}, b2[3] = {5, 5 + s, 5}, c2[3] = {5, 5 + s / 2, 5 + s * sqrt(3.0) / 2};
  pm_tri_measure_eval(a2, b2, c2, &q);
  PM_ASSERT_NEAR(q.radius_ratio, 1.0, 1e-9);
  PM_ASSERT_NEAR(q.aspect_ratio, 1.0 / sqrt(3.0), 1e-9);
}

static void right_isosceles_triangle(void **state) {
  (void)state;
  double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0, 1, 0};
  pm_tri_measure q;
  pm_tri_measure_eval(a, b, c, &q);
  /* legs 1: r = (2 - sqrt2)/2, R = sqrt2/2, q = 2 r / R = 2 (sqrt2 - 1) */
  PM_ASSERT_NEAR(q.radius_ratio, 2.0 * (sqrt(2.0) - 1.0), 1e-14);
  PM_ASSERT_NEAR(q.radius_ratio, 0.8284271247461902, 1e-14);
  PM_ASSERT_NEAR(q.aspect_ratio, sqrt(2.0) / 2.0, 1e-14); /* R / l_min, l_min = 1 */
  PM_ASSERT_NEAR(q.min_angle, 45.0, 1e-12);
  PM_ASSERT_NEAR(q.max_angle, 90.0, 1e-12);
  /* Orientation does not matter. */
  pm_tri_measure_eval(a, c, b, &q);
  PM_ASSERT_NEAR(q.radius_ratio, 2.0 * (sqrt(2.0) - 1.0), 1e-14);
}

static void degenerate_triangle(void **state) {
  (void)state;
  double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {2, 0, 0}, d[3] = {0, 0, 0};
  pm_tri_measure q;
  pm_tri_measure_eval(a, b, c, &q);
  assert_true(q.degenerate);
  assert_true(q.radius_ratio == 0.0 && q.aspect_ratio == PM_QUALITY_HUGE);
  assert_true(q.min_angle == 0.0 && q.max_angle == 180.0);
  pm_tri_measure_eval(a, b, d, &q); /* two coincident vertices */
  assert_true(q.degenerate && q.radius_ratio == 0.0);
  double n[3] = {NAN, 0, 0};
  pm_tri_measure_eval(a, b, n, &q);
  assert_true(q.degenerate && q.radius_ratio == 0.0 && q.area == 0.0);
  /* Thin but not degenerate: finite, tiny radius ratio. */
  double e[3] = {0.5, 1e-9, 0};
  pm_tri_measure_eval(a, b, e, &q);
  assert_false(q.degenerate);
  assert_true(q.radius_ratio > 0 && q.radius_ratio < 1e-8);
  PM_ASSERT_NEAR(q.max_angle, 180.0, 1e-6);
  /* pm_tri_degenerate gives the same verdicts without the measures, also just either side of
   * the flatness bound (a height of 1e-12 of the longest edge, 2: 2e-12). */
  double f[3] = {0.5, 1.98e-12, 0}, g[3] = {0.5, 2.02e-12, 0};
  assert_true(pm_tri_degenerate(a, b, c) && pm_tri_degenerate(a, b, d) && pm_tri_degenerate(a, b, n));
  assert_false(pm_tri_degenerate(a, b, e));
  double far[3] = {2, 0, 0};
  pm_tri_measure_eval(a, far, f, &q);
  assert_int_equal(pm_tri_degenerate(a, far, f), q.degenerate);
  assert_true(pm_tri_degenerate(a, far, f));
  pm_tri_measure_eval(a, far, g, &q);
  assert_int_equal(pm_tri_degenerate(a, far, g), q.degenerate);
  assert_false(pm_tri_degenerate(a, far, g));
}

/* A regular tet with positive orientation. */
static const double reg[4][3] = {{1, 1, 1}, {-1, 1, -1}, {1, -1, -1}, {-1, -1, 1}};

static void regular_tet(void **state) {
  (void)state;
  pm_tet_measure q;
  pm_tet_measure_eval(reg[0], reg[1], reg[2], reg[3], &q);
  assert_false(q.degenerate);
  assert_true(q.volume > 0);
  PM_ASSERT_NEAR(q.volume, 8.0 / 3.0, 1e-14); /* edge 2 sqrt2: a^3 / (6 sqrt2) */
  PM_ASSERT_NEAR(q.radius_ratio, 1.0, 1e-14);
  PM_ASSERT_NEAR(q.rr, 1.0 / 3.0, 1e-14);
  PM_ASSERT_NEAR(q.aspect_ratio, sqrt(6.0) / 4.0, 1e-14);
  PM_ASSERT_NEAR(q.min_dihedral, DEG(acos(1.0 / 3.0)), 1e-12);
  PM_ASSERT_NEAR(q.max_dihedral, 70.528779365509308, 1e-12);
  /* Swapping two vertices flips the sign of the volume only. */
  pm_tet_measure_eval(reg[1], reg[0], reg[2], reg[3], &q);
  assert_true(q.volume < 0);
  PM_ASSERT_NEAR(q.radius_ratio, 1.0, 1e-14);
}

static void right_corner_tet(void **state) {
  (void)state;
  /* The corner tet (0, e1, e2, e3): dihedral angles 90 (x3, at the axes) and
   * acos(1/sqrt3) = 54.7356 (x3, at the slanted face); r = 1 / (3 + sqrt3), R = sqrt3 / 2. */
  double o[3] = {0, 0, 0}, x[3] = {1, 0, 0}, y[3] = {0, 1, 0}, z[3] = {0, 0, 1};
  pm_tet_measure q;
  pm_tet_measure_eval(o, x, y, z, &q);
  PM_ASSERT_NEAR(q.volume, 1.0 / 6.0, 1e-15);
  PM_ASSERT_NEAR(q.min_dihedral, DEG(acos(1.0 / sqrt(3.0))), 1e-12);
  PM_ASSERT_NEAR(q.max_dihedral, 90.0, 1e-12);
  PM_ASSERT_NEAR(q.radius_ratio, 3.0 * (1.0 / (3.0 + sqrt(3.0))) / (sqrt(3.0) / 2.0), 1e-14);
  PM_ASSERT_NEAR(q.aspect_ratio, (sqrt(3.0) / 2.0) / 1.0, 1e-14);
}

static void sliver_tet(void **state) {
  (void)state;
  /* Four points near the corners of the unit square, the diagonal pairs lifted by +-h: every
   * edge is long, yet the tet is flat (the classic sliver). */
  double h = 1e-4;
  double a[3] = {0, 0, 0}, b[3] = {1, 1, 0}, c[3] = {1, 0, h}, d[3] = {0, 1, h};
  pm_tet_measure q;
  pm_tet_measure_eval(a, b, c, d, &q);
  if (q.volume < 0) pm_tet_measure_eval(b, a, c, d, &q);
  assert_false(q.degenerate);
  assert_true(q.radius_ratio > 0 && q.radius_ratio < 1e-3);
  assert_true(q.min_dihedral < 0.1);
  assert_true(q.max_dihedral > 179.9);
  /* ...while R / l_min stays near that of the square (R = sqrt2/2, l_min = 1): this measure
   * does not see slivers, which is why the radius ratio is reported beside it. */
  PM_ASSERT_NEAR(q.aspect_ratio, sqrt(2.0) / 2.0, 1e-3);
  /* Exactly flat: degenerate. */
  double c0[3] = {1, 0, 0}, d0[3] = {0, 1, 0};
  pm_tet_measure_eval(a, b, c0, d0, &q);
  assert_true(q.degenerate && q.radius_ratio == 0 && q.aspect_ratio == PM_QUALITY_HUGE);
  assert_true(q.min_dihedral == 0 && q.max_dihedral == 180);
}

static void percentiles(void **state) {
  (void)state;
  double v[4] = {4, 1, 3, 2};
  pm_summary s;
  pm_error e = {0};
  PM_ASSERT_OK(pm_summary_compute(v, 4, &s, &e), e);
  assert_int_equal(s.n, 4);
  assert_true(s.min == 1 && s.max == 4);
  PM_ASSERT_NEAR(s.p25, 1.75, 1e-15);
  PM_ASSERT_NEAR(s.median, 2.5, 1e-15);
  PM_ASSERT_NEAR(s.p75, 3.25, 1e-15);
  PM_ASSERT_NEAR(s.mean, 2.5, 1e-15);
  assert_true(v[0] == 4 && v[1] == 1); /* input untouched */
  double w[4] = {5, NAN, 1, 3};
  PM_ASSERT_OK(pm_summary_compute(w, 4, &s, &e), e);
  assert_int_equal(s.n, 3);
  PM_ASSERT_NEAR(s.median, 3, 0);
  PM_ASSERT_NEAR(s.p25, 2, 0);
  PM_ASSERT_OK(pm_summary_compute(w, 0, &s, &e), e);
  assert_int_equal(s.n, 0);
  double one = 7;
  PM_ASSERT_OK(pm_summary_compute(&one, 1, &s, &e), e);
  assert_true(s.min == 7 && s.p25 == 7 && s.median == 7 && s.max == 7 && s.mean == 7);

  /* The radix path (n >= 256), with negative numbers, -0.0 and repeated values: -500 .. 499
   * in a scrambled order, each value once, plus nothing else. */
  enum { N = 1000 };
  double *x = malloc(N * sizeof *x);
  for (int i = 0; i < N; ++i) x[i] = (double)(((i * 7919) % N) - 500);
  PM_ASSERT_OK(pm_summary_compute(x, N, &s, &e), e);
  assert_true(s.min == -500 && s.max == 499);
  PM_ASSERT_NEAR(s.p25, -500 + 249.75, 1e-12);
  PM_ASSERT_NEAR(s.median, -0.5, 1e-12);
  PM_ASSERT_NEAR(s.p75, -500 + 749.25, 1e-12);
  PM_ASSERT_NEAR(s.mean, -0.5, 1e-12);
  PM_ASSERT_OK(pm_sort_doubles(x, N, &e), e);
  for (int i = 0; i < N; ++i) assert_true(x[i] == i - 500);
  for (int i = 0; i < N; ++i) x[i] = (i % 3 == 0) ? -0.0 : (i % 3 == 1 ? 1e-300 : -1e300);
  PM_ASSERT_OK(pm_sort_doubles(x, N, &e), e);
  for (int i = 1; i < N; ++i) assert_true(x[i - 1] <= x[i]);
  assert_true(x[0] == -1e300 && x[N - 1] == 1e-300);
  free(x);
  assert_true(pm_percentile_sorted((double[]){1, 2}, 2, 0.5) == 1.5);
}

/* A k x k grid of unit squares, nodes (i, j) = i + (k + 1) j, each square split along the
 * diagonal (i, j)-(i+1, j+1), except the square at `flip` (-1: none). */
static pm_mesh *grid(int k, int flip, int classify) {
  pm_mesh *m = pm_mesh_create();
  pm_error e = {0};
  for (int j = 0; j <= k; ++j)
    for (int i = 0; i <= k; ++i) {
      double p[3] = {i, j, 0};
      int inner = i > 0 && i < k && j > 0 && j < k;
      pm_mesh_add_node(m, p, classify ? (inner ? 2 : 1) : -1, classify ? 0 : -1, NULL, NULL, &e);
    }
  for (int j = 0; j < k; ++j)
    for (int i = 0; i < k; ++i) {
      int32_t a = i + (k + 1) * j, b = a + 1, c = a + k + 2, d = a + k + 1;
      if (i + k * j == flip) {
        pm_mesh_add_tri(m, a, b, d, 0, &e);
        pm_mesh_add_tri(m, b, c, d, 0, &e);
      } else {
        pm_mesh_add_tri(m, a, b, c, 0, &e);
        pm_mesh_add_tri(m, a, c, d, 0, &e);
      }
    }
  return m;
}

static double unit_size(const double xyz[3], void *user) {
  (void)xyz;
  return *(const double *)user;
}
static double bad_size(const double xyz[3], void *user) {
  (void)user;
  return xyz[0] > 2 ? -1.0 : 1.0;
}

static void mesh_measures(void **state) {
  (void)state;
  pm_error e = {0};
  pm_quality q;
  /* 3 x 3 squares, all diagonals alike: the four inner nodes have degree 6. */
  for (int classify = 0; classify < 2; ++classify) {
    pm_mesh *m = grid(3, -1, classify);
    PM_ASSERT_OK(pm_quality_compute_fn(m, NULL, NULL, &q, &e), e);
    assert_int_equal(q.tri.n, 18);
    assert_int_equal(q.tri.eps_t_nodes, 4);
    PM_ASSERT_NEAR(q.tri.eps_t, 0.0, 0);
    /* Every triangle is right isosceles: r/R = sqrt2 - 1, eps_g = 0.5 - (sqrt2 - 1). */
    PM_ASSERT_NEAR(q.tri.eps_g, 1.5 - sqrt(2.0), 1e-15);
    PM_ASSERT_NEAR(q.tri.s_radius_ratio.median, 2 * (sqrt(2.0) - 1), 1e-14);
    PM_ASSERT_NEAR(q.tri.s_min_angle.min, 45, 1e-12);
    PM_ASSERT_NEAR(q.tri.s_max_angle.max, 90, 1e-12);
    assert_int_equal(q.tri_min_angle_bins[4], 18); /* [40, 50) */
    assert_int_equal(q.tri_max_angle_over[0], 0);  /* 90 is not > 90 */
    /* Sites: only the middle square's two triangles have three inner corners. */
    assert_int_equal(q.tri_site_aspect[PM_TRI_BOUNDARY].n, 16);
    assert_int_equal(q.tri_site_aspect[PM_TRI_IRREGULAR].n, 0);
    assert_int_equal(q.tri_site_aspect[PM_TRI_REGULAR].n, 2);
    PM_ASSERT_NEAR(q.tri_site_aspect[PM_TRI_REGULAR].median, sqrt(0.5), 1e-14);
    assert_false(q.tri.has_size);
    assert_int_equal(q.tet.n, 0);
    pm_quality_clear(&q);
    pm_mesh_destroy(m);
  }
  /* Flip the diagonal of the middle square (index 4): the inner nodes get degrees 5, 7, 7, 5. */
  for (int classify = 0; classify < 2; ++classify) {
    pm_mesh *m = grid(3, 4, classify);
    PM_ASSERT_OK(pm_quality_compute_fn(m, NULL, NULL, &q, &e), e);
    assert_int_equal(q.tri.eps_t_nodes, 4);
    PM_ASSERT_NEAR(q.tri.eps_t, 1.0, 0);
    assert_int_equal(q.tri_site_aspect[PM_TRI_BOUNDARY].n, 16);
    assert_int_equal(q.tri_site_aspect[PM_TRI_IRREGULAR].n, 2);
    assert_int_equal(q.tri_site_aspect[PM_TRI_REGULAR].n, 0);
    pm_quality_clear(&q);
    pm_mesh_destroy(m);
  }
  /* Every node classified on the face: the boundary nodes count too. Degrees on the 3x3 grid:
   * corners (0,0) and (3,3) have 3, corners (3,0) and (0,3) have 2, the 8 other boundary nodes 4,
   * inner 6: eps_t = (3 + 3 + 4 + 4 + 8 * 2 + 0) / 16. */
  {
    pm_mesh *m = grid(3, -1, 0);
    for (int32_t v = 0; v < m->nnode; ++v) m->node_dim[v] = 2;
    PM_ASSERT_OK(pm_quality_compute_fn(m, NULL, NULL, &q, &e), e);
    assert_int_equal(q.tri.eps_t_nodes, 16);
    PM_ASSERT_NEAR(q.tri.eps_t, 30.0 / 16.0, 1e-15);
    pm_quality_clear(&q);
    pm_mesh_destroy(m);
  }
  /* Size conformity with d = 1: 24 unit edges and 9 diagonals. */
  {
    pm_mesh *m = grid(3, -1, 0);
    double d = 1.0;
    PM_ASSERT_OK(pm_quality_compute_fn(m, unit_size, &d, &q, &e), e);
    assert_true(q.tri.has_size);
    assert_int_equal(q.tri.nedge, 33);
    double mean = (24 + 9 * sqrt(2.0)) / 33;
    double var = (24 * (1 - mean) * (1 - mean) + 9 * (sqrt(2.0) - mean) * (sqrt(2.0) - mean)) / 33;
    PM_ASSERT_NEAR(q.tri.size_ratio.mean, mean, 1e-14);
    PM_ASSERT_NEAR(q.tri.size_ratio_std, sqrt(var), 1e-14);
    PM_ASSERT_NEAR(q.tri.size_ratio.min, 1, 1e-15);
    PM_ASSERT_NEAR(q.tri.size_ratio.max, sqrt(2.0), 1e-15);
    pm_quality_clear(&q);
    d = 0.5;
    PM_ASSERT_OK(pm_quality_compute_fn(m, unit_size, &d, &q, &e), e);
    PM_ASSERT_NEAR(q.tri.size_ratio.mean, 2 * mean, 1e-14);
    pm_quality_clear(&q);
    /* The same through a pm_sizing: an expression field that is 0.5 everywhere. */
    pm_sizing *sz = NULL;
    PM_ASSERT_OK(pm_sizing_parse("0.25+0.25", &sz, &e), e);
    PM_ASSERT_OK(pm_quality_compute(m, sz, &q, &e), e);
    PM_ASSERT_NEAR(q.tri.size_ratio.mean, 2 * mean, 1e-14);
    PM_ASSERT_NEAR(q.tri.size_ratio_std, 2 * sqrt(var), 1e-14);
    pm_quality_clear(&q);
    pm_sizing_destroy(sz);
    PM_ASSERT_OK(pm_quality_compute(m, NULL, &q, &e), e);
    assert_false(q.tri.has_size);
    pm_quality_clear(&q);
    assert_int_equal(pm_quality_compute_fn(m, bad_size, NULL, &q, &e), PM_ERR_ARG);
    assert_non_null(strstr(e.msg, "size field is -1"));
    assert_int_equal(q.tri.n, 0); /* cleared on failure */
    pm_mesh_destroy(m);
  }
}

/* The hexagon of side 2 cut from the unit triangular lattice: 19 nodes, 24 equilateral
 * triangles. The centre and its six neighbours are interior with degree 6, so the six triangles
 * around the centre are regular and the 18 others touch the boundary; then one inner node moves,
 * which changes the shapes but not the sites. */
static void triangle_sites(void **state) {
  (void)state;
  pm_error e = {0};
  pm_mesh *m = pm_mesh_create();
  int32_t id[5][5];
  for (int j = -2; j <= 2; ++j)
    for (int i = -2; i <= 2; ++i) {
      id[j + 2][i + 2] = -1;
      if (abs(i + j) > 2) continue;
      double p[3] = {i + 0.5 * j, 0.5 * sqrt(3.0) * j, 0};
      id[j + 2][i + 2] = m->nnode;
      PM_ASSERT_OK(pm_mesh_add_node(m, p, -1, -1, NULL, NULL, &e), e);
    }
#define AT(i, j) ((i) < -2 || (i) > 2 || (j) < -2 || (j) > 2 ? -1 : id[(j) + 2][(i) + 2])
  for (int j = -2; j <= 2; ++j)
    for (int i = -2; i <= 2; ++i) {
      int32_t p = AT(i, j), a = AT(i + 1, j), b = AT(i, j + 1), ab = AT(i + 1, j + 1);
      if (p >= 0 && a >= 0 && b >= 0) PM_ASSERT_OK(pm_mesh_add_tri(m, p, a, b, 0, &e), e);
      if (a >= 0 && ab >= 0 && b >= 0) PM_ASSERT_OK(pm_mesh_add_tri(m, a, ab, b, 0, &e), e);
    }
  assert_int_equal(m->nnode, 19);
  assert_int_equal(m->ntri, 24);
  pm_quality q;
  PM_ASSERT_OK(pm_quality_compute_fn(m, NULL, NULL, &q, &e), e);
  assert_int_equal(q.tri.eps_t_nodes, 7);
  assert_int_equal(q.tri_site_aspect[PM_TRI_BOUNDARY].n, 18);
  assert_int_equal(q.tri_site_aspect[PM_TRI_IRREGULAR].n, 0);
  assert_int_equal(q.tri_site_aspect[PM_TRI_REGULAR].n, 6);
  PM_ASSERT_NEAR(q.tri_site_aspect[PM_TRI_REGULAR].median, 1 / sqrt(3.0), 1e-14);
  PM_ASSERT_NEAR(q.tri_site_aspect[PM_TRI_BOUNDARY].max, 1 / sqrt(3.0), 1e-14);
  pm_quality_clear(&q);
  m->xyz[3 * AT(0, 0)] = 0.2;
  PM_ASSERT_OK(pm_quality_compute_fn(m, NULL, NULL, &q, &e), e);
  assert_int_equal(q.tri_site_aspect[PM_TRI_REGULAR].n, 6);
  assert_true(q.tri_site_aspect[PM_TRI_REGULAR].max > 0.6);
  PM_ASSERT_NEAR(q.tri_site_aspect[PM_TRI_BOUNDARY].max, 1 / sqrt(3.0), 1e-14);
  assert_string_equal(pm_tri_site_name(PM_TRI_IRREGULAR), "irregular");
#undef AT
  pm_quality_clear(&q);
  pm_mesh_destroy(m);
}

static void degenerate_in_mesh(void **state) {
  (void)state;
  pm_mesh *m = pm_mesh_create();
  pm_error e = {0};
  double p[4][3] = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0.5, sqrt(3.0) / 2, 0}};
  for (int i = 0; i < 4; ++i) pm_mesh_add_node(m, p[i], -1, -1, NULL, NULL, &e);
  pm_mesh_add_tri(m, 0, 1, 3, 0, &e); /* equilateral */
  pm_mesh_add_tri(m, 0, 1, 2, 0, &e); /* flat */
  pm_quality q;
  PM_ASSERT_OK(pm_quality_compute_fn(m, NULL, NULL, &q, &e), e);
  assert_int_equal(q.tri.degenerate, 1);
  PM_ASSERT_NEAR(q.tri.s_radius_ratio.mean, 0.5, 1e-14);
  PM_ASSERT_NEAR(q.tri.s_radius_ratio.min, 0.0, 0);
  assert_true(q.tri.s_aspect_ratio.max == PM_QUALITY_HUGE);
  assert_true(isfinite(q.tri.s_aspect_ratio.mean));
  PM_ASSERT_NEAR(q.tri.eps_g, 0.5 * (0.0 + 0.5), 1e-14); /* (0.5 - 0.5 + 0.5 - 0) / 2 */
  assert_int_equal(q.tri_min_angle_bins[0], 1);
  assert_int_equal(q.tri_min_angle_bins[5], 1); /* 60 lands in [50, 60] */
  assert_int_equal(q.tri_max_angle_over[2], 1);
  pm_quality_clear(&q);
  /* Bad indices are an argument error, not a crash. */
  pm_mesh_add_tri(m, 0, 1, 9, 0, &e);
  assert_int_equal(pm_quality_compute_fn(m, NULL, NULL, &q, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "triangle 2"));
  pm_mesh_destroy(m);
}

static void tet_mesh_measures(void **state) {
  (void)state;
  /* The unit cube split into 12 tets around its centre: the centre is the only interior node,
   * joined to the 8 corners: eps_t = |8 - 12| = 4. */
  pm_mesh *m = pm_mesh_create();
  pm_error e = {0};
  for (int i = 0; i < 8; ++i) {
    double p[3] = {i & 1, (i >> 1) & 1, (i >> 2) & 1};
    pm_mesh_add_node(m, p, -1, -1, NULL, NULL, &e);
  }
  double ctr[3] = {0.5, 0.5, 0.5};
  pm_mesh_add_node(m, ctr, -1, -1, NULL, NULL, &e);
  static const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                  {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (int f = 0; f < 6; ++f) {
    const int *q = quads[f];
    pm_mesh_add_tet(m, q[0], q[2], q[1], 8, 0, &e);
    pm_mesh_add_tet(m, q[0], q[3], q[2], 8, 0, &e);
  }
  pm_quality q;
  PM_ASSERT_OK(pm_quality_compute_fn(m, NULL, NULL, &q, &e), e);
  assert_int_equal(q.tet.n, 12);
  assert_int_equal(q.tet.degenerate, 0);
  assert_int_equal(q.tet.eps_t_nodes, 1);
  PM_ASSERT_NEAR(q.tet.eps_t, 4.0, 0);
  /* Classified: the centre in the volume, the corners on vertices: same answer. */
  for (int i = 0; i < 8; ++i) m->node_dim[i] = 0;
  m->node_dim[8] = 3;
  pm_quality_clear(&q);
  PM_ASSERT_OK(pm_quality_compute_fn(m, NULL, NULL, &q, &e), e);
  assert_int_equal(q.tet.eps_t_nodes, 1);
  PM_ASSERT_NEAR(q.tet.eps_t, 4.0, 0);
  /* All 12 tets are congruent: (corner, corner, corner, centre) with a right isosceles base of
   * legs 1 and apex height 1/2; each measure is constant, so min = max = mean. */
  pm_tet_measure one;
  pm_tet_measure_eval(m->xyz + 0, m->xyz + 3 * 3, m->xyz + 3 * 2, m->xyz + 3 * 8, &one);
  PM_ASSERT_NEAR(q.tet.s_radius_ratio.min, one.radius_ratio, 1e-14);
  PM_ASSERT_NEAR(q.tet.s_radius_ratio.max, one.radius_ratio, 1e-14);
  PM_ASSERT_NEAR(q.tet.eps_g, PM_EPS_G_A_TET - one.rr, 1e-14);
  pm_quality_clear(&q);
  pm_mesh_destroy(m);

  /* A regular tet alone: eps_g = sqrt(2/11) - 1/3 (the paper's A is not reached). */
  m = pm_mesh_create();
  for (int i = 0; i < 4; ++i) pm_mesh_add_node(m, reg[i], -1, -1, NULL, NULL, &e);
  pm_mesh_add_tet(m, 0, 1, 2, 3, 0, &e);
  PM_ASSERT_OK(pm_quality_compute_fn(m, NULL, NULL, &q, &e), e);
  PM_ASSERT_NEAR(q.tet.eps_g, sqrt(2.0 / 11.0) - 1.0 / 3.0, 1e-14);
  PM_ASSERT_NEAR(q.tet.s_min_angle.min, DEG(acos(1.0 / 3.0)), 1e-12);
  assert_int_equal(q.tet.eps_t_nodes, 0);
  pm_quality_clear(&q);
  pm_mesh_destroy(m);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(equilateral_triangle), cmocka_unit_test(right_isosceles_triangle),
      cmocka_unit_test(degenerate_triangle),  cmocka_unit_test(regular_tet),
      cmocka_unit_test(right_corner_tet),     cmocka_unit_test(sliver_tet),
      cmocka_unit_test(percentiles),          cmocka_unit_test(mesh_measures),
      cmocka_unit_test(degenerate_in_mesh),   cmocka_unit_test(tet_mesh_measures),
      cmocka_unit_test(triangle_sites),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
