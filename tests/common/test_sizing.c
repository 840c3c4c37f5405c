/* Size fields: constants, expressions (DESIGN.md's built-in fields at known points), parse
 * errors and bad values, scaled and callback fields, fields sampled on triangle and tet meshes,
 * concurrent evaluation, and the check against a model. */
#include "test_support.h"

#include <stdlib.h>
#include <string.h>

#include "common/input/cases.h"
#include "common/base/rng.h"
#include "common/sizing/sizing.h"

static double eval3(const pm_sizing *s, double x, double y, double z) {
  double p[3] = {x, y, z};
  return pm_sizing_eval(s, p);
}

static void constant_field(void **state) {
  (void)state;
  pm_sizing *s = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_sizing_constant(0.1, &s, &e), e);
  PM_ASSERT_NEAR(eval3(s, 0, 0, 0), 0.1, 0);
  PM_ASSERT_NEAR(eval3(s, -7, 3e5, 2), 0.1, 0);
  assert_string_equal(pm_sizing_describe(s), "0.1");
  pm_sizing_destroy(s);
  static const double bad[] = {0, -0.5, NAN, INFINITY, -INFINITY};
  for (int i = 0; i < 5; ++i) {
    s = (pm_sizing *)&e; /* must be reset to NULL on failure */
    assert_int_equal(pm_sizing_constant(bad[i], &s, &e), PM_ERR_ARG);
    assert_null(s);
    assert_non_null(strstr(e.msg, "> 0"));
  }
  pm_sizing_destroy(NULL);
}

/* DESIGN.md built-in fields at points with known values. */
static void builtin_expressions(void **state) {
  (void)state;
  pm_sizing *s = NULL;
  pm_error e = {0};
  /* qi3: d = 0.2 |r - 2| + 0.15 */
  PM_ASSERT_OK(pm_sizing_parse("0.2*abs(r-2)+0.15", &s, &e), e);
  PM_ASSERT_NEAR(eval3(s, 3, 0, 0), 0.35, 1e-15);
  PM_ASSERT_NEAR(eval3(s, 0, 2, 0), 0.15, 1e-15);
  PM_ASSERT_NEAR(eval3(s, 0.6, 0.8, 0), 0.15 + 0.2 * 1, 1e-15);
  assert_string_equal(pm_sizing_describe(s), "0.2*abs(r-2)+0.15");
  pm_sizing_destroy(s);
  /* shimada: 0.04 / (1.5 + sin(3 + 4xy)) */
  PM_ASSERT_OK(pm_sizing_parse("0.04/(1.5+sin(3+4*x*y))", &s, &e), e);
  PM_ASSERT_NEAR(eval3(s, 0.5, 0.5, 0), 0.04 / (1.5 + sin(4.0)), 1e-15);
  PM_ASSERT_NEAR(eval3(s, 0.5, 0.5, 0), 0.0538215, 1e-7);
  PM_ASSERT_NEAR(eval3(s, 0, 0, 0), 0.04 / (1.5 + sin(3.0)), 1e-15);
  pm_sizing_destroy(s);
  /* qi2: r / 8 (zero at the origin, which is outside the domain: accepted) */
  PM_ASSERT_OK(pm_sizing_parse("r/8", &s, &e), e);
  PM_ASSERT_NEAR(eval3(s, 0.3, 0.4, 0), 0.0625, 1e-16);
  PM_ASSERT_NEAR(eval3(s, 0, 0, 0), 0, 0);
  pm_sizing_destroy(s);
  /* qi4 as cases.c writes it, against the formula in C */
  const char *qi4 = "min(0.25-0.15*(r-1), min(0.05+0.08*(sqrt((x+0.4)^2+y^2)-0.5), "
                    "((sqrt((x+0.4)^2+y^2)-0.5)-(r-1))/2))";
  PM_ASSERT_OK(pm_sizing_parse(qi4, &s, &e), e);
  double pts[3][2] = {{0.5, 0.2}, {-0.95, 0.1}, {0.3, -0.7}};
  for (int i = 0; i < 3; ++i) {
    double x = pts[i][0], y = pts[i][1], r = sqrt(x * x + y * y);
    double d1 = r - 1, d2 = sqrt((x + 0.4) * (x + 0.4) + y * y) - 0.5;
    double want = fmin(0.25 - 0.15 * d1, fmin(0.05 + 0.08 * d2, (d2 - d1) / 2));
    PM_ASSERT_NEAR(eval3(s, x, y, 0), want, 1e-15);
  }
  pm_sizing_destroy(s);
}

