/* The gmsh peers (gmsh-meshadapt, gmsh-delaunay, gmsh-frontal) through the pm_method interface:
 * planar cases against the lattice node count, size conformity and angle figures; arcs of every
 * construction path (full circle, short arc, long arc); the reference figure on qi3; solids and a
 * shared CAD model (valid, closed shells); volumes with gmsh's 3D Delaunay and with TetGen;
 * determinism; gmsh left as it was found (no mesh, options restored); bad input. */
#include "peer_test_util.h"

#include <gmshc.h>

#include "common/geom/geom_analytic.h"
#include "common/geom/geom_cad.h"
#include "common/backends/gmsh_session.h"
#include "common/mesh/element_measure.h"
#include "peers/peer_common.h"

static const pm_method *const gmsh_methods[3] = {&peer_gmsh_meshadapt, &peer_gmsh_delaunay,
                                                 &peer_gmsh_frontal};

static int teardown(void **state) {
  (void)state;
  pm_gmsh_shutdown();
  return 0;
}

static void quality_of(const pm_mesh *m, const pm_sizing *sz, pm_quality *q) {
  pm_error e = {0};
  PM_ASSERT_OK(pm_quality_compute(m, sz, q, &e), e);
}

/* qi1, d = 0.1 (papers/004 sec. 3.1): every algorithm makes a valid mesh whose node count is
 * within 15% of the lattice count (985: 924 inside, the boundary's share 60), whose mean edge
 * length is within 10% of d and whose smallest angle exceeds 20 degrees. */
static void qi1_uniform(void **state) {
  (void)state;
  pm_model *md = NULL;
  pm_sizing *sz = NULL;
  peer_test_case("qi1", &md, &sz);
  double expect = peer_test_expected_nodes(8, 12, 0.1);
  PM_ASSERT_NEAR(expect, 985, 1);
  for (int k = 0; k < 3; ++k) {
    pm_mesh *m = NULL;
    pm_error e = {0};
    PM_ASSERT_OK(peer_test_run(gmsh_methods[k], md, sz, 0, NULL, &m, &e), e);
    peer_test_expect_valid(m, md);
    pm_quality q;
    quality_of(m, sz, &q);
    print_message("%s qi1: %d nodes (lattice %.0f), mean l/d %.3f, min angle %.1f\n",
                  gmsh_methods[k]->name, m->nnode, expect, q.tri.size_ratio.mean,
                  q.tri.s_min_angle.min);
    PM_ASSERT_NEAR(m->nnode / expect, 1, 0.15);
    PM_ASSERT_NEAR(q.tri.size_ratio.mean, 1, 0.10);
    assert_true(q.tri.s_min_angle.min > 20);
    assert_int_equal(m->ntet, 0);
    /* Classification: corners on vertices, boundary on curves, the rest on the face. */
    int32_t count[3] = {0, 0, 0};
    for (int32_t i = 0; i < m->nnode; ++i) {
      assert_true(m->node_dim[i] >= 0 && m->node_dim[i] <= 2);
      count[m->node_dim[i]]++;
      if (m->node_dim[i] == PM_FACE) {
        assert_true(m->node_par[2 * i] == m->xyz[3 * i] && m->node_par[2 * i + 1] == m->xyz[3 * i + 1]);
      } else if (m->node_dim[i] == PM_CURVE) {
        double p[3];
        pm_cell_point(&md->cells[PM_CURVE][m->node_cell[i]], &m->node_par[2 * i], p);
        PM_ASSERT_NEAR(p[0], m->xyz[3 * i], 1e-12);
        PM_ASSERT_NEAR(p[1], m->xyz[3 * i + 1], 1e-12);
      }
    }
    assert_int_equal(count[0], 4);
    /* The perimeter 12 at spacing ~0.1: about 120 boundary nodes, 4 of them the corners. */
    PM_ASSERT_NEAR(count[1] + 4, 120, 8);
    pm_quality_clear(&q);
    pm_mesh_destroy(m);
  }
  pm_sizing_destroy(sz);
  pm_model_destroy(md);
}

/* qi3's graded field d = 0.2 |r - 2| + 0.15: the mean edge length over d within 15% of 1 for
 * every algorithm; and the reference figure of gmsh's Frontal-Delaunay on qi3: about 736 nodes,
 * mean radius ratio 0.967, minimum 0.611, minimum angle 31.8 degrees. */
