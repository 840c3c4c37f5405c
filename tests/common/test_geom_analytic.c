/* The geometry core on planar analytic domains: topology, loops, the exact inside test, the
 * parameter displacement and the clip rule, projection, curvature, derivatives. */
#include "test_support.h"

#include <string.h>

#include "common/input/cases.h"
#include "common/geom/geom.h"
#include "common/geom/geom_analytic.h"
#include "common/base/rng.h"
#include "common/geom/trim.h"

static pm_model *open_case(const char *name) {
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_case_open(name, &m, NULL, &e), e);
  return m;
}

static void qi2_topology_and_loops(void **state) {
  (void)state;
  pm_model *m = open_case("qi2");
  /* Square: 4 vertices, 4 lines; hole: 1 vertex, 1 full circle; one face. */
  assert_int_equal(pm_model_count(m, PM_VERTEX), 5);
  assert_int_equal(pm_model_count(m, PM_CURVE), 5);
  assert_int_equal(pm_model_count(m, PM_FACE), 1);
  assert_int_equal(m->dim, 2);
  const pm_cell *f = pm_model_cell(m, PM_FACE, 0);
  assert_int_equal(f->nloop, 2);
  assert_int_equal(f->loop[0].outer, 1);
  assert_int_equal(f->loop[1].outer, 0);
  /* Outer counter-clockwise with the square's area, hole clockwise with the disk's. */
  PM_ASSERT_NEAR(pm_polyline_area(f->loop[0].uv, f->loop[0].npts), 4.0, 1e-12);
  /* The polyline lies within 2e-4 of the parameter box's diagonal (sqrt 8) of the circle, so the
   * area is off by at most the perimeter times that. */
  PM_ASSERT_NEAR(pm_polyline_area(f->loop[1].uv, f->loop[1].npts), -M_PI * 0.04,
                 2 * M_PI * 0.2 * 2e-4 * sqrt(8.0));
  assert_int_equal(f->nbound, 5);
  /* Every curve bounds the face; every square vertex ends two curves, the circle's vertex one. */
  for (int32_t i = 0; i < pm_model_count(m, PM_CURVE); ++i) {
    const pm_cell *c = pm_model_cell(m, PM_CURVE, i);
    assert_int_equal(c->nup, 1);
    assert_int_equal(c->up[0], 0);
  }
  int ones = 0, twos = 0;
  for (int32_t i = 0; i < pm_model_count(m, PM_VERTEX); ++i) {
    int n = pm_model_cell(m, PM_VERTEX, i)->nup;
    ones += n == 1, twos += n == 2;
  }
  assert_int_equal(twos, 4);
  assert_int_equal(ones, 1);
  PM_ASSERT_NEAR(m->diagonal, sqrt(8.0), 1e-12);
  pm_model_destroy(m);
}

static void qi2_inside_test(void **state) {
  (void)state;
  pm_model *m = open_case("qi2");
  const pm_cell *f = pm_model_cell(m, PM_FACE, 0);
  const double in[][2] = {{0.5, 0.5}, {-0.9, 0.9}, {0.25, 0}, {0, -0.21}, {0.99, -0.99}};
  const double out[][2] = {{0, 0}, {0.1, 0.1}, {1.5, 0}, {0, -1.01}, {-2, -2}, {0.19, 0}};
  for (size_t k = 0; k < sizeof in / sizeof in[0]; ++k) assert_int_equal(pm_face_inside(f, in[k]), 1);
  for (size_t k = 0; k < sizeof out / sizeof out[0]; ++k) assert_int_equal(pm_face_inside(f, out[k]), 0);
  /* The outer boundary counts as inside, exactly (the region is closed). */
  const double on[][2] = {{1, 0.3}, {-1, -1}, {0.2, -1}, {1, 1}};
  for (size_t k = 0; k < sizeof on / sizeof on[0]; ++k) assert_int_equal(pm_face_inside(f, on[k]), 1);
  /* Against the analytic answer on a dense grid, away from the polyline's tolerance band. */
  int checked = 0;
  for (int a = 0; a <= 200; ++a)
    for (int b = 0; b <= 200; ++b) {
      double p[2] = {-1.2 + 2.4 * a / 200, -1.2 + 2.4 * b / 200};
      double r = hypot(p[0], p[1]);
      if (fabs(r - 0.2) < 1e-3 || fabs(fabs(p[0]) - 1) < 1e-9 || fabs(fabs(p[1]) - 1) < 1e-9) continue;
      int truth = fabs(p[0]) <= 1 && fabs(p[1]) <= 1 && r > 0.2;
      assert_int_equal(pm_face_inside(f, p), truth);
      ++checked;
    }
  assert_true(checked > 39000);
  pm_model_destroy(m);
}

