/* pm_connect on planar domains and on curved CAD faces: conformity (pm_mesh_check), counts,
 * holes, orientation, the 3D flips (they improve curved faces and never cross a constraint),
 * determinism, and volumes through TetGen in both modes. */
#include "test_support.h"

#include <math.h>
#include <string.h>

#include "common/connect/connect.h"
#include "common/base/vec3.h"
#include "common/connect/face_smooth.h"
#include "common/geom/geom_analytic.h"
#include "common/geom/geom_cad.h"
#include "common/input/cases.h"
#include "common/mesh/mesh_check.h"
#include "common/measure/quality.h"

/* Nodes for a planar model: every curve sampled every ~h (its own nodes only), the face filled
 * with a triangular lattice of spacing h kept h/2 away from the boundary curves. */
static pm_mesh *planar_nodes(const pm_model *m, double h) {
  pm_mesh *mesh = pm_mesh_create();
  pm_error e = {0};
  for (int32_t v = 0; v < pm_model_count(m, PM_VERTEX); ++v)
    PM_ASSERT_OK(pm_mesh_add_node(mesh, pm_model_cell(m, PM_VERTEX, v)->xyz, 0, v, NULL, NULL, &e), e);
  for (int32_t c = 0; c < pm_model_count(m, PM_CURVE); ++c) {
    const pm_cell *cv = pm_model_cell(m, PM_CURVE, c);
    int n = (int)ceil((cv->hi[0] - cv->lo[0]) / h);
    for (int k = 1; k < n; ++k) {
      double t = cv->lo[0] + (cv->hi[0] - cv->lo[0]) * k / n, x[3];
      pm_cell_point(cv, &t, x);
      PM_ASSERT_OK(pm_mesh_add_node(mesh, x, 1, c, &t, NULL, &e), e);
    }
  }
  const pm_cell *f = pm_model_cell(m, PM_FACE, 0);
  for (int j = 0;; ++j) {
    double y = f->lo[1] + j * h * sqrt(3) / 2;
    if (y > f->hi[1]) break;
    for (int i = -1;; ++i) {
      double x = f->lo[0] + (i + 0.5 * (j % 2)) * h;
      if (x > f->hi[0]) break;
      double uv[2] = {x, y}, p[3] = {x, y, 0}, par[2], dist;
      if (!pm_face_inside(f, uv)) continue;
      /* Keep away from the boundary: the distance to the closest curve. */
      double dmin = 1e300;
      for (int32_t c = 0; c < pm_model_count(m, PM_CURVE); ++c) {
        PM_ASSERT_OK(pm_cell_project(pm_model_cell(m, PM_CURVE, c), p, NULL, par, NULL, &dist, &e), e);
        dmin = fmin(dmin, dist);
      }
      if (dmin < 0.5 * h) continue;
      PM_ASSERT_OK(pm_mesh_add_node(mesh, p, 2, 0, uv, NULL, &e), e);
    }
  }
  return mesh;
}

static pm_model *square_with_hole(double hole) {
  const pm_planar_piece sq[4] = {{PM_PIECE_LINE, {-1, -1}, {0, 0}, 0}, {PM_PIECE_LINE, {1, -1}, {0, 0}, 0},
                                 {PM_PIECE_LINE, {1, 1}, {0, 0}, 0}, {PM_PIECE_LINE, {-1, 1}, {0, 0}, 0}};
  const pm_planar_piece circ[1] = {{PM_PIECE_ARC, {hole, 0}, {0, 0}, 0}};
  pm_planar_loop loops[2] = {{4, sq}, {1, circ}};
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_planar_model("square", hole > 0 ? 2 : 1, loops, &m, &e), e);
  return m;
}

static void check_valid(const pm_mesh *mesh, const pm_model *m, pm_check_report *r) {
  pm_error e = {0};
  PM_ASSERT_OK(pm_mesh_check(mesh, m, r, &e), e);
  if (!r->valid)
    for (int i = 0; i < r->nproblem; ++i) print_error("problem: %s\n", r->problem[i]);
  assert_true(r->valid);
}

static void planar_square(void **state) {
  (void)state;
  pm_model *m = square_with_hole(0);
  pm_mesh *mesh = planar_nodes(m, 0.1);
  pm_connect_report rep;
  pm_error e = {0};
  PM_ASSERT_OK(pm_connect(m, mesh, NULL, &rep, &e), e);
  /* 20 nodes per side of length 2 at h = 0.1: 80 segments. */
  assert_int_equal(mesh->nseg, 80);
  pm_check_report r = {0};
  check_valid(mesh, m, &r);
  /* A disk: V - E + F = 1 (Euler with the outer face not counted). Triangles of a triangulated
   * polygon with b boundary and i interior nodes: 2 i + b - 2. */
  int32_t b = 80, i = mesh->nnode - 80;
  assert_int_equal(mesh->ntri, 2 * i + b - 2);
  double area = 0;
  for (int32_t t = 0; t < mesh->ntri; ++t) {
    const double *A = &mesh->xyz[3 * mesh->tri[3 * t]], *B = &mesh->xyz[3 * mesh->tri[3 * t + 1]],
                 *C = &mesh->xyz[3 * mesh->tri[3 * t + 2]];
    double z = (B[0] - A[0]) * (C[1] - A[1]) - (B[1] - A[1]) * (C[0] - A[0]);
    assert_true(z > 0); /* along the face's natural normal +z */
    area += 0.5 * z;
  }
  PM_ASSERT_NEAR(area, 4.0, 1e-12);
  assert_int_equal(rep.dropped_nodes, 0);
  assert_int_equal(rep.added_nodes, 0);
  pm_check_report_clear(&r);
  pm_mesh_destroy(mesh);
  pm_model_destroy(m);
}

