/* Tests of distance.c: the two-sided mesh-to-model distance against closed-form answers (a plane
 * meshed in its plane, a lifted node, the sagitta of an inscribed polygon, the chordal error of an
 * inscribed sphere polyhedron, a dangling wire), classified against unclassified meshes, thread-
 * count independence, the pruned searches and split reference quads against the previous code
 * paths, parameters and bad input. */
#include "test_rect_model.h"

#include <gmshc.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "common/backends/closest_embree.h"
#include "common/measure/distance.h"
#include "common/geom/geom_analytic.h"
#include "common/geom/geom_cad.h"
#include "common/input/cases.h"
#include "common/input/input.h"
#include "common/mesh/mesh.h"
#include "common/base/vec3.h"
#include "common/sizing/sizing.h"

/* ---- models and meshes ----------------------------------------------------------------------- */

static pm_model *square_model(void) { return pm_test_rect_model("square", 1); }

static pm_model *disk_model(double R) {
  const pm_planar_piece arc[1] = {{PM_PIECE_ARC, {R, 0}, {0, 0}, 1}};
  pm_planar_loop l = {1, arc};
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_planar_model("disk", 1, &l, &m, &e), e);
  return m;
}

/* The unit square as an n x n grid of cells, two triangles each, in z = 0; classified on face 0
 * with (u, v) = (x, y) when `classify`. */
static pm_mesh *square_mesh(int n, int classify) {
  pm_mesh *me = pm_mesh_create();
  pm_error e = {0};
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      double p[3] = {(double)i / n, (double)j / n, 0}, uv[2] = {p[0], p[1]};
      PM_ASSERT_OK(pm_mesh_add_node(me, p, classify ? PM_FACE : -1, classify ? 0 : -1,
                                    classify ? uv : NULL, NULL, &e), e);
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      int32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      PM_ASSERT_OK(pm_mesh_add_tri(me, a, b, d, classify ? 0 : -1, &e), e);
      PM_ASSERT_OK(pm_mesh_add_tri(me, a, d, c, classify ? 0 : -1, &e), e);
    }
  return me;
}

/* The regular n-gon inscribed in the circle of radius R, as a fan of n triangles around the
 * centre. */
static pm_mesh *fan_mesh(int n, double R) {
  pm_mesh *me = pm_mesh_create();
  pm_error e = {0};
  const double o[3] = {0, 0, 0};
  PM_ASSERT_OK(pm_mesh_add_node(me, o, -1, -1, NULL, NULL, &e), e);
  for (int k = 0; k < n; ++k) {
    double p[3] = {R * cos(2 * M_PI * k / n), R * sin(2 * M_PI * k / n), 0};
    PM_ASSERT_OK(pm_mesh_add_node(me, p, -1, -1, NULL, NULL, &e), e);
  }
  for (int k = 0; k < n; ++k) PM_ASSERT_OK(pm_mesh_add_tri(me, 0, 1 + k, 1 + (k + 1) % n, -1, &e), e);
  return me;
}

/* ---- plane ---------------------------------------------------------------------------------- */

static void test_square_in_plane_is_zero(void **state) {
  (void)state;
  pm_model *m = square_model();
  for (int classify = 0; classify < 2; ++classify) {
    pm_mesh *me = square_mesh(8, classify);
    pm_distance d;
    pm_error e = {0};
    PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, NULL, &d, &e), e);
    PM_ASSERT_NEAR(d.max, 0.0, 1e-14);
    PM_ASSERT_NEAR(d.mean, 0.0, 1e-14);
    PM_ASSERT_NEAR(d.mesh_to_model_max, 0.0, 1e-14);
    PM_ASSERT_NEAR(d.model_to_mesh_max, 0.0, 1e-14);
    PM_ASSERT_NEAR(d.bbox_diagonal, sqrt(2.0), 1e-12);
    assert_int_equal(d.tri_level, 4);
    /* Each lattice point once: 81 nodes, 3 points on each of the 208 edges, 3 inside each of
     * the 128 triangles (level 4). */
    assert_int_equal(d.nsamples_mesh, 81 + 3 * 208 + 3 * 128);
    assert_true(d.nsamples_model > 1000);
    assert_int_equal(d.nfallback, 0);
    assert_int_equal(d.has_size, 0);
    pm_mesh_destroy(me);
  }
  pm_model_destroy(m);
}

/* One interior node lifted by delta: the mesh -> model maximum is delta (at the node), the mean
 * is the exact mean height of the mesh (z is linear on each triangle, and the lattice average of
 * a linear function is its mean); the model point under the node is within delta of the tent. */
static void test_square_lifted_node(void **state) {
  (void)state;
  pm_model *m = square_model();
  const int n = 8;
  const double delta = 0.01;
  for (int classify = 0; classify < 2; ++classify) {
    pm_mesh *me = square_mesh(n, classify);
    int32_t mid = (n / 2) * (n + 1) + n / 2;
    me->xyz[3 * mid + 2] = delta;
    pm_distance d;
    pm_error e = {0};
    PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, NULL, &d, &e), e);
    PM_ASSERT_NEAR(d.mesh_to_model_max, delta, 1e-14);
    PM_ASSERT_NEAR(d.max, delta, 1e-14);
    assert_int_equal(d.max_from_model, 0);
    PM_ASSERT_NEAR(d.max_at[0], 0.5, 1e-14);
    PM_ASSERT_NEAR(d.max_at[1], 0.5, 1e-14);
    double sum_az = 0, sum_a = 0;
    for (int32_t t = 0; t < me->ntri; ++t) {
      const int32_t *v = &me->tri[3 * t];
      double ab[3], ac[3], nn[3], z = 0;
      for (int k = 0; k < 3; ++k) {
        ab[k] = me->xyz[3 * v[1] + k] - me->xyz[3 * v[0] + k];
        ac[k] = me->xyz[3 * v[2] + k] - me->xyz[3 * v[0] + k];
        z += me->xyz[3 * v[k] + 2] / 3;
      }
      nn[0] = ab[1] * ac[2] - ab[2] * ac[1], nn[1] = ab[2] * ac[0] - ab[0] * ac[2], nn[2] = ab[0] * ac[1] - ab[1] * ac[0];
      double a = 0.5 * sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
      sum_az += a * z, sum_a += a;
    }
    PM_ASSERT_NEAR(d.mesh_to_model_mean, sum_az / sum_a, 1e-12 * delta);
    /* Model -> mesh: at most delta, and most of it right under the node (the tent's faces have
     * slope delta / h, so the distance there is delta / sqrt(1 + (delta n)^2) for this grid). */
    assert_true(d.model_to_mesh_max <= delta);
    assert_true(d.model_to_mesh_max > 0.99 * delta / sqrt(1 + (delta * n) * (delta * n)));
    pm_mesh_destroy(me);
  }
  pm_model_destroy(m);
}

/* ---- disk: the sagitta of an inscribed polygon ------------------------------------------------- */

static void test_disk_sagitta(void **state) {
  (void)state;
  const double R = 1.3;
  pm_model *m = disk_model(R);
  const int ns[3] = {6, 16, 64};
  for (int q = 0; q < 3; ++q) {
    int n = ns[q];
    pm_mesh *me = fan_mesh(n, R);
    pm_distance d;
    pm_error e = {0};
    PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, NULL, &d, &e), e);
    double sag = R * (1 - cos(M_PI / n));
    /* The triangles lie in the disk's plane, inside it (the polygon's corners, on the circle,
     * are projected onto it: rounding only). */
    PM_ASSERT_NEAR(d.mesh_to_model_max, 0.0, 1e-12);
    /* The disk's boundary bulges out of the polygon by the sagitta, at the arcs' midpoints. */
    PM_ASSERT_NEAR(d.model_to_mesh_max, sag, 1e-3 * sag);
    PM_ASSERT_NEAR(d.max, sag, 1e-3 * sag);
    assert_int_equal(d.max_from_model, 1);
    PM_ASSERT_NEAR(hypot(d.max_at[0], d.max_at[1]), R, 1e-9);
    pm_mesh_destroy(me);
  }
  pm_model_destroy(m);
}

