/* The psys method with given and inferred sizes: the calibration of a given size (mean edge / d
 * within 5% of 1 on uniform fields), graded fields, the sizing inference handed out as a sampled
 * field, and the error paths. Every mesh goes through pm_mesh_check. */
#include "test_psys_run_util.h"

#include <unistd.h>

/* A given uniform size d: sigma = d / edge_per_sigma makes the mean edge length d within 5%,
 * on a plane, a sphere and a solid with curved and flat faces. */
static void uniform_size_calibration(void **state) {
  (void)state;
  const struct {
    const char *input;
    double d;
  } runs[] = {{"case:qi1", 0.1}, {"case:sphere", 0.1}, {"case:boxhole", 0.06}};
  for (int k = 0; k < 3; ++k) {
    pm_model *m = psys_test_open(runs[k].input);
    pm_sizing *size = NULL;
    pm_error e = {0};
    PM_ASSERT_OK(pm_sizing_constant(runs[k].d, &size, &e), e);
    pm_mesh *mesh = psys_test_run(m, size, 1, 2, 0, NULL, NULL, NULL, NULL);
    psys_test_assert_valid(mesh, m);
    double ratio = 0;
    pm_summary a = psys_test_aspect(mesh, size, &ratio);
    if (!(fabs(ratio - 1) <= 0.05))
      fail_msg("%s, d = %g: mean edge / d = %.4f", runs[k].input, runs[k].d, ratio);
    assert_true(a.median < 0.66);
    pm_mesh_destroy(mesh);
    pm_sizing_destroy(size);
    pm_model_destroy(m);
  }
}

/* A given graded field is followed: the edges near the fine end are shorter. */
static void graded_size_is_followed(void **state) {
  (void)state;
  pm_model *m = psys_test_open("case:qi1");
  pm_sizing *size = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_sizing_parse("0.04+0.04*(y+2)", &size, &e), e);
  pm_mesh *mesh = psys_test_run(m, size, 1, 2, 0, NULL, NULL, NULL, NULL);
  psys_test_assert_valid(mesh, m);
  double ratio = 0;
  psys_test_aspect(mesh, size, &ratio);
  assert_true(fabs(ratio - 1) < 0.1);
  /* mean edge length in the lowest and highest quarter */
  double lo = 0, hi = 0;
  int nlo = 0, nhi = 0;
  for (int32_t t = 0; t < mesh->ntri; ++t) {
    const double *a = &mesh->xyz[3 * mesh->tri[3 * t]], *b = &mesh->xyz[3 * mesh->tri[3 * t + 1]];
    double y = 0.5 * (a[1] + b[1]), l = pm_v3_dist(a, b);
    if (y < -1) lo += l, ++nlo;
    if (y > 1) hi += l, ++nhi;
  }
  lo /= nlo, hi /= nhi;
  /* d goes 0.04 .. 0.08 in the low quarter, 0.16 .. 0.2 in the high one */
  assert_true(hi / lo > 2.5 && hi / lo < 4.5);
  pm_mesh_destroy(mesh);
  pm_sizing_destroy(size);
  pm_model_destroy(m);
}

/* The sizing inference handed out for other methods: a sampled field (an edge length), smaller
 * where the inferred sigma is (the hole of case:boxhole: curvature 4 and a 0.25 wall). */
static void inferred_field_as_sizing(void **state) {
  (void)state;
  pm_model *m = psys_test_open("case:boxhole");
  pm_sizing *f = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(psys_infer_size(m, NULL, 1, 2, &f, &e), e);
  assert_non_null(f);
  psys_params p;
  psys_params_init(&p);
  /* at the hole wall: sigma <= 1 / (2 x 4) = 0.125, edge <= 0.66 x 0.125 */
  const double hole[3] = {0.25, 0, 0}, corner[3] = {1, 0.5, 0.3};
  double dh = pm_sizing_eval(f, hole), dc = pm_sizing_eval(f, corner);
  assert_true(dh > 0 && dh <= p.edge_per_sigma * 0.125 * 1.01);
  assert_true(dc > 1.3 * dh);
  /* bounded by the limits of eq. 12-13, converted to an edge length */
  const double diag = m->diagonal;
  assert_true(dc <= p.edge_per_sigma * diag / 10 * (1 + 1e-9));
  assert_true(strstr(pm_sizing_describe(f), "sampled") != NULL);
  /* and it drives psys itself as a given field */
  pm_mesh *mesh = psys_test_run(m, f, 1, 2, 0, NULL, NULL, NULL, NULL);
  psys_test_assert_valid(mesh, m);
  pm_mesh_destroy(mesh);
  /* the method's default field for callers that scale it (--target-nodes) is the same */
  pm_sizing *g = NULL;
  PM_ASSERT_OK(psys_method.default_size(m, &p, 1, 1, &g, &e), e);
  PM_ASSERT_NEAR(pm_sizing_eval(g, hole), dh, 1e-12);
  pm_sizing_destroy(g);
  pm_sizing_destroy(f);
  pm_model_destroy(m);
}

