/* Suite parsing and expansion into rows (compare/src/suite.c): accepted forms, sweep
 * ranges, strict keys, row order with matched node counts, ids. */
#include "test_support.h"

#include <stdlib.h>
#include <string.h>

#include "compare/src/study.h"

static void parse_ok(const char *text, pm_cmp_suite *s) {
  pm_error e = {0};
  PM_ASSERT_OK(pm_cmp_suite_parse(text, "/base", "t.json", s, &e), e);
}

static void parse_fails(const char *text, const char *needle) {
  pm_cmp_suite s;
  pm_error e = {0};
  pm_status st = pm_cmp_suite_parse(text, "/base", "t.json", &s, &e);
  if (st == PM_OK) fail_msg("accepted: %s", text);
  if (!strstr(e.msg, needle)) fail_msg("message '%s' lacks '%s'", e.msg, needle);
}

static void test_forms(void **state) {
  (void)state;
  pm_cmp_suite s;
  parse_ok("{\"name\": \"x\", \"cases\": [\"case:qi1\", {\"input\": \"parts/a.step\", \"size\": 2.5,"
           " \"volume\": true}, {\"input\": \"/abs/b.brep\", \"name\": \"bee\"}],"
           " \"size\": \"0.1+x\","
           " \"methods\": [\"bubble\", {\"method\": \"psys\", \"label\": \"p1\","
           " \"set\": {\"s_kappa\": 1, \"L\": 0.3}}, {\"method\": \"cgal\", \"set\": [\"a=b\"],"
           " \"cases\": [\"qi1\"]}], \"repeats\": 3}",
           &s);
  assert_string_equal(s.name, "x");
  assert_int_equal(s.ncase, 3);
  assert_string_equal(s.cases[0].name, "qi1");
  assert_string_equal(s.cases[0].input, "case:qi1");
  assert_string_equal(s.cases[0].size, "0.1+x"); /* the suite's default size */
  assert_string_equal(s.cases[1].name, "a");
  assert_string_equal(s.cases[1].input, "/base/parts/a.step"); /* relative to the suite */
  assert_string_equal(s.cases[1].size, "2.5");
  assert_int_equal(s.cases[1].volume, 1);
  assert_string_equal(s.cases[2].name, "bee");
  assert_int_equal(s.nmethod, 3);
  assert_string_equal(s.methods[1].label, "p1");
  assert_string_equal(s.methods[1].name, "psys");
  assert_int_equal(s.methods[1].nset, 2);
  assert_string_equal(s.methods[1].sets[0], "s_kappa=1");
  assert_string_equal(s.methods[1].sets[1], "L=0.3");
  assert_string_equal(s.methods[2].sets[0], "a=b");
  assert_int_equal(s.methods[2].nonly, 1);
  assert_int_equal(s.nseed, 3);
  assert_int_equal(s.seeds[2], 3);
  assert_int_equal(s.match_nodes, 0);
  assert_int_equal(s.match_surface, 0);   /* "match": "all" */
  assert_int_equal(s.whiskers_minmax, 0); /* "whiskers": "tukey" */
  assert_int_equal(s.trace, 1);
  PM_ASSERT_NEAR(s.timeout_s, 600, 0);
  pm_cmp_suite_clear(&s);
  parse_ok("{\"cases\": [\"case:qi1\"], \"methods\": [\"bubble\"],"
           " \"options\": {\"match_nodes\": true, \"match\": \"surface\", \"whiskers\": \"minmax\"}}",
           &s);
  assert_int_equal(s.match_surface, 1);
  assert_int_equal(s.whiskers_minmax, 1);
  pm_cmp_suite_clear(&s);
}