static void qi3_graded(void **state) {
  (void)state;
  pm_model *md = NULL;
  pm_sizing *sz = NULL;
  peer_test_case("qi3", &md, &sz);
  for (int k = 0; k < 3; ++k) {
    pm_mesh *m = NULL;
    pm_error e = {0};
    PM_ASSERT_OK(peer_test_run(gmsh_methods[k], md, sz, 0, NULL, &m, &e), e);
    peer_test_expect_valid(m, md);
    pm_quality q;
    quality_of(m, sz, &q);
    print_message("%s qi3: %d nodes, rr %.3f (min %.3f), min angle %.2f, l/d %.3f\n",
                  gmsh_methods[k]->name, m->nnode, q.tri.s_radius_ratio.mean,
                  q.tri.s_radius_ratio.min, q.tri.s_min_angle.min, q.tri.size_ratio.mean);
    PM_ASSERT_NEAR(q.tri.size_ratio.mean, 1, 0.15);
    if (gmsh_methods[k] == &peer_gmsh_frontal) {
      PM_ASSERT_NEAR(m->nnode, 736, 15);
      PM_ASSERT_NEAR(q.tri.s_radius_ratio.mean, 0.967, 0.005);
      PM_ASSERT_NEAR(q.tri.s_radius_ratio.min, 0.611, 0.03);
      PM_ASSERT_NEAR(q.tri.s_min_angle.min, 31.8, 1.0);
    }
    pm_quality_clear(&q);
    pm_mesh_destroy(m);
  }
  pm_sizing_destroy(sz);
  pm_model_destroy(md);
}

/* A planar domain with every kind of arc: the outer loop a 270-degree arc (built as a rational
 * B-spline) and two lines, a hole of a 120-degree arc (a gmsh circle arc) and a line, and a
 * full-circle hole. The gmsh geometry must map one-to-one onto the cells (a wrong match would put
 * nodes off their curves, which the peer refuses), boundary nodes lie exactly on their curves,
 * and each curve gets about length / d segments. */
static void arcs_of_every_kind(void **state) {
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
  pm_model *md = NULL;
  pm_sizing *sz = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_planar_model("arcs", 3, loops, &md, &e), e);
  PM_ASSERT_OK(pm_sizing_constant(0.05, &sz, &e), e);
  for (int k = 0; k < 3; ++k) {
    pm_mesh *m = NULL;
    PM_ASSERT_OK(peer_test_run(gmsh_methods[k], md, sz, 0, NULL, &m, &e), e);
    peer_test_expect_valid(m, md);
    for (int32_t i = 0; i < m->nnode; ++i) {
      if (m->node_dim[i] != PM_CURVE) continue;
      double par, dist;
      PM_ASSERT_OK(pm_cell_project(&md->cells[PM_CURVE][m->node_cell[i]], &m->xyz[3 * i], NULL,
                                   &par, NULL, &dist, &e),
                   e);
      assert_true(dist < 1e-12);
    }
    for (int32_t c = 0; c < md->count[PM_CURVE]; ++c) {
      const pm_cell *cc = &md->cells[PM_CURVE][c];
      int32_t nseg = 0;
      for (int32_t s = 0; s < m->nseg; ++s) nseg += m->seg_cell[s] == c;
      double want = (cc->hi[0] - cc->lo[0]) / 0.05;
      if (fabs(nseg - want) > 0.1 * want + 1)
        fail_msg("%s: curve %d of length %g has %d segments, expected about %.1f",
                 gmsh_methods[k]->name, c, cc->hi[0] - cc->lo[0], nseg, want);
    }
    /* The triangles cover the domain: 3/4 of the unit disk minus the holes (the half disk's
     * segment of 120 degrees and the circle), up to the chords' sag. */
    double area = 0;
    for (int32_t t = 0; t < m->ntri; ++t) {
      const double *a = &m->xyz[3 * m->tri[3 * t]], *b = &m->xyz[3 * m->tri[3 * t + 1]],
                   *c = &m->xyz[3 * m->tri[3 * t + 2]];
      double a2 = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
      assert_true(a2 > 0);
      area += 0.5 * a2;
    }
    double seg120 = 0.5 * 0.04 * (2 * M_PI / 3 - sin(2 * M_PI / 3));
    double exact = 0.75 * M_PI - seg120 - M_PI * 0.15 * 0.15;
    PM_ASSERT_NEAR(area, exact, 0.005 * exact);
    pm_mesh_destroy(m);
  }
  pm_sizing_destroy(sz);
  pm_model_destroy(md);
}