static void planar_hole_and_determinism(void **state) {
  (void)state;
  pm_model *m = square_with_hole(0.3);
  pm_mesh *mesh = planar_nodes(m, 0.08);
  pm_mesh *copy = pm_mesh_copy(mesh);
  pm_error e = {0};
  PM_ASSERT_OK(pm_connect(m, mesh, NULL, NULL, &e), e);
  pm_check_report r = {0};
  check_valid(mesh, m, &r);
  /* Nothing inside the hole: every centroid lies outside the circle. */
  for (int32_t t = 0; t < mesh->ntri; ++t) {
    double cx = 0, cy = 0;
    for (int q = 0; q < 3; ++q) cx += mesh->xyz[3 * mesh->tri[3 * t + q]] / 3, cy += mesh->xyz[3 * mesh->tri[3 * t + q] + 1] / 3;
    assert_true(hypot(cx, cy) > 0.25);
  }
  /* The same nodes give the same mesh, element by element. */
  PM_ASSERT_OK(pm_connect(m, copy, NULL, NULL, &e), e);
  assert_int_equal(copy->ntri, mesh->ntri);
  assert_memory_equal(copy->tri, mesh->tri, sizeof(int32_t) * 3 * (size_t)mesh->ntri);
  pm_check_report_clear(&r);
  pm_mesh_destroy(mesh);
  pm_mesh_destroy(copy);
  pm_model_destroy(m);
}

static void bad_nodes_rejected(void **state) {
  (void)state;
  pm_model *m = square_with_hole(0);
  pm_mesh *mesh = planar_nodes(m, 0.25);
  pm_error e = {0};
  double x[3] = {0, 0, 0};
  /* A second node on vertex 0. */
  PM_ASSERT_OK(pm_mesh_add_node(mesh, pm_model_cell(m, 0, 0)->xyz, 0, 0, NULL, NULL, &e), e);
  assert_int_equal(pm_connect(m, mesh, NULL, NULL, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "vertex"));
  mesh->nnode--;
  /* A node on a face the model lacks. */
  PM_ASSERT_OK(pm_mesh_add_node(mesh, x, 2, 5, x, NULL, &e), e);
  assert_int_equal(pm_connect(m, mesh, NULL, NULL, &e), PM_ERR_ARG);
  assert_int_equal(mesh->ntri, 0);
  pm_mesh_destroy(mesh);
  pm_model_destroy(m);
}

/* Nodes on a CAD model from a (u, v) grid per face and a uniform t grid per curve: a grid in
 * parameter space is badly shaped on a sphere or torus, which is what the flips are for. */
static pm_mesh *grid_nodes(const pm_model *m, int n) {
  pm_mesh *mesh = pm_mesh_create();
  pm_error e = {0};
  for (int32_t v = 0; v < pm_model_count(m, 0); ++v)
    PM_ASSERT_OK(pm_mesh_add_node(mesh, pm_model_cell(m, 0, v)->xyz, 0, v, NULL, NULL, &e), e);
  for (int32_t c = 0; c < pm_model_count(m, 1); ++c) {
    const pm_cell *cv = pm_model_cell(m, 1, c);
    if (cv->degenerate) continue;
    for (int k = 1; k < n; ++k) {
      double t = cv->lo[0] + (cv->hi[0] - cv->lo[0]) * k / n, x[3];
      pm_cell_point(cv, &t, x);
      PM_ASSERT_OK(pm_mesh_add_node(mesh, x, 1, c, &t, NULL, &e), e);
    }
  }
  for (int32_t f = 0; f < pm_model_count(m, 2); ++f) {
    const pm_cell *fc = pm_model_cell(m, 2, f);
    for (int a = 1; a < n; ++a)
      for (int b = 1; b < n; ++b) {
        double uv[2] = {fc->lo[0] + (fc->hi[0] - fc->lo[0]) * (a + 0.3 * (b % 2) + 0.137) / n,
                        fc->lo[1] + (fc->hi[1] - fc->lo[1]) * (b + 0.071) / n}, x[3];
        if (!pm_face_inside(fc, uv)) continue;
        pm_cell_point(fc, uv, x);
        PM_ASSERT_OK(pm_mesh_add_node(mesh, x, 2, f, uv, NULL, &e), e);
      }
  }
  return mesh;
}