/* The clearance of qi2's face: the distance to the nearer of the square's sides and the hole's
 * polyline (within its sampling tolerance), never more than rmax; every point nearer than it to
 * an inside point is inside. */
static void qi2_clearance(void **state) {
  (void)state;
  pm_model *m = open_case("qi2");
  const pm_cell *f = pm_model_cell(m, PM_FACE, 0);
  const double p1[2] = {0.9, 0.5}, p2[2] = {0.5, 0.5}, p3[2] = {0, 0.5};
  PM_ASSERT_NEAR(pm_trim_clearance(f, p1, 1), 0.1, 1e-9);
  PM_ASSERT_NEAR(pm_trim_clearance(f, p2, 1), 0.5, 1e-9);
  PM_ASSERT_NEAR(pm_trim_clearance(f, p3, 1), 0.3, 1e-3); /* the hole's radius is 0.2 */
  PM_ASSERT_NEAR(pm_trim_clearance(f, p2, 0.05), 0.05, 1e-9);
  const double bad[2] = {NAN, 0};
  assert_true(pm_trim_clearance(f, bad, 1) == 0);
  pm_rng r;
  pm_rng_init(&r, 4, 0);
  int tested = 0;
  for (int k = 0; k < 2000; ++k) {
    double c[2] = {pm_rng_range(&r, -1, 1), pm_rng_range(&r, -1, 1)};
    if (!pm_face_inside(f, c)) continue;
    double cl = pm_trim_clearance(f, c, 0.5), ang = pm_rng_range(&r, 0, 2 * M_PI), t = pm_rng_range(&r, 0, 1);
    double q[2] = {c[0] + t * cl * cos(ang), c[1] + t * cl * sin(ang)};
    assert_int_equal(pm_face_inside(f, q), 1);
    ++tested;
  }
  assert_true(tested > 1000);
  pm_model_destroy(m);
}

static void planar_displacement_is_identity(void **state) {
  (void)state;
  pm_model *m = open_case("qi1");
  const pm_cell *f = pm_model_cell(m, PM_FACE, 0);
  double uv[2] = {0.1, 0.2}, dx[3] = {0.03, -0.02, 0.5}, d[2];
  pm_cell_param_delta(f, uv, NULL, dx, d);
  /* In the plane z = 0, M = I and J dx drops the normal component. */
  PM_ASSERT_NEAR(d[0], 0.03, 1e-15);
  PM_ASSERT_NEAR(d[1], -0.02, 1e-15);
  double out[2];
  assert_int_equal(pm_cell_displace(f, uv, dx, out), PM_MOVE_FREE);
  PM_ASSERT_NEAR(out[0], 0.13, 1e-15);
  PM_ASSERT_NEAR(out[1], 0.18, 1e-15);
  pm_model_destroy(m);
}

static void clip_rule_on_faces(void **state) {
  (void)state;
  pm_model *m = open_case("qi2");
  const pm_cell *f = pm_model_cell(m, PM_FACE, 0);
  /* Towards the hole: the step from x = 0.5 by -0.5 crosses the circle at x = 0.2 and stops just
   * inside, PM_CLIP_BACKOFF of the step before the crossing (the polyline is within 2e-4 of the
   * diagonal of the circle). */
  double uv[2] = {0.5, 0}, d[2] = {-0.5, 0}, out[2];
  assert_int_equal(pm_cell_move(f, uv, d, out), PM_MOVE_CLIPPED);
  PM_ASSERT_NEAR(out[0], 0.2 + PM_CLIP_BACKOFF * 0.5, 2e-4);
  PM_ASSERT_NEAR(out[1], 0, 1e-15);
  assert_int_equal(pm_face_inside(f, out), 1);
  /* Through the outer boundary. */
  double uv2[2] = {0.9, 0.5}, d2[2] = {0.3, 0.3};
  assert_int_equal(pm_cell_move(f, uv2, d2, out), PM_MOVE_CLIPPED);
  PM_ASSERT_NEAR(out[0], 1 - PM_CLIP_BACKOFF * 0.3, 1e-9);
  PM_ASSERT_NEAR(out[1], 0.6 - PM_CLIP_BACKOFF * 0.3, 1e-9);
  /* A step that stays inside is taken whole; one that starts outside too. */
  double d3[2] = {0.05, 0.05};
  assert_int_equal(pm_cell_move(f, uv2, d3, out), PM_MOVE_FREE);
  double outside[2] = {0.05, 0}, d4[2] = {0.01, 0};
  assert_int_equal(pm_cell_move(f, outside, d4, out), PM_MOVE_FREE);
  PM_ASSERT_NEAR(out[0], 0.06, 1e-15);
  pm_model_destroy(m);
}

