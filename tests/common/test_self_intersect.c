/* Tests of self_intersect.c: the exact pair test on hand-made configurations for every number of
 * shared vertices, its symmetry and cross-checks on random configurations, and the whole-mesh
 * driver (Embree broad phase) against brute force over all pairs. */
#include "test_support.h"

#include <stdlib.h>
#include <string.h>

#include "common/mesh/mesh.h"
#include "common/base/rng.h"
#include "common/mesh/self_intersect.h"

/* ---- hand-made pairs --------------------------------------------------------------------------- */

static int pair(const double *xyz, int32_t a, int32_t b, int32_t c, int32_t d, int32_t e, int32_t f) {
  const int32_t t0[3] = {a, b, c}, t1[3] = {d, e, f};
  int r = pm_triangle_pair_intersects(xyz, t0, t1);
  /* The answer never depends on the order of the triangles nor on where each one starts. */
  const int32_t s0[3] = {b, c, a}, s1[3] = {f, d, e};
  assert_int_equal(pm_triangle_pair_intersects(xyz, t1, t0), r);
  assert_int_equal(pm_triangle_pair_intersects(xyz, s0, s1), r);
  assert_int_equal(pm_triangle_pair_intersects(xyz, s1, s0), r);
  return r;
}

static void test_pair_shared_edge(void **state) {
  (void)state;
  /* a = 0, b = 1 the shared edge along x; c above it (y > 0). */
  const double xyz[] = {
      0, 0, 0,      /* 0 a */
      1, 0, 0,      /* 1 b */
      0.5, 1, 0,    /* 2 c */
      0.3, 0.5, 0,  /* 3 d: coplanar, same side as c: folded onto abc */
      0.5, -1, 0,   /* 4 d: coplanar, other side: a flat pair */
      0.5, 1, 1,    /* 5 d: out of plane: a dihedral */
      0.5, 0, 0,    /* 6 d on the line ab (degenerate triangle abd) */
  };
  assert_int_equal(pair(xyz, 0, 1, 2, 1, 0, 3), 1);
  assert_int_equal(pair(xyz, 0, 1, 2, 1, 0, 4), 0);
  assert_int_equal(pair(xyz, 0, 1, 2, 1, 0, 5), 0);
  assert_int_equal(pair(xyz, 0, 1, 2, 1, 0, 6), 0); /* degenerate: not a pair verdict */
  /* The same triangle twice (a duplicated face), in either orientation. */
  assert_int_equal(pair(xyz, 0, 1, 2, 0, 1, 2), 1);
  assert_int_equal(pair(xyz, 0, 1, 2, 2, 1, 0), 1);
}

static void test_pair_shared_vertex(void **state) {
  (void)state;
  const double xyz[] = {
      0, 0, 0,      /* 0 a, shared */
      1, 0, 0,      /* 1 b */
      0, 1, 0,      /* 2 c: t0 = abc in z = 0, wedge = first quadrant */
      -1, 0, 0,     /* 3 */
      0, -1, 0,     /* 4: a-3-4 in z = 0, third quadrant: touches only at a */
      1, 1, 0,      /* 5 */
      2, -1, 0,     /* 6: a-5-6 coplanar, its wedge overlaps t0's */
      1, 1, 1,      /* 7 */
      1, 1, -1,     /* 8: a-7-8 stands on the diagonal x = y, piercing t0 */
      -1, -1, 1,    /* 9 */
      -1, -1, -1,   /* 10: a-9-10 stands on the other diagonal, away from t0 */
      2, 0, 0,      /* 11 */
      2, 0, 1,      /* 12: a-11-12 has its edge a-11 along t0's edge a-b */
      -1, 0, 1,     /* 13: a-3-13 in the plane y = 0, on the other side of a: touch at a */
      0.5, 0.5, 1,  /* 14 */
      0.5, 0.5, 2,  /* 15: a-14-15 leaves t0's plane at a only (above, inside the wedge) */
      0.2, 0.2, 0,  /* 16 */
      0.3, 0.1, 0,  /* 17: a-16-17 coplanar and inside t0's wedge */
  };
  assert_int_equal(pair(xyz, 0, 1, 2, 0, 3, 4), 0);
  assert_int_equal(pair(xyz, 0, 1, 2, 0, 5, 6), 1);
  assert_int_equal(pair(xyz, 0, 1, 2, 0, 7, 8), 1);
  assert_int_equal(pair(xyz, 0, 1, 2, 0, 9, 10), 0);
  assert_int_equal(pair(xyz, 0, 1, 2, 0, 11, 12), 1);
  assert_int_equal(pair(xyz, 0, 1, 2, 0, 3, 13), 0);
  assert_int_equal(pair(xyz, 0, 1, 2, 0, 14, 15), 0);
  assert_int_equal(pair(xyz, 0, 1, 2, 0, 16, 17), 1);
}