static void functions_available(void **state) {
  (void)state;
  pm_sizing *s = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_sizing_expression("min(x, y) + max(y, z) + abs(z - 3) + sqrt(x) + sin(_pi/2)", &s, &e), e);
  /* at (4, 1, 2): 1 + 2 + 1 + 2 + 1 */
  PM_ASSERT_NEAR(eval3(s, 4, 1, 2), 7, 1e-15);
  pm_sizing_destroy(s);
  PM_ASSERT_OK(pm_sizing_expression("exp(-x)+log(y)+z^2+(x>1 ? 1 : 2)", &s, &e), e);
  PM_ASSERT_NEAR(eval3(s, 2, 1, 3), exp(-2.0) + 0 + 9 + 1, 1e-14);
  pm_sizing_destroy(s);
  /* r is the distance from the origin in 3D */
  PM_ASSERT_OK(pm_sizing_expression("r", &s, &e), e);
  PM_ASSERT_NEAR(eval3(s, 1, 2, 2), 3, 1e-15);
  pm_sizing_destroy(s);
}

/* A non-positive, non-finite or unparsable size: the right status and a message that names the
 * problem. */
static void parse_errors(void **state) {
  (void)state;
  pm_sizing *s = NULL;
  pm_error e = {0};
  assert_int_equal(pm_sizing_parse("0.1*(x", &s, &e), PM_ERR_PARSE);
  assert_null(s);
  assert_non_null(strstr(e.msg, "size expression '0.1*(x'"));
  assert_non_null(strstr(e.msg, "parenthesis"));
  assert_non_null(strstr(e.msg, "position"));
  assert_null(strchr(e.msg, '\n'));
  assert_int_equal(pm_sizing_parse("foo+1", &s, &e), PM_ERR_PARSE);
  assert_non_null(strstr(e.msg, "foo"));
  assert_int_equal(pm_sizing_parse("0.1*sin(", &s, &e), PM_ERR_PARSE);
  assert_non_null(strstr(e.msg, "end of expression"));
  assert_int_equal(pm_sizing_parse("   ", &s, &e), PM_ERR_PARSE);
  assert_non_null(strstr(e.msg, "empty"));
  assert_int_equal(pm_sizing_parse(NULL, &s, &e), PM_ERR_PARSE);
  assert_int_equal(pm_sizing_parse("0,1", &s, &e), PM_ERR_PARSE); /* decimal comma */
  assert_non_null(strstr(e.msg, "2 values"));
  assert_int_equal(pm_sizing_expression("", &s, &e), PM_ERR_PARSE);
  /* numbers that are not sizes */
  assert_int_equal(pm_sizing_parse("0", &s, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "'0'"));
  assert_int_equal(pm_sizing_parse("-0.1", &s, &e), PM_ERR_ARG);
  assert_int_equal(pm_sizing_parse("nan", &s, &e), PM_ERR_ARG);
  assert_int_equal(pm_sizing_parse("inf", &s, &e), PM_ERR_ARG);
  assert_int_equal(pm_sizing_parse("1e999", &s, &e), PM_ERR_ARG);
  /* expressions bad wherever probed */
  assert_int_equal(pm_sizing_parse("-0.1*(1+x*x)", &s, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "-0.1*(1+x*x)"));
  assert_non_null(strstr(e.msg, "> 0"));
  assert_int_equal(pm_sizing_parse("sqrt(-1-x*x)", &s, &e), PM_ERR_ARG); /* NaN everywhere */
  assert_int_equal(pm_sizing_parse("0*x", &s, &e), PM_ERR_ARG);
  assert_int_equal(pm_sizing_parse("1/0", &s, &e), PM_ERR_ARG);
  assert_null(s);
  /* bad only in places: accepted here, caught by pm_sizing_check against the model */
  PM_ASSERT_OK(pm_sizing_parse("0.1*(x-0.5)", &s, &e), e);
  pm_sizing_destroy(s);
}