/* A triangle whose three nodes lie on the face's boundary curves takes its projections' start
 * from them, through the curve's pcurve on the face: a polygon inscribed in the disk, split
 * into a fan from its first corner (every node on the circle, classified on it with its
 * parameter), gives every sample a start (before, none had one: nhintless was the sample
 * count). */
static void test_boundary_triangles_start_from_the_curves(void **state) {
  (void)state;
  const double R = 1.3;
  const int n = 16;
  pm_model *m = disk_model(R);
  const pm_cell *circle = &m->cells[PM_CURVE][0];
  pm_mesh *me = pm_mesh_create();
  pm_error e = {0};
  for (int k = 0; k < n; ++k) {
    double p[3] = {R * cos(2 * M_PI * k / n), R * sin(2 * M_PI * k / n), 0}, t[2] = {0, 0};
    PM_ASSERT_OK(pm_cell_project(circle, p, NULL, t, NULL, NULL, &e), e);
    PM_ASSERT_OK(pm_mesh_add_node(me, p, PM_CURVE, 0, t, NULL, &e), e);
  }
  for (int k = 1; k + 1 < n; ++k) PM_ASSERT_OK(pm_mesh_add_tri(me, 0, k, k + 1, 0, &e), e);
  pm_distance d;
  PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, NULL, &d, &e), e);
  PM_ASSERT_NEAR(d.mesh_to_model_max, 0.0, 1e-12);
  const double sag = R * (1 - cos(M_PI / n));
  PM_ASSERT_NEAR(d.model_to_mesh_max, sag, 1e-3 * sag);
  assert_int_equal(d.nhintless, 0);
  assert_true(d.nsamples_mesh > 0);
  pm_mesh_destroy(me);
  pm_model_destroy(m);
}

/* A polygon whose vertices lie just inside the circle, between the circle and the face's trimming
 * polyline (which cuts the arc's corners by up to a quarter of the feature floor, here 2.8e-5,
 * and at least a quarter of that at a chord's middle): those points are in the face, at
 * distance 0, even though the polyline-based inside test says "outside" there. */
static void test_disk_points_between_polyline_and_circle(void **state) {
  (void)state;
  const double R = 1.3;
  pm_model *m = disk_model(R);
  const pm_cell *f = &m->cells[PM_FACE][0];
  const int n = 7;
  pm_mesh *me = fan_mesh(n, R * (1 - 2e-6));
  int outside = 0;
  for (int k = 1; k <= n; ++k) outside += !pm_face_inside(f, &me->xyz[3 * k]);
  assert_true(outside > 0); /* the situation the test is about does occur */
  pm_distance d;
  pm_error e = {0};
  PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, NULL, &d, &e), e);
  PM_ASSERT_NEAR(d.mesh_to_model_max, 0.0, 1e-12); /* rounding, not the inset 2.6e-6 */
  /* Just outside the circle instead: the distance is the radial offset. */
  pm_mesh_destroy(me);
  me = fan_mesh(n, R * (1 + 2e-5));
  PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, NULL, &d, &e), e);
  PM_ASSERT_NEAR(d.mesh_to_model_max, 2e-5 * R, 1e-12);
  pm_mesh_destroy(me);
  pm_model_destroy(m);
}

/* An annulus meshed by a ring of triangles between two regular 1024-gons inscribed in its circles.
 * Mesh -> model: the inner polygon's edges cut into the hole by r (1 - cos(pi/1024)), less than
 * the hole's trimming polyline does (its chords span 0.0123 radians), so only the curve itself can tell that those points are off
 * the face. Model -> mesh: the outer circle bulges out of the outer polygon by
 * R (1 - cos(pi/1024)); the hole's circle lies inside the ring of triangles. */
static void test_annulus_hole_sagitta(void **state) {
  (void)state;
  const double R = 1.0, r = 0.4;
  const int n = 1024;
  const pm_planar_piece outer[1] = {{PM_PIECE_ARC, {R, 0}, {0, 0}, 1}};
  const pm_planar_piece hole[1] = {{PM_PIECE_ARC, {r, 0}, {0, 0}, 0}};
  pm_planar_loop loops[2] = {{1, outer}, {1, hole}};
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_planar_model("annulus", 2, loops, &m, &e), e);
  pm_mesh *me = pm_mesh_create();
  for (int k = 0; k < n; ++k) {
    double a = 2 * M_PI * k / n;
    double po[3] = {R * cos(a), R * sin(a), 0}, pi[3] = {r * cos(a), r * sin(a), 0};
    PM_ASSERT_OK(pm_mesh_add_node(me, po, -1, -1, NULL, NULL, &e), e);
    PM_ASSERT_OK(pm_mesh_add_node(me, pi, -1, -1, NULL, NULL, &e), e);
  }
  for (int k = 0; k < n; ++k) {
    int32_t o0 = 2 * k, i0 = 2 * k + 1, o1 = 2 * ((k + 1) % n), i1 = o1 + 1;
    PM_ASSERT_OK(pm_mesh_add_tri(me, i0, o0, o1, -1, &e), e);
    PM_ASSERT_OK(pm_mesh_add_tri(me, i0, o1, i1, -1, &e), e);
  }
  /* The hole's inscribed polygon lies inside the polyline region of the face: the polyline-based
   * test alone would put the inner edges on the face. */
  const pm_cell *f = &m->cells[PM_FACE][0];
  double mid[2] = {0.5 * (me->xyz[3] + me->xyz[9]), 0.5 * (me->xyz[4] + me->xyz[10])};
  assert_true(pm_face_inside(f, mid));
  pm_distance d;
  PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, NULL, &d, &e), e);
  double sag_in = r * (1 - cos(M_PI / n)), sag_out = R * (1 - cos(M_PI / n));
  PM_ASSERT_NEAR(d.mesh_to_model_max, sag_in, 1e-3 * sag_in);
  PM_ASSERT_NEAR(d.model_to_mesh_max, sag_out, 1e-3 * sag_out);
  pm_mesh_destroy(me);
  pm_model_destroy(m);
}

/* The means over the disk: zero inside the polygon, the distance to the chord in each circular
 * segment. Per segment of half-angle a (c = R cos a):
 *   int (x - c) dA = (2/3) R^3 sin^3 a - c R^2 (a - sin a cos a),
 * model -> mesh mean = n x that / (pi R^2); two-sided mean = n x that / (pi R^2 + polygon area).
 * Dense sampling makes the grid quadrature good to about a percent. */
static void test_disk_means_and_size(void **state) {
  (void)state;
  const double R = 1.0;
  const int n = 6;
  pm_model *m = disk_model(R);
  pm_mesh *me = fan_mesh(n, R);
  pm_distance_params p;
  pm_distance_params_init(&p);
  p.spacing = 0.02;
  p.model_per_tri = 1000000; /* dense sampling whatever the (6-triangle) mesh */
  pm_sizing *sz = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_sizing_constant(0.5, &sz, &e), e);
  pm_distance d;
  PM_ASSERT_OK(pm_mesh_distance(me, m, sz, &p, &d, &e), e);
  double a = M_PI / n, c = R * cos(a);
  double I = (2.0 / 3.0) * R * R * R * pow(sin(a), 3) - c * R * R * (a - sin(a) * cos(a));
  double disk = M_PI * R * R, poly = 0.5 * n * R * R * sin(2 * a);
  PM_ASSERT_NEAR(d.model_to_mesh_mean, n * I / disk, 0.02 * n * I / disk);
  PM_ASSERT_NEAR(d.mean, n * I / (disk + poly), 0.02 * n * I / (disk + poly));
  PM_ASSERT_NEAR(d.mesh_to_model_mean, 0.0, 1e-14);
  /* Relative to a constant size 0.5: twice the distances. */
  assert_int_equal(d.has_size, 1);
  PM_ASSERT_NEAR(d.rel_mean, d.mean / 0.5, 1e-12);
  PM_ASSERT_NEAR(d.rel_max, d.max / 0.5, 1e-12);
  pm_sizing_destroy(sz);
  pm_mesh_destroy(me);
  pm_model_destroy(m);
}