static double mean_radius_ratio(const pm_mesh *mesh) {
  double s = 0;
  for (int32_t t = 0; t < mesh->ntri; ++t) {
    pm_tri_measure q;
    pm_tri_measure_eval(&mesh->xyz[3 * mesh->tri[3 * t]], &mesh->xyz[3 * mesh->tri[3 * t + 1]],
                        &mesh->xyz[3 * mesh->tri[3 * t + 2]], &q);
    s += q.radius_ratio;
  }
  return s / mesh->ntri;
}

/* Closed shells with the right Euler characteristic on curved solids; the 3D flips improve the
 * triangles. The flips are measured on their own (no affine scaling and no parameter-space
 * flips under the local metric first, which would already do part of their work): mean R/l_min
 * must drop and the mean radius ratio rise. With the default scaling on, flips must not lower
 * the mean radius ratio. The metric flips alone (no scaling, no 3D flips) must raise it too. */
static void curved_faces_flip_and_close(void **state) {
  (void)state;
  const char *cases[] = {"sphere", "torus", "cylinder", "boxhole"};
  for (size_t k = 0; k < sizeof cases / sizeof cases[0]; ++k) {
    pm_model *m = NULL;
    pm_error e = {0};
    PM_ASSERT_OK(pm_case_open(cases[k], &m, NULL, &e), e);
    double rr[2][2];
    for (int affine = 0; affine < 2; ++affine)
      for (int flips = 0; flips < 2; ++flips) {
        pm_mesh *mesh = grid_nodes(m, 24);
        pm_connect_params p;
        pm_connect_params_init(&p);
        p.affine = affine;
        p.metric_flips = 0;
        p.flips = flips ? PM_FLIP_DIAMETRIC : PM_FLIP_NONE;
        pm_connect_report rep;
        PM_ASSERT_OK(pm_connect(m, mesh, &p, &rep, &e), e);
        pm_check_report r = {0};
        check_valid(mesh, m, &r);
        /* One closed shell per volume with the Euler characteristic of its genus. */
        assert_int_equal(r.nshell, pm_model_count(m, 3));
        int genus = strcmp(cases[k], "torus") == 0 || strcmp(cases[k], "boxhole") == 0;
        assert_true(r.shell[0].closed);
        assert_int_equal(r.shell[0].euler, 2 - 2 * genus);
        rr[affine][flips] = mean_radius_ratio(mesh);
        if (flips && !affine) {
          print_message("%s (no affine scaling): %d flips, mean R/l_min on curved faces %.4f -> %.4f\n",
                        cases[k], rep.flips, rep.aspect_before, rep.aspect_after);
          assert_true(rep.flips > 0);
          assert_true(rep.aspect_after < rep.aspect_before);
        }
        pm_check_report_clear(&r);
        pm_mesh_destroy(mesh);
      }
    pm_mesh *mesh = grid_nodes(m, 24);
    pm_connect_params p;
    pm_connect_params_init(&p);
    p.affine = 0;
    p.flips = PM_FLIP_NONE;
    pm_connect_report rep;
    PM_ASSERT_OK(pm_connect(m, mesh, &p, &rep, &e), e);
    pm_check_report r = {0};
    check_valid(mesh, m, &r);
    pm_check_report_clear(&r);
    double rr_metric = mean_radius_ratio(mesh);
    pm_mesh_destroy(mesh);
    print_message("%s: mean radius ratio %.4f -> %.4f (no scaling), %.4f -> %.4f (scaling), "
                  "%.4f (metric flips alone: %d)\n", cases[k], rr[0][0], rr[0][1], rr[1][0],
                  rr[1][1], rr_metric, rep.metric_flips);
    assert_true(rr[0][1] > rr[0][0]);
    assert_true(rr_metric >= rr[0][0] - 1e-12);
    assert_true(rr[1][1] >= rr[1][0] - 1e-12);
    pm_model_destroy(m);
  }
}

/* Even nodes on a sphere model, independent of its parametrization: vertices, curves every ~h
 * of arc length, and a Fibonacci spiral of points (golden-angle steps, equal-area rows)
 * projected onto the face, those within h/2 of a curve node or a pole left out. Near the poles
 * the spiral's nodes sit at irregular angles around the pole, as a mesher's nodes do. */
