/* Needles told forced or unforced (needles.h) on hand-built meshes of a planar strip, whose
 * width is set against the model's feature floor (PM_FEATURE_FLOOR x the diagonal). */
#include "test_support.h"

#include <stdlib.h>

#include "common/geom/geom_analytic.h"
#include "common/mesh/mesh.h"
#include "common/measure/needles.h"

/* The rectangle [0, 1] x [0, w]: curve 0 the bottom (0,0)-(1,0), 1 the right side, 2 the top
 * (1,w)-(0,w), 3 the left side; vertex k starts curve k. */
static pm_model *strip(double w) {
  pm_planar_piece p[4] = {{PM_PIECE_LINE, {0, 0}, {0, 0}, 0},
                          {PM_PIECE_LINE, {1, 0}, {0, 0}, 0},
                          {PM_PIECE_LINE, {1, w}, {0, 0}, 0},
                          {PM_PIECE_LINE, {0, w}, {0, 0}, 0}};
  pm_planar_loop loop = {4, p};
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_planar_model("strip", 1, &loop, &m, &e), e);
  return m;
}

typedef struct node {
  double x, y;
  int dim;
  int32_t cell;
} node;

/* Classify the one triangle (a, b, c) of face 0. */
static pm_needles one_triangle(const pm_model *m, node a, node b, node c) {
  pm_mesh *mesh = pm_mesh_create();
  pm_error e = {0};
  const node n[3] = {a, b, c};
  for (int k = 0; k < 3; ++k) {
    double xyz[3] = {n[k].x, n[k].y, 0};
    PM_ASSERT_OK(pm_mesh_add_node(mesh, xyz, n[k].dim, n[k].cell, NULL, NULL, &e), e);
  }
  PM_ASSERT_OK(pm_mesh_add_tri(mesh, 0, 1, 2, 0, &e), e);
  pm_needles out;
  PM_ASSERT_OK(pm_needles_classify(mesh, m, PM_NEEDLE_DEG, &out, NULL, &e), e);
  pm_mesh_destroy(mesh);
  return out;
}

/* Two nodes on the bottom, one on the top between them, 0.05 from each: every edge is far
 * longer than the floor, the height across the strip is its width. */
static void strip_below_the_floor_forces(void **state) {
  (void)state;
  double w = 2e-5; /* the floor is 3e-5 x the diagonal (1.0000000002) */
  pm_model *m = strip(w);
  pm_needles n = one_triangle(m, (node){0.2, 0, PM_CURVE, 0}, (node){0.3, 0, PM_CURVE, 0},
                              (node){0.25, w, PM_CURVE, 2});
  assert_int_equal(n.count, 1);
  assert_int_equal(n.feature, 1);
  assert_int_equal(n.unforced, 0);
  /* A vertex across the strip counts the same way. */
  n = one_triangle(m, (node){0.99, 0, PM_CURVE, 0}, (node){1, w, PM_VERTEX, 2},
                   (node){0.95, w, PM_CURVE, 2});
  assert_int_equal(n.feature + n.corner, 1);
  pm_model_destroy(m);
}

static void strip_above_the_floor_does_not(void **state) {
  (void)state;
  double w = 1e-3; /* 33 floors: a finer spacing resolves it */
  pm_model *m = strip(w);
  pm_needles n = one_triangle(m, (node){0.2, 0, PM_CURVE, 0}, (node){0.3, 0, PM_CURVE, 0},
                              (node){0.25, w, PM_CURVE, 2});
  assert_int_equal(n.count, 1);
  assert_int_equal(n.unforced, 1);
  assert_int_equal(n.first_unforced, 0);
  pm_model_destroy(m);
}

/* Three nodes along one curve and its end vertex: a flat triangle the mesher made, not the
 * geometry, however thin. */
static void flat_along_one_curve_does_not(void **state) {
  (void)state;
  pm_model *m = strip(2e-5);
  pm_needles n = one_triangle(m, (node){0.2, 0, PM_CURVE, 0}, (node){1, 0, PM_VERTEX, 1},
                              (node){0.6, 1e-6, PM_CURVE, 0});
  assert_int_equal(n.count, 1);
  assert_int_equal(n.unforced, 1);
  /* A face node: the strip has room for it only if it is wider than the node's triangle. */
  n = one_triangle(m, (node){0.2, 0, PM_CURVE, 0}, (node){0.3, 0, PM_CURVE, 0},
                   (node){0.25, 1e-5, PM_FACE, 0});
  assert_int_equal(n.unforced, 1);
  pm_model_destroy(m);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(strip_below_the_floor_forces),
      cmocka_unit_test(strip_above_the_floor_does_not),
      cmocka_unit_test(flat_along_one_curve_does_not),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
