/* Self-intersection of a triangulated surface (see self_intersect.h for what counts).
 *
 * Broad phase: Embree's rtcCollide over the triangles' boxes (pm_bvh_overlapping_pairs). Narrow
 * phase: exact predicates only. The case analysis by the number of shared vertices k:
 *   k = 3  a duplicated face: intersecting.
 *   k = 2  (edge ab shared, T0 = abc, T1 = abd): two planes through the line ab meet only on
 *          that line, and each triangle meets the line in ab, so they intersect elsewhere only
 *          when d is coplanar with abc and on the same side of ab as c.
 *   k = 1  (vertex a shared, T0 = abc, T1 = ade): if all five points are coplanar, the triangles
 *          overlap beyond a iff their angular wedges at a overlap, i.e. iff a boundary ray of one
 *          wedge lies in the other (closed) wedge. Otherwise T0 n T1 is a segment [a, p] on the
 *          line where the planes meet, and its far end p lies on the boundary of T0 or T1. On
 *          an edge not through a, bc meets T1 or de meets T0. On an edge through a, say ab, p is
 *          where ab leaves T1 or p = b: then p is b (in T1, so bc meets T1), or lies on de (de
 *          meets T0), or is d or e (in T0, so de meets T0). So the two segment tests decide.
 *   k = 0  coplanar: a 2D triangle-triangle test (an edge pair meets, or a vertex lies in the
 *          other triangle); otherwise the intersection, when not empty, is a segment whose ends
 *          lie on edges, so some edge of one triangle meets the other (segment-triangle tests).
 * A segment pq meets a triangle abc (closed sets) when p and q are not strictly on one side of
 * its plane and the line pq passes through the triangle: orient3d(p, q, a, b), (p, q, b, c),
 * (p, q, c, a) never of opposite signs (the Pluecker side test); a segment in the plane is
 * tested in 2D. Coplanar configurations are projected to the coordinate plane of the largest
 * normal component of the triangle whose plane it is, where orient2d is exact and, for points of
 * that plane, has the sign of the in-plane orientation (up to one fixed sign per projection).
 */
#include "common/mesh/self_intersect.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/backends/closest_embree.h"
#include "common/backends/predicates.h"

/* ---- exact 2D helpers on a projection --------------------------------------------------------- */

/* Project p onto the coordinate plane that drops axis `ax`. */
static inline void proj(const double p[3], int ax, double q[2]) {
  q[0] = p[ax == 0 ? 1 : 0];
  q[1] = p[ax == 2 ? 1 : 2];
}

/* The projection axis for the plane of triangle (a, b, c): the largest normal component, checked
 * exactly (orient2d of the projection is that component's sign); -1 for collinear points. */
static int plane_axis(const double a[3], const double b[3], const double c[3]) {
  double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  double n[3] = {fabs(u[1] * v[2] - u[2] * v[1]), fabs(u[2] * v[0] - u[0] * v[2]),
                 fabs(u[0] * v[1] - u[1] * v[0])};
  int order[3] = {0, 1, 2};
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j)
      if (n[order[j]] > n[order[i]]) {
        int t = order[i];
        order[i] = order[j], order[j] = t;
      }
  for (int i = 0; i < 3; ++i) {
    double pa[2], pb[2], pc[2];
    proj(a, order[i], pa), proj(b, order[i], pb), proj(c, order[i], pc);
    if (pm_orient2d(pa, pb, pc) != 0) return order[i];
  }
  return -1;
}

/* Collinear p on segment ab (closed)? */
static int on_segment2(const double p[2], const double a[2], const double b[2]) {
  return fmin(a[0], b[0]) <= p[0] && p[0] <= fmax(a[0], b[0]) && fmin(a[1], b[1]) <= p[1] &&
         p[1] <= fmax(a[1], b[1]);
}

/* Closed segments pq and ab meet. */
static int seg_seg2(const double p[2], const double q[2], const double a[2], const double b[2]) {
  int o1 = pm_orient2d(p, q, a), o2 = pm_orient2d(p, q, b);
  int o3 = pm_orient2d(a, b, p), o4 = pm_orient2d(a, b, q);
  if (o1 * o2 < 0 && o3 * o4 < 0) return 1;
  if (o1 == 0 && on_segment2(a, p, q)) return 1;
  if (o2 == 0 && on_segment2(b, p, q)) return 1;
  if (o3 == 0 && on_segment2(p, a, b)) return 1;
  if (o4 == 0 && on_segment2(q, a, b)) return 1;
  return 0;
}

