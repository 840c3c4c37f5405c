/* pm_rng: reproducible, stream-independent, uniform. */
#include "test_support.h"

#include "common/base/rng.h"

static void same_seed_same_sequence(void **state) {
  (void)state;
  pm_rng a, b;
  pm_rng_init(&a, 42, 7);
  pm_rng_init(&b, 42, 7);
  for (int i = 0; i < 1000; ++i) assert_true(pm_rng_next(&a) == pm_rng_next(&b));
}

static void streams_differ(void **state) {
  (void)state;
  pm_rng a, b;
  pm_rng_init(&a, 42, 7);
  pm_rng_init(&b, 42, 8);
  int equal = 0;
  for (int i = 0; i < 1000; ++i) equal += pm_rng_next(&a) == pm_rng_next(&b);
  assert_int_equal(equal, 0);
}

static void uniform_moments(void **state) {
  (void)state;
  pm_rng r;
  pm_rng_init(&r, 1, 0);
  const int n = 200000;
  double sum = 0, sum2 = 0, lo = 1, hi = 0;
  for (int i = 0; i < n; ++i) {
    double x = pm_rng_uniform(&r);
    sum += x, sum2 += x * x;
    if (x < lo) lo = x;
    if (x > hi) hi = x;
  }
  double mean = sum / n, var = sum2 / n - mean * mean;
  /* mean 1/2 and variance 1/12; the tolerances are ~5 standard errors. */
  PM_ASSERT_NEAR(mean, 0.5, 5 * sqrt(1.0 / 12 / n));
  PM_ASSERT_NEAR(var, 1.0 / 12, 0.002);
  assert_true(lo >= 0 && hi < 1);
}

static void below_covers_range(void **state) {
  (void)state;
  pm_rng r;
  pm_rng_init(&r, 3, 0);
  int count[7] = {0};
  for (int i = 0; i < 70000; ++i) count[pm_rng_below(&r, 7)]++;
  for (int k = 0; k < 7; ++k) assert_true(count[k] > 9000 && count[k] < 11000);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(same_seed_same_sequence),
      cmocka_unit_test(streams_differ),
      cmocka_unit_test(uniform_moments),
      cmocka_unit_test(below_covers_range),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