/* ---- sphere: the chordal error of an inscribed polyhedron ----------------------------------------- */

/* A subdivided octahedron with its vertices on the unit sphere (welded: nodes shared between
 * faces), k subdivisions per octant edge. When `classify`, triangles are tagged with face 0 and
 * every node off the poles carries its sphere (u, v) = (longitude in [0, 2 pi), latitude) -- so
 * that triangles across the seam u = 0 have nodes at u near 0 and near 2 pi. */
static pm_mesh *octasphere(int k, int classify) {
  pm_mesh *me = pm_mesh_create();
  pm_error e = {0};
  const double V[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  const int F[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  int per = (k + 1) * (k + 2) / 2;
  int32_t *id = malloc(sizeof(int32_t) * 8 * per);
  double *pts = NULL;
  int32_t np = 0;
  for (int f = 0; f < 8; ++f)
    for (int i = 0; i <= k; ++i)
      for (int j = 0; i + j <= k; ++j) {
        double p[3], s = 0;
        for (int q = 0; q < 3; ++q) {
          p[q] = ((k - i - j) * V[F[f][0]][q] + i * V[F[f][1]][q] + j * V[F[f][2]][q]) / k;
          s += p[q] * p[q];
        }
        for (int q = 0; q < 3; ++q) p[q] /= sqrt(s);
        /* Weld: identical coordinates are produced for shared edge points (exact integer
         * combinations before the normalization). */
        int32_t found = -1;
        for (int32_t r = 0; r < np && found < 0; ++r)
          if (pts[3 * r] == p[0] && pts[3 * r + 1] == p[1] && pts[3 * r + 2] == p[2]) found = r;
        if (found < 0) {
          pts = realloc(pts, sizeof(double) * 3 * (size_t)(np + 1));
          memcpy(&pts[3 * np], p, sizeof p);
          found = np++;
          int pole = p[0] == 0 && p[1] == 0;
          double uv[2] = {atan2(p[1], p[0]), asin(fmax(-1.0, fmin(1.0, p[2])))};
          if (uv[0] < 0) uv[0] += 2 * M_PI;
          int cls = classify && !pole;
          PM_ASSERT_OK(pm_mesh_add_node(me, p, cls ? PM_FACE : -1, cls ? 0 : -1, cls ? uv : NULL, NULL, &e), e);
        }
        id[f * per + i * (k + 1) - i * (i - 1) / 2 + j] = found;
      }
  for (int f = 0; f < 8; ++f) {
#define ID(i, j) id[f * per + (i) * (k + 1) - (i) * ((i)-1) / 2 + (j)]
    for (int i = 0; i < k; ++i)
      for (int j = 0; i + j < k; ++j) {
        PM_ASSERT_OK(pm_mesh_add_tri(me, ID(i, j), ID(i + 1, j), ID(i, j + 1), classify ? 0 : -1, &e), e);
        if (i + j + 1 < k)
          PM_ASSERT_OK(pm_mesh_add_tri(me, ID(i + 1, j), ID(i + 1, j + 1), ID(i, j + 1), classify ? 0 : -1, &e), e);
      }
#undef ID
  }
  free(id), free(pts);
  return me;
}

/* The largest distance from the unit sphere of a point of the polyhedron: per triangle,
 * 1 - (the distance from the origin to the triangle); where the origin's foot on the plane (the
 * circumcentre) lies in the triangle this is 1 - |n . a| for the unit normal n. */
static double sphere_chord_max(const pm_mesh *me, int *all_acute) {
  double best = 0;
  const double o[3] = {0, 0, 0};
  *all_acute = 1;
  for (int32_t t = 0; t < me->ntri; ++t) {
    const int32_t *v = &me->tri[3 * t];
    const double *a = &me->xyz[3 * v[0]], *b = &me->xyz[3 * v[1]], *c = &me->xyz[3 * v[2]];
    double q[3], w[3];
    double dist = pm_point_triangle_closest(o, a, b, c, q, w);
    if (!(w[0] > 0 && w[1] > 0 && w[2] > 0)) *all_acute = 0;
    double ab[3], ac[3], nn[3];
    for (int k = 0; k < 3; ++k) ab[k] = b[k] - a[k], ac[k] = c[k] - a[k];
    nn[0] = ab[1] * ac[2] - ab[2] * ac[1], nn[1] = ab[2] * ac[0] - ab[0] * ac[2], nn[2] = ab[0] * ac[1] - ab[1] * ac[0];
    double ln = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
    double na = fabs(nn[0] * a[0] + nn[1] * a[1] + nn[2] * a[2]) / ln;
    if (w[0] > 0 && w[1] > 0 && w[2] > 0) PM_ASSERT_NEAR(dist, na, 1e-12);
    best = fmax(best, 1 - dist);
  }
  return best;
}

static void test_sphere_chordal_error(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_case_open("sphere", &m, NULL, &e), e);
  double dmax[2];
  for (int classify = 0; classify < 2; ++classify) {
    pm_mesh *me = octasphere(6, classify);
    int acute;
    double expect = sphere_chord_max(me, &acute);
    assert_true(acute);
    pm_distance d;
    PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, NULL, &d, &e), e);
    if (getenv("PM_TEST_VERBOSE"))
      printf("sphere classify=%d expect %.10g m2M %.10g M2m %.10g mean %.6g/%.6g ref_chord %.3g nmesh %lld nmodel %lld\n",
             classify, expect, d.mesh_to_model_max, d.model_to_mesh_max, d.mesh_to_model_mean,
             d.model_to_mesh_mean, d.ref_chord, (long long)d.nsamples_mesh, (long long)d.nsamples_model);
    /* Mesh -> model: the distance of a point x inside the sphere is 1 - |x|. */
    PM_ASSERT_NEAR(d.mesh_to_model_max, expect, 1e-3 * expect);
    /* Model -> mesh: the sphere point above the worst triangle's circumcentre is as far from the
     * polyhedron as that circumcentre is from the sphere. */
    PM_ASSERT_NEAR(d.model_to_mesh_max, expect, 1e-3 * expect);
    PM_ASSERT_NEAR(d.bbox_diagonal, 2 * sqrt(3.0), 1e-6);
    assert_int_equal(d.nfallback, 0);
    /* The reference tessellation (at most ref_per_tri = 16 points per mesh triangle) has a
     * chordal error well below the mesh's own, measured here; it only seeds the projections. */
    assert_true(d.ref_chord > 0 && d.ref_chord < 0.05 * expect);
    /* Classified, every sample finds its foot from its own triangle on the one face: the
     * reference's hierarchy is never needed, so never built. Unclassified, it starts them all. */
    assert_int_equal(d.ref_tree_built, !classify);
    dmax[classify] = d.mesh_to_model_max;
    /* The mean mesh -> model distance is below the maximum and of its order. */
    assert_true(d.mesh_to_model_mean > 0.2 * expect && d.mesh_to_model_mean < expect);
    pm_mesh_destroy(me);
  }
  /* The classification hints (with the seam unwrapped) only speed things up: same answer. */
  PM_ASSERT_NEAR(dmax[0], dmax[1], 1e-9);
  pm_model_destroy(m);
}

/* The mesh side's mean is the integral of the distance over the mesh, divided by its area: on
 * the octasphere inside the unit sphere the distance of x is 1 - |x|, integrated here over each
 * triangle by the centroids of its 48 x 48 subdivision (the reference, exact to about 1e-7 of
 * itself). The composite quadratic rule (quadrature 2, the default) gets it within 1e-3, the
 * piecewise-linear one (1) within 10% below, equal weights (0, the previous path) a quarter
 * below, as the chordal deviation vanishes at the nodes that make most of the lattice. */
