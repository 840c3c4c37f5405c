/* The CGAL Mesh_2 peer through the pm_method interface: node counts, size conformity and the
 * shape bound on the planar cases; Lloyd and ODT smoothing; holes and arcs (boundary nodes on
 * the curves, the domain's area covered); determinism; refusal of non-planar models; bad
 * parameters, fields and caps. */
#include "peer_test_util.h"

#include "common/report/run_report.h"
#include "common/geom/geom_analytic.h"
#include "common/geom/geom_cad.h"
#include "common/backends/gmsh_session.h"
#include "common/report/stats.h"

static int teardown(void **state) {
  (void)state;
  pm_gmsh_shutdown();
  return 0;
}

static double mesh_area(const pm_mesh *m) {
  double area = 0;
  for (int32_t t = 0; t < m->ntri; ++t) {
    const double *a = &m->xyz[3 * m->tri[3 * t]], *b = &m->xyz[3 * m->tri[3 * t + 1]],
                 *c = &m->xyz[3 * m->tri[3 * t + 2]];
    double a2 = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    assert_true(a2 > 0);
    area += 0.5 * a2;
  }
  return area;
}

/* Every node classified on a curve lies on it (parameters and position agree). */
static void expect_on_curves(const pm_mesh *m, const pm_model *md) {
  for (int32_t i = 0; i < m->nnode; ++i) {
    if (m->node_dim[i] != PM_CURVE) continue;
    double p[3];
    pm_cell_point(&md->cells[PM_CURVE][m->node_cell[i]], &m->node_par[2 * i], p);
    assert_true(sqrt(pm_test_d2(p, &m->xyz[3 * i])) < 1e-12);
  }
}

static void summary(const pm_mesh *m, const pm_sizing *sz, pm_quality *q) {
  pm_error e = {0};
  PM_ASSERT_OK(pm_quality_compute(m, sz, q, &e), e);
}

/* qi1, d = 0.1: within 15% of the lattice count, mean edge length within 10% of d, and CGAL's
 * shape bound B = 0.125 respected (no angle below 20.7 degrees: the domain has no small input
 * angle). qi3's graded field: mean l/d within 15%. */
static void uniform_and_graded(void **state) {
  (void)state;
  static const char *const names[2] = {"qi1", "qi3"};
  for (int c = 0; c < 2; ++c) {
    pm_model *md = NULL;
    pm_sizing *sz = NULL;
    peer_test_case(names[c], &md, &sz);
    pm_mesh *m = NULL;
    pm_error e = {0};
    PM_ASSERT_OK(peer_test_run(&peer_cgal, md, sz, 0, NULL, &m, &e), e);
    peer_test_expect_valid(m, md);
    expect_on_curves(m, md);
    pm_quality q;
    summary(m, sz, &q);
    print_message("cgal %s: %d nodes, l/d %.3f, min angle %.2f, rr %.3f\n", names[c], m->nnode,
                  q.tri.size_ratio.mean, q.tri.s_min_angle.min, q.tri.s_radius_ratio.mean);
    if (c == 0) {
      PM_ASSERT_NEAR(m->nnode / peer_test_expected_nodes(8, 12, 0.1), 1, 0.15);
      PM_ASSERT_NEAR(q.tri.size_ratio.mean, 1, 0.10);
      PM_ASSERT_NEAR(mesh_area(m), 8, 1e-9);
    } else {
      PM_ASSERT_NEAR(q.tri.size_ratio.mean, 1, 0.15);
      PM_ASSERT_NEAR(mesh_area(m), 36, 1e-9);
    }
    assert_true(q.tri.s_min_angle.min > asin(sqrt(0.125)) * 180 / M_PI - 1e-9);
    pm_quality_clear(&q);
    pm_mesh_destroy(m);
    pm_sizing_destroy(sz);
    pm_model_destroy(md);
  }
}

/* Lloyd and ODT smoothing move interior nodes only and raise the mean radius ratio; a tighter
 * shape bound raises the smallest angle. */
