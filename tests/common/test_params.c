/* Parameter tables: defaults, --set parsing, range checks, unknown keys. */
#include "test_support.h"

#include <string.h>

#include "common/base/params.h"

typedef struct demo_params {
  double k0;
  int steps;
  int adaptive;
  int scheme;
} demo_params;

static const char *const schemes[] = {"rk4", "rk2", NULL};
static const pm_param_desc demo_desc[] = {
    {"k0", PM_PARAM_DOUBLE, offsetof(demo_params, k0), 30, 0.1, 150, PM_RANGE_CLOSED, "",
     "stiffness", "003 eq. 11", NULL},
    {"steps", PM_PARAM_INT, offsetof(demo_params, steps), 100, 1, 1e6, PM_RANGE_CLOSED, "",
     "max steps", "-", NULL},
    {"adaptive", PM_PARAM_BOOL, offsetof(demo_params, adaptive), 1, 0, 1, 0, "", "adaptive stop",
     "004 sec. 2.4", NULL},
    {"scheme", PM_PARAM_CHOICE, offsetof(demo_params, scheme), 0, 0, 0, 0, "", "integrator",
     "003 eq. 14", schemes},
};
static const pm_param_table demo_table = {"demo", demo_desc, 4};

static void defaults_and_set(void **state) {
  (void)state;
  demo_params p;
  memset(&p, 0xff, sizeof p);
  pm_params_defaults(&demo_table, &p);
  assert_true(p.k0 == 30 && p.steps == 100 && p.adaptive == 1 && p.scheme == 0);
  pm_error e = {0};
  PM_ASSERT_OK(pm_params_set_pair(&demo_table, &p, "k0=0.5", &e), e);
  PM_ASSERT_OK(pm_params_set_pair(&demo_table, &p, "scheme=RK2", &e), e);
  PM_ASSERT_OK(pm_params_set_pair(&demo_table, &p, "adaptive=off", &e), e);
  assert_true(p.k0 == 0.5 && p.scheme == 1 && p.adaptive == 0);
  PM_ASSERT_OK(pm_params_check(&demo_table, &p, &e), e);
}

static void rejects_bad_values(void **state) {
  (void)state;
  demo_params p;
  pm_params_defaults(&demo_table, &p);
  pm_error e = {0};
  assert_int_equal(pm_params_set_pair(&demo_table, &p, "k0=0", &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "k0"));
  assert_int_equal(pm_params_set_pair(&demo_table, &p, "k0=nan", &e), PM_ERR_ARG);
  assert_int_equal(pm_params_set_pair(&demo_table, &p, "k0=abc", &e), PM_ERR_ARG);
  assert_int_equal(pm_params_set_pair(&demo_table, &p, "steps=2.5", &e), PM_ERR_ARG);
  assert_int_equal(pm_params_set_pair(&demo_table, &p, "scheme=euler", &e), PM_ERR_ARG);
  assert_int_equal(pm_params_set_pair(&demo_table, &p, "nokey=1", &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "unknown"));
  assert_int_equal(pm_params_set_pair(&demo_table, &p, "k0", &e), PM_ERR_ARG);
  assert_true(p.k0 == 30); /* a rejected value leaves the field alone */
  p.k0 = 1000;
  assert_int_equal(pm_params_check(&demo_table, &p, &e), PM_ERR_ARG);
}

static void help_lists_every_key(void **state) {
  (void)state;
  char buf[4096] = {0};
  FILE *f = fmemopen(buf, sizeof buf - 1, "w");
  pm_params_help(&demo_table, f);
  fclose(f);
  for (int i = 0; i < demo_table.n; ++i) assert_non_null(strstr(buf, demo_desc[i].name));
  assert_non_null(strstr(buf, "003 eq. 11"));
  assert_non_null(strstr(buf, "rk4|rk2"));
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(defaults_and_set),
      cmocka_unit_test(rejects_bad_values),
      cmocka_unit_test(help_lists_every_key),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
