/* Needles told forced or unforced (needles.h) on hand-built meshes of a planar strip, whose
 * width is set against the model's feature floor (PM_FEATURE_FLOOR x the diagonal). */
#include "test_rect_model.h"

#include <stdlib.h>

#include "common/geom/geom_analytic.h"
#include "common/input/input.h"
#include "common/mesh/mesh.h"
#include "common/measure/needles.h"

/* The rectangle [0, 1] x [0, w]: curve 0 the bottom (0,0)-(1,0), 1 the right side, 2 the top
 * (1,w)-(0,w), 3 the left side; vertex k starts curve k. */
static pm_model *strip(double w) { return pm_test_rect_model("strip", w); }

typedef struct node {
  double x, y;
  int dim;
  int32_t cell;
} node;

/* Three nodes of one face, classified against model m; returns the counts. */
static pm_needles classify_xyz(const pm_model *m, const double xyz[3][3], const int dim[3],
                               const int32_t cell[3], int32_t face) {
  pm_mesh *mesh = pm_mesh_create();
  pm_error e = {0};
  for (int k = 0; k < 3; ++k)
    PM_ASSERT_OK(pm_mesh_add_node(mesh, xyz[k], dim[k], cell[k], NULL, NULL, &e), e);
  PM_ASSERT_OK(pm_mesh_add_tri(mesh, 0, 1, 2, face, &e), e);
  pm_needles out;
  PM_ASSERT_OK(pm_needles_classify(mesh, m, PM_NEEDLE_DEG, &out, NULL, &e), e);
  pm_mesh_destroy(mesh);
  return out;
}