static void test_mesh_side_mean_is_its_integral(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_case_open("sphere", &m, NULL, &e), e);
  pm_mesh *me = octasphere(6, 1);
  const int L = 48;
  double integral = 0, area = 0;
  for (int32_t t = 0; t < me->ntri; ++t) {
    const int32_t *v = &me->tri[3 * t];
    const double *a = &me->xyz[3 * v[0]], *b = &me->xyz[3 * v[1]], *c = &me->xyz[3 * v[2]];
    double ab[3], ac[3], n[3];
    pm_v3_sub(ab, b, a), pm_v3_sub(ac, c, a), pm_v3_cross(n, ab, ac);
    const double A = 0.5 * pm_v3_norm(n);
    double sum = 0;
    /* the small triangles' centroids: (i + 1/3, j + 1/3) upright, (i + 2/3, j + 2/3) inverted */
    for (int i = 0; i < L; ++i)
      for (int j = 0; i + j < L; ++j)
        for (int up = 0; up < 2 - (i + j + 1 == L); ++up) {
          const double s = (i + (up ? 2.0 : 1.0) / 3) / L, r = (j + (up ? 2.0 : 1.0) / 3) / L;
          double x[3];
          for (int k = 0; k < 3; ++k) x[k] = a[k] + s * ab[k] + r * ac[k];
          sum += 1 - pm_v3_norm(x);
        }
    integral += A * sum / ((double)L * L), area += A;
  }
  const double exact = integral / area;
  /* The same rule summed here over the level-4 lattice of every triangle, from the sphere's
   * exact distances: the projections stop once a distance is known to 1e-12 of the diagonal
   * (FOOT_VALUE_TOL), and the mean agrees with it to that. */
  double rule = 0;
  for (int32_t t = 0; t < me->ntri; ++t) {
    const int32_t *v = &me->tri[3 * t];
    const double *a = &me->xyz[3 * v[0]], *b = &me->xyz[3 * v[1]], *c = &me->xyz[3 * v[2]];
    double ab[3], ac[3], n[3];
    pm_v3_sub(ab, b, a), pm_v3_sub(ac, c, a), pm_v3_cross(n, ab, ac);
    for (int i = 0; i <= 4; ++i)
      for (int j = 0; i + j <= 4; ++j) {
        if (i % 2 == 0 && j % 2 == 0) continue; /* on the level-2 lattice: weight 0 */
        const int boundary = i == 0 || j == 0 || i + j == 4;
        double x[3];
        for (int k = 0; k < 3; ++k) x[k] = a[k] + 0.25 * i * ab[k] + 0.25 * j * ac[k];
        rule += 0.5 * pm_v3_norm(n) * (boundary ? 1.0 / 12 : 1.0 / 6) * (1 - pm_v3_norm(x));
      }
  }
  rule /= area;
  pm_distance_params p;
  pm_distance_params_init(&p);
  assert_int_equal(p.quadrature, 2);
  pm_distance d2, d1, d0;
  PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, &p, &d2, &e), e);
  p.quadrature = 1;
  PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, &p, &d1, &e), e);
  p.quadrature = 0;
  PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, &p, &d0, &e), e);
  print_message("octasphere: mesh -> model mean %.6e (quadratic rule) %.6e (piecewise linear) "
                "%.6e (equal weights), integral %.6e, the rule summed here %.15e (measured %.15e); "
                "model -> mesh %.6e\n", d2.mesh_to_model_mean, d1.mesh_to_model_mean,
                d0.mesh_to_model_mean, exact, rule, d2.mesh_to_model_mean, d2.model_to_mesh_mean);
  PM_ASSERT_NEAR(d2.mesh_to_model_mean, exact, 1e-3 * exact);
  PM_ASSERT_NEAR(d2.mesh_to_model_mean, rule, 1e-12 * d2.bbox_diagonal);
  assert_true(d1.mesh_to_model_mean < exact && d1.mesh_to_model_mean > 0.9 * exact);
  assert_true(d0.mesh_to_model_mean < 0.8 * exact);
  /* The weights change the mean only: the same samples, the same maximum. */
  assert_true(d0.mesh_to_model_max == d2.mesh_to_model_max && d1.mesh_to_model_max == d2.mesh_to_model_max);
  assert_int_equal(d0.nsamples_mesh, d2.nsamples_mesh);
  pm_mesh_destroy(me);
  pm_model_destroy(m);
}

/* The refinement's quadratic jumps (refine_fit) reach the same smooth maxima with fewer
 * surface evaluations: on the octasphere the worst triangle's maximum is at the foot of its
 * circumcentre, and both searches find it to 1e-9 of itself. The sphere's class is replaced by
 * one that counts the evaluations. */
static const pm_cell_class *sphere_class;
static long sphere_evals;

static void counting_eval(const pm_cell *self, const double uv[2], int order, pm_face_point *out) {
  ++sphere_evals;
  sphere_class->face_eval(self, uv, order, out);
}

static void test_refine_fit_saves_evaluations(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_case_open("sphere", &m, NULL, &e), e);
  pm_cell *f = &m->cells[PM_FACE][0];
  sphere_class = f->cls;
  pm_cell_class cls = *f->cls;
  cls.face_eval = counting_eval, cls.face_eval_many = NULL;
  f->cls = &cls;
  pm_mesh *me = octasphere(6, 1);
  int acute;
  const double expect = sphere_chord_max(me, &acute);
  pm_distance_params p;
  pm_distance_params_init(&p);
  assert_int_equal(p.refine_fit, 1);
  pm_distance d[2];
  long evals[2];
  for (int fit = 0; fit < 2; ++fit) {
    p.refine_fit = fit;
    sphere_evals = 0;
    PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, &p, &d[fit], &e), e);
    evals[fit] = sphere_evals;
    PM_ASSERT_NEAR(d[fit].mesh_to_model_max, expect, 1e-9 * expect);
  }
  print_message("octasphere: %ld evaluations with the jumps, %ld halving only\n", evals[1], evals[0]);
  assert_true(d[0].mesh_to_model_mean == d[1].mesh_to_model_mean);
  /* The samples' evaluations are the same: the difference is the refinements' alone. */
  assert_true(evals[1] < evals[0]);
  f->cls = sphere_class;
  pm_mesh_destroy(me);
  pm_model_destroy(m);
}

/* Nodes whose parameters do not put them on their cell (a .msh read back without parameters
 * has zeros there) do not start projections: the figures are those of the same mesh with its
 * parameters. On an OpenCASCADE sphere, projections started at (0, 0) stop at local minima up to
 * 1.4 from the foot, and the maximum read 1.41 instead of 0.0028. */
static void test_wrong_parameters_are_not_trusted(void **state) {
  (void)state;
  if (!pm_test_have_cad()) skip();
  char path[512];
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_input_open(pm_test_cad("synth_sphere.brep", path, sizeof path), &m, NULL, &e), e);
  /* The octasphere's (u, v) are the analytic sphere's; the OpenCASCADE sphere's own come from
   * projecting each node onto it. */
  pm_mesh *me = octasphere(6, 1);
  for (int32_t v = 0; v < me->nnode; ++v) {
    if (me->node_dim[v] < 0) continue;
    double *par = &me->node_par[2 * (size_t)v];
    PM_ASSERT_OK(pm_cell_project(&m->cells[PM_FACE][0], &me->xyz[3 * (size_t)v], NULL, par, NULL,
                                 NULL, &e), e);
  }
  pm_distance good, zeroed;
  PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, NULL, &good, &e), e);
  memset(me->node_par, 0, 2 * sizeof(double) * (size_t)me->nnode);
  PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, NULL, &zeroed, &e), e);
  PM_ASSERT_NEAR(zeroed.mesh_to_model_max, good.mesh_to_model_max, 1e-9);
  PM_ASSERT_NEAR(zeroed.mean, good.mean, 1e-9);
  int acute;
  const double expect = sphere_chord_max(me, &acute);
  PM_ASSERT_NEAR(good.mesh_to_model_max, expect, 1e-3 * expect);
  pm_mesh_destroy(me);
  pm_model_destroy(m);
}

