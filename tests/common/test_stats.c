/* The stats record: the JSON keys of DESIGN.md with the computed values, extra keys, flattening
 * for CSV, CSV quoting, the per-element CSV and atomic JSON output. */
#include "test_support.h"

#include <cjson/cJSON.h>
#include <stdlib.h>
#include <string.h>

#include "common/mesh/mesh.h"
#include "common/mesh/mesh_check.h"
#include "common/measure/quality.h"
#include "common/report/stats.h"

/* Two right isosceles triangles (the unit square) and one regular tet off to the side. */
static pm_mesh *sample(void) {
  pm_mesh *m = pm_mesh_create();
  pm_error e = {0};
  double p[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                    {11, 11, 11}, {9, 11, 9}, {11, 9, 9}, {9, 9, 11}};
  for (int i = 0; i < 8; ++i) pm_mesh_add_node(m, p[i], -1, -1, NULL, NULL, &e);
  pm_mesh_add_tri(m, 0, 1, 2, 0, &e);
  pm_mesh_add_tri(m, 0, 2, 3, 0, &e);
  pm_mesh_add_tet(m, 4, 5, 6, 7, 0, &e);
  pm_mesh_add_seg(m, 0, 1, 0, &e);
  return m;
}

static double one(const double *x, void *u) {
  (void)x;
  (void)u;
  return 1.0;
}

static const cJSON *at(const cJSON *root, const char *path) {
  char buf[256];
  snprintf(buf, sizeof buf, "%s", path);
  const cJSON *v = root;
  for (char *part = strtok(buf, "."); part && v; part = strtok(NULL, "."))
    v = cJSON_GetObjectItemCaseSensitive(v, part);
  if (!v) fail_msg("no key %s", path);
  return v;
}

static void fill(pm_stats *s, pm_mesh *m, pm_quality *q, pm_check_report *r) {
  pm_error e = {0};
  PM_ASSERT_OK(pm_quality_compute_fn(m, one, NULL, q, &e), e);
  PM_ASSERT_OK(pm_mesh_check(m, NULL, r, &e), e);
  pm_stats_init(s);
  pm_stats_set_run(s, "external", "mesh.msh");
  pm_stats_set_mesh(s, m);
  PM_ASSERT_OK(pm_stats_set_check(s, r, &e), e);
  pm_stats_set_quality(s, q);
  s->iterations = 900;
  PM_ASSERT_OK(pm_stats_set_time(s, "total", 0.25, &e), e);
  PM_ASSERT_OK(pm_stats_set_time(s, "place", 0.125, &e), e);
  PM_ASSERT_OK(pm_stats_set_time(s, "connect", 0.0625, &e), e);
  PM_ASSERT_OK(pm_stats_set_time(s, "place", 0.2, &e), e); /* replaced */
}