static void clip_rule_on_curves(void **state) {
  (void)state;
  pm_model *m = open_case("qi1");
  const pm_cell *c = pm_model_cell(m, PM_CURVE, 0); /* (-1,-2) -> (1,-2), t in [0, 2] */
  PM_ASSERT_NEAR(c->hi[0], 2.0, 1e-15);
  double t = 1.8, out;
  double dx[3] = {0.5, 0.7, 0}; /* tangential part 0.5 along +x */
  assert_int_equal(pm_cell_displace(c, &t, dx, &out), PM_MOVE_CLIPPED);
  PM_ASSERT_NEAR(out, 1.8 + (0.2 / 0.5 - PM_CLIP_BACKOFF) * 0.5, 1e-12);
  double dt = -0.3;
  assert_int_equal(pm_cell_move(c, &t, &dt, &out), PM_MOVE_FREE);
  PM_ASSERT_NEAR(out, 1.5, 1e-15);
  pm_model_destroy(m);
}

static void arcs_evaluate_and_project(void **state) {
  (void)state;
  pm_model *m = open_case("qi4");
  /* Outer unit circle (periodic, ccw) and the hole circle of radius 0.5 (cw). */
  for (int32_t i = 0; i < pm_model_count(m, PM_CURVE); ++i) {
    const pm_cell *c = pm_model_cell(m, PM_CURVE, i);
    assert_int_equal(c->periodic[0], 1);
    double R = c->hi[0] / (2 * M_PI);
    assert_true(fabs(R - 1) < 1e-12 || fabs(R - 0.5) < 1e-12);
    for (int k = 0; k < 7; ++k) {
      double t = c->hi[0] * k / 7.0;
      PM_ASSERT_NEAR(pm_curve_curvature(c, t), 1 / R, 1e-12);
      /* Derivatives against central differences. */
      pm_curve_point a, b, p;
      double h = 1e-5;
      pm_curve_eval(c, t, 2, &p);
      pm_curve_eval(c, t - h, 1, &a);
      pm_curve_eval(c, t + h, 1, &b);
      for (int q = 0; q < 2; ++q) {
        PM_ASSERT_NEAR(p.d1[q], (b.p[q] - a.p[q]) / (2 * h), 1e-9);
        PM_ASSERT_NEAR(p.d2[q], (b.d1[q] - a.d1[q]) / (2 * h), 1e-8);
      }
      /* Projection of a point off the curve along the normal returns t. */
      double x[3] = {p.p[0] + 0.05 * p.d2[0] * R, p.p[1] + 0.05 * p.d2[1] * R, 0.3}, tt, cl[3], dist;
      pm_error e = {0};
      PM_ASSERT_OK(pm_cell_project(c, x, NULL, &tt, cl, &dist, &e), e);
      double dd = fabs(tt - t);
      if (dd > c->hi[0] / 2) dd = c->hi[0] - dd;
      PM_ASSERT_NEAR(dd, 0, 1e-9);
      PM_ASSERT_NEAR(dist, hypot(0.05, 0.3), 1e-9);
    }
  }
  /* The hole is a hole: its centre is outside, a point between the circles inside. */
  const pm_cell *f = pm_model_cell(m, PM_FACE, 0);
  double hc[2] = {-0.4, 0}, mid[2] = {0.5, 0};
  assert_int_equal(pm_face_inside(f, hc), 0);
  assert_int_equal(pm_face_inside(f, mid), 1);
  pm_model_destroy(m);
}