static void optimizers_and_shape(void **state) {
  (void)state;
  pm_model *md = NULL;
  pm_sizing *sz = NULL;
  peer_test_case("qi3", &md, &sz);
  pm_mesh *base = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(peer_test_run(&peer_cgal, md, sz, 0, NULL, &base, &e), e);
  pm_quality q0;
  summary(base, sz, &q0);
  static const char *const sets[2][3] = {{"optimizer=lloyd", NULL, NULL},
                                         {"optimizer=odt", "opt_iterations=20", NULL}};
  for (int k = 0; k < 2; ++k) {
    pm_mesh *m = NULL;
    PM_ASSERT_OK(peer_test_run(&peer_cgal, md, sz, 0, sets[k], &m, &e), e);
    peer_test_expect_valid(m, md);
    assert_int_equal(m->nnode, base->nnode);
    int32_t moved = 0;
    for (int32_t i = 0; i < m->nnode; ++i) {
      assert_int_equal(m->node_dim[i], base->node_dim[i]);
      int same = m->xyz[3 * i] == base->xyz[3 * i] && m->xyz[3 * i + 1] == base->xyz[3 * i + 1];
      if (m->node_dim[i] != PM_FACE) assert_true(same);
      moved += !same;
    }
    assert_true(moved > m->nnode / 2);
    pm_quality q;
    summary(m, sz, &q);
    print_message("cgal qi3 %s: rr %.3f -> %.3f, rr min %.3f -> %.3f\n", sets[k][0],
                  q0.tri.s_radius_ratio.mean, q.tri.s_radius_ratio.mean, q0.tri.s_radius_ratio.min,
                  q.tri.s_radius_ratio.min);
    assert_true(q.tri.s_radius_ratio.mean > q0.tri.s_radius_ratio.mean + 0.02);
    PM_ASSERT_NEAR(q.tri.size_ratio.mean, 1, 0.15);
    pm_quality_clear(&q);
    pm_mesh_destroy(m);
  }
  /* B = 0.2 is not allowed (no termination guarantee); B = 0.1 loosens the bound to 18.4
   * degrees, and the smallest angle may drop but stays above it. */
  pm_mesh *m = NULL;
  static const char *const loose[] = {"shape_bound=0.1", NULL};
  PM_ASSERT_OK(peer_test_run(&peer_cgal, md, sz, 0, loose, &m, &e), e);
  pm_quality q;
  summary(m, sz, &q);
  assert_true(q.tri.s_min_angle.min > asin(sqrt(0.1)) * 180 / M_PI - 1e-9);
  pm_quality_clear(&q);
  pm_mesh_destroy(m);
  pm_quality_clear(&q0);
  pm_mesh_destroy(base);
  pm_sizing_destroy(sz);
  pm_model_destroy(md);
}

/* Holes and arcs: qi2 (a circular hole), qi4 (disk minus an off-centre disk) and a domain with
 * a 270-degree arc, a 120-degree arc and a full circle. Triangles cover exactly the domain (the
 * holes stay empty), boundary nodes lie on their curves, and no node Mesh_2 added on an arc's
 * chord was left there. */
static void holes_and_arcs(void **state) {
  (void)state;
  const double c60 = 0.5, s60 = sqrt(3.0) / 2;
  const pm_planar_piece outer[3] = {{PM_PIECE_ARC, {1, 0}, {0, 0}, 1},
                                    {PM_PIECE_LINE, {0, -1}, {0, 0}, 0},
                                    {PM_PIECE_LINE, {0, 0}, {0, 0}, 0}};
  const pm_planar_piece half[2] = {
      {PM_PIECE_ARC, {-0.4 + 0.2 * c60, 0.3 - 0.2 * s60}, {-0.4, 0.3}, 1},
      {PM_PIECE_LINE, {-0.4 + 0.2 * c60, 0.3 + 0.2 * s60}, {0, 0}, 0}};
  const pm_planar_piece circle[1] = {{PM_PIECE_ARC, {-0.15, -0.4}, {-0.3, -0.4}, 0}};
  const pm_planar_loop loops[3] = {{3, outer}, {2, half}, {1, circle}};
  double seg120 = 0.5 * 0.04 * (2 * M_PI / 3 - sin(2 * M_PI / 3));
  const struct {
    const char *name;
    double area;
  } cases[3] = {{"qi2", 4 - M_PI * 0.04},
                {"qi4", M_PI * (1 - 0.25)},
                {"arcs", 0.75 * M_PI - seg120 - M_PI * 0.15 * 0.15}};
  for (int c = 0; c < 3; ++c) {
    pm_model *md = NULL;
    pm_sizing *sz = NULL;
    pm_error e = {0};
    if (c < 2) {
      peer_test_case(cases[c].name, &md, &sz);
    } else {
      PM_ASSERT_OK(pm_planar_model("arcs", 3, loops, &md, &e), e);
      PM_ASSERT_OK(pm_sizing_expression("0.03+0.05*abs(x)", &sz, &e), e);
    }
    pm_stats st;
    pm_stats_init(&st);
    void *params = calloc(1, peer_cgal.params_size);
    peer_cgal.params_init(params);
    pm_run_input in = {md, sz, 1, 1, 0, 1000000, NULL};
    pm_run_output out;
    memset(&out, 0, sizeof out);
    pm_run_report report = {&st, NULL, NULL};
    pm_run_observer observer;
    pm_run_report_observer(&report, &observer);
    in.observer = &observer;
    PM_ASSERT_OK(peer_cgal.run(&in, params, &out, &e), e);
    peer_test_expect_valid(out.mesh, md);
    expect_on_curves(out.mesh, md);
    double area = mesh_area(out.mesh);
    /* Polygons inscribed in the arcs: off by the chords' sag. */
    PM_ASSERT_NEAR(area, cases[c].area, 0.005 * cases[c].area);
    char *json = NULL;
    PM_ASSERT_OK(pm_stats_to_json(&st, &json, &e), e);
    free(json);
    pm_stats_flat flat;
    PM_ASSERT_OK(pm_stats_flatten(&st, &flat, &e), e);
    const pm_stats_item *it = pm_stats_flat_find(&flat, "cgal_chord_nodes");
    assert_non_null(it);
    assert_true(it->num == 0);
    it = pm_stats_flat_find(&flat, "cgal_hole_seeds");
    assert_non_null(it);
    assert_true(it->num == (c == 2 ? 2 : 1));
    assert_non_null(pm_stats_flat_find(&flat, "time_s.refine"));
    pm_stats_flat_clear(&flat);
    pm_stats_clear(&st);
    free(params);
    pm_mesh_destroy(out.mesh);
    pm_sizing_destroy(sz);
    pm_model_destroy(md);
  }
}

