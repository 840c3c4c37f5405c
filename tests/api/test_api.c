/* The public C API through <packmesh/packmesh.h> alone: what a program that embeds packmesh
 * sees. Models and cases, methods and their parameter sets, pm_generate (defaults, determinism
 * over threads, the node-target search, progress and cancel, misfits), mesh views and files,
 * quality and the checker. */
#include "test_support.h"

#include <stdlib.h>
#include <string.h>

#include <packmesh/packmesh.h>

static pm_model *open_model(const char *spec, pm_sizing **size) {
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_model_open(spec, &m, size, &e), e);
  assert_non_null(m);
  return m;
}

static pm_mesh *generate(const pm_model *m, const pm_sizing *size, const char *method,
                         const pm_generate_options *o, pm_generate_result *r) {
  pm_mesh *mesh = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_generate(m, size, pm_method_find(method), NULL, o, &mesh, r, &e), e);
  assert_non_null(mesh);
  return mesh;
}

static void models_and_cases(void **state) {
  (void)state;
  pm_sizing *size = NULL;
  pm_model *m = open_model("case:qi3", &size);
  assert_string_equal(pm_model_name(m), "case:qi3");
  assert_int_equal(pm_model_dimension(m), 2);
  assert_int_equal(pm_model_cell_count(m, 2), 1);
  assert_int_equal(pm_model_cell_count(m, 1), 4);
  double box[6];
  pm_model_box(m, box);
  PM_ASSERT_NEAR(box[0], -3, 0);
  PM_ASSERT_NEAR(box[4], 3, 0);
  PM_ASSERT_NEAR(pm_model_diagonal(m), 6 * sqrt(2), 1e-12);
  assert_string_equal(pm_model_healed(m), "");
  assert_non_null(size);
  assert_string_equal(pm_sizing_describe(size), "0.2*abs(r-2)+0.15");
  PM_ASSERT_NEAR(pm_sizing_eval(size, (double[3]){2, 0, 0}), 0.15, 1e-12);
  pm_sizing_destroy(size);
  pm_model_destroy(m);

  int n = pm_case_count();
  assert_true(n >= 10);
  int found = 0;
  for (int i = 0; i < n; ++i)
    if (strcmp(pm_case_name(i), "boxhole") == 0) {
      found = 1;
      assert_string_equal(pm_case_default_size(i), "0.125");
      assert_int_equal(pm_case_dimension(i), 3);
      assert_non_null(strstr(pm_case_source(i), "OpenCASCADE"));
      assert_non_null(strstr(pm_case_description(i), "hole"));
    }
  assert_true(found);
  assert_null(pm_case_name(n));
  assert_int_equal(pm_case_dimension(0), 2); /* the planar cases come first */
  assert_non_null(strstr(pm_case_source(0), "papers/"));

  pm_error e = {0};
  m = (pm_model *)&e;
  assert_int_equal(pm_model_open("case:nosuch", &m, NULL, &e), PM_ERR_ARG);
  assert_null(m);
  assert_non_null(strstr(e.msg, "qi3"));
  assert_int_equal(pm_model_open("/nonexistent/part.step", &m, NULL, &e), PM_ERR_IO);
  assert_null(m);
}

