/* pm_keyindex: every key put is found with its id after the table has grown many times, absent
 * keys are not, and the table stays at most half full. */
#include "test_support.h"

#include "common/base/keyindex.h"

/* Lattice-like keys: packed (i, j) of a square, the pattern the placement uses. */
static uint64_t key_of(int32_t i, int32_t j) { return ((uint64_t)(uint32_t)i << 32) | (uint32_t)j; }

static void put_get_grow(void **state) {
  (void)state;
  pm_keyindex t = PM_KEYINDEX_INIT;
  assert_int_equal(pm_keyindex_get(&t, 7), -1);
  int32_t n = 0;
  for (int32_t i = -150; i < 150; ++i)
    for (int32_t j = -100; j < 100; j += 2) {
      assert_true(pm_keyindex_reserve(&t, n + 1));
      assert_int_equal(pm_keyindex_get(&t, key_of(i, j)), -1);
      pm_keyindex_put(&t, key_of(i, j), n++);
      assert_true(2 * (uint64_t)t.n <= t.mask + 1);
    }
  assert_int_equal(t.n, n);
  assert_true(t.mask + 1 > 1024); /* it grew */
  int32_t k = 0;
  for (int32_t i = -150; i < 150; ++i)
    for (int32_t j = -100; j < 100; j += 2) {
      assert_int_equal(pm_keyindex_get(&t, key_of(i, j)), k++);
      assert_int_equal(pm_keyindex_get(&t, key_of(i, j + 1)), -1); /* odd columns: never put */
    }
  pm_keyindex_free(&t);
  assert_int_equal(pm_keyindex_get(&t, key_of(0, 0)), -1);
}

int main(void) {
  const struct CMUnitTest tests[] = {cmocka_unit_test(put_get_grow)};
  return cmocka_run_group_tests(tests, NULL, NULL);
}
