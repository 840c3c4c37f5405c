/* The extended C API through <packmesh/packmesh_extended.h> alone: what `packmesh mesh` and
 * `packmesh quality` are built from. Method names and tables, the fit checks, the run's record
 * (stats keys and values, trace rows over a node-target search, measures, the quality table and
 * the per-element CSV), file formats and output sets. */
#include "test_support.h"

#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cjson/cJSON.h>
#include <packmesh/packmesh_extended.h>

/* What f (rewound) holds, malloc'ed, and closes f. */
static char *slurp(FILE *f) {
  assert_non_null(f);
  long n = ftell(f);
  assert_true(n >= 0);
  rewind(f);
  char *s = malloc((size_t)n + 1);
  assert_non_null(s);
  assert_int_equal(fread(s, 1, (size_t)n, f), (size_t)n);
  s[n] = '\0';
  fclose(f);
  return s;
}

static pm_model *open_model(const char *spec, pm_sizing **size) {
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_model_open(spec, &m, size, &e), e);
  return m;
}

static void method_tables(void **state) {
  (void)state;
  char names[256];
  pm_method_names(names, sizeof names);
  assert_non_null(strstr(names, "bubble, psys, gmsh-frontal"));
  char shortbuf[8];
  pm_method_names(shortbuf, sizeof shortbuf);
  assert_int_equal(strlen(shortbuf), 7); /* truncated to fit, terminated */

  pm_method_params *p = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_method_params_create(pm_method_find("bubble"), &p, &e), e);
  PM_ASSERT_OK(pm_method_params_set_pair(p, "k0=2.5", &e), e);
  char v[64];
  PM_ASSERT_OK(pm_method_params_get(p, "k0", v, sizeof v, &e), e);
  assert_string_equal(v, "2.5");
  assert_int_equal(pm_method_params_set_pair(p, "k0", &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "KEY=VALUE"));
  assert_int_equal(pm_method_params_set_pair(p, "nosuch=1", &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "nosuch"));
  PM_ASSERT_OK(pm_method_params_get(p, "k0", v, sizeof v, &e), e);
  assert_string_equal(v, "2.5"); /* unchanged by the failures */
  pm_method_params_destroy(p);

  /* The help table: one row per parameter, with its source; a method without: the marker. */
  for (int i = 0; i < pm_method_count(); ++i) {
    const pm_method *m = pm_method_at(i);
    FILE *f = tmpfile();
    pm_method_help(m, f);
    char *text = slurp(f);
    if (pm_method_param_count(m) == 0) {
      assert_non_null(strstr(text, "(no parameters)"));
    } else {
      pm_param_info info;
      for (int k = 0; k < pm_method_param_count(m); ++k) {
        PM_ASSERT_OK(pm_method_param_info(m, k, &info, &e), e);
        assert_non_null(strstr(text, info.key));
      }
      assert_true(pm_test_count_lines(text) >= pm_method_param_count(m));
    }
    free(text);
  }
}

static void fit_checks(void **state) {
  (void)state;
  pm_model *qi3 = open_model("case:qi3", NULL), *box = open_model("case:boxhole", NULL);
  pm_generate_options o;
  pm_generate_options_init(&o);
  pm_generate_misfit why = PM_MISFIT_TARGET;
  pm_error e = {0};
  PM_ASSERT_OK(pm_generate_check(qi3, NULL, pm_method_find("bubble"), &o, &why, &e), e);
  assert_int_equal(why, PM_MISFIT_NONE);
  o.volume = 1;
  assert_int_equal(pm_generate_check(qi3, NULL, pm_method_find("bubble"), &o, &why, &e),
                   PM_ERR_ARG);
  assert_int_equal(why, PM_MISFIT_VOLUME);
  PM_ASSERT_OK(pm_generate_check(box, NULL, pm_method_find("bubble"), &o, &why, &e), e);
  o.volume = 0;
  assert_int_equal(pm_generate_check(box, NULL, pm_method_find("cgal"), &o, &why, &e),
                   PM_ERR_ARG);
  assert_int_equal(why, PM_MISFIT_PLANAR_ONLY);
  assert_non_null(strstr(e.msg, "cgal"));
  pm_model_destroy(qi3);
  pm_model_destroy(box);
}