/* describe() gives text that parse() takes back to the same field. */
static void describe_round_trip(void **state) {
  (void)state;
  const char *texts[] = {"0.1", "  0.25 ", "0.2*abs(r-2)+0.15", "1e-3", "0.3333333333333333"};
  const char *want[] = {"0.1", "0.25", "0.2*abs(r-2)+0.15", "0.001", "0.3333333333333333"};
  for (int i = 0; i < 5; ++i) {
    pm_sizing *a = NULL, *b = NULL;
    pm_error e = {0};
    PM_ASSERT_OK(pm_sizing_parse(texts[i], &a, &e), e);
    assert_string_equal(pm_sizing_describe(a), want[i]);
    PM_ASSERT_OK(pm_sizing_parse(pm_sizing_describe(a), &b, &e), e);
    for (int k = 0; k < 10; ++k)
      assert_true(eval3(a, 0.3 * k, -0.2 * k, 0.1) == eval3(b, 0.3 * k, -0.2 * k, 0.1));
    pm_sizing_destroy(a);
    pm_sizing_destroy(b);
  }
}

static void scaled_field(void **state) {
  (void)state;
  pm_sizing *base = NULL, *s = NULL, *s2 = NULL, *back = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_sizing_parse("0.2*abs(r-2)+0.15", &base, &e), e);
  PM_ASSERT_OK(pm_sizing_scaled(base, 1.5, &s, &e), e);
  PM_ASSERT_NEAR(eval3(s, 3, 0, 0), 1.5 * 0.35, 1e-15);
  assert_string_equal(pm_sizing_describe(s), "1.5*(0.2*abs(r-2)+0.15)");
  /* its description is an expression --size takes back */
  PM_ASSERT_OK(pm_sizing_parse(pm_sizing_describe(s), &back, &e), e);
  PM_ASSERT_NEAR(eval3(back, 3, 0, 0), 1.5 * 0.35, 1e-15);
  pm_sizing_destroy(back);
  /* a scale of a scale multiplies the factors */
  PM_ASSERT_OK(pm_sizing_scaled(s, 2, &s2, &e), e);
  PM_ASSERT_NEAR(eval3(s2, 3, 0, 0), 3 * 0.35, 1e-15);
  assert_string_equal(pm_sizing_describe(s2), "3*(0.2*abs(r-2)+0.15)");
  /* the base is shared: destroying it first leaves the scaled fields working */
  pm_sizing_destroy(base);
  PM_ASSERT_NEAR(eval3(s, 0, 2, 0), 1.5 * 0.15, 1e-15);
  pm_sizing_destroy(s);
  PM_ASSERT_NEAR(eval3(s2, 0, 2, 0), 3 * 0.15, 1e-15);
  pm_sizing_destroy(s2);
  /* a scaled constant is a constant */
  PM_ASSERT_OK(pm_sizing_constant(0.1, &base, &e), e);
  PM_ASSERT_OK(pm_sizing_scaled(base, 2.5, &s, &e), e);
  PM_ASSERT_NEAR(eval3(s, 1, 1, 1), 0.25, 1e-16);
  assert_string_equal(pm_sizing_describe(s), "0.25");
  pm_sizing_destroy(s);
  /* bad factors */
  assert_int_equal(pm_sizing_scaled(base, 0, &s, &e), PM_ERR_ARG);
  assert_int_equal(pm_sizing_scaled(base, -1, &s, &e), PM_ERR_ARG);
  assert_int_equal(pm_sizing_scaled(base, NAN, &s, &e), PM_ERR_ARG);
  pm_sizing *big = NULL;
  PM_ASSERT_OK(pm_sizing_constant(1e10, &big, &e), e);
  assert_int_equal(pm_sizing_scaled(big, 1e300, &s, &e), PM_ERR_ARG); /* 1e310 overflows */
  pm_sizing_destroy(big);
  assert_int_equal(pm_sizing_scaled(NULL, 2, &s, &e), PM_ERR_ARG);
  assert_null(s);
  pm_sizing_destroy(base);
}

static double plane_fn(const double xyz[3], void *user) {
  const double *c = user;
  return c[0] + c[1] * xyz[0] + c[2] * xyz[1];
}

