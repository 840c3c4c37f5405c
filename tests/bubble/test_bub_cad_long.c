/* One shared CAD model (argv[1]) meshed by the bubble method with its default size rule, as
 * `packmesh mesh FILE --method bubble` does: the mesh must pass pm_mesh_check, have triangles on
 * every face, and keep nearly all triangles at min angle >= 30 degrees except where the model has
 * slivers of its own. One ctest entry per model (long: minutes in all). */
#include "bub_test_util.h"

#include "common/geom/geom_cad.h"
#include "common/mesh/mesh_check.h"
#include "common/measure/quality.h"

static const char *path;

static void cad_model(void **state) {
  (void)state;
  if (!pm_test_have_cad()) skip();
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_cad_load(path, &m, &e), e);
  bub_params p;
  bub_params_init(&p);
  pm_run_input in = {m, NULL, 1, 2, 0, PM_DEFAULT_MAX_NODES, NULL};
  pm_run_output out;
  memset(&out, 0, sizeof out);
  PM_ASSERT_OK(bub_run(&in, &p, &out, &e), e);
  pm_check_report r;
  memset(&r, 0, sizeof r);
  PM_ASSERT_OK(pm_mesh_check(out.mesh, m, &r, &e), e);
  for (int i = 0; i < r.nproblem; ++i) print_error("problem: %s\n", r.problem[i]);
  assert_true(r.valid);
  pm_check_report_clear(&r);
  pm_quality q;
  PM_ASSERT_OK(pm_quality_compute(out.mesh, NULL, &q, &e), e);
  int64_t over30 = q.tri_min_angle_bins[3] + q.tri_min_angle_bins[4] + q.tri_min_angle_bins[5];
  double share = (double)over30 / (double)q.tri.n;
  print_message("%s: %d nodes, %d triangles, radius ratio %.4f, %.1f%% >= 30 degrees, %s\n", path,
                (int)out.mesh->nnode, (int)out.mesh->ntri, q.tri.s_radius_ratio.mean, 100 * share,
                out.stop_reason);
  assert_true(share > 0.9);
  assert_true(q.tri.s_radius_ratio.mean > 0.9);
  pm_quality_clear(&q);
  pm_mesh_destroy(out.mesh);
  pm_model_destroy(m);
}

int main(int argc, char **argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: test_bub_cad_long MODEL\n");
    return 2;
  }
  path = argv[1];
  const struct CMUnitTest tests[] = {cmocka_unit_test(cad_model)};
  return cmocka_run_group_tests(tests, NULL, NULL);
}