/* Holes of the built-in cases (full circles): valid meshes, mean edge length near d. */
static void qi2_qi4_holes(void **state) {
  (void)state;
  static const char *const names[2] = {"qi2", "qi4"};
  for (int c = 0; c < 2; ++c) {
    pm_model *md = NULL;
    pm_sizing *sz = NULL;
    peer_test_case(names[c], &md, &sz);
    pm_mesh *m = NULL;
    pm_error e = {0};
    PM_ASSERT_OK(peer_test_run(&peer_gmsh_frontal, md, sz, 0, NULL, &m, &e), e);
    peer_test_expect_valid(m, md);
    pm_quality q;
    quality_of(m, sz, &q);
    PM_ASSERT_NEAR(q.tri.size_ratio.mean, 1, 0.15);
    pm_quality_clear(&q);
    pm_mesh_destroy(m);
    pm_sizing_destroy(sz);
    pm_model_destroy(md);
  }
  /* A field coarser than the circles: the field governs, not gmsh's floor of 7 nodes per
   * circle (qi4's circles of length 2 pi and pi get 3 or 4 segments at d = 2). */
  pm_model *md = NULL;
  pm_sizing *sz = NULL;
  pm_error e = {0};
  peer_test_case("qi4", &md, NULL);
  PM_ASSERT_OK(pm_sizing_constant(2, &sz, &e), e);
  pm_mesh *m = NULL;
  PM_ASSERT_OK(peer_test_run(&peer_gmsh_frontal, md, sz, 0, NULL, &m, &e), e);
  peer_test_expect_valid(m, md);
  for (int32_t c = 0; c < md->count[PM_CURVE]; ++c) {
    int32_t nseg = 0;
    for (int32_t s = 0; s < m->nseg; ++s) nseg += m->seg_cell[s] == c;
    assert_true(nseg >= 3 && nseg <= 4);
  }
  pm_mesh_destroy(m);
  pm_sizing_destroy(sz);
  pm_model_destroy(md);
}

/* Solids and a shared CAD model: valid meshes with closed, outward shells of the right Euler
 * characteristic. */
static void solids_and_cad(void **state) {
  (void)state;
  pm_model *md = NULL;
  pm_sizing *sz = NULL;
  peer_test_case("sphere", &md, &sz);
  for (int k = 0; k < 3; ++k) {
    pm_mesh *m = NULL;
    pm_error e = {0};
    PM_ASSERT_OK(peer_test_run(gmsh_methods[k], md, sz, 0, NULL, &m, &e), e);
    pm_check_report r;
    PM_ASSERT_OK(pm_mesh_check(m, md, &r, &e), e);
    if (!r.valid) fail_msg("%s sphere: %s", gmsh_methods[k]->name, r.problem[0]);
    assert_int_equal(r.nshell, 1);
    assert_true(r.shell[0].closed);
    assert_int_equal(r.shell[0].euler, 2);
    /* Inscribed polyhedron: a little less than 4/3 pi at this size. */
    PM_ASSERT_NEAR(r.shell[0].enclosed, 4.0 / 3.0 * M_PI, 0.03 * 4.0 / 3.0 * M_PI);
    assert_true(r.shell[0].enclosed < 4.0 / 3.0 * M_PI);
    pm_check_report_clear(&r);
    pm_mesh_destroy(m);
  }
  pm_sizing_destroy(sz);
  pm_model_destroy(md);

  if (!pm_test_have_cad()) return;
  char path[512];
  pm_error e = {0};
  PM_ASSERT_OK(pm_cad_load(pm_test_cad("screw.step", path, sizeof path), &md, &e), e);
  for (int k = 0; k < 3; ++k) {
    pm_mesh *m = NULL;
    /* No size: the peers' default, 1/30 of the diagonal. */
    PM_ASSERT_OK(peer_test_run(gmsh_methods[k], md, NULL, 0, NULL, &m, &e), e);
    pm_check_report r;
    PM_ASSERT_OK(pm_mesh_check(m, md, &r, &e), e);
    if (!r.valid) fail_msg("%s screw.step: %s", gmsh_methods[k]->name, r.problem[0]);
    assert_int_equal(r.nshell, 1);
    assert_true(r.shell[0].closed);
    assert_true(r.shell[0].enclosed > 0);
    pm_check_report_clear(&r);
    /* Face nodes carry gmsh's (u, v), which are ours: they evaluate back to the node. */
    for (int32_t i = 0; i < m->nnode; i += 7) {
      if (m->node_dim[i] != PM_FACE) continue;
      double p[3];
      pm_cell_point(&md->cells[PM_FACE][m->node_cell[i]], &m->node_par[2 * i], p);
      assert_true(sqrt(pm_test_d2(p, &m->xyz[3 * i])) < 1e-6 * md->diagonal);
    }
    pm_sizing *def = NULL;
    PM_ASSERT_OK(gmsh_methods[k]->default_size(md, NULL, 0, 1, &def, &e), e);
    pm_quality q;
    quality_of(m, def, &q);
    PM_ASSERT_NEAR(q.tri.size_ratio.mean, 1, 0.10);
    pm_quality_clear(&q);
    pm_sizing_destroy(def);
    pm_mesh_destroy(m);
  }
  pm_model_destroy(md);
}

