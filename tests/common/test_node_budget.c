/* The node count a size field needs (node_budget.h): the surface estimate against the area of a
 * rectangle, the volume estimate against the volume of a ball, the early stop, and the checks
 * that refuse a field beyond a cap with one line naming the cap and the count. */
#include "test_rect_model.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/input/input.h"
#include "common/sizing/node_budget.h"
#include "peers/peers.h"

/* case:qi1 is the rectangle [-1,1] x [-2,2] (area 8): at d = 0.1 the lattice of equilateral
 * triangles has 8 / (sqrt(3)/2 0.01) = 923.76 nodes. The face's parameter box is the rectangle,
 * so the midpoint rule of a constant field is exact. */
static void surface_estimate(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_sizing *d = NULL, *bad = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_input_open("case:qi1", &m, NULL, &e), e);
  PM_ASSERT_OK(pm_sizing_constant(0.1, &d, &e), e);
  double est = 0;
  PM_ASSERT_OK(pm_node_estimate_surface(m, d, INFINITY, &est, &e), e);
  PM_ASSERT_NEAR(est, 8 / (sqrt(3.0) / 2 * 0.01), 1e-9);
  /* It stops once the sum passes `stop`: one top cell is 923.76 / 256 nodes. */
  PM_ASSERT_OK(pm_node_estimate_surface(m, d, 100, &est, &e), e);
  assert_true(est > 100 && est < 100 + 923.77 / 256);

  /* Within 1.5 x the cap: passes (the method's own count decides); beyond: refused at once. */
  PM_ASSERT_OK(pm_node_budget_check(m, d, 1000, "node cap", "m", &e), e);
  PM_ASSERT_OK(pm_node_budget_check(m, d, 616, "node cap", "m", &e), e);
  assert_int_equal(pm_node_budget_check(m, d, 615, "node cap", "m", &e), PM_ERR_LIMIT);
  assert_string_equal(e.msg,
                      "m: the size field would need about 924 surface nodes, over the node cap 615");
  assert_int_equal(pm_node_budget_check(m, d, 10, "cap max_bubbles", "bubble", &e), PM_ERR_LIMIT);
  assert_string_equal(
      e.msg, "bubble: the size field would need about 924 surface nodes, over the cap max_bubbles 10");
  PM_ASSERT_OK(pm_node_budget_check(m, d, 0, "node cap", "m", &e), e); /* no cap */
  /* A field that is not > 0 inside the face: named with the point. */
  PM_ASSERT_OK(pm_sizing_expression("x - 5", &bad, &e), e);
  assert_int_equal(pm_node_budget_check(m, bad, 1000, "node cap", "m", &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "m: the size field is"));
  assert_non_null(strstr(e.msg, "not > 0"));
  assert_null(strchr(e.msg, '\n'));
  pm_sizing_destroy(bad);
  pm_sizing_destroy(d);
  pm_model_destroy(m);
}

/* A sliver face, 1 long and 1e-6 wide, at d = 1e-4: cells are split along the sides longer
 * than d only, 2^10 pieces per top cell along the face; splitting both sides would make 4^10
 * (a quarter of a billion evaluations: minutes, as slender_face.brep took). The estimate is
 * the area over the lattice's area per node. */
static void sliver_estimate(void **state) {
  (void)state;
  pm_model *m = pm_test_rect_model("sliver", 1e-6);
  pm_sizing *d = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_sizing_constant(1e-4, &d, &e), e);
  double est = 0;
  PM_ASSERT_OK(pm_node_estimate_surface(m, d, INFINITY, &est, &e), e);
  PM_ASSERT_NEAR(est, 1e-6 / (sqrt(3.0) / 2 * 1e-8), 1e-6 * est);
  pm_sizing_destroy(d);
  pm_model_destroy(m);
}

/* case:sphere is the unit ball: with gmsh's surface mesh at d = 0.1 (a polyhedron within 0.2%
 * of the ball's volume), the volume estimate at d = 0.1 is (4/3 pi) / (0.001 / sqrt(2)) = 5924
 * nodes, up to the cells' centres deciding what is inside. */
static void volume_estimate(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_sizing *d = NULL, *shell = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_input_open("case:sphere", &m, NULL, &e), e);
  PM_ASSERT_OK(pm_sizing_constant(0.1, &d, &e), e);
  pm_run_input in;
  memset(&in, 0, sizeof in);
  in.model = m, in.size = d, in.seed = 1, in.threads = 1, in.max_nodes = 100000;
  pm_run_output out;
  memset(&out, 0, sizeof out);
  peer_gmsh_params gp;
  peer_gmsh_params_init(&gp);
  PM_ASSERT_OK(peer_gmsh_frontal.run(&in, &gp, &out, &e), e);
  pm_mesh *surface = out.mesh;
  assert_int_equal(surface->ntet, 0);
  double est = 0, want = 4.0 / 3.0 * M_PI / (1e-3 / sqrt(2.0));
  PM_ASSERT_OK(pm_node_estimate_volume(m, surface, d, INFINITY, &est, &e), e);
  if (fabs(est / want - 1) > 0.03) fail_msg("volume estimate %g, want %g within 3%%", est, want);

  /* A field fine on the sphere (0.5 at r = 1) and far too fine inside (1e-5 at r = 0.5): the
   * surface check passes it, the volume check refuses it. */
  PM_ASSERT_OK(pm_sizing_expression("max(1e-5, abs(r - 0.5))", &shell, &e), e);
  PM_ASSERT_OK(pm_node_budget_check(m, shell, PM_DEFAULT_MAX_NODES, "node cap", "m", &e), e);
  assert_int_equal(pm_node_budget_check_volume(m, surface, shell, PM_DEFAULT_MAX_NODES,
                                               "node cap", "m", &e),
                   PM_ERR_LIMIT);
  assert_non_null(strstr(e.msg, "m: the size field would need more than 3e+07 nodes with the "
                                "volumes"));
  assert_non_null(strstr(e.msg, "over the node cap 20000000"));
  /* The surface's own nodes count: a cap below them is refused whatever the volumes need. */
  assert_int_equal(pm_node_budget_check_volume(m, surface, d, surface->nnode / 2, "node cap",
                                               "m", &e),
                   PM_ERR_LIMIT);
  char on[64];
  snprintf(on, sizeof on, "(%d on the surface mesh)", (int)surface->nnode);
  assert_non_null(strstr(e.msg, on));
  PM_ASSERT_OK(pm_node_budget_check_volume(m, surface, d, 100000, "node cap", "m", &e), e);

  /* gmsh's 3D mesher is not started on such a field. */
  pm_mesh_destroy(surface);
  in.size = shell, in.volume = 1, in.max_nodes = PM_DEFAULT_MAX_NODES;
  memset(&out, 0, sizeof out);
  assert_int_equal(peer_gmsh_frontal.run(&in, &gp, &out, &e), PM_ERR_LIMIT);
  assert_null(out.mesh);
  assert_non_null(strstr(e.msg, "gmsh-frontal: the size field would need more than"));
  pm_sizing_destroy(shell);
  pm_sizing_destroy(d);
  pm_model_destroy(m);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(surface_estimate),
      cmocka_unit_test(sliver_estimate),
      cmocka_unit_test(volume_estimate),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