static void callback_field(void **state) {
  (void)state;
  double coef[3] = {1, 0.5, 0.25};
  pm_sizing *s = NULL, *sc = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_sizing_callback(plane_fn, coef, "plane", &s, &e), e);
  PM_ASSERT_NEAR(eval3(s, 2, 4, 9), 3, 0);
  assert_string_equal(pm_sizing_describe(s), "plane");
  PM_ASSERT_OK(pm_sizing_scaled(s, 2, &sc, &e), e);
  PM_ASSERT_NEAR(eval3(sc, 2, 4, 9), 6, 0);
  assert_string_equal(pm_sizing_describe(sc), "2 x (plane)");
  pm_sizing_destroy(s);
  pm_sizing_destroy(sc);
  PM_ASSERT_OK(pm_sizing_callback(plane_fn, coef, NULL, &s, &e), e);
  assert_string_equal(pm_sizing_describe(s), "callback");
  pm_sizing_destroy(s);
  assert_int_equal(pm_sizing_callback(NULL, coef, "x", &s, &e), PM_ERR_ARG);
}

/* ---- sampled fields ------------------------------------------------------------------------ */

static double lin2(double x, double y) { return 0.1 + 0.2 * x + 0.3 * y; }
static double lin3(double x, double y, double z) { return 0.1 + 0.2 * x + 0.3 * y + 0.05 * z; }

/* An n x n grid of nodes on [0,1]^2 (interior nodes jittered), two triangles per square. */
static void planar_mesh(pm_mesh *m, int n, pm_rng *g) {
  pm_error e = {0};
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      double p[3] = {(double)i / (n - 1), (double)j / (n - 1), 0};
      if (i > 0 && i < n - 1 && j > 0 && j < n - 1) {
        p[0] += 0.2 / (n - 1) * (pm_rng_uniform(g) - 0.5);
        p[1] += 0.2 / (n - 1) * (pm_rng_uniform(g) - 0.5);
      }
      PM_ASSERT_OK(pm_mesh_add_node(m, p, -1, -1, NULL, NULL, &e), e);
    }
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      int32_t a = j * n + i, b = a + 1, c = a + n, d = c + 1;
      PM_ASSERT_OK(pm_mesh_add_tri(m, a, b, d, -1, &e), e);
      PM_ASSERT_OK(pm_mesh_add_tri(m, a, d, c, -1, &e), e);
    }
}

static void sampled_triangles(void **state) {
  (void)state;
  pm_rng g;
  pm_rng_init(&g, 3, 0);
  pm_mesh *m = pm_mesh_create();
  assert_non_null(m);
  planar_mesh(m, 5, &g);
  double *val = malloc(sizeof(double) * (size_t)m->nnode);
  double vmin = INFINITY, vmax = 0;
  for (int32_t i = 0; i < m->nnode; ++i) {
    val[i] = lin2(m->xyz[3 * i], m->xyz[3 * i + 1]);
    vmin = fmin(vmin, val[i]), vmax = fmax(vmax, val[i]);
  }
  pm_sizing *s = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_sizing_sampled(m, val, &s, &e), e);
  assert_string_equal(pm_sizing_describe(s), "sampled (25 nodes)");
  /* a linear function is reproduced inside the triangles */
  for (int k = 0; k < 2000; ++k) {
    double x = pm_rng_uniform(&g), y = pm_rng_uniform(&g);
    PM_ASSERT_NEAR(eval3(s, x, y, 0), lin2(x, y), 1e-12);
  }
  /* at the nodes, the node values */
  for (int32_t i = 0; i < m->nnode; ++i)
    PM_ASSERT_NEAR(eval3(s, m->xyz[3 * i], m->xyz[3 * i + 1], 0), val[i], 1e-14);
  /* just off the mesh (within the 0.1 h band): the value at the nearest point of the mesh */
  PM_ASSERT_NEAR(eval3(s, 1.01, 0.5, 0), lin2(1, 0.5), 1e-12);
  PM_ASSERT_NEAR(eval3(s, 0.3, 0.4, 0.01), lin2(0.3, 0.4), 1e-12);
  /* far away: within the sample range */
  double far[][3] = {{3, 3, 0}, {-2, 0.5, 0}, {0.5, 0.5, 5}, {1e6, -1e6, 1e6}, {0.5, 1.6, 0}};
  for (int k = 0; k < 5; ++k) {
    double v = pm_sizing_eval(s, far[k]);
    assert_true(v >= vmin && v <= vmax);
  }
  /* far beyond the corner (1, 1): the nearest nodes dominate the weighting */
  PM_ASSERT_NEAR(eval3(s, 1.5, 1.5, 0), lin2(1, 1), 0.1);
  pm_sizing_destroy(s);
  free(val);
  pm_mesh_destroy(m);
}