static pm_mesh *spiral_sphere_nodes(const pm_model *m, int n) {
  pm_mesh *mesh = pm_mesh_create();
  pm_error e = {0};
  double h = sqrt(4 * M_PI / n);
  for (int32_t v = 0; v < pm_model_count(m, 0); ++v)
    PM_ASSERT_OK(pm_mesh_add_node(mesh, pm_model_cell(m, 0, v)->xyz, 0, v, NULL, NULL, &e), e);
  for (int32_t c = 0; c < pm_model_count(m, 1); ++c) {
    const pm_cell *cv = pm_model_cell(m, 1, c);
    if (cv->degenerate) continue;
    int k = (int)ceil(M_PI / h); /* the seam is a half meridian */
    for (int i = 1; i < k; ++i) {
      double t = cv->lo[0] + (cv->hi[0] - cv->lo[0]) * i / k, x[3];
      pm_cell_point(cv, &t, x);
      PM_ASSERT_OK(pm_mesh_add_node(mesh, x, 1, c, &t, NULL, &e), e);
    }
  }
  int32_t nb = mesh->nnode;
  const pm_cell *f = pm_model_cell(m, 2, 0);
  for (int i = 0; i < n; ++i) {
    double z = 1 - (2.0 * i + 1) / n, r = sqrt(1 - z * z), a = i * M_PI * (3 - sqrt(5.0));
    double x[3] = {r * cos(a), r * sin(a), z}, uv[2], y[3];
    int near = 0;
    for (int32_t j = 0; j < nb && !near; ++j) {
      double d[3] = {x[0] - mesh->xyz[3 * j], x[1] - mesh->xyz[3 * j + 1], x[2] - mesh->xyz[3 * j + 2]};
      near = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < 0.25 * h * h;
    }
    if (near) continue;
    PM_ASSERT_OK(pm_cell_project(f, x, NULL, uv, y, NULL, &e), e);
    PM_ASSERT_OK(pm_mesh_add_node(mesh, y, 2, 0, uv, NULL, &e), e);
  }
  return mesh;
}

/* Around a pole the triangles must form a fan of proper triangles (no triangle reaching round
 * the pole, none collapsed on a ruling). The connection's flips work on nodes, the pole being
 * one node with no normal, so they may reshape the fan; with even nodes the worst triangle
 * anywhere on the sphere then keeps a min angle of a good Delaunay triangulation. */
static void pole_fans_on_even_nodes(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_case_open("sphere", &m, NULL, &e), e);
  pm_mesh *mesh = spiral_sphere_nodes(m, 600);
  PM_ASSERT_OK(pm_connect(m, mesh, NULL, NULL, &e), e);
  pm_check_report r = {0};
  check_valid(mesh, m, &r);
  assert_int_equal(r.shell[0].euler, 2);
  double worst = 180, worst_pole = 180;
  for (int32_t t = 0; t < mesh->ntri; ++t) {
    const int32_t *v = &mesh->tri[3 * t];
    pm_tri_measure q;
    pm_tri_measure_eval(&mesh->xyz[3 * v[0]], &mesh->xyz[3 * v[1]], &mesh->xyz[3 * v[2]], &q);
    worst = fmin(worst, q.min_angle);
    for (int k = 0; k < 3; ++k)
      if (mesh->node_dim[v[k]] == 0) worst_pole = fmin(worst_pole, q.min_angle);
  }
  print_message("sphere, %d spiral nodes: min angle %.2f (at the poles %.2f) degrees\n",
                (int)mesh->nnode, worst, worst_pole);
  /* Measured: 34.7 at the poles, 25.9 overall (flips on points, not nodes: 12.5 at a pole). */
  assert_true(worst_pole > 30);
  assert_true(worst > 22);
  pm_check_report_clear(&r);
  pm_mesh_destroy(mesh);
  pm_model_destroy(m);
}

/* The points and unit normals of face f at n parameter pairs uv. */
static void face_nodes(const pm_cell *f, int n, const double *uv, double *xyz, double *nrm) {
  for (int v = 0; v < n; ++v) {
    pm_face_point fp;
    pm_face_eval(f, &uv[2 * v], 1, &fp);
    memcpy(&xyz[3 * v], fp.p, sizeof fp.p);
    pm_v3_cross(&nrm[3 * v], fp.su, fp.sv);
    pm_v3_scale(&nrm[3 * v], &nrm[3 * v], 1 / pm_v3_norm(&nrm[3 * v]));
  }
}

/* face_smooth.h on a hexagonal fan of a planar face: the centre node, pushed off the middle,
 * goes to the centroid of its ring in one sweep (the Laplacian step is taken whole when it
 * improves the ring), the ring's nodes stay, and a second sweep has nothing left to do. */
static void smooth_fan_recentres(void **state) {
  (void)state;
  pm_model *m = square_with_hole(0);
  const pm_cell *f = pm_model_cell(m, PM_FACE, 0);
  double xyz[3 * 7], uv[2 * 7], nrm[3 * 7];
  const uint8_t movable[7] = {1, 0, 0, 0, 0, 0, 0};
  int32_t tri[3 * 6];
  uv[0] = 0.2, uv[1] = -0.1;
  for (int k = 0; k < 6; ++k) {
    uv[2 * (k + 1)] = 0.5 * cos(k * M_PI / 3);
    uv[2 * (k + 1) + 1] = 0.5 * sin(k * M_PI / 3);
    tri[3 * k] = 0, tri[3 * k + 1] = 1 + k, tri[3 * k + 2] = 1 + (k + 1) % 6;
  }
  face_nodes(f, 7, uv, xyz, nrm);
  double ring[3 * 6];
  memcpy(ring, &xyz[3], sizeof ring);
  assert_int_equal(pm_face_smooth_sweep(f, 7, xyz, uv, nrm, movable, 6, tri, 0, NULL), 1);
  PM_ASSERT_NEAR(xyz[0], 0, 1e-12);
  PM_ASSERT_NEAR(xyz[1], 0, 1e-12);
  PM_ASSERT_NEAR(uv[0], 0, 1e-12);
  PM_ASSERT_NEAR(uv[1], 0, 1e-12);
  assert_memory_equal(ring, &xyz[3], sizeof ring);
  assert_int_equal(pm_face_smooth_sweep(f, 7, xyz, uv, nrm, movable, 6, tri, 0, NULL), 0);
  pm_model_destroy(m);
}

