/* Relocating the interior nodes of one face's triangulation (see face_smooth.h). */
#include "common/connect/face_smooth.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/vec3.h"

/* R / l_min of triangle (a, b, c): R = l0 l1 l2 / (4 area), so R / l_min is the product of the
 * two longer edges over 4 area. Returns HUGE_VAL for a degenerate triangle, and for one whose
 * normal turns against a node's surface normal (na, nb, nc, each zero where there is none). */
static double ring_ratio(const double *a, const double *b, const double *c, const double *na,
                         const double *nb, const double *nc) {
  double ab[3], bc[3], ca[3], n[3];
  pm_v3_sub(ab, b, a), pm_v3_sub(bc, c, b), pm_v3_sub(ca, a, c);
  pm_v3_cross(n, ab, ca);
  pm_v3_scale(n, n, -1.0);
  double l0 = pm_v3_dot(ab, ab), l1 = pm_v3_dot(bc, bc), l2 = pm_v3_dot(ca, ca);
  double n2 = pm_v3_dot(n, n), lmax = fmax(l0, fmax(l1, l2));
  if (!(n2 > 1e-20 * lmax * lmax)) return HUGE_VAL;
  if (pm_v3_dot(n, na) < 0 || pm_v3_dot(n, nb) < 0 || pm_v3_dot(n, nc) < 0) return HUGE_VAL;
  double lmin = fmin(l0, fmin(l1, l2));
  /* area = |n| / 2, so 4 area = 2 |n|; the two longer edges' squared product is l0 l1 l2 / lmin. */
  return sqrt(l0 * l1 * l2 / lmin) / (2 * sqrt(n2));
}

/* The worst and the summed R / l_min of node v's ring, with v at position p and normal pn, and
 * how many of its triangles' corners other than v have an angle whose cosine exceeds `thin_cos`
 * (an angle below the limit; 2: none counted). */
static void ring_measure(int32_t v, const double *p, const double *pn, const double *xyz,
                         const double *nrm, const int32_t *tri, const int32_t *ring, int32_t nring,
                         double thin_cos, double *worst, double *sum, int *nthin) {
  *worst = 0, *sum = 0, *nthin = 0;
  for (int32_t k = 0; k < nring; ++k) {
    const int32_t *t = &tri[3 * ring[k]];
    const double *P[3], *N[3];
    for (int q = 0; q < 3; ++q) {
      P[q] = t[q] == v ? p : &xyz[3 * t[q]];
      N[q] = t[q] == v ? pn : &nrm[3 * t[q]];
    }
    double r = ring_ratio(P[0], P[1], P[2], N[0], N[1], N[2]);
    *worst = fmax(*worst, r), *sum += r;
    if (thin_cos > 1) continue;
    for (int q = 0; q < 3; ++q) {
      if (t[q] == v) continue;
      double a[3], b[3];
      pm_v3_sub(a, P[(q + 1) % 3], P[q]), pm_v3_sub(b, P[(q + 2) % 3], P[q]);
      *nthin += pm_v3_dot(a, b) > thin_cos * pm_v3_norm(a) * pm_v3_norm(b);
    }
  }
}

/* The point of face f a move dx away from the face point (uv0, der0 = Su | Sv there): the
 * least-squares parameter step whose image Su du + Sv dv is the tangential part of dx
 * (pm_cell_param_delta), evaluated exactly -- its parameters, position and unit normal. Returns
 * 0 when it leaves the trimmed region or the surface has no normal there. One step, not the
 * closest point of the surface to the node's target: the target is a heuristic aim (a centroid,
 * an apex) and the test that follows measures the exact point, whereas projecting the target
 * onto the surface took a Newton iteration of second-derivative evaluations (three gmsh calls
 * each on a B-spline face): `packmesh mesh wrench.stp --method bubble --target-nodes 100000
 * --threads 1 --stats`, two alternating runs each on a loaded machine, the connection 4.24 and
 * 4.54 s with the projection, 2.52 and 2.29 s with the step (1.09 s without smoothing); the
 * median R / l_min 0.596178 either way. */