/* A vertex pushed off the sphere: the mesh -> model maximum is its radial offset. */
static void test_sphere_pushed_vertex(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_case_open("sphere", &m, NULL, &e), e);
  pm_mesh *me = octasphere(5, 0);
  /* The node nearest to (1, 1, 1)/sqrt(3), pushed out to radius 1.05. */
  int32_t best = 0;
  double bd = -1;
  for (int32_t i = 0; i < me->nnode; ++i) {
    double s = me->xyz[3 * i] + me->xyz[3 * i + 1] + me->xyz[3 * i + 2];
    if (s > bd) bd = s, best = i;
  }
  for (int k = 0; k < 3; ++k) me->xyz[3 * best + k] *= 1.05;
  pm_distance d;
  PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, NULL, &d, &e), e);
  PM_ASSERT_NEAR(d.mesh_to_model_max, 0.05, 1e-9);
  PM_ASSERT_NEAR(d.max, 0.05, 1e-9);
  assert_int_equal(d.max_from_model, 0);
  pm_mesh_destroy(me);
  pm_model_destroy(m);
}

/* The cylinder case (radius 0.5, z in [-1, 1]): a prism over the regular n-gon with its caps as
 * fans. Three faces, a periodic side with a seam, circles shared by two faces. Both directions'
 * maxima are the sagitta r (1 - cos(pi/n)): the middle of a side facet is that far inside the
 * cylinder, and the cylinder (side and cap rims) bulges that far out of the prism. */
static void test_cylinder_prism(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_case_open("cylinder", &m, NULL, &e), e);
  const int n = 24, layers = 6;
  const double r = 0.5;
  pm_mesh *me = pm_mesh_create();
  for (int j = 0; j <= layers; ++j)
    for (int k = 0; k < n; ++k) {
      double a = 2 * M_PI * k / n, p[3] = {r * cos(a), r * sin(a), -1 + 2.0 * j / layers};
      PM_ASSERT_OK(pm_mesh_add_node(me, p, -1, -1, NULL, NULL, &e), e);
    }
  const double bot[3] = {0, 0, -1}, top[3] = {0, 0, 1};
  int32_t cb = me->nnode, ct = cb + 1;
  PM_ASSERT_OK(pm_mesh_add_node(me, bot, -1, -1, NULL, NULL, &e), e);
  PM_ASSERT_OK(pm_mesh_add_node(me, top, -1, -1, NULL, NULL, &e), e);
  for (int j = 0; j < layers; ++j)
    for (int k = 0; k < n; ++k) {
      int32_t a = j * n + k, b = j * n + (k + 1) % n, c = a + n, d = b + n;
      PM_ASSERT_OK(pm_mesh_add_tri(me, a, b, d, -1, &e), e);
      PM_ASSERT_OK(pm_mesh_add_tri(me, a, d, c, -1, &e), e);
    }
  for (int k = 0; k < n; ++k) {
    PM_ASSERT_OK(pm_mesh_add_tri(me, cb, (k + 1) % n, k, -1, &e), e);
    PM_ASSERT_OK(pm_mesh_add_tri(me, ct, layers * n + k, layers * n + (k + 1) % n, -1, &e), e);
  }
  pm_distance d;
  PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, NULL, &d, &e), e);
  double sag = r * (1 - cos(M_PI / n));
  PM_ASSERT_NEAR(d.mesh_to_model_max, sag, 1e-3 * sag);
  PM_ASSERT_NEAR(d.model_to_mesh_max, sag, 1e-3 * sag);
  assert_int_equal(d.nfallback, 0);
  assert_int_equal(d.ref_faces_degraded, 0);
  pm_mesh_destroy(me);
  pm_model_destroy(m);
}

/* The torus case (R = 1, r = 0.35 about z; S(u, v) = ((R + r cos v) cos u, (R + r cos v) sin u,
 * r sin v), periodic in both parameters) meshed on a 24 x 12 parameter grid. The distance of a
 * point to the torus has a closed form, | sqrt((sqrt(x^2 + y^2) - R)^2 + z^2) - r |, so the mesh ->
 * model maximum is checked against a dense lattice on every triangle; model -> mesh against a
 * dense parameter grid of the torus queried with the (brute-force checked) BVH. Classified nodes
 * carry (u, v) in [0, 2 pi): triangles across both seams interpolate unwrapped parameters. */
static double torus_dist(const double x[3]) {
  double rho = hypot(x[0], x[1]) - 1.0;
  return fabs(hypot(rho, x[2]) - 0.35);
}

static void test_torus_doubly_periodic(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_case_open("torus", &m, NULL, &e), e);
  const int nu = 24, nv = 12;
  double res[2];
  for (int classify = 0; classify < 2; ++classify) {
    pm_mesh *me = pm_mesh_create();
    for (int j = 0; j < nv; ++j)
      for (int i = 0; i < nu; ++i) {
        double uv[2] = {2 * M_PI * i / nu, 2 * M_PI * j / nv};
        double p[3] = {(1 + 0.35 * cos(uv[1])) * cos(uv[0]), (1 + 0.35 * cos(uv[1])) * sin(uv[0]),
                       0.35 * sin(uv[1])};
        PM_ASSERT_OK(pm_mesh_add_node(me, p, classify ? PM_FACE : -1, classify ? 0 : -1,
                                      classify ? uv : NULL, NULL, &e), e);
      }
    for (int j = 0; j < nv; ++j)
      for (int i = 0; i < nu; ++i) {
        int32_t a = j * nu + i, b = j * nu + (i + 1) % nu, c = ((j + 1) % nv) * nu + i,
                d = ((j + 1) % nv) * nu + (i + 1) % nu;
        PM_ASSERT_OK(pm_mesh_add_tri(me, a, b, d, classify ? 0 : -1, &e), e);
        PM_ASSERT_OK(pm_mesh_add_tri(me, a, d, c, classify ? 0 : -1, &e), e);
      }
    /* Mesh -> model by brute force: a level-40 lattice on every triangle. */
    double brute = 0;
    for (int32_t t = 0; t < me->ntri; ++t) {
      const int32_t *v = &me->tri[3 * t];
      for (int i = 0; i <= 40; ++i)
        for (int j = 0; i + j <= 40; ++j) {
          double x[3];
          for (int k = 0; k < 3; ++k)
            x[k] = (1 - (i + j) / 40.0) * me->xyz[3 * v[0] + k] + i / 40.0 * me->xyz[3 * v[1] + k] +
                   j / 40.0 * me->xyz[3 * v[2] + k];
          brute = fmax(brute, torus_dist(x));
        }
    }
    /* Model -> mesh: a 480 x 240 grid on the torus, each point's distance to the mesh. */
    pm_bvh *bvh = NULL;
    PM_ASSERT_OK(pm_bvh_create(me->xyz, me->nnode, me->tri, me->ntri, &bvh, &e), e);
    double grid = 0;
    for (int j = 0; j < 240; ++j)
      for (int i = 0; i < 480; ++i) {
        double u = 2 * M_PI * i / 480, w = 2 * M_PI * j / 240;
        double x[3] = {(1 + 0.35 * cos(w)) * cos(u), (1 + 0.35 * cos(w)) * sin(u), 0.35 * sin(w)};
        pm_bvh_hit h;
        pm_bvh_closest(bvh, x, INFINITY, &h);
        grid = fmax(grid, h.dist);
      }
    pm_bvh_destroy(bvh);
    pm_distance d;
    PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, NULL, &d, &e), e);
    /* The refined maxima are at least the dense samples' (less round-off) and hardly more. */
    assert_true(d.mesh_to_model_max >= brute - 1e-12);
    PM_ASSERT_NEAR(d.mesh_to_model_max, brute, 1e-3 * brute);
    assert_true(d.model_to_mesh_max >= grid - 1e-12);
    PM_ASSERT_NEAR(d.model_to_mesh_max, grid, 1e-2 * grid);
    assert_int_equal(d.nfallback, 0);
    res[classify] = d.mesh_to_model_max;
    pm_mesh_destroy(me);
  }
  PM_ASSERT_NEAR(res[0], res[1], 1e-9);
  pm_model_destroy(m);
}