/* The smallest angle at node 0 over the triangles tri[3 * nt] (degrees). */
static double angle_at_first(const double *xyz, const int32_t *tri, int nt) {
  double best = 180;
  for (int t = 0; t < nt; ++t) {
    const int32_t *v = &tri[3 * t];
    double u[3], w[3];
    pm_v3_sub(u, &xyz[3 * v[1]], &xyz[3 * v[0]]), pm_v3_sub(w, &xyz[3 * v[2]], &xyz[3 * v[0]]);
    best = fmin(best, acos(pm_v3_dot(u, w) / (pm_v3_norm(u) * pm_v3_norm(w))) * 180 / M_PI);
  }
  return best;
}

/* The smoothing's needle moves (face_smooth.h, needle_deg): a face node 0.6 above four boundary
 * segments of 0.1 has 9.0 to 9.5 degrees at itself in the triangles on them, and the far side of
 * its ring puts the centroid above it, so the Laplacian step (and its half) is refused. With
 * needle_deg 10 one sweep moves it towards the edge of the thinnest one, to where every angle
 * at it exceeds 10 degrees; with 0 it stays. */
static void smooth_needle_moves_towards_short_edges(void **state) {
  (void)state;
  pm_model *m = square_with_hole(0);
  const pm_cell *f = pm_model_cell(m, PM_FACE, 0);
  /* node 0 the face node, 1..5 boundary nodes along y = -0.9, 6..8 the far side */
  const double uv0[2 * 9] = {0, -0.3, -0.2, -0.9, -0.1, -0.9, 0, -0.9, 0.1, -0.9,
                             0.2, -0.9, 0.6, 0.9, 0, 1.0, -0.6, 0.9};
  const int32_t tri[3 * 8] = {0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 5, 0, 5, 6, 0, 6, 7, 0, 7, 8, 0, 8, 1};
  const uint8_t movable[9] = {1, 0, 0, 0, 0, 0, 0, 0, 0};
  for (int needle = 0; needle <= 1; ++needle) {
    double xyz[3 * 9], uv[2 * 9], nrm[3 * 9];
    memcpy(uv, uv0, sizeof uv);
    face_nodes(f, 9, uv, xyz, nrm);
    const double before = angle_at_first(xyz, tri, 8);
    PM_ASSERT_NEAR(before, (atan(0.2 / 0.6) - atan(0.1 / 0.6)) * 180 / M_PI, 1e-9);
    const int32_t moved = pm_face_smooth_sweep(f, 9, xyz, uv, nrm, movable, 8, tri,
                                               needle ? 10.0 : 0.0, NULL);
    const double after = angle_at_first(xyz, tri, 8);
    print_message("needle_deg %d: %d moved, angle at the node %.2f -> %.2f degrees\n",
                  needle ? 10 : 0, (int)moved, before, after);
    if (!needle) {
      assert_int_equal(moved, 0);
      assert_memory_equal(uv, uv0, sizeof uv);
      continue;
    }
    /* towards the nearest point of the thinnest triangle's edge, (-0.1, -0.9), to 0.456 from it
     * (0.1 / (2 tan 6.25 degrees)): (-0.025, -0.45) */
    assert_int_equal(moved, 1);
    PM_ASSERT_NEAR(uv[0], -0.1 + 0.1 * 0.1 / (2 * tan(6.25 * M_PI / 180)) / sqrt(0.37), 1e-9);
    PM_ASSERT_NEAR(uv[1], -0.9 + 0.6 * 0.1 / (2 * tan(6.25 * M_PI / 180)) / sqrt(0.37), 1e-9);
    assert_true(after > 10);
  }
  pm_model_destroy(m);
}

/* The corners of triangles tri[3 * nt] away from node 0 with an angle below `deg`. */
static int small_corners_away(const double *xyz, const int32_t *tri, int nt, double deg) {
  int n = 0;
  for (int t = 0; t < nt; ++t)
    for (int q = 0; q < 3; ++q) {
      const int32_t *v = &tri[3 * t];
      if (v[q] == 0) continue;
      double a[3], b[3];
      pm_v3_sub(a, &xyz[3 * v[(q + 1) % 3]], &xyz[3 * v[q]]);
      pm_v3_sub(b, &xyz[3 * v[(q + 2) % 3]], &xyz[3 * v[q]]);
      n += acos(pm_v3_dot(a, b) / (pm_v3_norm(a) * pm_v3_norm(b))) * 180 / M_PI < deg;
    }
  return n;
}

