/* Exact predicates (CGAL): signs on clear cases and exact zeros on degenerate ones that a
 * naive floating-point determinant gets wrong. */
#include "test_support.h"

#include "common/backends/predicates.h"

static void orient2d_signs(void **state) {
  (void)state;
  double a[2] = {0, 0}, b[2] = {1, 0}, c[2] = {0, 1};
  assert_int_equal(pm_orient2d(a, b, c), 1);
  assert_int_equal(pm_orient2d(a, c, b), -1);
  double d[2] = {2, 0};
  assert_int_equal(pm_orient2d(a, b, d), 0);
}

static void orient2d_near_collinear_is_exact(void **state) {
  (void)state;
  /* Points on the line y = x, shifted by one ulp: a plain determinant loses the sign. */
  double a[2] = {0.5, 0.5}, b[2] = {12, 12}, c[2] = {24, 24};
  assert_int_equal(pm_orient2d(a, b, c), 0);
  double c2[2] = {24, nextafter(24.0, 25.0)};
  assert_int_equal(pm_orient2d(a, b, c2), 1);
  double c3[2] = {24, nextafter(24.0, 23.0)};
  assert_int_equal(pm_orient2d(a, b, c3), -1);
}

static void incircle_signs(void **state) {
  (void)state;
  double a[2] = {1, 0}, b[2] = {0, 1}, c[2] = {-1, 0};
  double in[2] = {0, 0}, on[2] = {0, -1}, out[2] = {2, 2};
  assert_int_equal(pm_incircle(a, b, c, in), 1);
  assert_int_equal(pm_incircle(a, b, c, on), 0);
  assert_int_equal(pm_incircle(a, b, c, out), -1);
  assert_int_equal(pm_incircle(a, c, b, in), -1); /* clockwise reverses the sign */
}

static void orient3d_and_insphere(void **state) {
  (void)state;
  double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0, 1, 0}, d[3] = {0, 0, 1};
  assert_int_equal(pm_orient3d(a, b, c, d), 1);
  assert_int_equal(pm_orient3d(a, c, b, d), -1);
  double e[3] = {0.5, 0.5, 0};
  assert_int_equal(pm_orient3d(a, b, c, e), 0);
  double centre[3] = {0.25, 0.25, 0.25}, far[3] = {3, 3, 3}, on[3] = {1, 1, 1};
  assert_int_equal(pm_insphere(a, b, c, d, centre), 1);
  assert_int_equal(pm_insphere(a, b, c, d, far), -1);
  assert_int_equal(pm_insphere(a, b, c, d, on), 0); /* (1,1,1) lies on the circumsphere */
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(orient2d_signs),
      cmocka_unit_test(orient2d_near_collinear_is_exact),
      cmocka_unit_test(incircle_signs),
      cmocka_unit_test(orient3d_and_insphere),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