/* A sample mesh graded over seven orders of magnitude: a quarter disk of rings at radii
 * 10^(-7 + 7 k / M) around a fan at the centre, its triangles about as wide as long at every
 * scale. Every point inside gets the linear interpolation of its own element, wherever in the
 * grading it lies, and a point just above an element (within its band) the value below it. The
 * bins are filed on the levels 2^-17 .. 2^0 here, the finest clamped by the span. */
static void sampled_graded(void **state) {
  (void)state;
  enum { M = 80, A = 8 };
  const double q = pow(10, 7.0 / M);
  pm_mesh *m = pm_mesh_create();
  assert_non_null(m);
  pm_error e = {0};
  PM_ASSERT_OK(pm_mesh_add_node(m, (double[3]){0, 0, 0}, -1, -1, NULL, NULL, &e), e);
  for (int k = 0; k <= M; ++k)
    for (int a = 0; a < A; ++a) {
      const double r = pow(10, -7 + 7.0 * k / M), th = 0.5 * M_PI * a / (A - 1);
      PM_ASSERT_OK(pm_mesh_add_node(m, (double[3]){r * cos(th), r * sin(th), 0}, -1, -1, NULL, NULL, &e), e);
    }
  for (int a = 0; a + 1 < A; ++a) PM_ASSERT_OK(pm_mesh_add_tri(m, 0, 1 + a, 2 + a, -1, &e), e);
  for (int k = 0; k < M; ++k)
    for (int a = 0; a + 1 < A; ++a) {
      const int32_t i = 1 + k * A + a, j = i + A;
      PM_ASSERT_OK(pm_mesh_add_tri(m, i, j, j + 1, -1, &e), e);
      PM_ASSERT_OK(pm_mesh_add_tri(m, i, j + 1, i + 1, -1, &e), e);
    }
  double *val = malloc(sizeof(double) * (size_t)m->nnode);
  for (int32_t i = 0; i < m->nnode; ++i) val[i] = lin2(m->xyz[3 * i], m->xyz[3 * i + 1]);
  pm_sizing *s = NULL;
  PM_ASSERT_OK(pm_sizing_sampled(m, val, &s, &e), e);
  pm_rng g;
  pm_rng_init(&g, 11, 0);
  for (int k = 0; k < 5000; ++k) {
    const double r = pow(10, -7 * pm_rng_uniform(&g)), th = 0.5 * M_PI * pm_rng_uniform(&g);
    const double x = r * cos(th), y = r * sin(th);
    /* inside the disk of the last ring's chords */
    if (r > cos(0.25 * M_PI / (A - 1))) continue;
    PM_ASSERT_NEAR(eval3(s, x, y, 0), lin2(x, y), 1e-13);
    /* above the point by a twentieth of the ring spacing there (inside the element's band) */
    PM_ASSERT_NEAR(eval3(s, x, y, 0.05 * r * (q - 1) / q), lin2(x, y), 1e-13);
  }
  pm_sizing_destroy(s);
  free(val);
  pm_mesh_destroy(m);
}

/* The unit cube as 6 tets around the diagonal (0,0,0)-(1,1,1), refined once by cutting it into 8
 * cubes. */