/* --volume on boxhole: gmsh's 3D Delaunay and TetGen refinement of gmsh's surface mesh; tets
 * valid, tagged with the volume, filling the solid (2 x 1 x 0.6 minus a cylinder of radius 0.25
 * and height 0.6), the surface mesh kept by TetGen. */
static void volumes(void **state) {
  (void)state;
  pm_model *md = NULL;
  pm_sizing *sz = NULL;
  peer_test_case("boxhole", &md, &sz);
  const char *tetgen[] = {"volume=tetgen", NULL};
  pm_mesh *surf = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(peer_test_run(&peer_gmsh_frontal, md, sz, 0, NULL, &surf, &e), e);
  for (int k = 0; k < 2; ++k) {
    pm_mesh *m = NULL;
    PM_ASSERT_OK(peer_test_run(&peer_gmsh_frontal, md, sz, 1, k ? tetgen : NULL, &m, &e), e);
    peer_test_expect_valid(m, md);
    assert_true(m->ntet > 500);
    double vol = 0;
    for (int32_t t = 0; t < m->ntet; ++t) {
      assert_int_equal(m->tet_cell[t], 0);
      pm_tet_measure tm;
      pm_tet_measure_eval(&m->xyz[3 * m->tet[4 * t]], &m->xyz[3 * m->tet[4 * t + 1]],
                          &m->xyz[3 * m->tet[4 * t + 2]], &m->xyz[3 * m->tet[4 * t + 3]], &tm);
      assert_true(tm.volume > 0);
      vol += tm.volume;
    }
    double exact = 2 * 1 * 0.6 - M_PI * 0.25 * 0.25 * 0.6;
    PM_ASSERT_NEAR(vol, exact, 0.01 * exact);
    int32_t inner = 0;
    for (int32_t i = 0; i < m->nnode; ++i) inner += m->node_dim[i] == PM_VOLUME;
    assert_true(inner > 0);
    /* TetGen keeps gmsh's surface: the same triangles as the surface-only run. */
    if (k == 1) {
      assert_int_equal(m->ntri, surf->ntri);
      assert_int_equal(m->nnode - inner, surf->nnode);
      assert_memory_equal(m->tri, surf->tri, sizeof(int32_t) * 3 * (size_t)surf->ntri);
    }
    print_message("boxhole %s: %d nodes, %d tets\n", k ? "tetgen" : "gmsh", m->nnode, m->ntet);
    pm_mesh_destroy(m);
  }
  pm_mesh_destroy(surf);
  pm_sizing_destroy(sz);
  pm_model_destroy(md);
}

