/* pm_input_open: built-in cases, CAD files, case files (planar loops, a CAD file, a case), and
 * the one-line errors for bad input. */
#include "test_support.h"

#include <stdlib.h>
#include <string.h>

#include "common/input.h"

static char dir[256];

static const char *write_file(const char *name, const char *text) {
  static char path[512];
  snprintf(path, sizeof path, "%s/%s", dir, name);
  FILE *f = fopen(path, "w");
  assert_non_null(f);
  fputs(text, f);
  fclose(f);
  return path;
}

static void builtin_cases(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_sizing *s = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_input_open("case:qi3", &m, &s, &e), e);
  assert_int_equal(pm_model_count(m, PM_FACE), 1);
  PM_ASSERT_NEAR(m->diagonal, 6 * sqrt(2.0), 1e-12);
  double x[3] = {3, 0, 0};
  PM_ASSERT_NEAR(pm_sizing_eval(s, x), 0.35, 1e-12); /* 0.2 |r - 2| + 0.15 */
  pm_sizing_destroy(s);
  pm_model_destroy(m);
  PM_ASSERT_OK(pm_input_open("case:torus", &m, &s, &e), e);
  assert_int_equal(pm_model_count(m, PM_VOLUME), 1);
  PM_ASSERT_NEAR(pm_sizing_eval(s, x), 0.2, 1e-12);
  pm_sizing_destroy(s);
  pm_model_destroy(m);
  assert_int_equal(pm_input_open("case:nothing", &m, &s, &e), PM_ERR_ARG);
  assert_null(m);
  assert_non_null(strstr(e.msg, "qi1"));
}

static void case_files(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_sizing *s = NULL;
  pm_error e = {0};
  const char *plate =
      "{\"name\": \"plate\", \"size\": \"0.05+0.1*abs(x-1)\", \"domain\": {\"loops\": ["
      "[{\"line\": [0, 0]}, {\"line\": [2, 0]}, {\"line\": [2, 1]}, {\"line\": [0, 1]}],"
      "[{\"arc\": {\"from\": [1.2, 0.5], \"centre\": [1, 0.5], \"ccw\": false}}]]}}";
  PM_ASSERT_OK(pm_input_open(write_file("plate.json", plate), &m, &s, &e), e);
  assert_int_equal(pm_model_count(m, PM_CURVE), 5);
  const pm_cell *f = pm_model_cell(m, PM_FACE, 0);
  double hole[2] = {1, 0.5}, in[2] = {0.5, 0.5};
  assert_int_equal(pm_face_inside(f, hole), 0);
  assert_int_equal(pm_face_inside(f, in), 1);
  double x[3] = {1.5, 0, 0};
  PM_ASSERT_NEAR(pm_sizing_eval(s, x), 0.1, 1e-12);
  assert_string_equal(m->name, "plate");
  pm_sizing_destroy(s);
  pm_model_destroy(m);
  /* A case by name, with a numeric size overriding its own. */
  PM_ASSERT_OK(pm_input_open(write_file("c.json", "{\"domain\": {\"case\": \"qi1\"}, \"size\": 0.25}"), &m, &s, &e), e);
  PM_ASSERT_NEAR(pm_sizing_eval(s, x), 0.25, 1e-15);
  pm_sizing_destroy(s);
  pm_model_destroy(m);
  if (pm_test_have_cad()) {
    char json[600];
    snprintf(json, sizeof json, "{\"domain\": {\"file\": \"%s/synth_torus.brep\"}}", PM_CAD_DIR);
    PM_ASSERT_OK(pm_input_open(write_file("t.json", json), &m, &s, &e), e);
    assert_null(s); /* a CAD file carries no size */
    assert_int_equal(pm_model_count(m, PM_FACE), 1);
    pm_model_destroy(m);
  }
}

static void bad_inputs(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_sizing *s = NULL;
  pm_error e = {0};
  struct {
    const char *name, *text, *expect;
    pm_status code;
  } bad[] = {
      {"a.json", "{not json", "not valid JSON", PM_ERR_PARSE},
      {"b.json", "{\"size\": 1}", "domain", PM_ERR_PARSE},
      {"c.json", "{\"domain\": {\"loops\": [[{\"line\": [0, 0]}, {\"line\": [0, 0]}, {\"line\": [1, 1]}]]}}",
       "zero-length", PM_ERR_ARG},
      {"d.json", "{\"domain\": {\"case\": \"qi1\"}, \"size\": \"-1\"}", "d.json", PM_ERR_ARG},
      {"e.json", "{\"domain\": {\"case\": \"qi1\"}, \"size\": \"0.1*(x\"}", "e.json", PM_ERR_PARSE},
      {"f.json", "{\"domain\": {\"loops\": [[{\"circle\": 1}]]}}", "piece", PM_ERR_PARSE},
  };
  for (size_t k = 0; k < sizeof bad / sizeof bad[0]; ++k) {
    pm_status st = pm_input_open(write_file(bad[k].name, bad[k].text), &m, &s, &e);
    if (st != bad[k].code || !strstr(e.msg, bad[k].expect))
      fail_msg("%s: status %d, message '%s'", bad[k].name, (int)st, e.msg);
    assert_null(m);
    assert_null(s);
    assert_null(strchr(e.msg, '\n'));
  }
  assert_int_equal(pm_input_open("/nonexistent/x.json", &m, &s, &e), PM_ERR_IO);
  assert_int_equal(pm_input_open("/nonexistent/x.step", &m, &s, &e), PM_ERR_IO);
  assert_int_equal(pm_input_open("model.xyz", &m, &s, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "case:NAME"));
  assert_int_equal(pm_input_open("", &m, &s, &e), PM_ERR_ARG);
}

int main(void) {
  snprintf(dir, sizeof dir, "/tmp/pm_test_input_%d", (int)getpid());
  char cmd[300];
  snprintf(cmd, sizeof cmd, "mkdir -p %s", dir);
  if (system(cmd) != 0) return 1;
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(builtin_cases),
      cmocka_unit_test(case_files),
      cmocka_unit_test(bad_inputs),
  };
  int rc = cmocka_run_group_tests(tests, NULL, NULL);
  snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
  if (system(cmd) != 0) rc = 1;
  return rc;
}