static void sampled_tets(void **state) {
  (void)state;
  pm_mesh *m = pm_mesh_create();
  pm_error e = {0};
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) {
        double p[3] = {0.5 * i, 0.5 * j, 0.5 * k};
        PM_ASSERT_OK(pm_mesh_add_node(m, p, -1, -1, NULL, NULL, &e), e);
      }
  static const int cyc[6][2] = {{1, 3}, {3, 2}, {2, 6}, {6, 4}, {4, 5}, {5, 1}};
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i) {
        int32_t c[8];
        for (int b = 0; b < 8; ++b)
          c[b] = (k + ((b >> 2) & 1)) * 9 + (j + ((b >> 1) & 1)) * 3 + (i + (b & 1));
        for (int t = 0; t < 6; ++t)
          PM_ASSERT_OK(pm_mesh_add_tet(m, c[0], c[cyc[t][0]], c[cyc[t][1]], c[7], -1, &e), e);
      }
  double val[27];
  for (int32_t i = 0; i < 27; ++i) val[i] = lin3(m->xyz[3 * i], m->xyz[3 * i + 1], m->xyz[3 * i + 2]);
  pm_sizing *s = NULL;
  PM_ASSERT_OK(pm_sizing_sampled(m, val, &s, &e), e);
  pm_rng g;
  pm_rng_init(&g, 4, 0);
  for (int k = 0; k < 2000; ++k) {
    double x = pm_rng_uniform(&g), y = pm_rng_uniform(&g), z = pm_rng_uniform(&g);
    PM_ASSERT_NEAR(eval3(s, x, y, z), lin3(x, y, z), 1e-12);
  }
  PM_ASSERT_NEAR(eval3(s, 1.02, 0.5, 0.5), lin3(1, 0.5, 0.5), 1e-12); /* in the band */
  double v = eval3(s, 4, 4, 4);
  assert_true(v >= lin3(0, 0, 0) && v <= lin3(1, 1, 1));
  pm_sizing_destroy(s);
  pm_mesh_destroy(m);
}

static void sampled_nodes_only_and_errors(void **state) {
  (void)state;
  pm_mesh *m = pm_mesh_create();
  pm_error e = {0};
  double p[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  for (int i = 0; i < 4; ++i) PM_ASSERT_OK(pm_mesh_add_node(m, p[i], -1, -1, NULL, NULL, &e), e);
  double val[4] = {1, 2, 3, 4};
  pm_sizing *s = NULL;
  PM_ASSERT_OK(pm_sizing_sampled(m, val, &s, &e), e);
  PM_ASSERT_NEAR(eval3(s, 1, 0, 0), 2, 0);      /* on a node */
  PM_ASSERT_NEAR(eval3(s, 0.5, 0.5, 0), 2.5, 1e-15); /* equidistant: the mean */
  double v = eval3(s, 0.1, 0.2, 0.3);
  assert_true(v > 1 && v < 4);
  pm_sizing_destroy(s);
  /* bad values and indices */
  val[2] = 0;
  assert_int_equal(pm_sizing_sampled(m, val, &s, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "node 2"));
  val[2] = NAN;
  assert_int_equal(pm_sizing_sampled(m, val, &s, &e), PM_ERR_ARG);
  val[2] = 3;
  PM_ASSERT_OK(pm_mesh_add_tri(m, 0, 1, 7, -1, &e), e);
  assert_int_equal(pm_sizing_sampled(m, val, &s, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "triangle 0"));
  assert_null(s);
  pm_mesh_clear(m);
  assert_int_equal(pm_sizing_sampled(m, val, &s, &e), PM_ERR_ARG);
  assert_int_equal(pm_sizing_sampled(NULL, val, &s, &e), PM_ERR_ARG);
  pm_mesh_destroy(m);
}

/* ---- threads ------------------------------------------------------------------------------- */

static void concurrent_evaluation(void **state) {
  (void)state;
  pm_rng g;
  pm_rng_init(&g, 8, 0);
  pm_mesh *m = pm_mesh_create();
  planar_mesh(m, 9, &g);
  double *val = malloc(sizeof(double) * (size_t)m->nnode);
  for (int32_t i = 0; i < m->nnode; ++i) val[i] = 0.05 + 0.1 * sin(3 * m->xyz[3 * i]) * sin(3 * m->xyz[3 * i]);
  pm_sizing *f[4] = {NULL, NULL, NULL, NULL};
  pm_error e = {0};
  PM_ASSERT_OK(pm_sizing_parse("0.04/(1.5+sin(3+4*x*y))", &f[0], &e), e);
  PM_ASSERT_OK(pm_sizing_parse("0.2*abs(r-2)+0.15", &f[1], &e), e);
  PM_ASSERT_OK(pm_sizing_scaled(f[1], 0.7, &f[2], &e), e);
  PM_ASSERT_OK(pm_sizing_sampled(m, val, &f[3], &e), e);
  const int n = 20000;
  double *x = malloc(sizeof(double) * 3 * n), *serial = malloc(sizeof(double) * 4 * n),
         *par = malloc(sizeof(double) * 4 * n);
  for (int i = 0; i < 3 * n; ++i) x[i] = 1.4 * pm_rng_uniform(&g) - 0.2;
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < 4; ++k) serial[4 * i + k] = pm_sizing_eval(f[k], x + 3 * i);
  /* every thread evaluates every field, interleaved, so handles are made while others evaluate */
#pragma omp parallel for num_threads(4) schedule(dynamic, 64)
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < 4; ++k) par[4 * i + k] = pm_sizing_eval(f[k], x + 3 * i);
  for (int i = 0; i < 4 * n; ++i)
    if (memcmp(&serial[i], &par[i], sizeof(double)) != 0)
      fail_msg("field %d at point %d: %.17g in parallel, %.17g serially", i % 4, i / 4, par[i], serial[i]);
  /* fields made and destroyed inside parallel regions */
  int bad = 0;