static void test_sweeps(void **state) {
  (void)state;
  pm_cmp_suite s;
  /* papers/004 Table 3's range: 0.5 to 1 by 0.05 gives 11 values, both ends included. */
  parse_ok("{\"cases\": [\"case:qi3\"], \"methods\": [\"bubble\"],"
           " \"sweep\": {\"key\": \"w2\", \"from\": 0.5, \"to\": 1, \"step\": 0.05}}",
           &s);
  assert_int_equal(s.nsweep, 11);
  assert_string_equal(s.sweep_key, "w2");
  assert_string_equal(s.sweep_values[0], "0.5");
  assert_string_equal(s.sweep_values[1], "0.55");
  assert_string_equal(s.sweep_values[10], "1");
  pm_cmp_suite_clear(&s);
  /* papers/000 section 6.4's range on a log scale: 0.1 * 1500^(i/4). */
  parse_ok("{\"cases\": [\"case:qi3\"], \"methods\": [\"bubble\"],"
           " \"sweep\": {\"key\": \"k0\", \"from\": 0.1, \"to\": 150, \"count\": 5,"
           " \"scale\": \"log\"}}",
           &s);
  assert_int_equal(s.nsweep, 5);
  assert_string_equal(s.sweep_values[0], "0.1");
  PM_ASSERT_NEAR(atof(s.sweep_values[1]), 0.1 * pow(1500, 0.25), 1e-5 * 0.62);
  PM_ASSERT_NEAR(atof(s.sweep_values[2]), 0.1 * pow(1500, 0.5), 1e-5 * 3.9);
  assert_string_equal(s.sweep_values[4], "150");
  pm_cmp_suite_clear(&s);
  parse_ok("{\"cases\": [\"case:qi3\"], \"methods\": [\"bubble\"],"
           " \"sweep\": {\"key\": \"size\", \"values\": [0.3, \"0.1+0.05*r\"]}}",
           &s);
  assert_int_equal(s.nsweep, 2);
  assert_string_equal(s.sweep_values[1], "0.1+0.05*r");
  pm_cmp_suite_clear(&s);
}

static void test_errors(void **state) {
  (void)state;
  parse_fails("{\"cases\": [\"case:qi1\"], ", "not valid JSON");
  parse_fails("[1]", "expected a JSON object");
  parse_fails("{\"methods\": [\"bubble\"]}", "\"cases\" must be a non-empty list");
  parse_fails("{\"cases\": [], \"methods\": [\"bubble\"]}", "\"cases\" must be a non-empty list");
  parse_fails("{\"cases\": [\"case:qi1\"]}", "\"methods\" must be a non-empty list");
  parse_fails("{\"cases\": [\"case:qi1\"], \"methods\": [\"bubble\"], \"match_nodes\": true}",
              "unknown key \"match_nodes\"");
  parse_fails("{\"cases\": [\"case:qi1\"], \"methods\": [\"bubble\"],"
              " \"options\": {\"match_node\": true}}",
              "options: unknown key \"match_node\"");
  parse_fails("{\"cases\": [\"case:qi1\", \"case:qi1\"], \"methods\": [\"bubble\"]}",
              "the name 'qi1' is used twice");
  parse_fails("{\"cases\": [\"case:qi1\"], \"methods\": [\"bubble\", \"bubble\"]}",
              "the label 'bubble' is used twice");
  parse_fails("{\"cases\": [\"case:qi1\"], \"methods\": [{\"method\": \"cgal\", \"cases\": [\"qi9\"]}]}",
              "'qi9', which is no case");
  parse_fails("{\"cases\": [\"case:qi1\"], \"methods\": [\"bubble\"],"
              " \"options\": {\"reference\": \"psys\"}}",
              "\"reference\" must be the label");
  parse_fails("{\"cases\": [\"case:qi1\"], \"methods\": [\"bubble\"], \"seeds\": [1.5]}",
              "whole numbers");
  parse_fails("{\"cases\": [\"case:qi1\"], \"methods\": [\"bubble\"], \"seeds\": [1], \"repeats\": 2}",
              "not both");
  parse_fails("{\"cases\": [\"case:qi1\"], \"methods\": [\"bubble\"],"
              " \"sweep\": {\"key\": \"k0\", \"from\": 1, \"to\": 2}}",
              "either a whole");
  parse_fails("{\"cases\": [\"case:qi1\"], \"methods\": [\"bubble\"],"
              " \"sweep\": {\"key\": \"k0\", \"from\": 0, \"to\": 2, \"count\": 3, \"scale\": \"log\"}}",
              "log scale needs");
  parse_fails("{\"cases\": [\"case:qi1\"], \"methods\": [\"bubble\"],"
              " \"options\": {\"timeout_s\": -1}}",
              "\"timeout_s\" must be a number");
  parse_fails("{\"cases\": [{\"size\": 1}], \"methods\": [\"bubble\"]}", "cases[0]: expected an input");
  parse_fails("{\"cases\": [\"case:qi1\"], \"methods\": [\"bubble\"],"
              " \"options\": {\"match\": \"surfaces\"}}",
              "options: \"match\" must be \"all\" or \"surface\"");
  parse_fails("{\"cases\": [\"case:qi1\"], \"methods\": [\"bubble\"],"
              " \"options\": {\"whiskers\": true}}",
              "options: \"whiskers\" must be \"tukey\" or \"minmax\"");
}