static void methods_and_parameters(void **state) {
  (void)state;
  assert_int_equal(pm_method_count(), 6);
  assert_null(pm_method_at(6));
  assert_null(pm_method_find("nosuch"));
  const pm_method *b = pm_method_find("bubble"), *c = pm_method_find("cgal");
  assert_string_equal(pm_method_name(b), "bubble");
  assert_true(pm_method_traces(b));
  assert_false(pm_method_traces(c));
  assert_true(pm_method_planar_only(c));
  assert_false(pm_method_planar_only(b));

  int np = pm_method_param_count(b), k0 = -1;
  assert_true(np > 10);
  pm_error e = {0};
  pm_param_info info;
  for (int i = 0; i < np; ++i) {
    PM_ASSERT_OK(pm_method_param_info(b, i, &info, &e), e);
    if (strcmp(info.key, "k0") == 0) k0 = i;
  }
  assert_true(k0 >= 0);
  assert_int_equal(pm_method_param_info(b, np, &info, &e), PM_ERR_ARG);

  pm_method_params *p = NULL;
  PM_ASSERT_OK(pm_method_params_create(pm_method_find("psys"), &p, &e), e);
  char buf[64];
  PM_ASSERT_OK(pm_method_params_set(p, "lambda_max", "2", &e), e);
  PM_ASSERT_OK(pm_method_params_get(p, "lambda_max", buf, sizeof buf, &e), e);
  assert_string_equal(buf, "2");
  assert_int_equal(pm_method_params_set(p, "nosuch", "1", &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "nosuch"));
  assert_int_equal(pm_method_params_set(p, "lambda_max", "x", &e), PM_ERR_ARG);
  PM_ASSERT_OK(pm_method_params_get(p, "lambda_max", buf, sizeof buf, &e), e);
  assert_string_equal(buf, "2"); /* a refused value leaves the set unchanged */
  PM_ASSERT_OK(pm_method_params_check(p, &e), e);
  /* A cross-parameter rule: lambda_min <= lambda_init <= lambda_max. */
  PM_ASSERT_OK(pm_method_params_set(p, "lambda_init", "1.5", &e), e);
  PM_ASSERT_OK(pm_method_params_set(p, "lambda_max", "1.2", &e), e);
  PM_ASSERT_OK(pm_method_params_check(p, &e), e); /* each value is within its own range */
  /* The rule is the method's: pm_generate refuses the run; a set of one method is refused by
   * another. */
  pm_model *m = open_model("case:qi1", NULL);
  pm_mesh *mesh = (pm_mesh *)&e;
  assert_int_equal(pm_generate(m, NULL, pm_method_find("psys"), p, NULL, &mesh, NULL, &e),
                   PM_ERR_ARG);
  assert_null(mesh);
  assert_non_null(strstr(e.msg, "lambda_min <= lambda_init <= lambda_max"));
  assert_int_equal(pm_generate(m, NULL, b, p, NULL, &mesh, NULL, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "psys"));
  pm_method_params_destroy(p);
  pm_model_destroy(m);
}

/* pm_generate with the defaults gives what the method gives; the thread count changes nothing. */
static void generate_views_and_threads(void **state) {
  (void)state;
  pm_sizing *size = NULL;
  pm_model *m = open_model("case:qi3", &size);
  pm_generate_options o;
  pm_generate_options_init(&o);
  assert_int_equal(o.seed, 1);
  assert_int_equal(o.threads, 1);
  pm_generate_result r1, r2;
  pm_mesh *a = generate(m, size, "bubble", &o, &r1);
  o.threads = 2;
  pm_mesh *b = generate(m, size, "bubble", &o, &r2);
  int32_t n = pm_mesh_node_count(a);
  assert_int_equal(n, pm_mesh_node_count(b));
  assert_memory_equal(pm_mesh_nodes(a), pm_mesh_nodes(b), sizeof(double) * 3 * (size_t)n);
  assert_int_equal(pm_mesh_element_count(a, 2), pm_mesh_element_count(b, 2));
  assert_memory_equal(pm_mesh_elements(a, 2), pm_mesh_elements(b, 2),
                      sizeof(int32_t) * 3 * (size_t)pm_mesh_element_count(a, 2));
  assert_true(r1.iterations > 20);
  assert_int_equal(r1.runs, 1);
  PM_ASSERT_NEAR(r1.size_scale, 1, 0);
  assert_non_null(strstr(r1.stop_reason, "converged"));
  /* Views: every element's nodes in range, triangles on face 0, nodes classified. */
  assert_true(n > 500 && n < 800);
  const int32_t *tri = pm_mesh_elements(a, 2), *cells = pm_mesh_element_cells(a, 2);
  for (int32_t t = 0; t < pm_mesh_element_count(a, 2); ++t) {
    for (int k = 0; k < 3; ++k) assert_true(tri[3 * t + k] >= 0 && tri[3 * t + k] < n);
    assert_int_equal(cells[t], 0);
  }
  assert_true(pm_mesh_element_count(a, 1) > 0);
  assert_int_equal(pm_mesh_element_count(a, 3), 0);
  assert_null(pm_mesh_elements(a, 4));
  const int8_t *dims = pm_mesh_node_dims(a);
  for (int32_t i = 0; i < n; ++i) assert_true(dims[i] >= 0 && dims[i] <= 2);

  /* Files: written and read back with the same nodes and triangles. */
  char path[] = "/tmp/pm_api_XXXXXX.vtu";
  int fd = mkstemps(path, 4);
  assert_true(fd >= 0);
  close(fd);
  pm_error e = {0};
  PM_ASSERT_OK(pm_mesh_write(a, path, &e), e);
  pm_mesh *back = NULL;
  PM_ASSERT_OK(pm_mesh_read(path, &back, &e), e);
  assert_int_equal(pm_mesh_node_count(back), n);
  assert_int_equal(pm_mesh_element_count(back, 2), pm_mesh_element_count(a, 2));
  unlink(path);

  /* Quality and the checker. */
  pm_quality *q = NULL;
  PM_ASSERT_OK(pm_quality_measure(a, size, &q, &e), e);
  pm_summary rr;
  PM_ASSERT_OK(pm_quality_summary(q, 2, PM_MEASURE_RADIUS_RATIO, &rr, &e), e);
  assert_int_equal(rr.n, pm_mesh_element_count(a, 2));
  assert_true(rr.median > 0.95 && rr.min > 0.5 && rr.max <= 1);
  int32_t nv = 0;
  const double *v = pm_quality_values(q, 2, PM_MEASURE_MIN_ANGLE, &nv);
  assert_int_equal(nv, rr.n);
  double lo = 180;
  for (int32_t i = 0; i < nv; ++i) lo = fmin(lo, v[i]);
  pm_summary ang;
  PM_ASSERT_OK(pm_quality_summary(q, 2, PM_MEASURE_MIN_ANGLE, &ang, &e), e);
  PM_ASSERT_NEAR(ang.min, lo, 0);
  pm_summary sr = pm_quality_size_ratio(q, 2);
  assert_true(sr.n > 0 && fabs(sr.mean - 1) < 0.1);
  assert_true(pm_quality_eps_t(q, 2) >= 0 && pm_quality_eps_t(q, 2) < 1);
  assert_int_equal(pm_quality_summary(q, 4, PM_MEASURE_MIN_ANGLE, &ang, &e), PM_ERR_ARG);
  pm_quality_destroy(q);
  pm_check_result chk;
  PM_ASSERT_OK(pm_mesh_validate(a, m, &chk, &e), e);
  assert_true(chk.valid);
  assert_int_equal(chk.nproblem, 0);
  pm_mesh_destroy(back);
  pm_mesh_destroy(a);
  pm_mesh_destroy(b);
  pm_sizing_destroy(size);
  pm_model_destroy(m);
}