#pragma omp parallel num_threads(4) reduction(+ : bad)
  {
    for (int rep = 0; rep < 20; ++rep) {
      pm_sizing *t = NULL;
      if (pm_sizing_parse("0.1+0.01*x*x", &t, NULL)) {
        bad++;
        continue;
      }
      double p[3] = {rep, 0, 0};
      bad += pm_sizing_eval(t, p) != 0.1 + 0.01 * rep * rep;
      pm_sizing_destroy(t);
    }
  }
  assert_int_equal(bad, 0);
  for (int k = 0; k < 4; ++k) pm_sizing_destroy(f[k]);
  free(x), free(serial), free(par), free(val);
  pm_mesh_destroy(m);
}

/* ---- check against a model ---------------------------------------------------------------- */

static void check_against_model(void **state) {
  (void)state;
  pm_model *model = NULL;
  pm_sizing *def = NULL, *s = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_case_open("qi3", &model, &def, &e), e); /* [-3,3]^2 */
  PM_ASSERT_OK(pm_sizing_check(def, model, &e), e);
  /* negative on the left half of the square */
  PM_ASSERT_OK(pm_sizing_parse("0.1*(x-0.5)", &s, &e), e);
  assert_int_equal(pm_sizing_check(s, model, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "0.1*(x-0.5)"));
  assert_non_null(strstr(e.msg, "vertex"));
  assert_null(strchr(e.msg, '\n'));
  pm_sizing_destroy(s);
  /* infinite at the right side x = 3 (vertices and curve there) */
  PM_ASSERT_OK(pm_sizing_parse("0.1/(3-x)", &s, &e), e);
  assert_int_equal(pm_sizing_check(s, model, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "inf"));
  pm_sizing_destroy(s);
  /* bad only inside the face, away from its boundary: found by the face samples */
  PM_ASSERT_OK(pm_sizing_parse("0.1*(r-0.5)", &s, &e), e);
  assert_int_equal(pm_sizing_check(s, model, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "face 0"));
  pm_sizing_destroy(s);
  /* bad only outside the model: fine */
  PM_ASSERT_OK(pm_sizing_parse("0.1*(10-x)", &s, &e), e);
  PM_ASSERT_OK(pm_sizing_check(s, model, &e), e);
  pm_sizing_destroy(s);
  pm_sizing_destroy(def);
  pm_model_destroy(model);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(constant_field),
      cmocka_unit_test(builtin_expressions),
      cmocka_unit_test(functions_available),
      cmocka_unit_test(parse_errors),
      cmocka_unit_test(describe_round_trip),
      cmocka_unit_test(scaled_field),
      cmocka_unit_test(callback_field),
      cmocka_unit_test(sampled_triangles),
      cmocka_unit_test(sampled_tets),
      cmocka_unit_test(sampled_graded),
      cmocka_unit_test(sampled_nodes_only_and_errors),
      cmocka_unit_test(concurrent_evaluation),
      cmocka_unit_test(check_against_model),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