/* Rows: case-major, then seed, sweep value, method with the reference first; ids unique. */
static void test_rows(void **state) {
  (void)state;
  pm_cmp_suite s;
  parse_ok("{\"cases\": [\"case:qi1\", \"case:sphere\"],"
           " \"methods\": [\"gmsh-frontal\", {\"method\": \"cgal\", \"cases\": [\"qi1\"]}, \"bubble\"],"
           " \"seeds\": [4, 7], \"options\": {\"match_nodes\": true, \"reference\": \"bubble\"},"
           " \"sweep\": {\"key\": \"k0\", \"values\": [1, 30]}}",
           &s);
  char dir[] = "/tmp/pm-test-rows-XXXXXX";
  assert_non_null(mkdtemp(dir));
  pm_cmp_study st;
  pm_error e = {0};
  PM_ASSERT_OK(pm_cmp_study_init(&st, &s, dir, &e), e);
  /* qi1: 2 seeds x 2 values x 3 methods; sphere: 2 x 2 x 2 (no cgal). */
  assert_int_equal(st.nrow, 12 + 8);
  const pm_cmp_row *r = st.rows;
  assert_string_equal(r[0].id, "qi1__bubble__s4__k0=1");
  assert_int_equal(r[0].ref_row, -1);
  assert_string_equal(r[1].id, "qi1__gmsh-frontal__s4__k0=1");
  assert_int_equal(r[1].ref_row, 0);
  assert_string_equal(r[2].id, "qi1__cgal__s4__k0=1");
  assert_int_equal(r[2].ref_row, 0);
  assert_string_equal(r[3].id, "qi1__bubble__s4__k0=30");
  assert_int_equal(r[4].ref_row, 3);
  assert_string_equal(r[6].id, "qi1__bubble__s7__k0=1");
  assert_string_equal(r[12].id, "sphere__bubble__s4__k0=1");
  assert_string_equal(r[13].id, "sphere__gmsh-frontal__s4__k0=1");
  assert_int_equal(r[13].ref_row, 12);
  for (int i = 0; i < st.nrow; ++i)
    for (int j = 0; j < i; ++j) assert_string_not_equal(st.rows[i].id, st.rows[j].id);
  char title[256];
  pm_cmp_row_title(&st, &r[13], title, sizeof title);
  assert_string_equal(title, "sphere gmsh-frontal seed 4 k0=1");
  pm_cmp_study_clear(&st);
  rmdir(dir);
}

static void test_quote(void **state) {
  (void)state;
  char q[128];
  pm_cmp_shell_quote("case:qi3", q, sizeof q);
  assert_string_equal(q, "case:qi3");
  pm_cmp_shell_quote("0.2*abs(r-2)+0.15", q, sizeof q);
  assert_string_equal(q, "'0.2*abs(r-2)+0.15'");
  pm_cmp_shell_quote("it's", q, sizeof q);
  assert_string_equal(q, "'it'\\''s'");
  pm_cmp_shell_quote("", q, sizeof q);
  assert_string_equal(q, "''");
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_forms),  cmocka_unit_test(test_sweeps), cmocka_unit_test(test_errors),
      cmocka_unit_test(test_rows),   cmocka_unit_test(test_quote),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