/* ---- pruned searches -------------------------------------------------------------------------- */

/* The cylinder prism of test_cylinder_prism (n sides, `layers` rows), classified as a mesher
 * leaves it: each triangle on the face nearest its centroid, each node on a face whose triangles
 * are all on that face, with its (u, v) by projection; nodes on the rims stay unclassified (the
 * hint then takes a face node's (u, v)). The top ring is pulled in to radius 0.4999 and down to
 * z = 0.998: points of the top cap's triangles near it are nearer to the side than to the cap
 * (the search of the other faces must find the side), and some of their feet on the cap lie
 * between the cap's trimming polyline and its circle (the exact inside test must see them). */
static pm_mesh *classified_prism(const pm_model *m, int n, int layers) {
  const double r = 0.5;
  int32_t nn = layers * n + n + 2;
  double *xyz = malloc(sizeof(double) * 3 * (size_t)nn);
  for (int j = 0; j <= layers; ++j)
    for (int k = 0; k < n; ++k) {
      double a = 2 * M_PI * k / n, *p = &xyz[3 * (j * n + k)];
      p[0] = r * cos(a), p[1] = r * sin(a), p[2] = -1 + 2.0 * j / layers;
      if (j == layers) p[0] *= 0.9998, p[1] *= 0.9998, p[2] = 0.998;
    }
  int32_t cb = (layers + 1) * n, ct = cb + 1;
  xyz[3 * cb] = xyz[3 * cb + 1] = 0, xyz[3 * cb + 2] = -1;
  xyz[3 * ct] = xyz[3 * ct + 1] = 0, xyz[3 * ct + 2] = 1;
  int32_t nt = 2 * layers * n + 2 * n, *tri = malloc(sizeof(int32_t) * 3 * (size_t)nt), q = 0;
  for (int j = 0; j < layers; ++j)
    for (int k = 0; k < n; ++k) {
      int32_t a = j * n + k, b = j * n + (k + 1) % n, c = a + n, d = b + n;
      tri[q++] = a, tri[q++] = b, tri[q++] = d, tri[q++] = a, tri[q++] = d, tri[q++] = c;
    }
  for (int k = 0; k < n; ++k) {
    tri[q++] = cb, tri[q++] = (k + 1) % n, tri[q++] = k;
    tri[q++] = ct, tri[q++] = layers * n + k, tri[q++] = layers * n + (k + 1) % n;
  }
  int32_t *tface = malloc(sizeof(int32_t) * (size_t)nt), *nface = malloc(sizeof(int32_t) * (size_t)nn);
  for (int32_t i = 0; i < nn; ++i) nface[i] = -2; /* -2 untouched, -1 on two faces */
  pm_error e = {0};
  for (int32_t t = 0; t < nt; ++t) {
    double g[3] = {0, 0, 0}, best = INFINITY;
    for (int k = 0; k < 3; ++k)
      for (int q2 = 0; q2 < 3; ++q2) g[q2] += xyz[3 * tri[3 * t + k] + q2] / 3;
    for (int32_t f = 0; f < m->count[PM_FACE]; ++f) {
      double par[2], foot[3], d;
      PM_ASSERT_OK(pm_cell_project(&m->cells[PM_FACE][f], g, NULL, par, foot, &d, &e), e);
      if (d < best) best = d, tface[t] = f;
    }
    for (int k = 0; k < 3; ++k) {
      int32_t v = tri[3 * t + k];
      nface[v] = nface[v] == -2 || nface[v] == tface[t] ? tface[t] : -1;
    }
  }
  pm_mesh *me = pm_mesh_create();
  for (int32_t i = 0; i < nn; ++i) {
    double uv[2], foot[3], d;
    int f = nface[i] >= 0 ? nface[i] : -1;
    if (f >= 0) PM_ASSERT_OK(pm_cell_project(&m->cells[PM_FACE][f], &xyz[3 * i], NULL, uv, foot, &d, &e), e);
    PM_ASSERT_OK(pm_mesh_add_node(me, &xyz[3 * i], f >= 0 ? PM_FACE : -1, f, f >= 0 ? uv : NULL, NULL, &e), e);
  }
  for (int32_t t = 0; t < nt; ++t)
    PM_ASSERT_OK(pm_mesh_add_tri(me, tri[3 * t], tri[3 * t + 1], tri[3 * t + 2], tface[t], &e), e);
  free(xyz), free(tri), free(tface), free(nface);
  return me;
}

/* The torus case meshed on a 24 x 12 parameter grid, classified with its (u, v), one node pushed
 * 0.02 off the surface. */
static pm_mesh *pushed_torus_mesh(void) {
  pm_mesh *me = pm_mesh_create();
  pm_error e = {0};
  const int nu = 24, nv = 12;
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      double uv[2] = {2 * M_PI * i / nu, 2 * M_PI * j / nv};
      double p[3] = {(1 + 0.35 * cos(uv[1])) * cos(uv[0]), (1 + 0.35 * cos(uv[1])) * sin(uv[0]),
                     0.35 * sin(uv[1])};
      if (i == 5 && j == 3) p[2] += 0.02;
      PM_ASSERT_OK(pm_mesh_add_node(me, p, PM_FACE, 0, uv, NULL, &e), e);
    }
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      int32_t a = j * nu + i, b = j * nu + (i + 1) % nu, c = ((j + 1) % nv) * nu + i,
              d = ((j + 1) % nv) * nu + (i + 1) % nu;
      PM_ASSERT_OK(pm_mesh_add_tri(me, a, b, d, 0, &e), e);
      PM_ASSERT_OK(pm_mesh_add_tri(me, a, d, c, 0, &e), e);
    }
  return me;
}

/* Pruning (distance.h: prune) skips searches that cannot find anything, so every figure is the
 * same as with the searches done everywhere: on the classified prism, whose samples near the rims
 * see the other faces and the circles, and on the torus with a node pushed off the surface. */
static void test_prune_changes_no_figure(void **state) {
  (void)state;
  pm_error e = {0};
  for (int which = 0; which < 2; ++which) {
    pm_model *m = NULL;
    PM_ASSERT_OK(pm_case_open(which ? "torus" : "cylinder", &m, NULL, &e), e);
    pm_mesh *me = NULL;
    if (which == 0) {
      me = classified_prism(m, 24, 6);
    } else {
      me = pushed_torus_mesh();
    }
    pm_distance_params p;
    pm_distance_params_init(&p);
    assert_int_equal(p.prune, 1);
    pm_distance dp, ds;
    PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, &p, &dp, &e), e);
    p.prune = 0;
    PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, &p, &ds, &e), e);
    if (getenv("PM_TEST_VERBOSE"))
      printf("%s: pruned mean %.17g max %.17g, searched mean %.17g max %.17g\n", which ? "torus" : "prism",
             dp.mean, dp.max, ds.mean, ds.max);
    assert_true(dp.mean == ds.mean);
    assert_true(dp.max == ds.max);
    assert_true(dp.mesh_to_model_mean == ds.mesh_to_model_mean);
    assert_true(dp.mesh_to_model_max == ds.mesh_to_model_max);
    assert_true(dp.model_to_mesh_mean == ds.model_to_mesh_mean);
    assert_true(dp.model_to_mesh_max == ds.model_to_mesh_max);
    assert_true(dp.nsamples_mesh == ds.nsamples_mesh && dp.nsamples_model == ds.nsamples_model);
    assert_true(ds.ref_tree_built); /* searched everywhere */
    assert_int_equal(dp.nfallback, 0);
    if (which == 0) {
      /* At least the prism's sagitta (test_cylinder_prism), the pulled ring adds to it. */
      double sag = 0.5 * (1 - cos(M_PI / 24));
      assert_true(dp.mesh_to_model_max > sag && dp.mesh_to_model_max < 2 * sag);
    } else {
      assert_true(dp.mesh_to_model_max > 0.015);
    }
    pm_mesh_destroy(me);
    pm_model_destroy(m);
  }
}

