/* One shared CAD model (argv[1]) meshed by psys with the default parameters and the inferred
 * field (papers/001), as `packmesh mesh FILE --method psys --volume` does: the surface mesh and,
 * for solids, the tets of TetGen's quality refinement (section 4.4) must pass pm_mesh_check,
 * every face must get triangles, and the triangles must stay near-equilateral in the median (the
 * statistic of 001 Fig. 11, R / l_min, 0.577 for an equilateral triangle). One ctest entry per
 * model (long: minutes in all). */
#include "test_psys_util.h"

#include "common/input/input.h"
#include "common/mesh/mesh_check.h"
#include "common/measure/quality.h"

static const char *path;

static void cad_model(void **state) {
  (void)state;
  if (!pm_test_have_cad()) skip();
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_input_open(path, &m, NULL, &e), e);
  psys_params p;
  psys_params_init(&p);
  pm_run_input in;
  memset(&in, 0, sizeof in);
  in.model = m, in.seed = 1, in.threads = 2, in.volume = m->count[PM_VOLUME] > 0;
  in.max_nodes = PM_DEFAULT_MAX_NODES;
  pm_run_output out;
  memset(&out, 0, sizeof out);
  PM_ASSERT_OK(psys_method.run(&in, &p, &out, &e), e);
  pm_check_report r;
  memset(&r, 0, sizeof r);
  PM_ASSERT_OK(pm_mesh_check(out.mesh, m, &r, &e), e);
  for (int i = 0; i < r.nproblem; ++i) print_error("problem: %s\n", r.problem[i]);
  assert_true(r.valid);
  pm_check_report_clear(&r);
  /* every face has triangles (a face without any would be a hole the checker's shells of a
   * surface model need not see) */
  uint8_t *has = calloc((size_t)m->count[PM_FACE] + 1, 1);
  for (int32_t t = 0; t < out.mesh->ntri; ++t) {
    int32_t f = out.mesh->tri_cell[t];
    if (f >= 0 && f < m->count[PM_FACE]) has[f] = 1;
  }
  for (int32_t f = 0; f < m->count[PM_FACE]; ++f)
    if (!has[f]) fail_msg("face %d has no triangle", pm_model_cell(m, PM_FACE, f)->tag);
  free(has);
  if (in.volume) assert_true(out.mesh->ntet > 0);
  pm_quality q;
  PM_ASSERT_OK(pm_quality_compute(out.mesh, NULL, &q, &e), e);
  const pm_summary a = q.tri.s_aspect_ratio;
  print_message("%s: %d nodes, %d triangles, %d tets, tri R/l_min %.3f/%.3f/%.3f/%.3f/%.3g, %s\n",
                path, (int)out.mesh->nnode, (int)out.mesh->ntri, (int)out.mesh->ntet, a.min, a.p25,
                a.median, a.p75, a.max, out.stop_reason);
  /* A loose bound, well above the benchmark's target (median 0.60, p75 0.65): it catches a
   * broken packing or connection, not a model that misses the target by a little. It holds on
   * slender_face.brep too, a 9.9 x 0.001 strip ten times narrower than sigma_min = diagonal /
   * 1000 (eq. 12), because feature_width lets sigma follow the strip's width (with the paper's
   * field, feature_width=0, its triangles span the strip: median 5.1). */
  assert_true(a.median < 0.70);
  assert_true(a.p75 < 0.80);
  pm_quality_clear(&q);
  pm_mesh_destroy(out.mesh);
  pm_model_destroy(m);
}

int main(int argc, char **argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: test_psys_cad_long MODEL\n");
    return 2;
  }
  path = argv[1];
  const struct CMUnitTest tests[] = {cmocka_unit_test(cad_model)};
  return cmocka_run_group_tests(tests, NULL, NULL);
}