typedef struct seen {
  int meshing, rows, done, cancel_at;
  int64_t last_iteration;
  int columns_ok;
} seen;

static int watch(void *user, const pm_progress *p) {
  seen *s = user;
  if (strcmp(p->stage, "meshing") == 0) s->meshing++;
  if (strcmp(p->stage, "done") == 0) s->done++;
  if (strcmp(p->stage, "iteration") == 0) {
    s->rows++;
    s->last_iteration = p->iteration;
    s->columns_ok = p->ncol > 2 && strcmp(p->columns[0], "step") == 0 &&
                    p->values[0] == (double)p->iteration;
    if (s->cancel_at && s->rows >= s->cancel_at) return 1;
  }
  return 0;
}

static void progress_and_cancel(void **state) {
  (void)state;
  pm_sizing *size = NULL;
  pm_model *m = open_model("case:qi3", &size);
  pm_generate_options o;
  pm_generate_options_init(&o);
  seen s = {0};
  o.progress = watch, o.progress_user = &s;
  pm_generate_result r;
  pm_mesh *mesh = generate(m, size, "bubble", &o, &r);
  assert_int_equal(s.meshing, 1);
  assert_int_equal(s.done, 1);
  assert_int_equal(s.rows, r.iterations); /* one row per iteration */
  assert_int_equal(s.last_iteration, r.iterations);
  assert_true(s.columns_ok);
  pm_mesh_destroy(mesh);

  seen c = {0};
  c.cancel_at = 5;
  o.progress_user = &c;
  pm_error e = {0};
  mesh = (pm_mesh *)&e;
  assert_int_equal(pm_generate(m, size, pm_method_find("bubble"), NULL, &o, &mesh, &r, &e),
                   PM_ERR_CANCELLED);
  assert_null(mesh);
  assert_int_equal(c.rows, 5);
  assert_non_null(strstr(e.msg, "cancelled"));
  assert_string_equal(pm_status_name(PM_ERR_CANCELLED), "cancelled");
  /* A method that reports no iterations is cancelled at a stage. */
  seen g = {0};
  g.cancel_at = 1;
  o.progress_user = &g;
  assert_int_equal(pm_generate(m, size, pm_method_find("gmsh-frontal"), NULL, &o, &mesh, &r, &e),
                   PM_OK);
  assert_int_equal(g.rows, 0);
  assert_int_equal(g.meshing, 1);
  pm_mesh_destroy(mesh);
  pm_sizing_destroy(size);
  pm_model_destroy(m);
}