/* The cylinder case drilled through along x at z = 0.3 by a hole of radius 0.003: two holes in
 * its side far smaller than a cell of the distance's reference grid (about 0.03 there). */
static int make_drilled_cylinder(void) {
  int ierr = 0;
  int cyl = gmshModelOccAddCylinder(0, 0, -1, 0, 0, 2, 0.5, -1, 2 * M_PI, &ierr);
  if (ierr) return ierr;
  int drill = gmshModelOccAddCylinder(-1, 0, 0.3, 2, 0, 0, 0.003, -1, 2 * M_PI, &ierr);
  if (ierr) return ierr;
  return pm_cad_occ_cut_volumes(cyl, drill);
}

/* The reference's split quads (distance.h: ref_split) replace the constrained triangulation
 * inside the faces only: the same points cover the same region, so a triangulation of them has
 * the same number of triangles, and the figures (which the reference only starts) agree. On the
 * drilled cylinder the quads around each tiny hole have their four corners inside, yet hold the
 * hole: they must stay with the constrained triangulation, or the count differs. On the torus,
 * periodic in both parameters, almost every quad is split. */
static void test_ref_split_same_reference(void **state) {
  (void)state;
  pm_error e = {0};
  for (int which = 0; which < 2; ++which) {
    pm_model *m = NULL;
    pm_mesh *me = NULL;
    if (which == 0) {
      PM_ASSERT_OK(pm_cad_build_shapes("drilled cylinder", make_drilled_cylinder, &m, &e), e);
      me = classified_prism(m, 24, 6);
    } else {
      PM_ASSERT_OK(pm_case_open("torus", &m, NULL, &e), e);
      me = pushed_torus_mesh();
    }
    pm_distance_params p;
    pm_distance_params_init(&p);
    assert_int_equal(p.ref_split, 1);
    pm_distance ds, dc;
    PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, &p, &ds, &e), e);
    p.ref_split = 0;
    PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, &p, &dc, &e), e);
    if (getenv("PM_TEST_VERBOSE"))
      printf("model %d: split %lld triangles, %lld points triangulated, mean %.17g max %.17g; "
             "unsplit %lld, %lld, mean %.17g max %.17g\n", which, (long long)ds.ref_triangles,
             (long long)ds.ref_cdt_points, ds.mean, ds.max, (long long)dc.ref_triangles,
             (long long)dc.ref_cdt_points, dc.mean, dc.max);
    assert_int_equal(ds.ref_faces_degraded, 0);
    assert_int_equal(dc.ref_faces_degraded, 0);
    assert_true(ds.ref_triangles > 1000);
    assert_int_equal(ds.ref_triangles, dc.ref_triangles);
    /* most points are inside, away from the boundary: fewer than half are triangulated (the
     * cylinder's disks are planar, with a reference of a few cells) */
    assert_true(2 * ds.ref_cdt_points < dc.ref_cdt_points);
    PM_ASSERT_NEAR(ds.mean, dc.mean, 1e-9 * dc.mean);
    PM_ASSERT_NEAR(ds.max, dc.max, 1e-9 * dc.max);
    assert_int_equal(ds.nfallback, 0);
    pm_mesh_destroy(me);
    pm_model_destroy(m);
  }
}

/* A boundary curve is sampled at most model_per_tri times per mesh segment on it (at least 256),
 * however short the face's shortest edges: the unit square meshed 5 x 5 with its first column
 * 1e-4 wide (7% of the edges that short, so the face's 5th-percentile edge is 1e-4), boundary
 * segments on their curves. Unbounded, each side would take 1 / (0.25 x 1e-4) = 40000 points. */
static void test_curve_samples_follow_segments(void **state) {
  (void)state;
  pm_model *m = square_model();
  pm_mesh *me = pm_mesh_create();
  pm_error e = {0};
  const int n = 5;
  double xs[6] = {0, 1e-4, 0.25, 0.5, 0.75, 1};
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      double p[3] = {xs[i], (double)j / n, 0}, uv[2] = {p[0], p[1]};
      PM_ASSERT_OK(pm_mesh_add_node(me, p, PM_FACE, 0, uv, NULL, &e), e);
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      int32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      PM_ASSERT_OK(pm_mesh_add_tri(me, a, b, d, 0, &e), e);
      PM_ASSERT_OK(pm_mesh_add_tri(me, a, d, c, 0, &e), e);
    }
  /* The boundary segments, each on the curve nearest its midpoint. */
  int32_t ring[4 * 5 + 1], nr = 0;
  for (int i = 0; i < n; ++i) ring[nr++] = i;
  for (int j = 0; j < n; ++j) ring[nr++] = j * (n + 1) + n;
  for (int i = n; i > 0; --i) ring[nr++] = n * (n + 1) + i;
  for (int j = n; j > 0; --j) ring[nr++] = j * (n + 1);
  ring[nr] = ring[0];
  for (int k = 0; k < nr; ++k) {
    double mid[3];
    for (int q = 0; q < 3; ++q) mid[q] = 0.5 * (me->xyz[3 * ring[k] + q] + me->xyz[3 * ring[k + 1] + q]);
    int32_t best = -1;
    double bd = INFINITY;
    for (int32_t cu = 0; cu < m->count[PM_CURVE]; ++cu) {
      double t, foot[3], d;
      PM_ASSERT_OK(pm_cell_project(&m->cells[PM_CURVE][cu], mid, NULL, &t, foot, &d, &e), e);
      if (d < bd) bd = d, best = cu;
    }
    PM_ASSERT_OK(pm_mesh_add_seg(me, ring[k], ring[k + 1], best, &e), e);
  }
  pm_distance d;
  PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, NULL, &d, &e), e);
  /* The face: at most 16 per triangle (800); the curves: 256 each. */
  assert_true(d.nsamples_model <= 800 + 4 * 256);
  assert_true(d.max < 1e-12);
  pm_mesh_destroy(me);
  pm_model_destroy(m);
}

/* ---- determinism --------------------------------------------------------------------------------- */

static void test_thread_count_independent(void **state) {
  (void)state;
  pm_model *m = disk_model(1.0);
  pm_mesh *me = fan_mesh(10, 1.0);
  /* Perturb the centre so that both directions have non-trivial sums. */
  me->xyz[2] = 0.03;
  pm_distance d1, d3;
  pm_error e = {0};
  int saved = omp_get_max_threads();
  omp_set_num_threads(1);
  PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, NULL, &d1, &e), e);
  omp_set_num_threads(3);
  PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, NULL, &d3, &e), e);
  omp_set_num_threads(saved);
  assert_true(d1.mean == d3.mean);
  assert_true(d1.max == d3.max);
  assert_true(d1.mesh_to_model_mean == d3.mesh_to_model_mean);
  assert_true(d1.model_to_mesh_mean == d3.model_to_mesh_mean);
  assert_true(d1.model_to_mesh_max == d3.model_to_mesh_max);
  assert_true(d1.mesh_to_model_max > 0.029);
  pm_mesh_destroy(me);
  pm_model_destroy(m);
}

/* ---- wire: the dangling segment of the non-manifold case ---------------------------------------- */

/* The non-manifold case's faces, meshed unclassified: the six cube faces as n x n grids and the
 * internal triangle as itself. */