/* The stats of a bubble run on qi3 with a node target: the last run's keys, its trace rows. */
static void report_of_a_run(void **state) {
  (void)state;
  pm_sizing *size = NULL;
  pm_model *m = open_model("case:qi3", &size);
  pm_report *r = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_report_create("bubble", "case:qi3", &r, &e), e);
  PM_ASSERT_OK(pm_report_record_trace(r, &e), e);
  pm_generate_options o;
  pm_generate_options_init(&o);
  o.target_nodes = 400;
  pm_mesh *mesh = NULL;
  pm_sizing *final_size = NULL;
  pm_generate_result res;
  PM_ASSERT_OK(pm_generate_report(m, size, pm_method_find("bubble"), NULL, &o, r, &final_size,
                                  &mesh, &res, &e),
               e);
  assert_true(res.runs >= 2);
  assert_non_null(final_size); /* a scaled copy of the case's field */
  assert_true(res.size_scale != 1);
  PM_ASSERT_OK(pm_report_record_run(r, m, pm_method_find("bubble"), NULL, &o, &res, final_size,
                                    &e),
               e);
  PM_ASSERT_OK(pm_report_measure(r, mesh, m, final_size, PM_REPORT_ALL, &e), e);
  PM_ASSERT_OK(pm_report_set_time(r, "total", 1.5, &e), e);
  PM_ASSERT_OK(pm_report_add_number(r, "extra.answer", 42, &e), e);
  assert_int_equal(pm_report_add_number(r, "nodes", 1, &e), PM_ERR_ARG);
  assert_int_equal(pm_report_add_text(r, "extra.answer", "again", &e), PM_ERR_ARG);
  /* A measure is taken once per report. */
  assert_int_equal(pm_report_measure(r, mesh, m, final_size, PM_REPORT_QUALITY, &e), PM_ERR_ARG);

  char *json = NULL;
  PM_ASSERT_OK(pm_report_stats_json(r, &json, &e), e);
  cJSON *s = cJSON_Parse(json);
  assert_non_null(s);
  assert_string_equal(cJSON_GetObjectItem(s, "method")->valuestring, "bubble");
  assert_string_equal(cJSON_GetObjectItem(s, "input")->valuestring, "case:qi3");
  assert_int_equal(cJSON_GetObjectItem(s, "nodes")->valuedouble, pm_mesh_node_count(mesh));
  assert_int_equal(cJSON_GetObjectItem(s, "triangles")->valuedouble,
                   pm_mesh_element_count(mesh, 2));
  assert_true(cJSON_IsTrue(cJSON_GetObjectItem(s, "valid")));
  assert_int_equal(cJSON_GetObjectItem(s, "iterations")->valuedouble, res.iterations);
  assert_string_equal(cJSON_GetObjectItem(s, "stop_reason")->valuestring, res.stop_reason);
  assert_string_equal(cJSON_GetObjectItem(s, "size")->valuestring, pm_sizing_describe(final_size));
  cJSON *params = cJSON_GetObjectItem(s, "params");
  assert_int_equal(cJSON_GetArraySize(params), pm_method_param_count(pm_method_find("bubble")));
  cJSON *times = cJSON_GetObjectItem(s, "time_s");
  PM_ASSERT_NEAR(cJSON_GetObjectItem(times, "total")->valuedouble, 1.5, 0);
  assert_non_null(cJSON_GetObjectItem(times, "distance"));
  cJSON *tri = cJSON_GetObjectItem(s, "tri");
  assert_int_equal(cJSON_GetObjectItem(tri, "count")->valuedouble, pm_mesh_element_count(mesh, 2));
  double rr_min = cJSON_GetObjectItem(cJSON_GetObjectItem(tri, "radius_ratio"), "min")->valuedouble;
  assert_true(rr_min > 0.3 && rr_min <= 1);
  cJSON *dist = cJSON_GetObjectItem(s, "distance");
  assert_true(cJSON_GetObjectItem(dist, "max")->valuedouble < 0.05);
  PM_ASSERT_NEAR(cJSON_GetObjectItem(cJSON_GetObjectItem(s, "extra"), "answer")->valuedouble, 42,
                 0);
  cJSON_Delete(s);
  free(json);

  /* The trace holds the last run only: one row per iteration (event 0, the last column), the
   * population controls between them, last the mesh's row (event 3), below its header. */
  char path[] = "/tmp/pm_api_trace_XXXXXX.csv";
  int fd = mkstemps(path, 4);
  assert_true(fd >= 0);
  close(fd);
  PM_ASSERT_OK(pm_report_write_trace(r, path, &e), e);
  FILE *f = fopen(path, "r");
  fseek(f, 0, SEEK_END);
  char *trace = slurp(f);
  int64_t steps = 0;
  for (const char *l = strstr(trace, ",0\n"); l; l = strstr(l + 1, ",0\n")) ++steps;
  assert_int_equal(steps, res.iterations);
  assert_true(pm_test_count_lines(trace) > res.iterations + 2);
  assert_true(strlen(trace) > 3 && strcmp(trace + strlen(trace) - 3, ",3\n") == 0);
  assert_true(strncmp(trace, "step,bubbles,", 13) == 0);
  free(trace);
  remove(path);

  /* The table and the per-element CSV of the same measures. */
  f = tmpfile();
  PM_ASSERT_OK(pm_report_write_table(r, "case:qi3", f, &e), e);
  char *table = slurp(f);
  assert_non_null(strstr(table, "radius ratio"));
  assert_non_null(strstr(table, "case:qi3"));
  free(table);
  f = tmpfile();
  PM_ASSERT_OK(pm_report_write_elements_csv(r, mesh, f, &e), e);
  char *csv = slurp(f);
  assert_true(strncmp(csv, "kind,index,cell,radius_ratio,", 29) == 0);
  assert_int_equal(pm_test_count_lines(csv),
                   1 + pm_mesh_element_count(mesh, 2)); /* triangles and tets only */
  free(csv);

  pm_report_destroy(r);
  pm_sizing_destroy(final_size);
  pm_sizing_destroy(size);
  pm_mesh_destroy(mesh);
  pm_model_destroy(m);
}