static void test_pair_disjoint_vertices(void **state) {
  (void)state;
  const double xyz[] = {
      0, 0, 0,  2, 0, 0,  0, 2, 0,           /* 0-2: t0 in z = 0 */
      0.5, 0.5, -1,  0.5, 0.5, 1,  3, 3, 0,  /* 3-5: pierces t0 */
      0.5, 0.5, 0,  1, 1, 1,  1, 0.5, 1,     /* 6-8: a vertex on t0's face (T-junction) */
      5, 5, 5,  6, 5, 5,  5, 6, 5,           /* 9-11: far away */
      0.5, 0.5, 0.1,  1, 1, 1,  1, 0.5, 1,   /* 12-14: hovers just above t0 */
      1, 1, 0,  3, 1, 0,  3, 3, 0,           /* 15-17: coplanar, a vertex on t0's hypotenuse */
      2.1, 0, 0,  3, 0, 0,  3, 1, 0,         /* 18-20: coplanar, apart */
      0.2, 0.2, 0,  0.4, 0.2, 0,  0.2, 0.4, 0, /* 21-23: coplanar, inside t0 */
      1, -1, 0,  1, 3, 0,  1, 1, 2,          /* 24-26: its edge 24-25 crosses t0 in its plane */
  };
  assert_int_equal(pair(xyz, 0, 1, 2, 3, 4, 5), 1);
  assert_int_equal(pair(xyz, 0, 1, 2, 6, 7, 8), 1);
  assert_int_equal(pair(xyz, 0, 1, 2, 9, 10, 11), 0);
  assert_int_equal(pair(xyz, 0, 1, 2, 12, 13, 14), 0);
  assert_int_equal(pair(xyz, 0, 1, 2, 15, 16, 17), 1);
  assert_int_equal(pair(xyz, 0, 1, 2, 18, 19, 20), 0);
  assert_int_equal(pair(xyz, 0, 1, 2, 21, 22, 23), 1);
  assert_int_equal(pair(xyz, 0, 1, 2, 24, 25, 26), 1);
}

/* Distinct nodes at the same place count as one vertex (an unwelded mesh). */
static void test_pair_unwelded(void **state) {
  (void)state;
  const double xyz[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0, -1, 0, 0, 0, -1, 0, 1, 0, 0};
  assert_int_equal(pair(xyz, 0, 1, 2, 3, 4, 5), 0); /* touch at the doubled vertex only */
  assert_int_equal(pair(xyz, 0, 1, 2, 3, 6, 5), 0); /* share an edge through copies, flat */
}

/* ---- random cross-checks --------------------------------------------------------------------------- */

/* Floating-point segment-triangle intersection (Moeller-Trumbore), for generic positions only. */
static int seg_tri_float(const double p[3], const double q[3], const double a[3], const double b[3],
                         const double c[3]) {
  double e1[3], e2[3], d[3], h[3], s[3], qv[3];
  for (int k = 0; k < 3; ++k) e1[k] = b[k] - a[k], e2[k] = c[k] - a[k], d[k] = q[k] - p[k];
  h[0] = d[1] * e2[2] - d[2] * e2[1], h[1] = d[2] * e2[0] - d[0] * e2[2], h[2] = d[0] * e2[1] - d[1] * e2[0];
  double det = e1[0] * h[0] + e1[1] * h[1] + e1[2] * h[2];
  if (fabs(det) < 1e-300) return 0;
  for (int k = 0; k < 3; ++k) s[k] = p[k] - a[k];
  double u = (s[0] * h[0] + s[1] * h[1] + s[2] * h[2]) / det;
  qv[0] = s[1] * e1[2] - s[2] * e1[1], qv[1] = s[2] * e1[0] - s[0] * e1[2], qv[2] = s[0] * e1[1] - s[1] * e1[0];
  double v = (d[0] * qv[0] + d[1] * qv[1] + d[2] * qv[2]) / det;
  double t = (e2[0] * qv[0] + e2[1] * qv[1] + e2[2] * qv[2]) / det;
  return u >= 0 && v >= 0 && u + v <= 1 && t >= 0 && t <= 1;
}