static void node_target(void **state) {
  (void)state;
  pm_model *m = open_model("case:qi1", NULL);
  pm_generate_options o;
  pm_generate_options_init(&o);
  o.target_nodes = 400;
  pm_generate_result r;
  pm_mesh *mesh = generate(m, NULL, "bubble", &o, &r); /* bubble's default field, scaled */
  assert_true(r.target_met);
  assert_true(fabs(pm_mesh_node_count(mesh) / 400.0 - 1) <= 0.03);
  assert_true(r.runs >= 2 && r.runs <= 8);
  assert_true(r.size_scale != 1);
  pm_mesh_destroy(mesh);
  pm_model_destroy(m);
}

static void misfits(void **state) {
  (void)state;
  pm_model *sphere = open_model("case:sphere", NULL), *qi1 = open_model("case:qi1", NULL);
  pm_generate_options o;
  pm_generate_options_init(&o);
  pm_error e = {0};
  pm_mesh *mesh = NULL;
  assert_int_equal(pm_generate(sphere, NULL, pm_method_find("cgal"), NULL, &o, &mesh, NULL, &e),
                   PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "planar domains only"));
  o.volume = 1;
  assert_int_equal(pm_generate(qi1, NULL, pm_method_find("bubble"), NULL, &o, &mesh, NULL, &e),
                   PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "no volumes"));
  o.volume = 0, o.threads = 0;
  assert_int_equal(pm_generate(qi1, NULL, pm_method_find("bubble"), NULL, &o, &mesh, NULL, &e),
                   PM_ERR_ARG);
  o.threads = 1, o.max_nodes = 10;
  assert_int_equal(pm_generate(qi1, NULL, pm_method_find("bubble"), NULL, &o, &mesh, NULL, &e),
                   PM_ERR_LIMIT);
  assert_null(mesh);
  assert_int_equal(pm_generate(qi1, NULL, NULL, NULL, NULL, &mesh, NULL, &e), PM_ERR_ARG);
  pm_model_destroy(sphere);
  pm_model_destroy(qi1);
}

/* A C callback as the size field, and the inferred field of psys handed to bubble. */
static double graded(const double xyz[3], void *user) {
  (void)user;
  return 0.05 + 0.1 * fabs(xyz[0]);
}

static void size_fields(void **state) {
  (void)state;
  pm_model *m = open_model("case:qi1", NULL);
  pm_error e = {0};
  pm_sizing *cb = NULL, *inf = NULL, *bad = NULL;
  PM_ASSERT_OK(pm_sizing_callback(graded, NULL, "graded in x", &cb, &e), e);
  assert_string_equal(pm_sizing_describe(cb), "graded in x");
  pm_mesh *mesh = generate(m, cb, "bubble", NULL, NULL);
  pm_quality *q = NULL;
  PM_ASSERT_OK(pm_quality_measure(mesh, cb, &q, &e), e);
  pm_summary sr = pm_quality_size_ratio(q, 2);
  assert_true(fabs(sr.median - 1) < 0.1);
  pm_quality_destroy(q);
  pm_mesh_destroy(mesh);
  PM_ASSERT_OK(pm_sizing_inferred(m, 1, 2, &inf, &e), e);
  assert_non_null(strstr(pm_sizing_describe(inf), "sampled"));
  mesh = generate(m, inf, "bubble", NULL, NULL);
  assert_true(pm_mesh_node_count(mesh) > 50);
  pm_mesh_destroy(mesh);
  assert_int_equal(pm_sizing_expression("0.1*(x", &bad, &e), PM_ERR_PARSE);
  assert_null(bad);
  assert_int_equal(pm_sizing_constant(-1, &bad, &e), PM_ERR_ARG);
  pm_sizing_destroy(cb);
  pm_sizing_destroy(inf);
  pm_model_destroy(m);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(models_and_cases),     cmocka_unit_test(methods_and_parameters),
      cmocka_unit_test(generate_views_and_threads), cmocka_unit_test(progress_and_cancel),
      cmocka_unit_test(node_target),          cmocka_unit_test(misfits),
      cmocka_unit_test(size_fields),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