static pm_mesh *cube_and_fin_mesh(int n) {
  pm_mesh *me = pm_mesh_create();
  pm_error e = {0};
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      int32_t base = me->nnode;
      for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
          double p[3];
          p[axis] = side, p[(axis + 1) % 3] = (double)i / n, p[(axis + 2) % 3] = (double)j / n;
          PM_ASSERT_OK(pm_mesh_add_node(me, p, -1, -1, NULL, NULL, &e), e);
        }
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          int32_t a = base + j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
          PM_ASSERT_OK(pm_mesh_add_tri(me, a, b, d, -1, &e), e);
          PM_ASSERT_OK(pm_mesh_add_tri(me, a, d, c, -1, &e), e);
        }
    }
  const double fin[3][3] = {{0, 0, 0}, {0, 0, 1}, {0.5, 0.5, 0.5}};
  int32_t f0 = me->nnode;
  for (int k = 0; k < 3; ++k) PM_ASSERT_OK(pm_mesh_add_node(me, fin[k], -1, -1, NULL, NULL, &e), e);
  PM_ASSERT_OK(pm_mesh_add_tri(me, f0, f0 + 1, f0 + 2, -1, &e), e);
  return me;
}

static void test_wire_dangling_segment(void **state) {
  (void)state;
  pm_model *m = NULL;
  pm_error e = {0};
  PM_ASSERT_OK(pm_case_open("nonmanifold", &m, NULL, &e), e);
  int32_t wire = -1;
  for (int32_t i = 0; i < m->count[PM_CURVE]; ++i)
    if (m->cells[PM_CURVE][i].nup == 0) wire = i;
  assert_true(wire >= 0);
  const pm_cell *wc = &m->cells[PM_CURVE][wire];
  pm_curve_point c0, c1;
  pm_curve_eval(wc, wc->lo[0], 0, &c0);
  pm_curve_eval(wc, wc->hi[0], 0, &c1);

  /* Without the wire in the mesh, the dangling curve is far from every triangle: the distance
   * says so. */
  pm_mesh *me = cube_and_fin_mesh(4);
  pm_distance d;
  PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, NULL, &d, &e), e);
  assert_true(d.model_to_mesh_max > 0.1);
  assert_int_equal(d.max_from_model, 1);

  /* With the wire as 4 classified segments on the curve: exact, everything is at distance 0. */
  const int ns = 4;
  int32_t first = me->nnode;
  for (int k = 0; k <= ns; ++k) {
    double t = wc->lo[0] + (wc->hi[0] - wc->lo[0]) * k / ns;
    pm_curve_point cp;
    pm_curve_eval(wc, t, 0, &cp);
    PM_ASSERT_OK(pm_mesh_add_node(me, cp.p, PM_CURVE, wire, &t, NULL, &e), e);
  }
  for (int k = 0; k < ns; ++k) PM_ASSERT_OK(pm_mesh_add_seg(me, first + k, first + k + 1, wire, &e), e);
  PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, NULL, &d, &e), e);
  PM_ASSERT_NEAR(d.max, 0.0, 1e-12);
  PM_ASSERT_NEAR(d.mean, 0.0, 1e-12);
  assert_int_equal(d.nfallback, 0);
  int64_t with_wire = d.nsamples_mesh;

  /* The wire's middle node moved by 0.02 across the curve: the mesh -> model maximum is 0.02. */
  double dir[3] = {c1.p[0] - c0.p[0], c1.p[1] - c0.p[1], c1.p[2] - c0.p[2]};
  double off[3] = {0, 0, 1}; /* the curve lies in z = 0.5: z is across it */
  (void)dir;
  for (int k = 0; k < 3; ++k) me->xyz[3 * (first + ns / 2) + k] += 0.02 * off[k];
  PM_ASSERT_OK(pm_mesh_distance(me, m, NULL, NULL, &d, &e), e);
  PM_ASSERT_NEAR(d.mesh_to_model_max, 0.02, 1e-12);
  assert_true(d.model_to_mesh_max > 0 && d.model_to_mesh_max <= 0.02);
  assert_true(d.nsamples_mesh == with_wire);
  pm_mesh_destroy(me);
  pm_model_destroy(m);
}

/* ---- parameters and bad input --------------------------------------------------------------------- */

static void test_params_and_bad_input(void **state) {
  (void)state;
  pm_distance_params p;
  pm_distance_params_init(&p);
  pm_error e = {0};
  PM_ASSERT_OK(pm_distance_params_check(&p, &e), e);
  p.spacing = 0;
  assert_int_equal(pm_distance_params_check(&p, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "spacing"));
  pm_distance_params_init(&p);
  p.tri_level = 40;
  assert_int_equal(pm_distance_params_check(&p, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "tri_level"));
  pm_distance_params_init(&p);
  p.ref_split = 2;
  assert_int_equal(pm_distance_params_check(&p, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "ref_split"));
  pm_distance_params_init(&p);
  p.quadrature = 3;
  assert_int_equal(pm_distance_params_check(&p, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "quadrature"));
  pm_distance_params_init(&p);
  p.refine_fit = -1;
  assert_int_equal(pm_distance_params_check(&p, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "refine_fit"));
  pm_distance_params_init(&p);
  p.ref_tol = 0.5;
  assert_int_equal(pm_distance_params_check(&p, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "ref_tol"));

  pm_model *m = square_model();
  pm_distance d;
  /* Bad parameters reach pm_mesh_distance's caller too. */
  pm_mesh *me = square_mesh(2, 0);
  assert_int_equal(pm_mesh_distance(me, m, NULL, &p, &d, &e), PM_ERR_ARG);
  /* A mesh without triangles for a model with a face. */
  pm_mesh *empty = pm_mesh_create();
  assert_int_equal(pm_mesh_distance(empty, m, NULL, NULL, &d, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "no triangles"));
  assert_int_equal(pm_mesh_distance(NULL, m, NULL, NULL, &d, &e), PM_ERR_ARG);
  /* A non-finite coordinate. */
  me->xyz[4] = NAN;
  assert_int_equal(pm_mesh_distance(me, m, NULL, NULL, &d, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "non-finite"));
  assert_true(d.max == 0 && d.mean == 0);
  /* The sample cap lowers the lattice level instead of failing. */
  me->xyz[4] = 0.5;
  pm_distance_params_init(&p);
  p.max_samples = 1000;
  pm_mesh *big = square_mesh(20, 0); /* 800 triangles: even level 1 exceeds the cap; it is the floor */
  PM_ASSERT_OK(pm_mesh_distance(big, m, NULL, &p, &d, &e), e);
  assert_int_equal(d.tri_level, 1);
  assert_true(d.nsamples_model <= 1000);
  PM_ASSERT_NEAR(d.max, 0.0, 1e-14);
  pm_mesh_destroy(big);
  pm_mesh_destroy(empty);
  pm_mesh_destroy(me);
  pm_model_destroy(m);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_square_in_plane_is_zero),
      cmocka_unit_test(test_square_lifted_node),
      cmocka_unit_test(test_disk_sagitta),
      cmocka_unit_test(test_boundary_triangles_start_from_the_curves),
      cmocka_unit_test(test_disk_points_between_polyline_and_circle),
      cmocka_unit_test(test_annulus_hole_sagitta),
      cmocka_unit_test(test_disk_means_and_size),
      cmocka_unit_test(test_sphere_chordal_error),
      cmocka_unit_test(test_mesh_side_mean_is_its_integral),
      cmocka_unit_test(test_refine_fit_saves_evaluations),
      cmocka_unit_test(test_sphere_pushed_vertex),
      cmocka_unit_test(test_wrong_parameters_are_not_trusted),
      cmocka_unit_test(test_cylinder_prism),
      cmocka_unit_test(test_torus_doubly_periodic),
      cmocka_unit_test(test_prune_changes_no_figure),
      cmocka_unit_test(test_ref_split_same_reference),
      cmocka_unit_test(test_curve_samples_follow_segments),
      cmocka_unit_test(test_thread_count_independent),
      cmocka_unit_test(test_wire_dangling_segment),
      cmocka_unit_test(test_params_and_bad_input),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
