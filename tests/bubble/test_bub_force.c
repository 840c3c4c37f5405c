/* The inter-bubble force of papers/003 eq. 10-11 / papers/004 eq. 2.1: its zeros, slopes,
 * saturation and potential. */
#include "bub_test_util.h"

/* f(lambda) = k0 (5/4 lambda^3 - 19/8 lambda^2 + 9/8): zero at 1 and 1.5, zero beyond. */
static void normalized_zeros(void **state) {
  (void)state;
  PM_ASSERT_NEAR(bub_force_normalized(30, 1.0), 0, 1e-14);
  PM_ASSERT_NEAR(bub_force_normalized(30, 1.5), 0, 1e-13);
  PM_ASSERT_NEAR(bub_force_normalized(30, 0.0), 30 * 9.0 / 8.0, 1e-13);
  assert_true(bub_force_normalized(30, 1.6) == 0);
  assert_true(bub_force_normalized(30, 1e9) == 0);
  /* Repulsive inside l0, attractive between l0 and 1.5 l0. */
  assert_true(bub_force_normalized(30, 0.5) > 0);
  assert_true(bub_force_normalized(30, 1.25) < 0);
  /* The attraction peaks at lambda = 19/15 (f' = 0 there) with value k0 * -0.0861. */
  double l = 19.0 / 15.0, fl = bub_force_normalized(1, l);
  assert_true(fl < bub_force_normalized(1, l - 1e-3) && fl < bub_force_normalized(1, l + 1e-3));
}

/* In length units F(l) = l0 f(l / l0): F(l0) = F(1.5 l0) = 0, F'(0) = 0, F'(l0) = -k0 for any
 * l0, as 003 eq. 11 states. df/dlambda at 1 is -k0 (004 eq. 2.1). */
static void slopes(void **state) {
  (void)state;
  const double k0s[3] = {0.1, 30, 150}, l0s[3] = {1e-3, 0.37, 25};
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      double k0 = k0s[a], l0 = l0s[b], h = 1e-6 * l0;
      PM_ASSERT_NEAR(bub_force(k0, l0, l0), 0, 1e-12 * k0 * l0);
      PM_ASSERT_NEAR(bub_force(k0, 1.5 * l0, l0), 0, 1e-12 * k0 * l0);
      /* Central differences (the cubic's third derivative makes them exact to h^2). */
      double d0 = (bub_force(k0, h, l0) - bub_force(k0, 0, l0)) / h; /* one-sided at 0 */
      PM_ASSERT_NEAR(d0, 0, 1e-5 * k0);
      double d1 = (bub_force(k0, l0 + h, l0) - bub_force(k0, l0 - h, l0)) / (2 * h);
      PM_ASSERT_NEAR(d1, -k0, 1e-6 * k0);
      double dl = (bub_force_normalized(k0, 1 + 1e-6) - bub_force_normalized(k0, 1 - 1e-6)) / 2e-6;
      PM_ASSERT_NEAR(dl, -k0, 1e-6 * k0);
      /* Saturation: bounded by 9/8 k0 l0 at l = 0 (003 section 3.3). */
      for (int k = 0; k <= 150; ++k)
        assert_true(fabs(bub_force(k0, k * 0.01 * l0, l0)) <= 1.125 * k0 * l0 * (1 + 1e-12));
    }
}

/* The potential is the integral of the force: -dU/dl = F, U(1.5 l0) = 0, minimum at l0. */
static void potential(void **state) {
  (void)state;
  double k0 = 30, l0 = 0.2;
  PM_ASSERT_NEAR(bub_potential(k0, 1.5 * l0, l0), 0, 1e-15);
  assert_true(bub_potential(k0, 2 * l0, l0) == 0);
  for (int k = 1; k < 15; ++k) {
    double l = k * 0.1 * l0, h = 1e-7;
    double dU = (bub_potential(k0, l + h, l0) - bub_potential(k0, l - h, l0)) / (2 * h);
    PM_ASSERT_NEAR(-dU, bub_force(k0, l, l0), 1e-6);
  }
  assert_true(bub_potential(k0, l0, l0) < bub_potential(k0, 0.99 * l0, l0));
  assert_true(bub_potential(k0, l0, l0) < bub_potential(k0, 1.01 * l0, l0));
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(normalized_zeros),
      cmocka_unit_test(slopes),
      cmocka_unit_test(potential),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