/* p in the closed triangle abc (non-degenerate). */
static int in_tri2(const double p[2], const double a[2], const double b[2], const double c[2]) {
  int o = pm_orient2d(a, b, c);
  return pm_orient2d(a, b, p) * o >= 0 && pm_orient2d(b, c, p) * o >= 0 &&
         pm_orient2d(c, a, p) * o >= 0;
}

/* Closed 2D triangles meet. */
static int tri_tri2(const double p[3][2], const double q[3][2]) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (seg_seg2(p[i], p[(i + 1) % 3], q[j], q[(j + 1) % 3])) return 1;
  return in_tri2(p[0], q[0], q[1], q[2]) || in_tri2(q[0], p[0], p[1], p[2]);
}

/* ---- exact 3D helpers ------------------------------------------------------------------------- */

/* Closed segment pq meets closed triangle abc (non-degenerate, axis = plane_axis(a, b, c)). */
static int seg_tri(const double p[3], const double q[3], const double a[3], const double b[3],
                   const double c[3], int ax) {
  int sp = pm_orient3d(a, b, c, p), sq = pm_orient3d(a, b, c, q);
  if (sp * sq > 0) return 0;
  if (sp == 0 && sq == 0) {
    double P[2], Q[2], A[2], B[2], C[2];
    proj(p, ax, P), proj(q, ax, Q), proj(a, ax, A), proj(b, ax, B), proj(c, ax, C);
    return in_tri2(P, A, B, C) || in_tri2(Q, A, B, C) || seg_seg2(P, Q, A, B) ||
           seg_seg2(P, Q, B, C) || seg_seg2(P, Q, C, A);
  }
  int s1 = pm_orient3d(p, q, a, b), s2 = pm_orient3d(p, q, b, c), s3 = pm_orient3d(p, q, c, a);
  return (s1 >= 0 && s2 >= 0 && s3 >= 0) || (s1 <= 0 && s2 <= 0 && s3 <= 0);
}

/* For r in the plane of (a, u, v), a != r: does the ray a -> r lie in the closed wedge spanned at
 * a by the rays a -> u and a -> v (the angle of triangle auv at a)? */
static int ray_in_wedge(const double r[3], const double a[3], const double u[3], const double v[3],
                        int ax) {
  double R[2], A[2], U[2], V[2];
  proj(r, ax, R), proj(a, ax, A), proj(u, ax, U), proj(v, ax, V);
  int o = pm_orient2d(A, U, V);
  return pm_orient2d(A, U, R) * o >= 0 && pm_orient2d(A, R, V) * o >= 0;
}

static inline int same_point(const double *xyz, int32_t i, int32_t j) {
  if (i == j) return 1;
  const double *p = &xyz[3 * (size_t)i], *q = &xyz[3 * (size_t)j];
  return p[0] == q[0] && p[1] == q[1] && p[2] == q[2];
}

