/* pm_input_open: built-in cases, CAD files, case files (planar loops, a CAD file, a case), and
 * the one-line errors for bad input: loose JSON (wrong types, unknown and repeated keys, text
 * after the object) and malformed domains (self-crossing loops, holes outside or touching,
 * crossing or nested holes, collinear loops, zero-length pieces, huge coordinates). */
#include "test_support.h"

#include <stdlib.h>
#include <string.h>

#include "common/input/input.h"

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

#define SQ "[{\"line\": [0, 0]}, {\"line\": [1, 0]}, {\"line\": [1, 1]}, {\"line\": [0, 1]}]"
#define LOOPS(x) "{\"size\": 0.1, \"domain\": {\"loops\": [" x "]}}"

/* Each fault gets one line naming it (and the loop and piece where there is one). */
static void strict_case_files(void **state) {
  (void)state;
  struct {
    const char *text, *expect;
    pm_status code;
  } bad[] = {
      /* JSON and keys */
      {"{\"domain\": {\"case\": \"qi1\"}, \"size\": 0.5} trailing", "text after the end of the JSON object (line 1, column 42)", PM_ERR_PARSE},
      {"{\"domain\": {\"case\": \"qi1\"}}\n}", "line 2, column 1", PM_ERR_PARSE},
      {"{\"domain\": {\"case\": \"qi1\"}, \"sise\": 0.2}", "unknown key \"sise\" in the top level", PM_ERR_PARSE},
      {"{\"domain\": {\"case\": \"qi1\"}, \"size\": 0.5, \"size\": 0.2}", "key \"size\" appears twice in the top level", PM_ERR_PARSE},
      {"{\"domain\": {\"case\": \"qi1\", \"file\": \"x.step\"}}", "exactly one of", PM_ERR_PARSE},
      {"{\"domain\": {\"case\": \"qi1\", \"extra\": 1}}", "unknown key \"extra\" in \"domain\"", PM_ERR_PARSE},
      {"{\"domain\": {\"case\": 3}}", "\"case\" must be a case name, not a number", PM_ERR_PARSE},
      {"{\"domain\": {\"case\": \"qi1\"}, \"name\": 7}", "\"name\" must be a string", PM_ERR_PARSE},
      {"{\"domain\": {\"case\": \"qi1\"}, \"size\": [1]}", "\"size\" must be a number or an expression string, not an array", PM_ERR_PARSE},
      {"[1, 2]", "a case file is a JSON object, not an array", PM_ERR_PARSE},
      {"{\"domain\": []}", "\"domain\" must be an object", PM_ERR_PARSE},
      /* pieces */
      {LOOPS("[{\"arc\": {\"from\": [1, 0], \"centre\": [0, 0], \"ccw\": \"yes\"}}]"), "loop 0 piece 0: \"ccw\" must be true or false, not a string", PM_ERR_PARSE},
      {LOOPS("[{\"arc\": {\"from\": [1, 0], \"centre\": [0, 0], \"ccw\": 1}}]"), "\"ccw\" must be true or false, not a number", PM_ERR_PARSE},
      {LOOPS("[{\"arc\": {\"from\": [1, 0], \"centre\": [0, 0], \"ccw\": null}}]"), "\"ccw\" must be true or false, not null", PM_ERR_PARSE},
      {LOOPS("[{\"line\": [0, 0], \"arc\": {\"from\": [1, 0], \"centre\": [0, 0]}}, {\"line\": [1, 0]}, {\"line\": [1, 1]}]"), "loop 0 piece 0 has both \"line\" and \"arc\"", PM_ERR_PARSE},
      {LOOPS("[{\"line\": [0, 0]}, {\"line\": [1, 0, 3]}, {\"line\": [1, 1]}]"), "loop 0 piece 1: \"line\" must be [x, y]", PM_ERR_PARSE},
      {LOOPS("[{\"line\": [0, 0]}, {\"line\": [1, \"0\"]}, {\"line\": [1, 1]}]"), "loop 0 piece 1: \"line\" must be [x, y]", PM_ERR_PARSE},
      {LOOPS("[{\"arc\": {\"from\": [1, 0], \"center\": [0, 0]}}]"), "unknown key \"center\" in loop 0 piece 0's \"arc\"", PM_ERR_PARSE},
      {LOOPS("[{\"arc\": {\"from\": [1, 0]}}]"), "the arc needs \"centre\"", PM_ERR_PARSE},
      {LOOPS(SQ ", []"), "loop 1 must be a non-empty array of pieces", PM_ERR_PARSE},
      /* domains */
      {LOOPS("[{\"line\": [0, 0]}, {\"line\": [1, 1]}, {\"line\": [1, 0]}, {\"line\": [0, 1]}]"), "loop 0: piece 0 crosses piece 2 at (0.5, 0.5)", PM_ERR_ARG},
      {LOOPS(SQ ", [{\"line\": [2, 0.2]}, {\"line\": [2.5, 0.2]}, {\"line\": [2.5, 0.6]}]"), "loop 1 (a hole) lies outside loop 0", PM_ERR_ARG},
      {LOOPS(SQ ", [{\"line\": [0.5, 0]}, {\"line\": [0.7, 0.3]}, {\"line\": [0.3, 0.3]}]"), "touches loop 1 piece 2 at (0.5, 0)", PM_ERR_ARG},
      {LOOPS(SQ ", [{\"line\": [0.2, 0.2]}, {\"line\": [0.6, 0.2]}, {\"line\": [0.6, 0.6]}, {\"line\": [0.2, 0.6]}],"
             "[{\"line\": [0.4, 0.4]}, {\"line\": [0.8, 0.4]}, {\"line\": [0.8, 0.8]}, {\"line\": [0.4, 0.8]}]"), "loop 1 piece 2 crosses loop 2 piece 3 at (0.4, 0.6)", PM_ERR_ARG},
      {LOOPS(SQ ", " SQ), "loop 0 piece 0 runs along loop 1 piece 0", PM_ERR_ARG},
      {LOOPS(SQ ", [{\"line\": [0.1, 0.1]}, {\"line\": [0.9, 0.1]}, {\"line\": [0.9, 0.9]}, {\"line\": [0.1, 0.9]}],"
             "[{\"line\": [0.4, 0.4]}, {\"line\": [0.6, 0.4]}, {\"line\": [0.6, 0.6]}, {\"line\": [0.4, 0.6]}]"), "loop 2 (a hole) lies inside loop 1 (another hole)", PM_ERR_ARG},
      {LOOPS("[{\"line\": [0, 0]}, {\"line\": [1, 0]}, {\"line\": [2, 0]}]"), "loop 0 encloses no area: its 3 points lie on one line", PM_ERR_ARG},
      {LOOPS("[{\"line\": [0, 0]}, {\"line\": [1, 0]}, {\"line\": [1, 0]}, {\"line\": [0, 1]}]"), "loop 0 piece 1: zero-length line", PM_ERR_ARG},
      {LOOPS("[{\"arc\": {\"from\": [0, 0], \"centre\": [0, 0]}}]"), "loop 0 piece 0: arc of radius 0", PM_ERR_ARG},
      {LOOPS("[{\"line\": [0, 0]}, {\"line\": [1e308, 0]}, {\"line\": [1e308, 1e308]}]"), "loop 0 piece 1: coordinate 1e+308 is beyond", PM_ERR_ARG},
      {LOOPS("[{\"line\": [0, 0]}, {\"line\": [1e999, 0]}, {\"line\": [1, 1]}]"), "loop 0 piece 1: a non-finite coordinate", PM_ERR_ARG},
      /* a circular hole touching the outer square from inside, and one crossing it */
      {LOOPS(SQ ", [{\"arc\": {\"from\": [0.5, 0], \"centre\": [0.5, 0.5]}}]"), "touches loop 1 piece 0", PM_ERR_ARG},
      {LOOPS(SQ ", [{\"arc\": {\"from\": [0.5, 0], \"centre\": [0.5, 0.25]}}]"), "loop 0 piece 0 touches loop 1 piece 0 at (0.5, 0)", PM_ERR_ARG},
      {LOOPS(SQ ", [{\"arc\": {\"from\": [0.5, -0.1], \"centre\": [0.5, 0.25]}}]"), "loop 0 piece 0 crosses loop 1 piece 0", PM_ERR_ARG},
      /* a loop pinched at a vertex, and a line folding back on itself */
      {LOOPS("[{\"line\": [0, 0]}, {\"line\": [1, 0]}, {\"line\": [0.5, 0.5]}, {\"line\": [1, 1]}, {\"line\": [0, 1]}, {\"line\": [0.5, 0.5]}]"), "loop 0: piece 1 touches piece 4 at (0.5, 0.5)", PM_ERR_ARG},
      {LOOPS("[{\"line\": [0, 0]}, {\"line\": [2, 0]}, {\"line\": [1, 0]}, {\"line\": [1, 1]}]"), "loop 0: piece 0 runs along piece 1 at (1.5, 0)", PM_ERR_ARG},
  };
  for (size_t k = 0; k < sizeof bad / sizeof bad[0]; ++k) {
    char name[32];
    snprintf(name, sizeof name, "strict%zu.json", k);
    pm_model *m = (pm_model *)0x1;
    pm_sizing *sz = (pm_sizing *)0x1;
    pm_error e = {0};
    pm_status st = pm_input_open(write_file(name, bad[k].text), &m, &sz, &e);
    if (st != bad[k].code || !strstr(e.msg, bad[k].expect) || !strstr(e.msg, name))
      fail_msg("case %zu: status %d (want %d), message '%s' (want '%s')", k, (int)st,
               (int)bad[k].code, e.msg, bad[k].expect);
    assert_null(m);
    assert_null(sz);
  }
  /* Well-formed domains the checks must let through: a line continued by a tangent arc (a
   * fillet), a disk with an off-centre hole close to its rim, holes running either way, a
   * circle made of two arcs, a hole near but apart from the outer loop. */
  const char *good[] = {
      LOOPS("[{\"line\": [0, 0]}, {\"line\": [2, 0]}, {\"arc\": {\"from\": [3, 1], \"centre\": [2, 1]}}, {\"line\": [2, 2]}, {\"line\": [0, 2]}]"),
      LOOPS("[{\"arc\": {\"from\": [1, 0], \"centre\": [0, 0]}}], [{\"arc\": {\"from\": [0.099, 0], \"centre\": [-0.4, 0], \"ccw\": false}}]"),
      LOOPS(SQ ", [{\"line\": [0.2, 0.2]}, {\"line\": [0.2, 0.4]}, {\"line\": [0.4, 0.4]}], [{\"line\": [0.6, 0.6]}, {\"line\": [0.8, 0.6]}, {\"line\": [0.8, 0.8]}]"),
      LOOPS("[{\"arc\": {\"from\": [1, 0], \"centre\": [0, 0]}}, {\"arc\": {\"from\": [-1, 0], \"centre\": [0, 0]}}]"),
      LOOPS(SQ ", [{\"line\": [1e-6, 0.2]}, {\"line\": [0.5, 0.2]}, {\"line\": [0.5, 0.5]}]"),
  };
  for (size_t k = 0; k < sizeof good / sizeof good[0]; ++k) {
    char name[32];
    snprintf(name, sizeof name, "good%zu.json", k);
    pm_model *m = NULL;
    pm_sizing *sz = NULL;
    pm_error e = {0};
    if (pm_input_open(write_file(name, good[k]), &m, &sz, &e)) fail_msg("good case %zu: %s", k, e.msg);
    pm_sizing_destroy(sz);
    pm_model_destroy(m);
  }
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
      cmocka_unit_test(strict_case_files),
  };
  int rc = cmocka_run_group_tests(tests, NULL, NULL);
  snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
  if (system(cmd) != 0) rc = 1;
  return rc;
}