static void expect_same(const pm_mesh *a, const pm_mesh *b) {
  assert_int_equal(a->nnode, b->nnode);
  assert_int_equal(a->ntri, b->ntri);
  assert_int_equal(a->nseg, b->nseg);
  assert_memory_equal(a->xyz, b->xyz, sizeof(double) * 3 * (size_t)a->nnode);
  assert_memory_equal(a->node_par, b->node_par, sizeof(double) * 2 * (size_t)a->nnode);
  assert_memory_equal(a->tri, b->tri, sizeof(int32_t) * 3 * (size_t)a->ntri);
  assert_memory_equal(a->tri_cell, b->tri_cell, sizeof(int32_t) * (size_t)a->ntri);
}

/* Same input twice, the identical mesh: on a planar case (a fresh gmsh model each time) and on
 * a gmsh-built solid (the same gmsh model, whose mesh must have been cleared in between). The
 * CAD model's gmsh model holds no mesh afterwards, and the options set for a run are restored. */
static void determinism_and_pristine(void **state) {
  (void)state;
  static const char *const names[2] = {"qi3", "torus"};
  int ierr = 0;
  double before[3];
  pm_error e0 = {0};
  PM_ASSERT_OK(pm_gmsh_begin(&e0), e0);
  pm_gmsh_lock();
  gmshOptionSetNumber("Mesh.Algorithm", 8, &ierr);
  gmshOptionSetNumber("Mesh.MeshSizeMax", 0.5, &ierr);
  gmshOptionSetNumber("Mesh.MeshSizeFromCurvature", 12, &ierr);
  gmshOptionGetNumber("Mesh.Algorithm", &before[0], &ierr);
  gmshOptionGetNumber("Mesh.MeshSizeMax", &before[1], &ierr);
  gmshOptionGetNumber("Mesh.MeshSizeFromCurvature", &before[2], &ierr);
  pm_gmsh_unlock();
  for (int c = 0; c < 2; ++c) {
    pm_model *md = NULL;
    pm_sizing *sz = NULL;
    peer_test_case(names[c], &md, &sz);
    pm_mesh *a = NULL, *b = NULL;
    pm_error e = {0};
    PM_ASSERT_OK(peer_test_run(&peer_gmsh_delaunay, md, sz, 0, NULL, &a, &e), e);
    PM_ASSERT_OK(peer_test_run(&peer_gmsh_delaunay, md, sz, 0, NULL, &b, &e), e);
    expect_same(a, b);
    if (pm_cad_gmsh_model(md)) {
      pm_gmsh_scope scope;
      PM_ASSERT_OK(pm_gmsh_scope_enter(&scope, pm_cad_gmsh_model(md), 0, &e), e);
      size_t *nt = NULL, nn = 0, nc = 0, np = 0;
      double *coord = NULL, *par = NULL;
      gmshModelMeshGetNodes(&nt, &nn, &coord, &nc, &par, &np, -1, -1, 0, 0, &ierr);
      pm_gmsh_scope_leave(&scope, 0);
      assert_int_equal(ierr, 0);
      assert_int_equal(nn, 0);
      if (nt) gmshFree(nt);
      if (coord) gmshFree(coord);
      if (par) gmshFree(par);
    }
    pm_mesh_destroy(a);
    pm_mesh_destroy(b);
    pm_sizing_destroy(sz);
    pm_model_destroy(md);
  }
  double after[3];
  pm_gmsh_lock();
  gmshOptionGetNumber("Mesh.Algorithm", &after[0], &ierr);
  gmshOptionGetNumber("Mesh.MeshSizeMax", &after[1], &ierr);
  gmshOptionGetNumber("Mesh.MeshSizeFromCurvature", &after[2], &ierr);
  pm_gmsh_unlock();
  for (int k = 0; k < 3; ++k) assert_true(after[k] == before[k]);
}