/* A needle move does not trade the needle at the node for small corners elsewhere: the node
 * 0.6 above a boundary segment of 0.01 (0.95 degrees at it) aims at 0.046 from the segment's
 * nearer end, where two corners of its ring away from it would fall below 10 degrees (9.0 at the
 * far end of the segment three further on): thin triangles, but better than the first one, so
 * the ring's worst R / l_min alone would take the step. The halved step, which leaves no corner
 * away from the node below 10 degrees, is taken instead. */
static void smooth_needle_moves_make_no_new_small_corners(void **state) {
  (void)state;
  pm_model *m = square_with_hole(0);
  const pm_cell *f = pm_model_cell(m, PM_FACE, 0);
  double uv[2 * 9] = {0, -0.3, -0.2, -0.9, -0.19, -0.9, -0.1, -0.9, 0, -0.9,
                      0.1, -0.9, 0.6, 0.3, 0, 0.5, -0.6, 0};
  const int32_t tri[3 * 8] = {0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 5, 0, 5, 6, 0, 6, 7, 0, 7, 8, 0, 8, 1};
  const uint8_t movable[9] = {1, 0, 0, 0, 0, 0, 0, 0, 0};
  double xyz[3 * 9], nrm[3 * 9];
  face_nodes(f, 9, uv, xyz, nrm);
  assert_int_equal(small_corners_away(xyz, tri, 8, 10), 0);
  /* the whole step's target (face_smooth.c, needle_target) and the corner it would make */
  const double aim = 0.01 / (2 * tan(6.25 * M_PI / 180)), d[2] = {0.19, 0.6};
  const double L = sqrt(d[0] * d[0] + d[1] * d[1]);
  const double whole[2] = {-0.19 + aim * d[0] / L, -0.9 + aim * d[1] / L};
  PM_ASSERT_NEAR(atan2(whole[1] + 0.9, 0.1 - whole[0]) * 180 / M_PI, 9.0, 0.1);
  assert_int_equal(pm_face_smooth_sweep(f, 9, xyz, uv, nrm, movable, 8, tri, 10.0, NULL), 1);
  PM_ASSERT_NEAR(uv[0], 0.5 * whole[0], 1e-9);
  PM_ASSERT_NEAR(uv[1], 0.5 * (-0.3 + whole[1]), 1e-9);
  assert_int_equal(small_corners_away(xyz, tri, 8, 10), 0);
  pm_model_destroy(m);
}

/* A face node beside a run of short boundary segments rather than above them: node 0 at (0.3,
 * -0.3), segments of 0.1 from x = -0.15 to 0.15 along y = -0.9, 6.6 to 8.6 degrees at the node.
 * The step towards the thinnest one's edge aims at its nearer end, (-0.05, -0.9), and leaves 9.7
 * degrees there; the try steps again while an angle below 10 degrees remains, so one sweep
 * leaves every angle at the node above 10 (one step a sweep left 9.9-degree needles after the
 * connection's 4 sweeps on robust/step__SampleCrankshaft4A.stp with psys). */
static void smooth_needle_moves_step_again(void **state) {
  (void)state;
  pm_model *m = square_with_hole(0);
  const pm_cell *f = pm_model_cell(m, PM_FACE, 0);
  double uv[2 * 8] = {0.3, -0.3, -0.15, -0.9, -0.05, -0.9, 0.05, -0.9,
                      0.15, -0.9, 0.8, -0.2, 0.3, 0.3, -0.3, -0.1};
  const int32_t tri[3 * 7] = {0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 5, 0, 5, 6, 0, 6, 7, 0, 7, 1};
  const uint8_t movable[8] = {1, 0, 0, 0, 0, 0, 0, 0};
  double xyz[3 * 8], nrm[3 * 8];
  face_nodes(f, 8, uv, xyz, nrm);
  const double before = angle_at_first(xyz, tri, 7);
  PM_ASSERT_NEAR(before, (atan(0.45 / 0.6) - atan(0.35 / 0.6)) * 180 / M_PI, 1e-9);
  /* the first step alone: to 0.456 from (-0.05, -0.9) (0.1 / (2 tan 6.25 degrees)) */
  const double aim = 0.1 / (2 * tan(6.25 * M_PI / 180)), h = sqrt(0.35 * 0.35 + 0.6 * 0.6);
  const double first[2] = {-0.05 + 0.35 * aim / h, -0.9 + 0.6 * aim / h};
  const double at_first = (atan((first[0] + 0.15) / (first[1] + 0.9)) -
                           atan((first[0] + 0.05) / (first[1] + 0.9))) * 180 / M_PI;
  assert_true(at_first > 9 && at_first < 10);
  assert_int_equal(pm_face_smooth_sweep(f, 8, xyz, uv, nrm, movable, 7, tri, 10.0, NULL), 1);
  const double after = angle_at_first(xyz, tri, 7);
  print_message("angle at the node %.2f -> %.2f degrees (one step: %.2f)\n", before, after,
                at_first);
  assert_true(after > 10);
  assert_int_equal(small_corners_away(xyz, tri, 7, 10), 0);
  pm_model_destroy(m);
}

