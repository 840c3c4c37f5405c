/* Classification of untagged meshes (classify.h): a mesh packmesh made, stripped of every node
 * and element cell as a .stl or .vtk reader leaves it, is classified back to exactly the cells
 * it had -- vertices, curves, faces, the volume -- with its elements; nodes off the model are
 * counted, not forced onto it; a classified mesh is left alone. */
#include "test_support.h"

#include <stdlib.h>
#include <string.h>

#include "common/measure/classify.h"
#include "common/mesh/mesh.h"

/* bubble's mesh of case:boxhole with tets (a solid with a cylindrical hole: seams, circles). */
static pm_mesh *boxhole_mesh(pm_model **model) {
  pm_sizing *size = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_model_open("case:boxhole", model, &size, &e), e);
  pm_generate_options o;
  pm_generate_options_init(&o);
  o.volume = 1;
  pm_mesh *m = NULL;
  PM_ASSERT_OK(pm_generate(*model, size, pm_method_find("bubble"), NULL, &o, &m, NULL, &e), e);
  pm_sizing_destroy(size);
  return m;
}

/* What a reader of a format without tags gives: no node cell, and elements tagged with a
 * file's own number (here 0 for all), which names no model cell. */
static void strip(pm_mesh *m) {
  for (int32_t v = 0; v < m->nnode; ++v) {
    m->node_dim[v] = -1;
    m->node_cell[v] = -1;
    m->node_par[2 * v] = m->node_par[2 * v + 1] = 0;
  }
  memset(m->seg_cell, 0, (size_t)m->nseg * sizeof *m->seg_cell);
  memset(m->tri_cell, 0, (size_t)m->ntri * sizeof *m->tri_cell);
  memset(m->tet_cell, 0xff, (size_t)m->ntet * sizeof *m->tet_cell);
}

static void back_to_the_cells_it_had(void **state) {
  (void)state;
  pm_model *model = NULL;
  pm_mesh *m = boxhole_mesh(&model);
  int32_t n = m->nnode;
  int8_t *dim = malloc((size_t)n);
  int32_t *cell = malloc((size_t)n * sizeof *cell);
  int32_t *tri = malloc((size_t)m->ntri * sizeof *tri), *seg = malloc((size_t)m->nseg * sizeof *seg);
  memcpy(dim, m->node_dim, (size_t)n);
  memcpy(cell, m->node_cell, (size_t)n * sizeof *cell);
  memcpy(tri, m->tri_cell, (size_t)m->ntri * sizeof *tri);
  memcpy(seg, m->seg_cell, (size_t)m->nseg * sizeof *seg);
  int by_dim[4] = {0};
  for (int32_t v = 0; v < n; ++v) by_dim[dim[v]]++;
  assert_true(by_dim[0] > 0 && by_dim[1] > 0 && by_dim[2] > 0 && by_dim[3] > 0);

  strip(m);
  pm_classify_counts c;
  pm_error e = {0};
  PM_ASSERT_OK(pm_classify_mesh(m, model, &c, &e), e);
  assert_int_equal(c.nodes, n);
  assert_int_equal(c.unmatched, 0);
  assert_int_equal(c.elements, m->nseg + m->ntri + m->ntet);
  for (int d = 0; d < 4; ++d) assert_int_equal(c.by_dim[d], by_dim[d]);
  for (int32_t v = 0; v < n; ++v) {
    if (m->node_dim[v] != dim[v] || m->node_cell[v] != cell[v])
      fail_msg("node %d: classified %d/%d, made on %d/%d", (int)v, m->node_dim[v],
               (int)m->node_cell[v], dim[v], (int)cell[v]);
  }
  for (int32_t t = 0; t < m->ntri; ++t) assert_int_equal(m->tri_cell[t], tri[t]);
  for (int32_t s = 0; s < m->nseg; ++s) assert_int_equal(m->seg_cell[s], seg[s]);
  for (int32_t t = 0; t < m->ntet; ++t) assert_int_equal(m->tet_cell[t], 0);
  /* The parameters put a curve node back where it is. */
  for (int32_t v = 0; v < n; ++v)
    if (m->node_dim[v] == PM_CURVE) {
      pm_curve_point p;
      const pm_cell *cv = &model->cells[PM_CURVE][m->node_cell[v]];
      cv->cls->curve_eval(cv, m->node_par[2 * v], 0, &p);
      for (int k = 0; k < 3; ++k) PM_ASSERT_NEAR(p.p[k], m->xyz[3 * v + k], 1e-7);
    }

  /* Classified already: nothing changes. */
  PM_ASSERT_OK(pm_classify_mesh(m, model, &c, &e), e);
  assert_int_equal(c.nodes, 0);
  assert_int_equal(c.elements, 0);

  free(dim);
  free(cell);
  free(tri);
  free(seg);
  pm_mesh_destroy(m);
  pm_model_destroy(model);
}

/* A triangle node moved off the model by 1% of the diagonal is unmatched and stays at -1; the
 * rest are classified. */
static void off_the_model(void **state) {
  (void)state;
  pm_model *model = NULL;
  pm_mesh *m = boxhole_mesh(&model);
  strip(m);
  int32_t moved = -1;
  for (int32_t v = 0; v < m->nnode && moved < 0; ++v)
    if (m->xyz[3 * v + 2] > 0.29) moved = v; /* a node of the top face z = 0.3 */
  assert_true(moved >= 0);
  m->xyz[3 * moved + 2] += 0.01 * model->diagonal;
  pm_classify_counts c;
  pm_error e = {0};
  PM_ASSERT_OK(pm_classify_mesh(m, model, &c, &e), e);
  assert_int_equal(c.unmatched, 1);
  assert_int_equal(m->node_dim[moved], -1);
  assert_int_equal(c.nodes, m->nnode - 1);
  pm_mesh_destroy(m);
  pm_model_destroy(model);
}

static void refusals(void **state) {
  (void)state;
  pm_model *model = NULL;
  pm_mesh *m = boxhole_mesh(&model);
  pm_error e = {0};
  assert_int_equal(pm_classify_mesh(m, NULL, NULL, &e), PM_ERR_ARG);
  strip(m);
  m->tri[5] = m->nnode; /* a node that does not exist */
  assert_int_equal(pm_classify_mesh(m, model, NULL, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "triangle 1"));
  pm_mesh_destroy(m);
  pm_model_destroy(model);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(back_to_the_cells_it_had),
      cmocka_unit_test(off_the_model),
      cmocka_unit_test(refusals),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