/* A trace is refused for a method that does not trace, and without a recorded trace. */
static void report_refusals(void **state) {
  (void)state;
  pm_report *r = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_report_create("external", "x.msh", &r, &e), e);
  assert_int_equal(pm_report_write_trace(r, "/tmp/pm_never.csv", &e), PM_ERR_ARG);
  assert_int_equal(access("/tmp/pm_never.csv", F_OK), -1);
  FILE *f = tmpfile();
  /* Nothing measured: no table. */
  assert_int_equal(pm_report_write_table(r, NULL, f, &e), PM_ERR_ARG);
  fclose(f);
  PM_ASSERT_OK(pm_report_finish_frames(r, &e), e);
  pm_report_destroy(r);
  pm_report_destroy(NULL);
}

static void formats(void **state) {
  (void)state;
  pm_mesh_format fmt = PM_MESH_FORMAT_COUNT;
  pm_error e = {0};
  const char *exts[] = {"a.msh", "b/c.vtk", "x.vtu", "y.STL", "z.obj", "m.mesh"};
  for (int i = 0; i < PM_MESH_FORMAT_COUNT; ++i) {
    PM_ASSERT_OK(pm_mesh_format_of(exts[i], &fmt, &e), e);
    assert_int_equal(fmt, i);
  }
  assert_string_equal(pm_mesh_format_ext(PM_MESH_MEDIT), "mesh");
  assert_int_equal(pm_mesh_format_of("part.xyz", &fmt, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "xyz"));
  assert_int_equal(pm_mesh_format_holds(PM_MESH_STL, 2), 1);
  assert_int_equal(pm_mesh_format_holds(PM_MESH_STL, 1), 0);
  assert_int_equal(pm_mesh_format_holds(PM_MESH_OBJ, 3), 0);
  assert_int_equal(pm_mesh_format_holds(PM_MESH_VTU, 3), 1);
}

static int exists(const char *p) {
  struct stat st;
  return stat(p, &st) == 0;
}

static void output_sets(void **state) {
  (void)state;
  char dir[] = "/tmp/pm_api_outputs_XXXXXX";
  assert_non_null(mkdtemp(dir));
  char a[128], b[128], folder[128], a2[160];
  snprintf(a, sizeof a, "%s/a.txt", dir);
  snprintf(b, sizeof b, "%s/b.txt", dir);
  snprintf(folder, sizeof folder, "%s/new/frames", dir);
  snprintf(a2, sizeof a2, "%s/./a.txt", dir);
  assert_true(pm_path_same(a, a2));
  assert_false(pm_path_same(a, b));

  pm_error e = {0};
  /* Committed: every output appears, no temporary is left. */
  pm_outputs *s = pm_outputs_create();
  const char *ta = NULL, *tb = NULL, *tf = NULL;
  PM_ASSERT_OK(pm_outputs_add(s, a, 0, &ta, &e), e);
  PM_ASSERT_OK(pm_outputs_add(s, b, 0, &tb, &e), e);
  PM_ASSERT_OK(pm_outputs_add(s, folder, 1, &tf, &e), e);
  const char *tdup = NULL;
  assert_int_equal(pm_outputs_add(s, a2, 0, &tdup, &e), PM_ERR_ARG);
  assert_false(exists(a));
  FILE *f = fopen(ta, "w");
  assert_non_null(f);
  fputs("a\n", f);
  fclose(f);
  PM_ASSERT_OK(pm_outputs_commit(s, &e), e);
  pm_outputs_destroy(s);
  assert_true(exists(a) && exists(b) && exists(folder));

  /* Not committed: nothing is left, the made parent folder included. */
  char c[128], other[128];
  snprintf(c, sizeof c, "%s/c.txt", dir);
  snprintf(other, sizeof other, "%s/made/deep", dir);
  s = pm_outputs_create();
  PM_ASSERT_OK(pm_outputs_add(s, c, 0, &ta, &e), e);
  PM_ASSERT_OK(pm_outputs_add(s, other, 1, &tf, &e), e);
  assert_true(exists(ta));
  pm_outputs_destroy(s);
  snprintf(other, sizeof other, "%s/made", dir);
  assert_false(exists(c));
  assert_false(exists(other));

  /* An output that cannot be written is reported when it is reserved. */
  snprintf(c, sizeof c, "%s/a.txt/inside.txt", dir);
  s = pm_outputs_create();
  assert_int_equal(pm_outputs_add(s, c, 0, &ta, &e), PM_ERR_IO);
  assert_non_null(strstr(e.msg, "inside.txt"));
  pm_outputs_destroy(s);

  char cmd[200];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
  assert_int_equal(system(cmd), 0);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(method_tables), cmocka_unit_test(fit_checks),
      cmocka_unit_test(report_of_a_run), cmocka_unit_test(report_refusals),
      cmocka_unit_test(formats), cmocka_unit_test(output_sets),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