/* Bad input: one-line errors with the right codes, never a crash. */
static void bad_input(void **state) {
  (void)state;
  pm_model *md = NULL;
  pm_sizing *sz = NULL;
  peer_test_case("qi1", &md, &sz);
  pm_error e = {0};
  pm_mesh *m = NULL;
  /* Parameters outside their ranges or unknown. */
  static const char *const bad[][2] = {{"smoothing=-1", NULL}, {"smoothing=2.5", NULL},
                                       {"volume=netgen", NULL}, {"radius_edge=1", NULL},
                                       {"optimise=1", NULL}};
  for (size_t k = 0; k < sizeof bad / sizeof bad[0]; ++k) {
    assert_int_equal(peer_test_run(&peer_gmsh_frontal, md, sz, 0, bad[k], &m, &e), PM_ERR_ARG);
    assert_null(m);
    assert_null(strchr(e.msg, '\n'));
    assert_true(strlen(e.msg) > 10);
  }
  /* A checked struct is re-checked by run. */
  peer_gmsh_params p;
  peer_gmsh_params_init(&p);
  p.radius_edge = 0.5;
  pm_run_input in = {md, sz, 1, 1, 0, 1000000, NULL};
  pm_run_output out;
  memset(&out, 0, sizeof out);
  assert_int_equal(peer_gmsh_meshadapt.run(&in, &p, &out, &e), PM_ERR_ARG);
  assert_null(out.mesh);
  assert_non_null(strstr(e.msg, "radius_edge"));
  /* The node cap: refused before meshing when hopeless, after meshing when just exceeded. */
  peer_gmsh_params_init(&p);
  in.max_nodes = 100;
  assert_int_equal(peer_gmsh_frontal.run(&in, &p, &out, &e), PM_ERR_LIMIT);
  assert_non_null(strstr(e.msg, "cap"));
  in.max_nodes = 900;
  assert_int_equal(peer_gmsh_frontal.run(&in, &p, &out, &e), PM_ERR_LIMIT);
  assert_non_null(strstr(e.msg, "more than the cap 900"));
  assert_null(out.mesh);
  /* Fields that are not > 0 somewhere in the domain: found by the estimate before meshing (a
   * region), or by the size callback during meshing (a strip along the top edge that the
   * estimate's samples miss). A field tending to 0 inside the domain is refused by the
   * estimate, which gives up once the count passes the cap. */
  static const struct {
    const char *expr;
    pm_status code;
    const char *says;
  } fields[] = {{"(x < -0.5) ? -1 : 0.1", PM_ERR_ARG, "on face"},
                {"(y > 1.99) ? -1 : 0.1", PM_ERR_ARG, ", 2, 0), not > 0"},
                {"0.1*abs(x)", PM_ERR_LIMIT, "over the node cap"}};
  in.max_nodes = 1000000;
  for (size_t k = 0; k < sizeof fields / sizeof fields[0]; ++k) {
    pm_sizing *f = NULL;
    PM_ASSERT_OK(pm_sizing_expression(fields[k].expr, &f, &e), e);
    in.size = f;
    assert_int_equal(peer_gmsh_frontal.run(&in, &p, &out, &e), fields[k].code);
    if (!strstr(e.msg, fields[k].says)) fail_msg("%s: '%s'", fields[k].expr, e.msg);
    assert_non_null(strstr(e.msg, "gmsh-frontal"));
    assert_null(out.mesh);
    pm_sizing_destroy(f);
  }
  /* The model is fine for the next run after all these failures. */
  in.size = sz;
  PM_ASSERT_OK(peer_gmsh_frontal.run(&in, &p, &out, &e), e);
  peer_test_expect_valid(out.mesh, md);
  pm_mesh_destroy(out.mesh);
  pm_sizing_destroy(sz);
  pm_model_destroy(md);
}

/* The default size is 1/30 of the diagonal: qi1 (diagonal sqrt(20)) meshed with no field has
 * its mean edge length there. */
static void default_size(void **state) {
  (void)state;
  pm_model *md = NULL;
  peer_test_case("qi1", &md, NULL);
  pm_sizing *def = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(peer_gmsh_frontal.default_size(md, NULL, 0, 1, &def, &e), e);
  double d = sqrt(20.0) / 30, p[3] = {0.3, 0.1, 0};
  PM_ASSERT_NEAR(pm_sizing_eval(def, p), d, 1e-12);
  pm_mesh *m = NULL;
  PM_ASSERT_OK(peer_test_run(&peer_gmsh_frontal, md, NULL, 0, NULL, &m, &e), e);
  pm_quality q;
  quality_of(m, def, &q);
  PM_ASSERT_NEAR(q.tri.size_ratio.mean, 1, 0.10);
  PM_ASSERT_NEAR(m->nnode / peer_test_expected_nodes(8, 12, d), 1, 0.15);
  pm_quality_clear(&q);
  pm_mesh_destroy(m);
  pm_sizing_destroy(def);
  pm_model_destroy(md);
}