int pm_triangle_pair_intersects(const double *xyz, const int32_t t0[3], const int32_t t1[3]) {
  /* Shared vertices: match[i] = the vertex of t1 equal to vertex i of t0, or -1. */
  int match[3], k = 0;
  for (int i = 0; i < 3; ++i) {
    match[i] = -1;
    for (int j = 0; j < 3; ++j)
      if (same_point(xyz, t0[i], t1[j])) {
        match[i] = j;
        break;
      }
    k += match[i] >= 0;
  }
#define X(i) (&xyz[3 * (size_t)(i)])
  int ax0 = plane_axis(X(t0[0]), X(t0[1]), X(t0[2]));
  int ax1 = plane_axis(X(t1[0]), X(t1[1]), X(t1[2]));
  if (ax0 < 0 || ax1 < 0) return 0;
  if (k == 3) return 1;
  if (k == 2) {
    /* Rotate t0 so that its unshared vertex comes last: (a, b, c); d is t1's unshared one. */
    int i = match[0] < 0 ? 0 : (match[1] < 0 ? 1 : 2);
    const double *a = X(t0[(i + 1) % 3]), *b = X(t0[(i + 2) % 3]), *c = X(t0[i]);
    int used = (1 << match[(i + 1) % 3]) | (1 << match[(i + 2) % 3]);
    int jd = (used & 1) == 0 ? 0 : ((used & 2) == 0 ? 1 : 2);
    const double *d = X(t1[jd]);
    if (pm_orient3d(a, b, c, d) != 0) return 0;
    double A[2], B[2], C[2], D[2];
    proj(a, ax0, A), proj(b, ax0, B), proj(c, ax0, C), proj(d, ax0, D);
    return pm_orient2d(A, B, C) * pm_orient2d(A, B, D) > 0;
  }
  if (k == 1) {
    int i = match[0] >= 0 ? 0 : (match[1] >= 0 ? 1 : 2);
    int j = match[i];
    const double *a = X(t0[i]), *b = X(t0[(i + 1) % 3]), *c = X(t0[(i + 2) % 3]);
    const double *d = X(t1[(j + 1) % 3]), *e = X(t1[(j + 2) % 3]);
    int od = pm_orient3d(a, b, c, d), oe = pm_orient3d(a, b, c, e);
    if (od * oe > 0) return 0; /* t1 meets the plane of t0 only at a */
    if (od == 0 && oe == 0)
      return ray_in_wedge(d, a, b, c, ax0) || ray_in_wedge(e, a, b, c, ax0) ||
             ray_in_wedge(b, a, d, e, ax1) || ray_in_wedge(c, a, d, e, ax1);
    int ob = pm_orient3d(a, d, e, b), oc = pm_orient3d(a, d, e, c);
    if (ob * oc > 0) return 0; /* t0 meets the plane of t1 only at a */
    return seg_tri(b, c, a, d, e, ax1) || seg_tri(d, e, a, b, c, ax0);
  }
  /* k = 0 */
  const double *p[3] = {X(t0[0]), X(t0[1]), X(t0[2])}, *q[3] = {X(t1[0]), X(t1[1]), X(t1[2])};
#undef X
  int o[3];
  for (int v = 0; v < 3; ++v) o[v] = pm_orient3d(p[0], p[1], p[2], q[v]);
  if ((o[0] > 0 && o[1] > 0 && o[2] > 0) || (o[0] < 0 && o[1] < 0 && o[2] < 0)) return 0;
  if (o[0] == 0 && o[1] == 0 && o[2] == 0) {
    double P[3][2], Q[3][2];
    for (int v = 0; v < 3; ++v) proj(p[v], ax0, P[v]), proj(q[v], ax0, Q[v]);
    return tri_tri2(P, Q);
  }
  for (int v = 0; v < 3; ++v) o[v] = pm_orient3d(q[0], q[1], q[2], p[v]);
  if ((o[0] > 0 && o[1] > 0 && o[2] > 0) || (o[0] < 0 && o[1] < 0 && o[2] < 0)) return 0;
  for (int v = 0; v < 3; ++v) {
    if (seg_tri(p[v], p[(v + 1) % 3], q[0], q[1], q[2], ax1)) return 1;
    if (seg_tri(q[v], q[(v + 1) % 3], p[0], p[1], p[2], ax0)) return 1;
  }
  return 0;
}

/* ---- driver --------------------------------------------------------------------------------------- */

/* Candidate pairs are buffered and tested in parallel by batches of this many. */
#define CAND_BATCH (1 << 16)

typedef struct pair_buf {
  int64_t *v; /* pairs packed as (i << 32) | j */
  int64_t n, cap;
} pair_buf;

static int buf_push(pair_buf *b, int64_t x) {
  if (b->n == b->cap) {
    int64_t cap = b->cap ? 2 * b->cap : 1024;
    int64_t *nv = realloc(b->v, sizeof(int64_t) * (size_t)cap);
    if (!nv) return 0;
    b->v = nv, b->cap = cap;
  }
  b->v[b->n++] = x;
  return 1;
}

typedef struct si_ctx {
  const double *xyz;
  const int32_t *tri;
  const uint8_t *degenerate;
  int64_t cand[CAND_BATCH];
  uint8_t hit[CAND_BATCH];
  int32_t ncand;
  int64_t ncandidates;
  pair_buf hits;
  int nomem;
} si_ctx;

static void test_batch(si_ctx *c) {
  const int32_t n = c->ncand;
#pragma omp parallel for schedule(dynamic, 1024) if (n > 4096)
  for (int32_t k = 0; k < n; ++k) {
    int32_t i = (int32_t)(c->cand[k] >> 32), j = (int32_t)(c->cand[k] & 0xffffffff);
    c->hit[k] = (uint8_t)pm_triangle_pair_intersects(c->xyz, &c->tri[3 * (size_t)i],
                                                     &c->tri[3 * (size_t)j]);
  }
  for (int32_t k = 0; k < n; ++k)
    if (c->hit[k] && !buf_push(&c->hits, c->cand[k])) c->nomem = 1;
  c->ncandidates += n;
  c->ncand = 0;
}