/* A face node too near a long boundary segment: node 0 at (0, -0.85), 0.05 above the segment
 * from (-0.6, -0.9) to (0.6, -0.9), a flat triangle with 4.8 degrees at both ends of the segment
 * (box_sides.step with psys: 161 degrees at a face node 0.10 from a segment 1.28 long). The
 * needle moves aim at small angles at the node and the Laplacian step at the ring's centroid;
 * the flat move lifts the node above its foot to where the segment's ends see 12.5 degrees
 * (0.6 tan 12.5 degrees above it), and no corner of the ring is left below 10 degrees. */
static void smooth_flat_move_lifts_node_off_boundary(void **state) {
  (void)state;
  pm_model *m = square_with_hole(0);
  const pm_cell *f = pm_model_cell(m, PM_FACE, 0);
  double uv[2 * 6] = {0, -0.85, -0.6, -0.9, 0.6, -0.9, 0.6, 0.3, 0, 0.5, -0.6, 0.3};
  const int32_t tri[3 * 5] = {0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 5, 0, 5, 1};
  const uint8_t movable[6] = {1, 0, 0, 0, 0, 0};
  double xyz[3 * 6], nrm[3 * 6];
  face_nodes(f, 6, uv, xyz, nrm);
  assert_int_equal(small_corners_away(xyz, tri, 5, 10), 2);
  assert_int_equal(pm_face_smooth_sweep(f, 6, xyz, uv, nrm, movable, 5, tri, 10.0, NULL), 1);
  PM_ASSERT_NEAR(uv[0], 0.0, 1e-12);
  PM_ASSERT_NEAR(uv[1], -0.9 + 0.6 * tan(12.5 * M_PI / 180), 1e-9);
  assert_int_equal(small_corners_away(xyz, tri, 5, 10), 0);
  pm_model_destroy(m);
}

/* The smoothing's moves on a curved face step once along the node's tangent plane and evaluate
 * the surface there (face_smooth.c, surface_point): a fan on the sphere case, its centre pushed
 * off, is recentred in one sweep with two evaluations (the derivatives at the node, the point
 * of the whole step), where projecting the target onto the surface took six, four of them with
 * second derivatives; the node lies on the sphere, at S of its new
 * parameters, near the ring's centroid carried onto the sphere (the step's error is second order
 * in its length: 0.05 here). The face is
 * a copy of the sphere's cell whose class counts the evaluations. */
static const pm_cell *counted_face;
static int face_evals;

static void counting_face_eval(const pm_cell *self, const double uv[2], int order, pm_face_point *out) {
  (void)self;
  ++face_evals;
  counted_face->cls->face_eval(counted_face, uv, order, out);
}

static void smooth_moves_evaluate_the_surface_once(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_case_open("sphere", &m, NULL, &e), e);
  counted_face = pm_model_cell(m, PM_FACE, 0);
  pm_cell_class cls = *counted_face->cls;
  cls.face_eval = counting_face_eval, cls.face_eval_many = NULL, cls.project = NULL;
  pm_cell f = *counted_face;
  f.cls = &cls;
  const double u0 = 0.5 * (f.lo[0] + f.hi[0]), v0 = 0.5 * (f.lo[1] + f.hi[1]) + 0.3;
  double xyz[3 * 7], uv[2 * 7], nrm[3 * 7];
  const uint8_t movable[7] = {1, 0, 0, 0, 0, 0, 0};
  int32_t tri[3 * 6];
  uv[0] = u0 + 0.04, uv[1] = v0 - 0.03;
  for (int k = 0; k < 6; ++k) {
    uv[2 * (k + 1)] = u0 + 0.12 * cos(k * M_PI / 3) / cos(v0);
    uv[2 * (k + 1) + 1] = v0 + 0.12 * sin(k * M_PI / 3);
    tri[3 * k] = 0, tri[3 * k + 1] = 1 + k, tri[3 * k + 2] = 1 + (k + 1) % 6;
  }
  face_nodes(counted_face, 7, uv, xyz, nrm);
  double centroid[3] = {0, 0, 0}, before[3];
  for (int k = 1; k <= 6; ++k) pm_v3_axpy(centroid, centroid, 1.0 / 6, &xyz[3 * k]);
  pm_v3_scale(centroid, centroid, 1 / pm_v3_norm(centroid)); /* onto the unit sphere */
  memcpy(before, xyz, sizeof before);
  face_evals = 0;
  assert_int_equal(pm_face_smooth_sweep(&f, 7, xyz, uv, nrm, movable, 6, tri, 10.0, NULL), 1);
  print_message("sphere fan: %d surface evaluations, the node %.2e from the centroid (it was %.2e)\n",
                face_evals, pm_v3_dist(xyz, centroid), pm_v3_dist(before, centroid));
  assert_int_equal(face_evals, 2);
  double s[3];
  pm_cell_point(counted_face, uv, s);
  assert_true(pm_v3_dist2(s, xyz) < 1e-24);
  PM_ASSERT_NEAR(pm_v3_norm(xyz), 1.0, 1e-12);
  assert_true(pm_v3_dist(xyz, centroid) < 0.05 * pm_v3_dist(before, centroid));
  pm_model_destroy(m);
}