static void test_pair_random_generic(void **state) {
  (void)state;
  pm_rng r;
  pm_rng_init(&r, 99, 0);
  double xyz[3 * 7];
  int hits = 0, hits_shared = 0;
  for (int it = 0; it < 20000; ++it) {
    for (int i = 0; i < 21; ++i) xyz[i] = pm_rng_range(&r, -1, 1);
    /* No shared vertex: an edge of one crosses the other (generic positions). */
    int expect = 0;
    for (int v = 0; v < 3; ++v) {
      expect |= seg_tri_float(&xyz[3 * v], &xyz[3 * ((v + 1) % 3)], &xyz[9], &xyz[12], &xyz[15]);
      expect |= seg_tri_float(&xyz[9 + 3 * v], &xyz[9 + 3 * ((v + 1) % 3)], &xyz[0], &xyz[3], &xyz[6]);
    }
    assert_int_equal(pair(xyz, 0, 1, 2, 3, 4, 5), expect);
    hits += expect;
    /* Sharing vertex 0 with (0, 4, 5): beyond the shared vertex they meet iff the triangle
     * (a', 4, 5), with a' pulled from a slightly into its own triangle, meets (0, 1, 2). */
    double *ap = &xyz[18];
    for (int k = 0; k < 3; ++k) ap[k] = xyz[k] + 1e-6 * ((xyz[12 + k] + xyz[15 + k]) / 2 - xyz[k]);
    int e2 = 0;
    const int pv[3] = {0, 1, 2}, qv[3] = {6, 4, 5};
    for (int v = 0; v < 3; ++v) {
      e2 |= seg_tri_float(&xyz[3 * pv[v]], &xyz[3 * pv[(v + 1) % 3]], &xyz[18], &xyz[12], &xyz[15]);
      e2 |= seg_tri_float(&xyz[3 * qv[v]], &xyz[3 * qv[(v + 1) % 3]], &xyz[0], &xyz[3], &xyz[6]);
    }
    assert_int_equal(pair(xyz, 0, 1, 2, 0, 4, 5), e2);
    hits_shared += e2;
  }
  /* Both outcomes occur often enough for the check to mean something. */
  assert_true(hits > 1000 && hits < 19000);
  assert_true(hits_shared > 500 && hits_shared < 19500);
}

/* Integer coordinates on a tiny grid: coplanar, collinear and touching configurations abound. The
 * verdict must still be symmetric and independent of the starting vertex (checked in pair()). */
static void test_pair_random_degenerate(void **state) {
  (void)state;
  pm_rng r;
  pm_rng_init(&r, 5, 0);
  double xyz[3 * 6];
  int hits = 0;
  for (int it = 0; it < 20000; ++it) {
    for (int i = 0; i < 18; ++i) xyz[i] = (double)pm_rng_below(&r, 3);
    if (it % 3 == 0)
      for (int i = 0; i < 6; ++i) xyz[3 * i + 2] = 0; /* all in one plane */
    hits += pair(xyz, 0, 1, 2, 3, 4, 5);
    hits += pair(xyz, 0, 1, 2, 0, 4, 5);
    hits += pair(xyz, 0, 1, 2, 1, 0, 5);
  }
  assert_true(hits > 1000);
}

/* ---- whole meshes --------------------------------------------------------------------------------- */

static pm_mesh *mesh_from(const double *xyz, int32_t nnode, const int32_t *tri, int32_t ntri) {
  pm_mesh *m = pm_mesh_create();
  pm_error e = {0};
  for (int32_t i = 0; i < nnode; ++i) PM_ASSERT_OK(pm_mesh_add_node(m, &xyz[3 * i], -1, -1, NULL, NULL, &e), e);
  for (int32_t t = 0; t < ntri; ++t)
    PM_ASSERT_OK(pm_mesh_add_tri(m, tri[3 * t], tri[3 * t + 1], tri[3 * t + 2], -1, &e), e);
  return m;
}

