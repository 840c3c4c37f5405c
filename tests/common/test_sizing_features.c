/* The feature size (sizing_features.h) across planar strips whose width is set against the
 * model's feature floor (PM_FEATURE_FLOOR x the diagonal): a strip wider than the floor asks for
 * its width, one between half the floor and the floor asks for the floor, a narrower one for
 * nothing. */
#include "test_rect_model.h"

#include "common/geom/geom_analytic.h"
#include "common/sizing/sizing_features.h"

static pm_model *strip(double w) { return pm_test_rect_model("strip", w); }

/* f at the middle of the strip of width `floors` x the floor, with base size 0.1, grade 0.3. */
static double middle_size(double floors, double *floor_out) {
  const double diag = hypot(1, floors * PM_FEATURE_FLOOR); /* about 1 */
  const double w = floors * PM_FEATURE_FLOOR * diag;
  pm_model *m = strip(w);
  *floor_out = PM_FEATURE_FLOOR * m->diagonal;
  pm_feature_size *fs = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_feature_size_create(m, 0.1, 0.3, PM_FEATURE_ALL, &fs, &e), e);
  const double mid[3] = {0.5, 0.5 * w, 0};
  double f = pm_feature_size_eval(fs, mid);
  pm_feature_size_destroy(fs);
  pm_model_destroy(m);
  return f;
}

static void wider_than_the_floor_asks_its_width(void **state) {
  (void)state;
  double floor, f = middle_size(3, &floor);
  /* The width w = 3 floors, at w / 2 from the feature: w (1 + 0.3 / 2). */
  assert_true(f >= 3 * floor * (1 - 1e-9));
  assert_true(f <= 3 * floor * 1.15 * (1 + 1e-9));
}

static void just_below_the_floor_asks_the_floor(void **state) {
  (void)state;
  double floor, f = middle_size(0.8, &floor);
  /* Left out before: f was the base size 0.1 there. */
  assert_true(f >= floor * (1 - 1e-9));
  assert_true(f <= floor * (1 + 0.3 * 0.4) * (1 + 1e-9));
}

static void below_half_the_floor_asks_nothing(void **state) {
  (void)state;
  double floor, f = middle_size(0.4, &floor);
  assert_true(f > 1000 * floor);
  assert_true(f <= 0.1);
}

/* A hole of radius 2.5 whose top passes w = 0.001 below the edge y = 5 of the rectangle
 * [0, 6] x [0, 5]. The circle's polyline has 48 chords, which stray 0.0053 from it, and none of
 * its points is at the top (the circle starts 0.3 rad round): read at the chords' midpoints the
 * gap is about 0.005 wide, and f was 0.0088 there. Read on the curves themselves, f at the gap
 * is w plus the grade's growth over half of it and over the pieces the width is read at. */
static void curved_strip_is_read_on_the_curves(void **state) {
  (void)state;
  const double R = 2.5, w = 0.001, cy = 5 - w - R, a0 = 0.3;
  const pm_planar_piece outer[4] = {{PM_PIECE_LINE, {0, 0}, {0, 0}, 0},
                                    {PM_PIECE_LINE, {6, 0}, {0, 0}, 0},
                                    {PM_PIECE_LINE, {6, 5}, {0, 0}, 0},
                                    {PM_PIECE_LINE, {0, 5}, {0, 0}, 0}};
  const pm_planar_piece hole[1] = {{PM_PIECE_ARC, {3 + R * cos(a0), cy + R * sin(a0)}, {3, cy}, 0}};
  const pm_planar_loop loops[2] = {{4, outer}, {1, hole}};
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_planar_model("gap", 2, loops, &m, &e), e);
  assert_true(w > PM_FEATURE_FLOOR * m->diagonal);
  pm_feature_size *fs = NULL;
  PM_ASSERT_OK(pm_feature_size_create(m, 1, 0.3, PM_FEATURE_WIDTH, &fs, &e), e);
  const double gap[3] = {3, 5 - 0.5 * w, 0};
  const double f = pm_feature_size_eval(fs, gap);
  assert_true(f >= w * (1 - 1e-6));
  if (!(f <= 1.25 * w)) fail_msg("f = %g at the gap, w = %g", f, w);
  pm_feature_size_destroy(fs);
  pm_model_destroy(m);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(wider_than_the_floor_asks_its_width),
      cmocka_unit_test(just_below_the_floor_asks_the_floor),
      cmocka_unit_test(below_half_the_floor_asks_nothing),
      cmocka_unit_test(curved_strip_is_read_on_the_curves),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