static int surface_point(const pm_cell *f, const double dx[3], const double uv0[2],
                         const double der0[6], double uv[2], double p[3], double n[3]) {
  double duv[2] = {0, 0};
  pm_cell_param_delta(f, uv0, der0, dx, duv);
  uv[0] = uv0[0] + duv[0], uv[1] = uv0[1] + duv[1];
  pm_cell_wrap(f, uv);
  if (!pm_face_inside(f, uv)) return 0;
  pm_face_point fp;
  pm_face_eval(f, uv, 1, &fp);
  if (!pm_face_point_normal(&fp, PM_CONNECT_NORMAL_MIN_SIN, n)) return 0;
  memcpy(p, fp.p, sizeof fp.p);
  return 1;
}

/* The needle move of node v (face_smooth.h, needle_deg): among v's ring, the triangle with the
 * smallest angle at v; when that angle is below needle_deg, the point on the way from v to the
 * nearest point of the opposite edge (a, b) at which an isoceles triangle on that edge would have
 * NEEDLE_AIM x needle_deg at v; when v is no farther from the edge than that already (v beside
 * the edge's line rather than above it), that triangle's apex on v's side of the edge. Returns 0
 * when the angle is not below the limit. */
#define NEEDLE_AIM 1.25
#define NEEDLE_STEPS 8

/* The cosine of the angle at v of ring triangle rv (with the triangle's two other corners into
 * *x, *y), or NAN for a triangle degenerate at v. */
static double corner_cos(int32_t v, const double *xyz, const int32_t *t, const double **x,
                         const double **y) {
  const double *p = &xyz[3 * v];
  int q = t[0] == v ? 0 : (t[1] == v ? 1 : 2);
  *x = &xyz[3 * t[(q + 1) % 3]], *y = &xyz[3 * t[(q + 2) % 3]];
  double u[3], w[3];
  pm_v3_sub(u, *x, p), pm_v3_sub(w, *y, p);
  double nuw = pm_v3_norm(u) * pm_v3_norm(w);
  return nuw > 0 ? pm_v3_dot(u, w) / nuw : NAN;
}

static int needle_target(int32_t v, const double *xyz, const int32_t *tri, const int32_t *rv,
                         int32_t nring, double needle_deg, double target[3]) {
  const double *p = &xyz[3 * v];
  /* the smallest angle is the largest cosine; every node of every sweep comes here, so no acos */
  double best = cos(needle_deg * M_PI / 180), a[3] = {0, 0, 0}, b[3] = {0, 0, 0};
  int found = 0;
  for (int32_t k = 0; k < nring; ++k) {
    const double *x, *y;
    double c = corner_cos(v, xyz, &tri[3 * rv[k]], &x, &y);
    if (c > best) best = c, found = 1, pm_v3_copy(a, x), pm_v3_copy(b, y);
  }
  if (!found) return 0;
  double e[3], pa[3], foot[3];
  pm_v3_sub(e, b, a), pm_v3_sub(pa, p, a);
  const double L2 = pm_v3_dot(e, e);
  double t = L2 > 0 ? pm_v3_dot(pa, e) / L2 : 0;
  t = t < 0 ? 0 : (t > 1 ? 1 : t);
  pm_v3_axpy(foot, a, t, e);
  const double h = pm_v3_dist(p, foot);
  const double aim = sqrt(L2) / (2 * tan(NEEDLE_AIM * needle_deg * M_PI / 360));
  double d[3];
  if (h > aim) {
    pm_v3_sub(d, foot, p);
    pm_v3_axpy(target, p, 1 - aim / h, d);
    return 1;
  }
  /* v within aim of the edge's nearer end but beside the edge: the apex of the isoceles
   * triangle on the edge, on v's side of it */
  double mid[3], up[3];
  pm_v3_axpy(mid, a, 0.5, e);
  pm_v3_sub(up, p, mid);
  pm_v3_axpy(up, up, -pm_v3_dot(up, e) / L2, e);
  const double hu = pm_v3_norm(up);
  if (!(hu > 0)) return 0;
  pm_v3_axpy(target, mid, aim / hu, up);
  return 1;
}