static void on_pairs(void *user, const int32_t *pairs, int32_t npair) {
  si_ctx *c = user;
  for (int32_t k = 0; k < npair; ++k) {
    int32_t i = pairs[2 * k], j = pairs[2 * k + 1];
    if (c->degenerate[i] || c->degenerate[j]) continue;
    c->cand[c->ncand++] = ((int64_t)i << 32) | (int64_t)j;
    if (c->ncand == CAND_BATCH) test_batch(c);
  }
}

static int cmp_i64(const void *a, const void *b) {
  int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
  return (x > y) - (x < y);
}

void pm_selfint_report_free(pm_selfint_report *r) {
  if (!r) return;
  free(r->pairs);
  memset(r, 0, sizeof *r);
}

pm_status pm_triangles_self_intersections(const double *xyz, int32_t nnode, const int32_t *tri,
                                          int32_t ntri, int32_t max_report,
                                          pm_selfint_report *out, pm_error *err) {
  memset(out, 0, sizeof *out);
  out->first_degenerate = -1;
  if (max_report < 0)
    return pm_error_setf(err, PM_ERR_ARG, "self-intersection: max_report must be >= 0, got %d",
                         (int)max_report);
  pm_bvh *bvh = NULL;
  pm_status s = pm_bvh_create(xyz, nnode, tri, ntri, &bvh, err);
  if (s) {
    pm_error_prefix(err, "self-intersection");
    return s;
  }
  si_ctx *c = calloc(1, sizeof *c);
  uint8_t *deg = malloc((size_t)(ntri > 0 ? ntri : 1));
  if (!c || !deg) {
    free(c), free(deg);
    pm_bvh_destroy(bvh);
    return pm_error_setf(err, PM_ERR_NOMEM, "self-intersection: out of memory");
  }
  int32_t ndeg = 0;
#pragma omp parallel for reduction(+ : ndeg) schedule(static) if (ntri > 10000)
  for (int32_t t = 0; t < ntri; ++t) {
    const int32_t *v = &tri[3 * (size_t)t];
    deg[t] = plane_axis(&xyz[3 * (size_t)v[0]], &xyz[3 * (size_t)v[1]], &xyz[3 * (size_t)v[2]]) < 0;
    ndeg += deg[t];
  }
  out->ndegenerate = ndeg;
  for (int32_t t = 0; t < ntri && ndeg; ++t)
    if (deg[t]) {
      out->first_degenerate = t;
      break;
    }
  c->xyz = xyz, c->tri = tri, c->degenerate = deg;
  s = pm_bvh_overlapping_pairs(bvh, on_pairs, c, err);
  if (!s && c->ncand) test_batch(c);
  pm_bvh_destroy(bvh);
  free(deg);
  if (!s && c->nomem) s = pm_error_setf(err, PM_ERR_NOMEM, "self-intersection: out of memory");
  if (s) {
    free(c->hits.v);
    free(c);
    return s;
  }
  /* The broad phase reports pairs in an order that depends on Embree's traversal: sort, so that
   * the listed pairs are the first ones in (i, j) order whatever the order of discovery. */
  if (c->hits.n > 1) qsort(c->hits.v, (size_t)c->hits.n, sizeof(int64_t), cmp_i64);
  out->count = c->hits.n;
  out->ncandidates = c->ncandidates;
  int32_t nrep = (int32_t)(c->hits.n < max_report ? c->hits.n : max_report);
  if (nrep > 0) {
    out->pairs = malloc(sizeof(int32_t) * 2 * (size_t)nrep);
    if (!out->pairs) {
      free(c->hits.v);
      free(c);
      return pm_error_setf(err, PM_ERR_NOMEM, "self-intersection: out of memory");
    }
    for (int32_t k = 0; k < nrep; ++k) {
      out->pairs[2 * k] = (int32_t)(c->hits.v[k] >> 32);
      out->pairs[2 * k + 1] = (int32_t)(c->hits.v[k] & 0xffffffff);
    }
  }
  out->nreport = nrep;
  free(c->hits.v);
  free(c);
  return PM_OK;
}

pm_status pm_mesh_self_intersections(const pm_mesh *mesh, int32_t max_report,
                                     pm_selfint_report *out, pm_error *err) {
  return pm_triangles_self_intersections(mesh->xyz, mesh->nnode, mesh->tri, mesh->ntri, max_report,
                                         out, err);
}
