/* The mesh container: growth, classification storage, copy, clear. */
#include "test_support.h"

#include <string.h>

#include "common/mesh/mesh.h"

static void add_and_grow(void **state) {
  (void)state;
  pm_mesh *m = pm_mesh_create();
  assert_non_null(m);
  pm_error e = {0};
  const int32_t N = 100000;
  for (int32_t i = 0; i < N; ++i) {
    double p[3] = {i, 2.0 * i, -i}, par[2] = {0.5 * i, 0.25 * i};
    int32_t id = -1;
    PM_ASSERT_OK(pm_mesh_add_node(m, p, i % 4, i / 4, par, &id, &e), e);
    assert_int_equal(id, i);
  }
  assert_int_equal(m->nnode, N);
  assert_true(m->cap_node >= N);
  /* Geometric growth: far fewer reallocations than nodes, capacity within 1.5x + 16. */
  assert_true(m->cap_node <= N + N / 2 + 16);
  for (int32_t i = 0; i < N; i += 997) {
    assert_true(m->xyz[3 * i] == i && m->xyz[3 * i + 1] == 2.0 * i && m->xyz[3 * i + 2] == -i);
    assert_int_equal(m->node_dim[i], i % 4);
    assert_int_equal(m->node_cell[i], i / 4);
    /* Parameters are kept for curves (1) and faces (2) only. */
    double u = (i % 4 == 1 || i % 4 == 2) ? 0.5 * i : 0.0;
    double v = (i % 4 == 2) ? 0.25 * i : 0.0;
    assert_true(m->node_par[2 * i] == u && m->node_par[2 * i + 1] == v);
  }
  for (int32_t i = 0; i + 3 < 1000; ++i) {
    PM_ASSERT_OK(pm_mesh_add_seg(m, i, i + 1, 7, &e), e);
    PM_ASSERT_OK(pm_mesh_add_tri(m, i, i + 1, i + 2, 8, &e), e);
    PM_ASSERT_OK(pm_mesh_add_tet(m, i, i + 1, i + 2, i + 3, 9, &e), e);
  }
  assert_int_equal(m->nseg, 997);
  assert_int_equal(m->ntri, 997);
  assert_int_equal(m->ntet, 997);
  assert_int_equal(m->tet[4 * 996 + 3], 999);
  assert_int_equal(m->tri_cell[500], 8);

  pm_mesh *c = pm_mesh_copy(m);
  assert_non_null(c);
  assert_int_equal(c->nnode, N);
  assert_int_equal(c->ntet, 997);
  assert_memory_equal(c->xyz, m->xyz, 3 * (size_t)N * sizeof(double));
  assert_memory_equal(c->node_par, m->node_par, 2 * (size_t)N * sizeof(double));
  assert_memory_equal(c->tet, m->tet, 4 * 997 * sizeof(int32_t));
  assert_memory_equal(c->seg_cell, m->seg_cell, 997 * sizeof(int32_t));
  /* The copy is deep. */
  c->xyz[0] = 42;
  assert_true(m->xyz[0] == 0);

  int32_t cap = m->cap_node;
  pm_mesh_clear(m);
  assert_int_equal(m->nnode, 0);
  assert_int_equal(m->ntri, 0);
  assert_int_equal(m->cap_node, cap);
  double p[3] = {1, 2, 3};
  PM_ASSERT_OK(pm_mesh_add_node(m, p, -1, -1, NULL, NULL, &e), e);
  assert_int_equal(m->nnode, 1);
  assert_int_equal(m->node_dim[0], -1);
  pm_mesh_destroy(m);
  pm_mesh_destroy(c);
  pm_mesh_destroy(NULL);
}

static void reserve_and_empty_copy(void **state) {
  (void)state;
  pm_mesh *m = pm_mesh_create();
  pm_error e = {0};
  PM_ASSERT_OK(pm_mesh_reserve(m, 10, 20, 30, 40, &e), e);
  assert_true(m->cap_node >= 10 && m->cap_seg >= 20 && m->cap_tri >= 30 && m->cap_tet >= 40);
  assert_int_equal(m->nnode, 0);
  assert_int_equal(pm_mesh_reserve(m, -1, 0, 0, 0, &e), PM_ERR_ARG);
  pm_mesh *c = pm_mesh_copy(m);
  assert_non_null(c);
  assert_int_equal(c->nnode + c->nseg + c->ntri + c->ntet, 0);
  pm_mesh_destroy(c);
  pm_mesh_destroy(m);
  pm_mesh *z = pm_mesh_create();
  pm_mesh *zc = pm_mesh_copy(z);
  assert_non_null(zc);
  pm_mesh_destroy(z);
  pm_mesh_destroy(zc);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(add_and_grow),
      cmocka_unit_test(reserve_and_empty_copy),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