/* qi4 at d = 2: three chords per circle would cross (the inner circle's triangle pokes out of
 * the outer one's), so the arcs are sampled finer until the polylines are disjoint; the mesh is
 * valid and the stats say how much finer. At d = 0.7 no refinement is needed. */
static void coarse_arcs(void **state) {
  (void)state;
  pm_model *md = NULL;
  peer_test_case("qi4", &md, NULL);
  const double sizes[2] = {2, 0.7};
  const double refined[2] = {1, 0};
  for (int k = 0; k < 2; ++k) {
    pm_sizing *sz = NULL;
    pm_error e = {0};
    PM_ASSERT_OK(pm_sizing_constant(sizes[k], &sz, &e), e);
    pm_stats st;
    pm_stats_init(&st);
    peer_cgal_params p;
    peer_cgal_params_init(&p);
    pm_run_input in = {md, sz, 1, 1, 0, 1000000, NULL};
    pm_run_output out;
    memset(&out, 0, sizeof out);
    pm_run_report report = {&st, NULL, NULL};
    pm_run_observer observer;
    pm_run_report_observer(&report, &observer);
    in.observer = &observer;
    PM_ASSERT_OK(peer_cgal.run(&in, &p, &out, &e), e);
    peer_test_expect_valid(out.mesh, md);
    pm_stats_flat flat;
    PM_ASSERT_OK(pm_stats_flatten(&st, &flat, &e), e);
    const pm_stats_item *it = pm_stats_flat_find(&flat, "cgal_arc_refinement");
    assert_non_null(it);
    assert_true(it->num == refined[k]);
    pm_stats_flat_clear(&flat);
    pm_stats_clear(&st);
    pm_mesh_destroy(out.mesh);
    pm_sizing_destroy(sz);
  }
  pm_model_destroy(md);
}

/* Same input twice: the identical mesh (Mesh_2 and the optimizers are deterministic). */
static void determinism(void **state) {
  (void)state;
  pm_model *md = NULL;
  pm_sizing *sz = NULL;
  peer_test_case("qi4", &md, &sz);
  static const char *const odt[] = {"optimizer=odt", NULL};
  pm_mesh *a = NULL, *b = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(peer_test_run(&peer_cgal, md, sz, 0, odt, &a, &e), e);
  PM_ASSERT_OK(peer_test_run(&peer_cgal, md, sz, 0, odt, &b, &e), e);
  assert_int_equal(a->nnode, b->nnode);
  assert_int_equal(a->ntri, b->ntri);
  assert_memory_equal(a->xyz, b->xyz, sizeof(double) * 3 * (size_t)a->nnode);
  assert_memory_equal(a->tri, b->tri, sizeof(int32_t) * 3 * (size_t)a->ntri);
  assert_memory_equal(a->seg, b->seg, sizeof(int32_t) * 2 * (size_t)a->nseg);
  pm_mesh_destroy(a);
  pm_mesh_destroy(b);
  pm_sizing_destroy(sz);
  pm_model_destroy(md);
}

