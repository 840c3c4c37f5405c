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

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(wider_than_the_floor_asks_its_width),
      cmocka_unit_test(just_below_the_floor_asks_the_floor),
      cmocka_unit_test(below_half_the_floor_asks_nothing),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