/* The connection's smoothing (smooth > 0) on curved faces: the same nodes and as many
 * triangles, vertex and curve nodes where they were, face nodes moved along their face (each at
 * S(u, v) of its new parameters), a valid mesh whose mean R / l_min is lower than without it, and
 * the same mesh from the same nodes. */
static void smoothing_on_curved_faces(void **state) {
  (void)state;
  const char *cases[] = {"sphere", "torus", "cylinder"};
  for (size_t k = 0; k < sizeof cases / sizeof cases[0]; ++k) {
    pm_model *m = NULL;
    pm_error e = {0};
    PM_ASSERT_OK(pm_case_open(cases[k], &m, NULL, &e), e);
    pm_mesh *plain = grid_nodes(m, 24), *smooth = grid_nodes(m, 24), *again = grid_nodes(m, 24);
    pm_connect_params p;
    pm_connect_params_init(&p);
    PM_ASSERT_OK(pm_connect(m, plain, &p, NULL, &e), e);
    p.smooth = 4;
    pm_connect_report rep;
    PM_ASSERT_OK(pm_connect(m, smooth, &p, &rep, &e), e);
    PM_ASSERT_OK(pm_connect(m, again, &p, NULL, &e), e);
    pm_check_report r = {0};
    check_valid(smooth, m, &r);
    pm_check_report_clear(&r);
    assert_int_equal(smooth->nnode, plain->nnode);
    assert_int_equal(smooth->ntri, plain->ntri);
    assert_true(rep.smooth_moves > 0);
    int32_t moved = 0;
    for (int32_t i = 0; i < smooth->nnode; ++i) {
      const double *x = &smooth->xyz[3 * i];
      int same = memcmp(x, &plain->xyz[3 * i], 3 * sizeof(double)) == 0;
      if (smooth->node_dim[i] != PM_FACE) {
        assert_true(same);
        continue;
      }
      moved += !same;
      double s[3];
      pm_cell_point(pm_model_cell(m, PM_FACE, smooth->node_cell[i]), &smooth->node_par[2 * i], s);
      assert_true(pm_v3_dist2(s, x) < 1e-20);
    }
    double sum[2] = {0, 0};
    pm_mesh *ms[2] = {plain, smooth};
    for (int w = 0; w < 2; ++w)
      for (int32_t t = 0; t < ms[w]->ntri; ++t) {
        pm_tri_measure q;
        const int32_t *v = &ms[w]->tri[3 * t];
        pm_tri_measure_eval(&ms[w]->xyz[3 * v[0]], &ms[w]->xyz[3 * v[1]], &ms[w]->xyz[3 * v[2]], &q);
        sum[w] += q.aspect_ratio;
      }
    print_message("%s: %d of %d nodes moved (%d moves), mean R/l_min %.4f -> %.4f\n", cases[k],
                  moved, smooth->nnode, rep.smooth_moves, sum[0] / plain->ntri,
                  sum[1] / smooth->ntri);
    assert_true(moved > smooth->nnode / 4);
    assert_true(sum[1] / smooth->ntri < sum[0] / plain->ntri - 0.01);
    assert_memory_equal(again->xyz, smooth->xyz, sizeof(double) * 3 * (size_t)smooth->nnode);
    assert_memory_equal(again->tri, smooth->tri, sizeof(int32_t) * 3 * (size_t)smooth->ntri);
    pm_mesh_destroy(plain), pm_mesh_destroy(smooth), pm_mesh_destroy(again);
    pm_model_destroy(m);
  }
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(planar_square),
      cmocka_unit_test(planar_hole_and_determinism),
      cmocka_unit_test(bad_nodes_rejected),
      cmocka_unit_test(curved_faces_flip_and_close),
      cmocka_unit_test(pole_fans_on_even_nodes),
      cmocka_unit_test(smooth_fan_recentres),
      cmocka_unit_test(smooth_needle_moves_towards_short_edges),
      cmocka_unit_test(smooth_needle_moves_make_no_new_small_corners),
      cmocka_unit_test(smooth_needle_moves_step_again),
      cmocka_unit_test(smooth_flat_move_lifts_node_off_boundary),
      cmocka_unit_test(smooth_moves_evaluate_the_surface_once),
      cmocka_unit_test(smoothing_on_curved_faces),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