static void json_keys_and_values(void **state) {
  (void)state;
  pm_mesh *m = sample();
  pm_quality q;
  pm_check_report r;
  pm_stats s;
  fill(&s, m, &q, &r);
  pm_error e = {0};
  PM_ASSERT_OK(pm_stats_add_number(&s, "bubble.k0", 30, &e), e);
  PM_ASSERT_OK(pm_stats_add_text(&s, "bubble.scheme", "rk4", &e), e);
  PM_ASSERT_OK(pm_stats_add_number(&s, "seed", 7, &e), e);
  assert_int_equal(pm_stats_add_number(&s, "tri.eps_g", 1, &e), PM_ERR_ARG);
  assert_int_equal(pm_stats_add_number(&s, "tri.radius_ratio.n", 1, &e), PM_ERR_ARG);
  assert_int_equal(pm_stats_add_number(&s, "distance.max", 1, &e), PM_ERR_ARG);
  assert_int_equal(pm_stats_add_number(&s, "nodes.x", 1, &e), PM_ERR_ARG);
  assert_int_equal(pm_stats_add_number(&s, "time_s.place", 1, &e), PM_ERR_ARG);
  assert_int_equal(pm_stats_add_number(&s, "tri", 1, &e), PM_ERR_ARG);
  PM_ASSERT_OK(pm_stats_add_number(&s, "tri.short_edges", 3, &e), e);
  PM_ASSERT_OK(pm_stats_add_number(&s, "distance.rel_mean", 0.5, &e), e);
  assert_int_equal(pm_stats_add_number(&s, "bubble.k0", 1, &e), PM_ERR_ARG);
  assert_int_equal(pm_stats_add_number(&s, "bubble", 1, &e), PM_ERR_ARG);
  assert_int_equal(pm_stats_add_number(&s, "a..b", 1, &e), PM_ERR_ARG);
  /* Dotted phase times nest under time_s; a phase and its sub-phases cannot both be numbers. */
  PM_ASSERT_OK(pm_stats_set_time(&s, "relax.force", 0.5, &e), e);
  PM_ASSERT_OK(pm_stats_set_time(&s, "relax.lists", 0.125, &e), e);
  assert_int_equal(pm_stats_set_time(&s, "relax", 1, &e), PM_ERR_ARG);
  assert_int_equal(pm_stats_set_time(&s, "relax.force.x", 1, &e), PM_ERR_ARG);
  assert_int_equal(pm_stats_set_time(&s, "relax.", 1, &e), PM_ERR_ARG);
  assert_int_equal(pm_stats_set_time(&s, "total.x", 1, &e), PM_ERR_ARG);
  /* dotted timings nest under time_s; a name and its dotted extension cannot both be set */
  PM_ASSERT_OK(pm_stats_set_time(&s, "m.energy", 0.5, &e), e);
  PM_ASSERT_OK(pm_stats_set_time(&s, "m.phase3.energy", 0.375, &e), e);
  assert_int_equal(pm_stats_set_time(&s, "place.x", 1, &e), PM_ERR_ARG);
  assert_int_equal(pm_stats_set_time(&s, "m", 1, &e), PM_ERR_ARG);
  assert_int_equal(pm_stats_set_time(&s, "m.energy.x", 1, &e), PM_ERR_ARG);
  assert_int_equal(pm_stats_set_time(&s, "total.x", 1, &e), PM_ERR_ARG);
  assert_int_equal(pm_stats_set_time(&s, "a..b", 1, &e), PM_ERR_ARG);
  assert_int_equal(pm_stats_set_time(&s, "a.", 1, &e), PM_ERR_ARG);
  char *text = NULL;
  PM_ASSERT_OK(pm_stats_to_json(&s, &text, &e), e);
  cJSON *root = cJSON_Parse(text);
  assert_non_null(root);
  assert_string_equal(at(root, "method")->valuestring, "external");
  assert_string_equal(at(root, "input")->valuestring, "mesh.msh");
  assert_true(at(root, "nodes")->valuedouble == 8);
  assert_true(at(root, "segments")->valuedouble == 1);
  assert_true(at(root, "triangles")->valuedouble == 2);
  assert_true(at(root, "tets")->valuedouble == 1);
  assert_true(cJSON_IsTrue(at(root, "valid")));
  assert_true(cJSON_IsArray(at(root, "problems")));
  assert_int_equal(cJSON_GetArraySize(at(root, "problems")), 0);
  assert_true(at(root, "iterations")->valuedouble == 900);
  assert_true(at(root, "time_s.total")->valuedouble == 0.25);
  assert_true(at(root, "time_s.place")->valuedouble == 0.2);
  assert_true(at(root, "time_s.connect")->valuedouble == 0.0625);
  assert_true(at(root, "time_s.relax.force")->valuedouble == 0.5);
  assert_true(at(root, "time_s.relax.lists")->valuedouble == 0.125);
  assert_true(at(root, "time_s.m.energy")->valuedouble == 0.5);
  assert_true(at(root, "time_s.m.phase3.energy")->valuedouble == 0.375);
  static const char *const sums[] = {"tri.radius_ratio", "tri.aspect_ratio", "tri.min_angle_deg",
                                     "tri.max_angle_deg", "tet.radius_ratio", "tet.aspect_ratio",
                                     "tet.min_dihedral_deg"};
  static const char *const fields[] = {"min", "p25", "median", "p75", "max", "mean"};
  for (int i = 0; i < 7; ++i)
    for (int j = 0; j < 6; ++j) {
      char key[128];
      snprintf(key, sizeof key, "%s.%s", sums[i], fields[j]);
      assert_true(cJSON_IsNumber(at(root, key)));
    }
  PM_ASSERT_NEAR(at(root, "tri.radius_ratio.mean")->valuedouble, 2 * (sqrt(2.0) - 1), 1e-15);
  PM_ASSERT_NEAR(at(root, "tri.max_angle_deg.max")->valuedouble, 90, 1e-12);
  PM_ASSERT_NEAR(at(root, "tet.radius_ratio.min")->valuedouble, 1, 1e-14);
  PM_ASSERT_NEAR(at(root, "tet.min_dihedral_deg.median")->valuedouble, 70.528779365509308, 1e-12);
  PM_ASSERT_NEAR(at(root, "tri.eps_g")->valuedouble, 1.5 - sqrt(2.0), 1e-15);
  /* 5 unique triangle edges with d = 1: four of length 1, one of sqrt2. */
  PM_ASSERT_NEAR(at(root, "tri.size_ratio.mean")->valuedouble, (4 + sqrt(2.0)) / 5, 1e-15);
  assert_true(cJSON_IsNumber(at(root, "tri.size_ratio.std")));
  assert_true(at(root, "tri.min_angle_bins.40_50")->valuedouble == 2);
  assert_true(at(root, "tri.max_angle_over.90")->valuedouble == 0);
  /* Two triangles, every corner on the boundary: both are boundary triangles. */
  assert_true(at(root, "tri.by_site.boundary.count")->valuedouble == 2);
  assert_true(at(root, "tri.by_site.regular.count")->valuedouble == 0);
  PM_ASSERT_NEAR(at(root, "tri.by_site.boundary.aspect_ratio.median")->valuedouble, sqrt(0.5),
                 1e-15);
  assert_null(cJSON_GetObjectItemCaseSensitive(at(root, "tri.by_site.regular"), "aspect_ratio"));
  /* No interior node in this tiny mesh: eps_t is left out rather than written as 0. */
  assert_null(cJSON_GetObjectItemCaseSensitive(at(root, "tri"), "eps_t"));
  /* No distance computed: only the extra key is there. */
  assert_true(at(root, "distance.rel_mean")->valuedouble == 0.5);
  assert_null(cJSON_GetObjectItemCaseSensitive(at(root, "distance"), "mean"));
  assert_true(at(root, "bubble.k0")->valuedouble == 30);
  assert_true(at(root, "tri.short_edges")->valuedouble == 3);
  PM_ASSERT_NEAR(at(root, "tri.eps_g")->valuedouble, 1.5 - sqrt(2.0), 1e-15);
  assert_string_equal(at(root, "bubble.scheme")->valuestring, "rk4");
  assert_true(at(root, "shells")->child != NULL);
  cJSON_Delete(root);
  free(text);

  pm_stats_set_distance(&s, 0.001, 0.01, 2.5);
  PM_ASSERT_OK(pm_stats_to_json(&s, &text, &e), e);
  root = cJSON_Parse(text);
  assert_true(at(root, "distance.mean")->valuedouble == 0.001);
  assert_true(at(root, "distance.max")->valuedouble == 0.01);
  assert_true(at(root, "distance.bbox_diagonal")->valuedouble == 2.5);
  assert_true(at(root, "distance.rel_mean")->valuedouble == 0.5);
  cJSON_Delete(root);
  free(text);

  pm_stats_clear(&s);
  pm_quality_clear(&q);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);
}