static void face_projection_respects_trim(void **state) {
  (void)state;
  pm_model *m = open_case("qi2");
  const pm_cell *f = pm_model_cell(m, PM_FACE, 0);
  pm_error e = {0};
  double uv[2], cl[3], dist;
  /* Above the face: straight down. */
  double x1[3] = {0.5, -0.3, 2};
  PM_ASSERT_OK(pm_cell_project(f, x1, NULL, uv, cl, &dist, &e), e);
  PM_ASSERT_NEAR(uv[0], 0.5, 1e-12);
  PM_ASSERT_NEAR(uv[1], -0.3, 1e-12);
  PM_ASSERT_NEAR(dist, 2, 1e-12);
  /* Above the hole: the closest point of the trimmed face is on the hole's circle. */
  double x2[3] = {0.1, 0, 1};
  PM_ASSERT_OK(pm_cell_project(f, x2, NULL, uv, cl, &dist, &e), e);
  PM_ASSERT_NEAR(uv[0], 0.2, 1e-9);
  PM_ASSERT_NEAR(uv[1], 0, 1e-9);
  PM_ASSERT_NEAR(dist, hypot(0.1, 1), 1e-9);
  /* Beyond the outer boundary. */
  double x3[3] = {1.5, 0.25, 0};
  PM_ASSERT_OK(pm_cell_project(f, x3, NULL, uv, cl, &dist, &e), e);
  PM_ASSERT_NEAR(uv[0], 1, 1e-9);
  PM_ASSERT_NEAR(uv[1], 0.25, 1e-9);
  PM_ASSERT_NEAR(dist, 0.5, 1e-9);
  /* Flat: no curvature. */
  double k1, k2, n[3];
  pm_face_curvatures(f, uv, &k1, &k2, n);
  PM_ASSERT_NEAR(k1, 0, 1e-15);
  PM_ASSERT_NEAR(n[2], 1, 1e-15);
  pm_model_destroy(m);
}

/* The trimming polyline follows its curves to a quarter of the feature floor in 3D, not only to
 * 2e-4 of the parameter box: a 100 x 100 square whose bottom side is an arc bulging 1 below it
 * (radius 1250.5) has chords of its first 8 samples sagging 0.0156 into the face, under the
 * (u, v) tolerance of 0.028; points 0.002 inside the arc (half the floor, 0.0042) must be
 * inside the face. */
static void trim_follows_curves_in_3d(void **state) {
  (void)state;
  const double s = 1, L = 100, R = (L * L / 4 + s * s) / (2 * s), cy = R - s;
  const pm_planar_piece sq[4] = {{PM_PIECE_ARC, {0, 0}, {L / 2, cy}, 1},
                                 {PM_PIECE_LINE, {L, 0}, {0, 0}, 0},
                                 {PM_PIECE_LINE, {L, L}, {0, 0}, 0},
                                 {PM_PIECE_LINE, {0, L}, {0, 0}, 0}};
  pm_planar_loop l = {4, sq};
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_planar_model("bulge", 1, &l, &m, &e), e);
  const pm_cell *f = pm_model_cell(m, PM_FACE, 0);
  const double floor = PM_FEATURE_FLOOR * m->diagonal, half = asin(L / 2 / R);
  assert_true(0.002 < 0.5 * floor);
  int inside = 0, outside = 0;
  for (int k = 1; k < 400; ++k) {
    const double phi = -half + 2 * half * k / 400.0;
    const double in[2] = {L / 2 + (R - 0.002) * sin(phi), cy - (R - 0.002) * cos(phi)};
    const double out[2] = {L / 2 + (R + 0.002) * sin(phi), cy - (R + 0.002) * cos(phi)};
    inside += pm_face_inside(f, in);
    outside += !pm_face_inside(f, out);
  }
  assert_int_equal(inside, 399);
  assert_int_equal(outside, 399);
  pm_model_destroy(m);
}

static void bad_domains_rejected(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_error e = {0};
  const pm_planar_piece zero[3] = {{PM_PIECE_LINE, {0, 0}, {0, 0}, 0},
                                   {PM_PIECE_LINE, {0, 0}, {0, 0}, 0},
                                   {PM_PIECE_LINE, {1, 1}, {0, 0}, 0}};
  pm_planar_loop l = {3, zero};
  assert_int_equal(pm_planar_model("bad", 1, &l, &m, &e), PM_ERR_ARG);
  assert_null(m);
  assert_non_null(strstr(e.msg, "zero-length"));
  const pm_planar_piece arc[2] = {{PM_PIECE_ARC, {1, 0}, {0, 0}, 1},
                                  {PM_PIECE_LINE, {0, 2}, {0, 0}, 0}};
  l = (pm_planar_loop){2, arc};
  assert_int_equal(pm_planar_model("bad", 1, &l, &m, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "circle"));
  assert_int_equal(pm_case_open("nosuchcase", &m, NULL, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "qi3"));
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(qi2_topology_and_loops),
      cmocka_unit_test(qi2_inside_test),
      cmocka_unit_test(qi2_clearance),
      cmocka_unit_test(planar_displacement_is_identity),
      cmocka_unit_test(clip_rule_on_faces),
      cmocka_unit_test(clip_rule_on_curves),
      cmocka_unit_test(arcs_evaluate_and_project),
      cmocka_unit_test(face_projection_respects_trim),
      cmocka_unit_test(trim_follows_curves_in_3d),
      cmocka_unit_test(bad_domains_rejected),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