static void test_mesh_octahedron_clean(void **state) {
  (void)state;
  const double xyz[] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
  const int32_t tri[] = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
  pm_mesh *m = mesh_from(xyz, 6, tri, 8);
  pm_selfint_report rep;
  pm_error e = {0};
  PM_ASSERT_OK(pm_mesh_self_intersections(m, 10, &rep, &e), e);
  assert_int_equal(rep.count, 0);
  assert_int_equal(rep.nreport, 0);
  assert_null(rep.pairs);
  assert_int_equal(rep.ndegenerate, 0);
  assert_int_equal(rep.first_degenerate, -1);
  assert_true(rep.ncandidates >= 12); /* at least the 12 edge-adjacent pairs were tested */
  pm_selfint_report_free(&rep);
  pm_mesh_destroy(m);
}

static void test_mesh_two_tets(void **state) {
  (void)state;
  /* Two tetrahedra (closed surfaces of four triangles); the second is the first shifted by
   * (0.3, 0.2, 0.1), so they interpenetrate. */
  double xyz[24];
  const double base[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  for (int i = 0; i < 12; ++i) xyz[i] = base[i], xyz[12 + i] = base[i] + (i % 3 == 0 ? 0.3 : (i % 3 == 1 ? 0.2 : 0.1));
  const int32_t tri[] = {0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2, 4, 6, 5, 4, 5, 7, 5, 6, 7, 4, 7, 6};
  pm_mesh *m = mesh_from(xyz, 8, tri, 8);
  pm_selfint_report rep;
  pm_error e = {0};
  PM_ASSERT_OK(pm_mesh_self_intersections(m, 100, &rep, &e), e);
  assert_true(rep.count > 0);
  assert_int_equal(rep.nreport, rep.count);
  for (int32_t k = 0; k < rep.nreport; ++k) {
    /* Every pair has one triangle of each tet, and the list is sorted. */
    assert_true(rep.pairs[2 * k] < 4 && rep.pairs[2 * k + 1] >= 4);
    if (k > 0)
      assert_true(rep.pairs[2 * k - 2] < rep.pairs[2 * k] ||
                  (rep.pairs[2 * k - 2] == rep.pairs[2 * k] && rep.pairs[2 * k - 1] < rep.pairs[2 * k + 1]));
  }
  /* The slanted face (1, 2, 3) of the first tet is crossed by the second tet's faces through its
   * corner (0.3, 0.2, 0.1) + ... : (x + y + z = 1) cuts the shifted tet. */
  int slanted = 0;
  for (int32_t k = 0; k < rep.nreport; ++k) slanted |= rep.pairs[2 * k] == 2;
  assert_true(slanted);
  /* A cap on the list keeps the count. */
  pm_selfint_report rep2;
  PM_ASSERT_OK(pm_mesh_self_intersections(m, 1, &rep2, &e), e);
  assert_int_equal(rep2.count, rep.count);
  assert_int_equal(rep2.nreport, 1);
  assert_int_equal(rep2.pairs[0], rep.pairs[0]);
  assert_int_equal(rep2.pairs[1], rep.pairs[1]);
  pm_selfint_report_free(&rep2);
  pm_selfint_report_free(&rep);
  /* Moved apart, they are clean. */
  for (int i = 12; i < 24; i += 3) m->xyz[i] += 5;
  PM_ASSERT_OK(pm_mesh_self_intersections(m, 100, &rep, &e), e);
  assert_int_equal(rep.count, 0);
  pm_selfint_report_free(&rep);
  pm_mesh_destroy(m);
}

static void test_mesh_folded_and_vertex_touch(void **state) {
  (void)state;
  /* Folded: two triangles on one edge, the second lying on the first. */
  const double xyz[] = {0, 0, 0, 1, 0, 0, 0.5, 1, 0, 0.4, 0.6, 0, -1, 0, 0, 0, -1, 0.5};
  const int32_t folded[] = {0, 1, 2, 1, 0, 3};
  pm_mesh *m = mesh_from(xyz, 6, folded, 2);
  pm_selfint_report rep;
  pm_error e = {0};
  PM_ASSERT_OK(pm_mesh_self_intersections(m, 10, &rep, &e), e);
  assert_int_equal(rep.count, 1);
  assert_int_equal(rep.pairs[0], 0);
  assert_int_equal(rep.pairs[1], 1);
  pm_selfint_report_free(&rep);
  pm_mesh_destroy(m);
  /* Touching at a vertex only. */
  const int32_t touch[] = {0, 1, 2, 0, 4, 5};
  m = mesh_from(xyz, 6, touch, 2);
  PM_ASSERT_OK(pm_mesh_self_intersections(m, 10, &rep, &e), e);
  assert_int_equal(rep.count, 0);
  pm_selfint_report_free(&rep);
  pm_mesh_destroy(m);
}

static void test_mesh_degenerate_counted(void **state) {
  (void)state;
  const double xyz[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 2, 0, 0, 5, 5, 5};
  const int32_t tri[] = {0, 1, 2, 0, 1, 3, 4, 4, 4};
  pm_selfint_report rep;
  pm_error e = {0};
  PM_ASSERT_OK(pm_triangles_self_intersections(xyz, 5, tri, 3, 10, &rep, &e), e);
  assert_int_equal(rep.ndegenerate, 2);
  assert_int_equal(rep.first_degenerate, 1);
  assert_int_equal(rep.count, 0);
  pm_selfint_report_free(&rep);
}

static void test_mesh_bad_input(void **state) {
  (void)state;
  const double xyz[] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const int32_t tri[] = {0, 1, 7};
  pm_selfint_report rep;
  pm_error e = {0};
  assert_int_equal(pm_triangles_self_intersections(xyz, 3, tri, 1, 10, &rep, &e), PM_ERR_ARG);
  assert_non_null(strstr(e.msg, "self-intersection"));
  assert_non_null(strstr(e.msg, "node 7"));
  assert_int_equal(rep.count, 0);
  assert_null(rep.pairs);
  const int32_t ok[] = {0, 1, 2};
  assert_int_equal(pm_triangles_self_intersections(xyz, 3, ok, 1, -1, &rep, &e), PM_ERR_ARG);
  pm_selfint_report_free(NULL);
}

/* A random soup against brute force over all pairs: the broad phase misses nothing, and the
 * report is the sorted list. */
static void test_mesh_random_soup_vs_brute(void **state) {
  (void)state;
  pm_rng r;
  pm_rng_init(&r, 1234, 0);
  const int32_t ntri = 600, nnode = 800;
  double *xyz = malloc(sizeof(double) * 3 * nnode);
  int32_t *tri = malloc(sizeof(int32_t) * 3 * ntri);
  for (int32_t i = 0; i < nnode; ++i)
    for (int k = 0; k < 3; ++k) xyz[3 * i + k] = pm_rng_range(&r, 0, 1);
  /* Triangles of nearby nodes (sharing some), small enough that most pairs are apart. */
  for (int32_t t = 0; t < ntri; ++t) {
    int32_t a = (int32_t)pm_rng_below(&r, (uint64_t)nnode);
    tri[3 * t] = a;
    for (int v = 1; v < 3; ++v) {
      int32_t best = -1;
      double bd = INFINITY;
      for (int tries = 0; tries < 40; ++tries) {
        int32_t b = (int32_t)pm_rng_below(&r, (uint64_t)nnode);
        double d = 0;
        for (int k = 0; k < 3; ++k) d += (xyz[3 * a + k] - xyz[3 * b + k]) * (xyz[3 * a + k] - xyz[3 * b + k]);
        if (b != a && d < bd) bd = d, best = b;
      }
      tri[3 * t + v] = best;
    }
  }
  pm_selfint_report rep;
  pm_error e = {0};
  PM_ASSERT_OK(pm_triangles_self_intersections(xyz, nnode, tri, ntri, 1 << 20, &rep, &e), e);
  int64_t count = 0;
  for (int32_t i = 0; i < ntri; ++i)
    for (int32_t j = i + 1; j < ntri; ++j)
      if (pm_triangle_pair_intersects(xyz, &tri[3 * i], &tri[3 * j])) {
        assert_true(count < rep.nreport);
        assert_int_equal(rep.pairs[2 * count], i);
        assert_int_equal(rep.pairs[2 * count + 1], j);
        ++count;
      }
  assert_int_equal(rep.count, count);
  assert_true(count > 20);
  pm_selfint_report_free(&rep);
  free(xyz), free(tri);
}

/* A closed sphere-like surface (a subdivided octahedron pushed onto the unit sphere) is clean;
 * pushing one vertex through the opposite side makes it self-intersect. */
static void test_mesh_sphere_dent(void **state) {
  (void)state;
  /* Subdivide the octahedron n times by 4-splitting on a grid per face: (n+1)(n+2)/2 points per
   * face, duplicates welded by the exact-coordinate rule of the checker (no index sharing needed
   * across faces). */
  const int n = 12;
  const double V[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  const int F[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  int per = (n + 1) * (n + 2) / 2;
  double *xyz = malloc(sizeof(double) * 3 * 8 * per);
  int32_t *tri = malloc(sizeof(int32_t) * 3 * 8 * n * n);
  int32_t nt = 0;
  for (int f = 0; f < 8; ++f) {
    int32_t base = f * per;
#define IDX(i, j) (base + (i) * (n + 1) - (i) * ((i)-1) / 2 + (j))
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) {
        double p[3], s = 0;
        for (int k = 0; k < 3; ++k) {
          /* Points of the flat face, projected to the sphere; exact zeros stay zeros so that the
           * faces' shared edges produce identical coordinates. */
          p[k] = ((n - i - j) * V[F[f][0]][k] + i * V[F[f][1]][k] + j * V[F[f][2]][k]) / n;
          s += p[k] * p[k];
        }
        s = sqrt(s);
        for (int k = 0; k < 3; ++k) xyz[3 * IDX(i, j) + k] = p[k] / s;
      }
    for (int i = 0; i < n; ++i)
      for (int j = 0; i + j < n; ++j) {
        tri[3 * nt] = IDX(i, j), tri[3 * nt + 1] = IDX(i + 1, j), tri[3 * nt + 2] = IDX(i, j + 1), ++nt;
        if (i + j + 1 < n)
          tri[3 * nt] = IDX(i + 1, j), tri[3 * nt + 1] = IDX(i + 1, j + 1), tri[3 * nt + 2] = IDX(i, j + 1), ++nt;
      }
#undef IDX
  }
  pm_selfint_report rep;
  pm_error e = {0};
  PM_ASSERT_OK(pm_triangles_self_intersections(xyz, 8 * per, tri, nt, 10, &rep, &e), e);
  assert_int_equal(rep.count, 0);
  assert_int_equal(rep.ndegenerate, 0);
  pm_selfint_report_free(&rep);
  /* Push the north pole's copies (all nodes at (0, 0, 1)) to (0, 0, -1.5). */
  for (int32_t i = 0; i < 8 * per; ++i)
    if (xyz[3 * i] == 0 && xyz[3 * i + 1] == 0 && xyz[3 * i + 2] == 1) xyz[3 * i + 2] = -1.5;
  PM_ASSERT_OK(pm_triangles_self_intersections(xyz, 8 * per, tri, nt, 10, &rep, &e), e);
  assert_true(rep.count > 0);
  pm_selfint_report_free(&rep);
  free(xyz), free(tri);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_pair_shared_edge),
      cmocka_unit_test(test_pair_shared_vertex),
      cmocka_unit_test(test_pair_disjoint_vertices),
      cmocka_unit_test(test_pair_unwelded),
      cmocka_unit_test(test_pair_random_generic),
      cmocka_unit_test(test_pair_random_degenerate),
      cmocka_unit_test(test_mesh_octahedron_clean),
      cmocka_unit_test(test_mesh_two_tets),
      cmocka_unit_test(test_mesh_folded_and_vertex_touch),
      cmocka_unit_test(test_mesh_degenerate_counted),
      cmocka_unit_test(test_mesh_bad_input),
      cmocka_unit_test(test_mesh_random_soup_vs_brute),
      cmocka_unit_test(test_mesh_sphere_dent),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