static void flatten_and_csv(void **state) {
  (void)state;
  pm_mesh *m = sample();
  pm_quality q;
  pm_check_report r;
  pm_stats s;
  fill(&s, m, &q, &r);
  pm_error e = {0};
  /* Two problems, to see them joined in one column. */
  s.valid = 0;
  s.problems = malloc(2 * sizeof(char *));
  s.problems[0] = strdup("zero-area triangles: 1 (first: triangle 3, area 0)");
  s.problems[1] = strdup("duplicate \"nodes\"");
  s.nproblem = 2;
  PM_ASSERT_OK(pm_stats_set_time(&s, "m.energy", 0.5, &e), e);
  pm_stats_flat f;
  PM_ASSERT_OK(pm_stats_flatten(&s, &f, &e), e);
  const pm_stats_item *it = pm_stats_flat_find(&f, "tri.radius_ratio.mean");
  assert_non_null(it);
  assert_false(it->is_text);
  assert_true(it->num == q.tri.s_radius_ratio.mean);
  it = pm_stats_flat_find(&f, "valid");
  assert_true(it->is_text && strcmp(it->text, "false") == 0);
  it = pm_stats_flat_find(&f, "problems");
  assert_string_equal(it->text,
                      "zero-area triangles: 1 (first: triangle 3, area 0) | duplicate \"nodes\"");
  assert_non_null(pm_stats_flat_find(&f, "shells.0.euler"));
  assert_non_null(pm_stats_flat_find(&f, "time_s.place"));
  it = pm_stats_flat_find(&f, "time_s.m.energy");
  assert_true(it && !it->is_text && it->num == 0.5);
  assert_string_equal(f.item[0].key, "method"); /* document order */

  /* The same from the JSON text. */
  char *text = NULL;
  PM_ASSERT_OK(pm_stats_to_json(&s, &text, &e), e);
  pm_stats_flat g;
  PM_ASSERT_OK(pm_stats_flatten_json(text, &g, &e), e);
  assert_int_equal(g.n, f.n);
  for (int32_t i = 0; i < f.n; ++i) {
    assert_string_equal(f.item[i].key, g.item[i].key);
    if (!f.item[i].is_text) assert_true(f.item[i].num == g.item[i].num);
  }
  free(text);
  pm_stats_flat bad;
  assert_int_equal(pm_stats_flatten_json("{not json", &bad, &e), PM_ERR_PARSE);
  assert_int_equal(bad.n, 0);
  assert_int_equal(pm_stats_flatten_json("[1, 2]", &bad, &e), PM_ERR_PARSE);
  assert_int_equal(bad.n, 0);

  /* CSV: header and row, quoting. */
  char *buf = NULL;
  size_t len = 0;
  FILE *mf = open_memstream(&buf, &len);
  pm_stats_flat_csv_header(mf, &f);
  pm_stats_flat_csv_row(mf, &f);
  pm_csv_field(mf, "a,b");
  pm_csv_field(mf, "plain");
  pm_csv_number(mf, 0.1);
  pm_csv_number(mf, 1.0 / 3.0);
  fclose(mf);
  assert_non_null(strstr(buf, "method,input,nodes,"));
  assert_non_null(strstr(buf, "\"zero-area triangles: 1 (first: triangle 3, area 0) | duplicate \"\"nodes\"\"\""));
  assert_non_null(strstr(buf, "\"a,b\"plain0.10.33333333333333331"));
  free(buf);

  /* Per-element CSV: a header and one row per element. */
  mf = open_memstream(&buf, &len);
  PM_ASSERT_OK(pm_stats_write_elements_csv(mf, m, &q, &e), e);
  fclose(mf);
  int lines = 0;
  for (char *c = buf; *c; ++c) lines += *c == '\n';
  assert_int_equal(lines, 1 + 2 + 1);
  assert_non_null(strstr(buf, "kind,index,cell,radius_ratio,aspect_ratio,min_angle_deg,max_angle_deg\n"
                              "tri,0,0,0.82842712474619"));
  assert_non_null(strstr(buf, "\ntet,0,0,"));
  free(buf);
  pm_stats_flat_clear(&f);
  pm_stats_flat_clear(&g);
  pm_stats_clear(&s);
  pm_quality_clear(&q);
  pm_check_report_clear(&r);
  pm_mesh_destroy(m);
}