/* The flat move of node v (face_smooth.h, needle_deg): among v's ring, the triangle with the
 * largest angle at v; when that angle is obtuse, v's foot lies inside the opposite edge (a, b)
 * and the triangle has an angle below needle_deg at a or b (v lies too near the edge: a face
 * node beside a long boundary segment), the point above the foot, on v's side, at the height
 * where the smaller of those two angles is NEEDLE_AIM x needle_deg. Returns 0 otherwise. */
static int flat_target(int32_t v, const double *xyz, const int32_t *tri, const int32_t *rv,
                       int32_t nring, double needle_deg, double target[3]) {
  const double *p = &xyz[3 * v];
  double best = 0, a[3] = {0, 0, 0}, b[3] = {0, 0, 0}; /* cosine of an obtuse angle: < 0 */
  for (int32_t k = 0; k < nring; ++k) {
    const double *x, *y;
    double c = corner_cos(v, xyz, &tri[3 * rv[k]], &x, &y);
    if (c < best) best = c, pm_v3_copy(a, x), pm_v3_copy(b, y);
  }
  if (!(best < 0)) return 0;
  double e[3], pa[3], foot[3], up[3];
  pm_v3_sub(e, b, a), pm_v3_sub(pa, p, a);
  const double L2 = pm_v3_dot(e, e);
  if (!(L2 > 0)) return 0;
  const double t = pm_v3_dot(pa, e) / L2;
  if (!(t > 0 && t < 1)) return 0;
  pm_v3_axpy(foot, a, t, e);
  pm_v3_sub(up, p, foot);
  const double h = pm_v3_norm(up), far = (t > 0.5 ? t : 1 - t) * sqrt(L2);
  /* the smaller angle, at the end farther from the foot, and the height that makes it the aim */
  if (!(h > 0) || !(atan2(h, far) < needle_deg * M_PI / 180)) return 0;
  const double aim = far * tan(NEEDLE_AIM * needle_deg * M_PI / 180);
  pm_v3_axpy(target, foot, aim / h, up);
  return 1;
}

/* Try the move of node v towards `to`, whole and then halved: kept (1) when its ring gets better.
 * Better: the largest R / l_min does not grow and their sum falls (a Laplacian move, needle_deg
 * = 0); or, for a needle move, the largest falls and no more of the ring's corners away from v
 * have an angle below needle_deg. Not the sum: the thin triangles of a fan onto a finely spaced
 * curve all gain a little where the needle gains most, and their sum can rise a hair
 * (robust/step__SampleCrankshaft4A.stp with psys: the ring's worst 2.98 -> 2.93, its sum 9.950
 * -> 9.960, a 9.6-degree needle left; the next sweeps step again). Not more small corners away
 * from v: a step that turns the needle at v into one at a neighbour (a face node stepping to
 * 0.0013 from a curve node, the same file with bubble: a 6.9-degree corner at the curve node where
 * a needle forced by a CAD feature was) is no gain. */