/* Classify the one triangle (a, b, c) of face 0. */
static pm_needles one_triangle(const pm_model *m, node a, node b, node c) {
  const node n[3] = {a, b, c};
  double xyz[3][3];
  int dim[3];
  int32_t cell[3];
  for (int k = 0; k < 3; ++k)
    xyz[k][0] = n[k].x, xyz[k][1] = n[k].y, xyz[k][2] = 0, dim[k] = n[k].dim, cell[k] = n[k].cell;
  return classify_xyz(m, (const double(*)[3])xyz, dim, cell, 0);
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

/* Nodes off the model: a hand-built mesh may put them anywhere, which stands for a CAD file whose
 * face does not reach its boundary curve (the curve 0.01 above the plane) or whose curve misses
 * its end vertex by 0.01 (robust/step__SampleCrankshaft4A.stp has both, at 0.13 and 0.146). */
static void gap_between_curve_and_face_forces(void **state) {
  (void)state;
  pm_model *m = strip(0.1);
  const double g = 0.01; /* 333 floors */
  /* A base of 0.001 on curve 0, lifted g off the plane, and a face node on the plane: every
   * corner on the plane is about g from the base, an angle of about 0.001 / g rad. */
  pm_mesh *mesh = pm_mesh_create();
  pm_error e = {0};
  const double xyz[3][3] = {{0.2, 0, g}, {0.201, 0, g}, {0.2005, 0.005, 0}};
  const int dim[3] = {PM_CURVE, PM_CURVE, PM_FACE};
  for (int k = 0; k < 3; ++k) {
    const double par[2] = {xyz[k][0], xyz[k][1]};
    PM_ASSERT_OK(pm_mesh_add_node(mesh, xyz[k], dim[k], 0, k < 2 ? &xyz[k][0] : par, NULL, &e), e);
  }
  PM_ASSERT_OK(pm_mesh_add_tri(mesh, 0, 1, 2, 0, &e), e);
  pm_needles out;
  PM_ASSERT_OK(pm_needles_classify(mesh, m, PM_NEEDLE_DEG, &out, NULL, &e), e);
  assert_int_equal(out.count, 1);
  assert_int_equal(out.feature, 1);
  assert_int_equal(out.unforced, 0);
  pm_mesh_destroy(mesh);
  /* The same triangle with the curve on the plane: the mesher's choice, unforced. */
  pm_needles n = one_triangle(m, (node){0.2, 0, PM_CURVE, 0}, (node){0.201, 0, PM_CURVE, 0},
                              (node){0.2005, 0.01, PM_FACE, 0});
  assert_int_equal(n.count, 1);
  assert_int_equal(n.unforced, 1);
  pm_model_destroy(m);
}

static void vertex_missed_by_its_curve_forces(void **state) {
  (void)state;
  pm_model *m = strip(0.1);
  /* Vertex 1 ends curve 0 at (1, 0); its node 0.01 above the curve's end. */
  const double xyz[3][3] = {{0.99, 0, 0}, {0.9905, 0, 0}, {1, 0, 0.01}};
  const int dim[3] = {PM_CURVE, PM_CURVE, PM_VERTEX};
  const int32_t cell[3] = {0, 0, 1};
  pm_needles out = classify_xyz(m, xyz, dim, cell, 0);
  assert_int_equal(out.count, 1);
  assert_int_equal(out.feature, 1);
  /* The vertex where the curve ends: a flat triangle along one curve, unforced. */
  pm_needles n = one_triangle(m, (node){0.99, 0, PM_CURVE, 0}, (node){0.9905, 0, PM_CURVE, 0},
                              (node){1, 0.0004, PM_VERTEX, 1});
  assert_int_equal(n.count, 1);
  assert_int_equal(n.unforced, 1);
  pm_model_destroy(m);
}

/* robust/step__SampleCrankshaft4A.stp, from the shared models (the caller skips without them). */
static pm_model *open_crankshaft(void) {
  char path[512];
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(
      pm_input_open(pm_test_cad("robust/step__SampleCrankshaft4A.stp", path, sizeof path), &m,
                    NULL, &e),
      e);
  return m;
}

/* robust/step__SampleCrankshaft4A.stp: curves 13 and 337 (gmsh tags 14, 338) end 0.056 from
 * their vertex 11, where curve 10 ends too. bubble's triangle between curve 13's last two nodes
 * and curve 10's last node has 9.9 degrees and lies within twice the gap of the vertex: forced.
 * The same triangle moved 0.2 along the curves, away from the gap: unforced. */
static void triangle_across_a_vertex_gap_forces(void **state) {
  (void)state;
  if (!pm_test_have_cad()) skip();
  pm_model *m = open_crankshaft();
  const int dim[3] = {PM_CURVE, PM_CURVE, PM_CURVE};
  const int32_t cell[3] = {13, 10, 13};
  const double at_gap[3][3] = {{55.889256, -9.867038, 105.120647},
                               {55.870766, -9.824087, 105.160192},
                               {55.888002, -9.874434, 105.128290}};
  pm_needles n = classify_xyz(m, at_gap, dim, cell, 2);
  assert_int_equal(n.count, 1);
  assert_int_equal(n.feature, 1);
  assert_int_equal(n.unforced, 0);
  /* Curve 13's nodes 0.35 and 0.36 from its end, the corner on curve 10 0.36 from the vertex. */
  const double away[3][3] = {{55.809560, -10.335880, 105.574879},
                             {55.528107, -9.781079, 105.160192},
                             {55.811171, -10.326434, 105.566431}};
  n = classify_xyz(m, away, dim, cell, 2);
  assert_int_equal(n.count, 1);
  assert_int_equal(n.unforced, 1);
  pm_model_destroy(m);
}

/* The same file: curves 34 and 323 both end 0.11 from their vertex 33. psys's triangle on face
 * 112 of the vertex and the two curves' nodes nearest it (0.019 apart) has 7.3 degrees at the
 * vertex and spans the jump between the curves' ends and the vertex: forced. The same triangle
 * scaled three times about the vertex, its far corners beyond twice the gap: unforced. */
static void triangle_from_a_missed_vertex_forces(void **state) {
  (void)state;
  if (!pm_test_have_cad()) skip();
  pm_model *m = open_crankshaft();
  const int dim[3] = {PM_VERTEX, PM_CURVE, PM_CURVE};
  const int32_t cell[3] = {33, 323, 34};
  double at_gap[3][3] = {{-45.1636375577012, -8.480225269930195, 91.68980790979668},
                         {-45.08302268067044, -8.563184447111944, 91.77833461105746},
                         {-45.08331299333096, -8.57654093747308, 91.76533042982825}};
  pm_needles n = classify_xyz(m, (const double(*)[3])at_gap, dim, cell, 112);
  assert_int_equal(n.count, 1);
  assert_int_equal(n.feature, 1);
  assert_int_equal(n.unforced, 0);
  for (int k = 1; k < 3; ++k)
    for (int i = 0; i < 3; ++i) at_gap[k][i] = at_gap[0][i] + 3 * (at_gap[k][i] - at_gap[0][i]);
  n = classify_xyz(m, (const double(*)[3])at_gap, dim, cell, 112);
  assert_int_equal(n.count, 1);
  assert_int_equal(n.unforced, 1);
  pm_model_destroy(m);
}

/* robust/step__U_Joint_2.stp: face 38 is a lens between curves 152 and 154, which leave vertex
 * 124 tangent to each other (0.19 degrees apart 0.27 from it); the vertex is the image of a side
 * of the face's (u, v) box that collapses to a point (|Sv| = 7e-17 there). bubble's triangle on
 * vertex 124 and two nodes of curve 154 (0.08 degrees at the vertex) lies in that corner, its
 * bisector 1e-5 radians outside the curve's chord: forced. Read with the normal at the vertex,
 * the corner came out as the 359.8-degree complement, and by the bisector alone the triangle
 * outside the lens. */
static void triangle_in_a_cusp_at_a_pole_forces(void **state) {
  (void)state;
  if (!pm_test_have_cad()) skip();
  char path[512];
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_input_open(pm_test_cad("robust/step__U_Joint_2.stp", path, sizeof path), &m,
                             NULL, &e),
               e);
  const int dim[3] = {PM_CURVE, PM_CURVE, PM_VERTEX};
  const int32_t cell[3] = {154, 154, 124};
  const double fan[3][3] = {{-0.2526697708152376, 15.87298796672555, 0.0003892167476541254},
                            {-0.297299206297451, 15.87221406508532, 0.0005389879927463097},
                            {9.720312933465121e-16, 15.875, 0}};
  pm_needles n = classify_xyz(m, fan, dim, cell, 38);
  assert_int_equal(n.count, 1);
  assert_int_equal(n.corner, 1);
  assert_int_equal(n.unforced, 0);
  pm_model_destroy(m);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(strip_below_the_floor_forces),
      cmocka_unit_test(strip_above_the_floor_does_not),
      cmocka_unit_test(flat_along_one_curve_does_not),
      cmocka_unit_test(gap_between_curve_and_face_forces),
      cmocka_unit_test(vertex_missed_by_its_curve_forces),
      cmocka_unit_test(triangle_across_a_vertex_gap_forces),
      cmocka_unit_test(triangle_from_a_missed_vertex_forces),
      cmocka_unit_test(triangle_in_a_cusp_at_a_pole_forces),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