static void write_json_file(void **state) {
  (void)state;
  pm_stats s;
  pm_stats_init(&s);
  pm_stats_set_run(&s, "psys", "case:sphere");
  pm_error e = {0};
  char dir[] = "/tmp/pm_test_stats_XXXXXX";
  assert_non_null(mkdtemp(dir));
  char path[256];
  snprintf(path, sizeof path, "%s/s.json", dir);
  PM_ASSERT_OK(pm_stats_write_json(&s, path, &e), e);
  FILE *f = fopen(path, "r");
  char text[4096];
  size_t n = fread(text, 1, sizeof text - 1, f);
  text[n] = 0;
  fclose(f);
  cJSON *root = cJSON_Parse(text);
  assert_string_equal(at(root, "method")->valuestring, "psys");
  assert_null(cJSON_GetObjectItemCaseSensitive(root, "valid")); /* no check ran */
  assert_null(cJSON_GetObjectItemCaseSensitive(root, "tri"));
  cJSON_Delete(root);
  unlink(path);
  snprintf(path, sizeof path, "%s/missing/s.json", dir);
  assert_int_equal(pm_stats_write_json(&s, path, &e), PM_ERR_IO);
  rmdir(dir);
  pm_stats_clear(&s);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(json_keys_and_values),
      cmocka_unit_test(flatten_and_csv),
      cmocka_unit_test(write_json_file),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