/* peer_flip_flat_triangles: a fan around d over a straight boundary e0 - b - e1 - g, with the
 * flat triangle (b, e0, e1) that a backend makes when it joins three nodes of a straight curve.
 * The flip replaces it and its neighbour (e1, e0, d) by (b, e0, d) and (b, d, e1): no flat
 * triangle is left, the area is the same and every triangle keeps its turn. Across a face
 * boundary, or when the new edge exists already, nothing flips. */
static double signed_area_z(const pm_mesh *m, int32_t t) {
  const double *a = &m->xyz[3 * m->tri[3 * t]], *b = &m->xyz[3 * m->tri[3 * t + 1]],
               *c = &m->xyz[3 * m->tri[3 * t + 2]];
  return 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]));
}

static pm_mesh *flat_fan(int32_t neighbour_face) {
  pm_mesh *m = pm_mesh_create();
  pm_error e = {0};
  const double x[5][3] = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {1, 1, 0}, {3, 0, 0}}; /* e0 b e1 d g */
  for (int k = 0; k < 5; ++k) PM_ASSERT_OK(pm_mesh_add_node(m, x[k], 2, 0, NULL, NULL, &e), e);
  PM_ASSERT_OK(pm_mesh_add_tri(m, 1, 0, 2, 0, &e), e);              /* flat, turn -0 */
  PM_ASSERT_OK(pm_mesh_add_tri(m, 2, 0, 3, neighbour_face, &e), e); /* clockwise */
  PM_ASSERT_OK(pm_mesh_add_tri(m, 4, 2, 3, 0, &e), e);              /* clockwise */
  return m;
}

static void flat_triangles_flip(void **state) {
  (void)state;
  pm_mesh *m = flat_fan(0);
  const double area = signed_area_z(m, 1) + signed_area_z(m, 2);
  assert_int_equal(peer_flip_flat_triangles(m), 1);
  assert_int_equal(m->ntri, 3);
  double sum = 0;
  for (int32_t t = 0; t < m->ntri; ++t) {
    const double *a = &m->xyz[3 * m->tri[3 * t]], *b = &m->xyz[3 * m->tri[3 * t + 1]],
                 *c = &m->xyz[3 * m->tri[3 * t + 2]];
    assert_false(pm_tri_degenerate(a, b, c));
    assert_true(signed_area_z(m, t) < 0); /* the turn of the face kept */
    sum += signed_area_z(m, t);
  }
  PM_ASSERT_NEAR(sum, area, 1e-15);
  const int32_t want[6] = {1, 0, 3, 1, 3, 2};
  for (int k = 0; k < 6; ++k) assert_int_equal(m->tri[k], want[k]);
  assert_int_equal(peer_flip_flat_triangles(m), 0); /* nothing left to flip */
  pm_mesh_destroy(m);

  /* the neighbour on another face: the edge is a face boundary, nothing flips */
  m = flat_fan(1);
  assert_int_equal(peer_flip_flat_triangles(m), 0);
  assert_int_equal(m->tri[0], 1);
  pm_mesh_destroy(m);

  /* the new edge (b, d) exists already (a triangle (b, d, g) of the face): nothing flips */
  m = flat_fan(0);
  pm_error e = {0};
  PM_ASSERT_OK(pm_mesh_add_tri(m, 1, 3, 4, 0, &e), e);
  assert_int_equal(peer_flip_flat_triangles(m), 0);
  pm_mesh_destroy(m);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(qi1_uniform),     cmocka_unit_test(qi3_graded),
      cmocka_unit_test(arcs_of_every_kind), cmocka_unit_test(qi2_qi4_holes),
      cmocka_unit_test(solids_and_cad),  cmocka_unit_test(volumes),
      cmocka_unit_test(determinism_and_pristine), cmocka_unit_test(bad_input),
      cmocka_unit_test(default_size),    cmocka_unit_test(flat_triangles_flip),
  };
  /* PM_TEST_FILTER=name runs one test (cmocka's glob), for debugging. */
  if (getenv("PM_TEST_FILTER")) cmocka_set_test_filter(getenv("PM_TEST_FILTER"));
  return cmocka_run_group_tests(tests, NULL, teardown);
}