static int try_move(const pm_cell *f, int32_t v, const double to[3], double needle_deg,
                    double *xyz, double *uv, double *nrm, const int32_t *tri, const int32_t *rv,
                    int32_t nring) {
  double worst0, sum0;
  int nthin0;
  const double thin_cos = needle_deg > 0 ? cos(needle_deg * M_PI / 180) : 2;
  ring_measure(v, &xyz[3 * v], &nrm[3 * v], xyz, nrm, tri, rv, nring, thin_cos, &worst0, &sum0,
               &nthin0);
  pm_face_point fp0;
  pm_face_eval(f, &uv[2 * v], 1, &fp0);
  const double der0[6] = {fp0.su[0], fp0.su[1], fp0.su[2], fp0.sv[0], fp0.sv[1], fp0.sv[2]};
  for (int half = 0; half < 2; ++half) {
    double dx[3], nuv[2], p[3], n[3], worst, sum;
    int nthin;
    pm_v3_sub(dx, to, &xyz[3 * v]);
    pm_v3_scale(dx, dx, half ? 0.5 : 1.0);
    if (!surface_point(f, dx, &uv[2 * v], der0, nuv, p, n)) continue;
    ring_measure(v, p, n, xyz, nrm, tri, rv, nring, thin_cos, &worst, &sum, &nthin);
    if (needle_deg > 0 ? !(worst < worst0 && nthin <= nthin0) : !(worst <= worst0 && sum < sum0))
      continue;
    memcpy(&xyz[3 * v], p, sizeof p);
    memcpy(&nrm[3 * v], n, sizeof n);
    memcpy(&uv[2 * v], nuv, sizeof nuv);
    return 1;
  }
  return 0;
}

int32_t pm_face_smooth_sweep(const pm_cell *f, int32_t nv, double *xyz, double *uv, double *nrm,
                             const uint8_t *movable, int32_t ntri, const int32_t *tri,
                             double needle_deg, uint8_t *dirty) {
  /* The triangles around each node, as offsets into one array (counting sort by node). */
  int32_t *off = calloc((size_t)nv + 1, sizeof(int32_t));
  int32_t *ring = malloc(sizeof(int32_t) * 3 * (size_t)(ntri ? ntri : 1));
  if (!off || !ring) {
    free(off), free(ring);
    return -1;
  }
  for (int32_t i = 0; i < 3 * ntri; ++i) off[tri[i] + 1]++;
  for (int32_t v = 0; v < nv; ++v) off[v + 1] += off[v];
  for (int32_t t = 0; t < ntri; ++t)
    for (int q = 0; q < 3; ++q) ring[off[tri[3 * t + q]]++] = t;
  for (int32_t v = nv; v > 0; --v) off[v] = off[v - 1];
  off[0] = 0;

  int32_t moved = 0;
  for (int32_t v = 0; v < nv; ++v) {
    int32_t nring = off[v + 1] - off[v];
    if (!movable[v] || nring < 3 || (dirty && !dirty[v])) continue;
    if (dirty) dirty[v] = 0;
    const int32_t *rv = &ring[off[v]];
    /* The centroid of the ring's other nodes: each neighbour of an interior node appears in two
     * of its triangles, so the mean over triangles weighs them alike. */
    double c[3] = {0, 0, 0};
    for (int32_t k = 0; k < nring; ++k)
      for (int q = 0; q < 3; ++q)
        if (tri[3 * rv[k] + q] != v) pm_v3_add(c, c, &xyz[3 * tri[3 * rv[k] + q]]);
    pm_v3_scale(c, c, 0.5 / nring);
    double to[3];
    int ok = 0;
    for (int k = 0; k < NEEDLE_STEPS && needle_deg > 0 &&
                    needle_target(v, xyz, tri, rv, nring, needle_deg, to) &&
                    try_move(f, v, to, needle_deg, xyz, uv, nrm, tri, rv, nring);
         ++k)
      ok = 1;
    if (!ok && needle_deg > 0 && flat_target(v, xyz, tri, rv, nring, needle_deg, to))
      ok = try_move(f, v, to, needle_deg, xyz, uv, nrm, tri, rv, nring);
    if (!ok) ok = try_move(f, v, c, 0, xyz, uv, nrm, tri, rv, nring);
    if (!ok) continue;
    ++moved;
    if (dirty)
      for (int32_t k = 0; k < nring; ++k)
        for (int q = 0; q < 3; ++q) dirty[tri[3 * rv[k] + q]] = 1;
  }
  free(off), free(ring);
  return moved;
}