/* The median segment over the median edge between two face nodes. */
static double curve_over_face_spacing(const pm_mesh *mesh) {
  double *seg = malloc(sizeof(double) * ((size_t)mesh->nseg + 1));
  double *face = malloc(sizeof(double) * (3 * (size_t)mesh->ntri + 1));
  assert_non_null(seg);
  assert_non_null(face);
  for (int32_t k = 0; k < mesh->nseg; ++k)
    seg[k] = pm_v3_dist(&mesh->xyz[3 * mesh->seg[2 * k]], &mesh->xyz[3 * mesh->seg[2 * k + 1]]);
  size_t nf = 0;
  for (int32_t t = 0; t < mesh->ntri; ++t)
    for (int j = 0; j < 3; ++j) {
      int32_t a = mesh->tri[3 * t + j], b = mesh->tri[3 * t + (j + 1) % 3];
      /* an inner edge is in two triangles, once as (a, b) and once as (b, a) */
      if (a < b && mesh->node_dim[a] == PM_FACE && mesh->node_dim[b] == PM_FACE)
        face[nf++] = pm_v3_dist(&mesh->xyz[3 * a], &mesh->xyz[3 * b]);
    }
  pm_summary ss, fs;
  pm_error e = {0};
  PM_ASSERT_OK(pm_summary_compute(seg, (size_t)mesh->nseg, &ss, &e), e);
  PM_ASSERT_OK(pm_summary_compute(face, nf, &fs, &e), e);
  free(seg), free(face);
  return ss.median / fs.median;
}

/* The curves get the faces' spacing (ring_curve, psys_population.c): on a rectangle with a
 * uniform size the median segment is within 3% of the median edge between face nodes; with the
 * older ring_curve = 1.5 it is more than 5% shorter. */
static void curves_have_the_faces_spacing(void **state) {
  (void)state;
  pm_model *m = psys_test_open("case:qi1");
  pm_sizing *size = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_sizing_constant(0.1, &size, &e), e);
  pm_mesh *mesh = psys_test_run(m, size, 1, 2, 0, NULL, NULL, NULL, NULL);
  double r = curve_over_face_spacing(mesh);
  if (!(fabs(r - 1) <= 0.03)) fail_msg("segment / face edge = %.4f", r);
  pm_mesh_destroy(mesh);
  const char *const old[] = {"ring_curve=1.5", NULL};
  mesh = psys_test_run(m, size, 1, 2, 0, old, NULL, NULL, NULL);
  r = curve_over_face_spacing(mesh);
  if (!(r < 0.95)) fail_msg("ring_curve 1.5: segment / face edge = %.4f", r);
  pm_mesh_destroy(mesh);
  pm_sizing_destroy(size);
  pm_model_destroy(m);
}

/* Bad input: one-line errors, no mesh. */
static void errors(void **state) {
  (void)state;
  pm_model *m = psys_test_open("case:cylinder");
  psys_params p;
  psys_params_init(&p);
  pm_error e = {0};
  /* out-of-range parameters, through the table and the pair checks */
  assert_int_equal(pm_params_set(&psys_param_table, &p, "s_tau", "0", &e), PM_ERR_ARG);
  assert_int_equal(pm_params_set(&psys_param_table, &p, "L", "-1", &e), PM_ERR_ARG);
  assert_int_equal(pm_params_set(&psys_param_table, &p, "nonsense", "1", &e), PM_ERR_ARG);
  psys_params_init(&p);
  p.lambda_min = 0.5, p.lambda_init = 0.1;
  assert_int_equal(psys_params_check(&p, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "lambda"));
  psys_params_init(&p);
  p.kappa_min = 10, p.kappa_max = 1;
  assert_int_equal(psys_params_check(&p, &e), PM_ERR_ARG);
  psys_params_init(&p);
  /* the node cap */
  pm_run_input in;
  memset(&in, 0, sizeof in);
  in.model = m, in.seed = 1, in.threads = 1, in.max_nodes = 50;
  pm_run_output out;
  memset(&out, 0, sizeof out);
  assert_int_equal(psys_method.run(&in, &p, &out, &e), PM_ERR_LIMIT);
  assert_null(out.mesh);
  assert_non_null(strstr(e.msg, "cap"));
  /* a given field far beyond the cap is refused before the first particle, naming the cap and
   * the count it would need (it used to split towards it for hours) */
  pm_sizing *tiny = NULL;
  PM_ASSERT_OK(pm_sizing_constant(1e-12, &tiny, &e), e);
  in.size = tiny, in.max_nodes = 0;
  assert_int_equal(psys_method.run(&in, &p, &out, &e), PM_ERR_LIMIT);
  assert_null(out.mesh);
  assert_non_null(strstr(e.msg, "psys: size 1e-12 needs about"));
  assert_non_null(strstr(e.msg, "; a size of at least "));
  pm_sizing_destroy(tiny);
  /* a size field that is not positive on the model */
  pm_sizing *bad = NULL;
  PM_ASSERT_OK(pm_sizing_parse("z", &bad, &e), e);
  in.size = bad, in.max_nodes = PM_DEFAULT_MAX_NODES;
  assert_int_equal(psys_method.run(&in, &p, &out, &e), PM_ERR_ARG);
  assert_null(out.mesh);
  assert_non_null(strstr(e.msg, "size"));
  pm_sizing_destroy(bad);
  /* the help table lists every parameter once with its source */
  char *buf = NULL;
  size_t len = 0;
  FILE *f = open_memstream(&buf, &len);
  pm_params_help(&psys_param_table, f);
  fclose(f);
  for (int k = 0; k < psys_param_table.n; ++k)
    assert_non_null(strstr(buf, psys_param_table.desc[k].name));
  assert_non_null(strstr(buf, "001 eq. 4"));
  free(buf);
  pm_model_destroy(m);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(uniform_size_calibration),
      cmocka_unit_test(graded_size_is_followed),
      cmocka_unit_test(curves_have_the_faces_spacing),
      cmocka_unit_test(inferred_field_as_sizing),
      cmocka_unit_test(errors),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