/* Bad input: non-planar models, parameters, fields and caps; one-line errors. */
static void bad_input(void **state) {
  (void)state;
  pm_error e = {0};
  pm_mesh *m = NULL;
  assert_int_equal(peer_cgal.planar_only, 1);
  pm_model *solid = NULL;
  pm_sizing *ssz = NULL;
  peer_test_case("boxhole", &solid, &ssz);
  assert_int_equal(peer_test_run(&peer_cgal, solid, ssz, 0, NULL, &m, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "planar domains"));
  assert_null(m);
  pm_sizing_destroy(ssz);
  pm_model_destroy(solid);
  if (pm_test_have_cad()) {
    char path[512];
    PM_ASSERT_OK(pm_cad_load(pm_test_cad("slender_face.brep", path, sizeof path), &solid, &e), e);
    assert_int_equal(peer_test_run(&peer_cgal, solid, NULL, 0, NULL, &m, &e), PM_ERR_ARG);
    assert_non_null(strstr(e.msg, "planar domains"));
    pm_model_destroy(solid);
  }

  pm_model *md = NULL;
  pm_sizing *sz = NULL;
  peer_test_case("qi1", &md, &sz);
  static const char *const bad[][2] = {{"shape_bound=0.2", NULL}, {"shape_bound=0", NULL},
                                       {"size_factor=0.1", NULL}, {"optimizer=cvt", NULL},
                                       {"opt_iterations=0", NULL}, {"angle=30", NULL}};
  for (size_t k = 0; k < sizeof bad / sizeof bad[0]; ++k) {
    assert_int_equal(peer_test_run(&peer_cgal, md, sz, 0, bad[k], &m, &e), PM_ERR_ARG);
    assert_null(m);
    assert_null(strchr(e.msg, '\n'));
  }
  peer_cgal_params p;
  peer_cgal_params_init(&p);
  pm_run_input in = {md, sz, 1, 1, 0, 100, NULL};
  pm_run_output out;
  memset(&out, 0, sizeof out);
  /* Caps: hopeless (the estimate), then just exceeded during refinement. */
  assert_int_equal(peer_cgal.run(&in, &p, &out, &e), PM_ERR_LIMIT);
  assert_non_null(strstr(e.msg, "cap"));
  in.max_nodes = 900;
  assert_int_equal(peer_cgal.run(&in, &p, &out, &e), PM_ERR_LIMIT);
  assert_non_null(strstr(e.msg, "900"));
  assert_null(out.mesh);
  /* Fields not > 0: a region (the estimate), the top edge (the boundary sampling). */
  static const char *const fields[] = {"(x < -0.5) ? -1 : 0.1", "(y > 1.99) ? -1 : 0.1"};
  in.max_nodes = 1000000;
  for (int k = 0; k < 2; ++k) {
    pm_sizing *f = NULL;
    PM_ASSERT_OK(pm_sizing_expression(fields[k], &f, &e), e);
    in.size = f;
    assert_int_equal(peer_cgal.run(&in, &p, &out, &e), PM_ERR_ARG);
    assert_non_null(strstr(e.msg, "not > 0"));
    assert_null(out.mesh);
    pm_sizing_destroy(f);
  }
  /* A checked struct is re-checked by run. */
  in.size = sz;
  p.opt_iterations = -3;
  assert_int_equal(peer_cgal.run(&in, &p, &out, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "opt_iterations"));
  pm_sizing_destroy(sz);
  pm_model_destroy(md);
}

/* No field: 1/30 of the diagonal. */
static void default_size(void **state) {
  (void)state;
  pm_model *md = NULL;
  peer_test_case("shimada", &md, NULL);
  pm_sizing *def = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(peer_cgal.default_size(md, NULL, 0, 1, &def, &e), e);
  pm_mesh *m = NULL;
  PM_ASSERT_OK(peer_test_run(&peer_cgal, md, NULL, 0, NULL, &m, &e), e);
  peer_test_expect_valid(m, md);
  pm_quality q;
  summary(m, def, &q);
  PM_ASSERT_NEAR(q.tri.size_ratio.mean, 1, 0.10);
  double d = sqrt(2.0) / 30;
  PM_ASSERT_NEAR(m->nnode / peer_test_expected_nodes(1, 4, d), 1, 0.15);
  pm_quality_clear(&q);
  pm_mesh_destroy(m);
  pm_sizing_destroy(def);
  pm_model_destroy(md);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(uniform_and_graded), cmocka_unit_test(optimizers_and_shape),
      cmocka_unit_test(holes_and_arcs),     cmocka_unit_test(coarse_arcs),
      cmocka_unit_test(determinism),
      cmocka_unit_test(bad_input),          cmocka_unit_test(default_size),
  };
  if (getenv("PM_TEST_FILTER")) cmocka_set_test_filter(getenv("PM_TEST_FILTER"));
  return cmocka_run_group_tests(tests, NULL, teardown);
}
