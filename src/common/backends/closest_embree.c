/* Closest-point queries through Embree's BVH (see closest_embree.h for the contract and for why
 * the answers are exact despite Embree's single-precision boxes). */
#include "common/backends/closest_embree.h"

#include <embree3/rtcore.h>

#include <float.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/vec3.h"

/* Embree's errors arrive through a device callback, possibly from one of its threads; they are
 * kept here (first error wins) and turned into a pm_error by the function that made the call. */
typedef struct em_errors {
  pthread_mutex_t lock;
  enum RTCError code;
  char msg[400];
} em_errors;

struct pm_bvh {
  int32_t nnode, ntri;
  double *xyz;       /* [3*nnode] own copy */
  int32_t *tri;      /* [3*ntri] own copy */
  double coord_max;  /* the largest |coordinate| of a node a triangle uses */
  RTCDevice device;
  RTCScene scene;
  em_errors *errs;   /* mutable from const queries, hence behind a pointer */
};

/* Margin of the float query sphere, relative to the magnitude of the coordinates involved.
 * Rounding the query point to floats moves it by at most sqrt(3) 2^-24 |p|_inf, and Embree's
 * float box-sphere test errs by a few ulps of the coordinates; 8 x 2^-24 covers both with room
 * to spare. The search radius is also scaled by 1 + 1e-6 for the rounding of distances. */
#define SPHERE_MARGIN (8.0 * FLT_EPSILON / 2.0)
#define SPHERE_SCALE (1.0 + 1e-6)

/* ---- point-triangle distance ------------------------------------------------------------- */

/* Closest point of segment ab to p: t in [0, 1] along ab. */
static double seg_closest(const double p[3], const double a[3], const double b[3], double *t_out) {
  double ab[3], ap[3];
  pm_v3_sub(ab, b, a);
  pm_v3_sub(ap, p, a);
  double l2 = pm_v3_dot(ab, ab), t = 0;
  if (l2 > 0) {
    t = pm_v3_dot(ap, ab) / l2;
    t = t < 0 ? 0 : (t > 1 ? 1 : t);
  }
  double q[3];
  pm_v3_axpy(q, a, t, ab);
  *t_out = t;
  return pm_v3_dist(p, q);
}

double pm_point_triangle_closest(const double p[3], const double a[3], const double b[3],
                                 const double c[3], double q[3], double bary[3]) {
  double ab[3], ac[3], ap[3], n[3];
  pm_v3_sub(ab, b, a);
  pm_v3_sub(ac, c, a);
  pm_v3_cross(n, ab, ac);
  double nn = pm_v3_dot(n, n), scale = pm_v3_dot(ab, ab) * pm_v3_dot(ac, ac);
  double w[3];
  if (!(nn > 1e-20 * scale)) {
    /* A segment or a point (or a triangle thinner than 1e-10 of its edges, where the region
     * tests below lose their meaning): the closest point lies on one of the three edges. */
    const double *v[3] = {a, b, c};
    double best = INFINITY;
    for (int k = 0; k < 3; ++k) {
      double t, d = seg_closest(p, v[k], v[(k + 1) % 3], &t);
      if (d < best) {
        best = d;
        w[k] = 1 - t, w[(k + 1) % 3] = t, w[(k + 2) % 3] = 0;
      }
    }
  } else {
    /* The Voronoi regions of the vertices, edges and face of the triangle, tested in turn with
     * dot products (the classical region walk, e.g. Ericson, Real-Time Collision Detection 5.1.5).
     * In the face region va + vb + vc = |n|^2 > 0. */
    pm_v3_sub(ap, p, a);
    double d1 = pm_v3_dot(ab, ap), d2 = pm_v3_dot(ac, ap);
    double bp[3], cp[3];
    pm_v3_sub(bp, p, b);
    double d3 = pm_v3_dot(ab, bp), d4 = pm_v3_dot(ac, bp);
    pm_v3_sub(cp, p, c);
    double d5 = pm_v3_dot(ab, cp), d6 = pm_v3_dot(ac, cp);
    double vc = d1 * d4 - d3 * d2, vb = d5 * d2 - d1 * d6, va = d3 * d6 - d5 * d4;
    if (d1 <= 0 && d2 <= 0) {
      w[0] = 1, w[1] = 0, w[2] = 0;
    } else if (d3 >= 0 && d4 <= d3) {
      w[0] = 0, w[1] = 1, w[2] = 0;
    } else if (d6 >= 0 && d5 <= d6) {
      w[0] = 0, w[1] = 0, w[2] = 1;
    } else if (vc <= 0 && d1 >= 0 && d3 <= 0) {
      double t = d1 / (d1 - d3);
      w[0] = 1 - t, w[1] = t, w[2] = 0;
    } else if (vb <= 0 && d2 >= 0 && d6 <= 0) {
      double t = d2 / (d2 - d6);
      w[0] = 1 - t, w[1] = 0, w[2] = t;
    } else if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
      double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
      w[0] = 0, w[1] = 1 - t, w[2] = t;
    } else {
      double s = va + vb + vc;
      w[1] = vb / s, w[2] = vc / s, w[0] = 1 - w[1] - w[2];
    }
  }
  double r[3];
  for (int k = 0; k < 3; ++k) r[k] = w[0] * a[k] + w[1] * b[k] + w[2] * c[k];
  /* The face-region point is the foot of p on the plane; evaluate it as such, which is exact to
   * rounding even where the barycentric weights are poorly conditioned. */
  if (w[0] > 0 && w[1] > 0 && w[2] > 0 && nn > 1e-20 * scale) {
    double dp[3];
    pm_v3_sub(dp, p, a);
    double s = pm_v3_dot(dp, n) / nn;
    pm_v3_axpy(r, p, -s, n);
  }
  if (q) pm_v3_copy(q, r);
  if (bary) pm_v3_copy(bary, w);
  return pm_v3_dist(p, r);
}

/* ---- Embree plumbing ----------------------------------------------------------------------- */

static const char *rtc_error_name(enum RTCError e) {
  switch (e) {
    case RTC_ERROR_NONE: return "no error";
    case RTC_ERROR_UNKNOWN: return "unknown error";
    case RTC_ERROR_INVALID_ARGUMENT: return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION: return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY: return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU: return "unsupported CPU";
    case RTC_ERROR_CANCELLED: return "cancelled";
  }
  return "unknown error";
}

static void on_embree_error(void *user, enum RTCError code, const char *str) {
  em_errors *e = user;
  pthread_mutex_lock(&e->lock);
  if (e->code == RTC_ERROR_NONE) {
    e->code = code;
    snprintf(e->msg, sizeof e->msg, "%s%s%s", rtc_error_name(code), str && *str ? ": " : "",
             str ? str : "");
  }
  pthread_mutex_unlock(&e->lock);
}

/* PM_OK when Embree reported nothing since the last check, else the error (and clear it). */
static pm_status take_embree_error(em_errors *e, const char *what, pm_error *err) {
  pthread_mutex_lock(&e->lock);
  enum RTCError code = e->code;
  char msg[sizeof e->msg];
  memcpy(msg, e->msg, sizeof msg);
  e->code = RTC_ERROR_NONE;
  e->msg[0] = 0;
  pthread_mutex_unlock(&e->lock);
  if (code == RTC_ERROR_NONE) return PM_OK;
  return pm_error_setf(err, code == RTC_ERROR_OUT_OF_MEMORY ? PM_ERR_NOMEM : PM_ERR_BACKEND,
                       "Embree failed %s: %s", what, msg);
}

/* Round a double box outwards to floats, so that the float box contains the double one. */
static inline float round_down(double x) {
  float f = (float)x;
  return (double)f > x ? nextafterf(f, -INFINITY) : f;
}
static inline float round_up(double x) {
  float f = (float)x;
  return (double)f < x ? nextafterf(f, INFINITY) : f;
}

static void tri_box(const pm_bvh *b, int32_t t, double lo[3], double hi[3]) {
  const int32_t *v = &b->tri[3 * (size_t)t];
  for (int k = 0; k < 3; ++k) {
    double x0 = b->xyz[3 * (size_t)v[0] + k], x1 = b->xyz[3 * (size_t)v[1] + k],
           x2 = b->xyz[3 * (size_t)v[2] + k];
    lo[k] = fmin(x0, fmin(x1, x2));
    hi[k] = fmax(x0, fmax(x1, x2));
  }
}

static void bounds_cb(const struct RTCBoundsFunctionArguments *args) {
  const pm_bvh *b = args->geometryUserPtr;
  double lo[3], hi[3];
  tri_box(b, (int32_t)args->primID, lo, hi);
  struct RTCBounds *o = args->bounds_o;
  o->lower_x = round_down(lo[0]), o->lower_y = round_down(lo[1]), o->lower_z = round_down(lo[2]);
  o->upper_x = round_up(hi[0]), o->upper_y = round_up(hi[1]), o->upper_z = round_up(hi[2]);
}

pm_status pm_bvh_create(const double *xyz, int32_t nnode, const int32_t *tri, int32_t ntri,
                        pm_bvh **out, pm_error *err) {
  *out = NULL;
  if (nnode < 0 || ntri < 0)
    return pm_error_setf(err, PM_ERR_ARG, "BVH: negative count (%d nodes, %d triangles)",
                         (int)nnode, (int)ntri);
  if (ntri > 0 && (!xyz || !tri))
    return pm_error_setf(err, PM_ERR_ARG, "BVH: missing node or triangle array");
  double cmax = 0;
  for (int32_t t = 0; t < ntri; ++t)
    for (int k = 0; k < 3; ++k) {
      int32_t v = tri[3 * (size_t)t + k];
      if (v < 0 || v >= nnode)
        return pm_error_setf(err, PM_ERR_ARG, "BVH: triangle %d uses node %d of %d", (int)t,
                             (int)v, (int)nnode);
      for (int q = 0; q < 3; ++q) {
        double x = xyz[3 * (size_t)v + q];
        if (!isfinite(x))
          return pm_error_setf(err, PM_ERR_ARG, "BVH: node %d has a non-finite coordinate",
                               (int)v);
        cmax = fmax(cmax, fabs(x));
      }
    }
  pm_bvh *b = calloc(1, sizeof *b);
  em_errors *e = calloc(1, sizeof *e);
  if (!b || !e) {
    free(b), free(e);
    return pm_error_setf(err, PM_ERR_NOMEM, "BVH: out of memory");
  }
  pthread_mutex_init(&e->lock, NULL);
  e->code = RTC_ERROR_NONE;
  b->errs = e;
  b->nnode = nnode, b->ntri = ntri, b->coord_max = cmax;
  b->xyz = malloc(sizeof(double) * 3 * (size_t)(nnode > 0 ? nnode : 1));
  b->tri = malloc(sizeof(int32_t) * 3 * (size_t)(ntri > 0 ? ntri : 1));
  if (!b->xyz || !b->tri) {
    pm_bvh_destroy(b);
    return pm_error_setf(err, PM_ERR_NOMEM, "BVH: out of memory copying %d nodes, %d triangles",
                         (int)nnode, (int)ntri);
  }
  if (nnode) memcpy(b->xyz, xyz, sizeof(double) * 3 * (size_t)nnode);
  if (ntri) memcpy(b->tri, tri, sizeof(int32_t) * 3 * (size_t)ntri);

  /* One Embree thread: the callers parallelize their queries with OpenMP, and a second pool
   * (Embree's TBB workers) would only compete for the same cores (see bench_closest for the
   * build times this costs). */
  b->device = rtcNewDevice("threads=1");
  if (!b->device) {
    enum RTCError code = rtcGetDeviceError(NULL);
    pm_bvh_destroy(b);
    return pm_error_setf(err, code == RTC_ERROR_OUT_OF_MEMORY ? PM_ERR_NOMEM : PM_ERR_BACKEND,
                         "Embree failed creating a device: %s", rtc_error_name(code));
  }
  rtcSetDeviceErrorFunction(b->device, on_embree_error, e);
  pm_status s;
  b->scene = rtcNewScene(b->device);
  if ((s = take_embree_error(e, "creating a scene", err)) || !b->scene) {
    if (!s) s = pm_error_setf(err, PM_ERR_BACKEND, "Embree failed creating a scene");
    pm_bvh_destroy(b);
    return s;
  }
  /* Embree's low build quality (its Morton-code builder): the hierarchy's build, on one thread,
   * was most of the cost of the distance's reference, and a closest point is exact and its ties
   * go to the lowest index whatever the tree, so the answers stay the same. `bench_closest
   * 100000` with one thread, this build against the default quality: 100488 triangles 0.054 s
   * against 0.090 s, the queries as fast (556k to 563k per second against 490k to 544k). */
  rtcSetSceneBuildQuality(b->scene, RTC_BUILD_QUALITY_LOW);
  if (ntri > 0) {
    /* User primitives rather than Embree triangles: their boxes are ours (rounded outwards from
     * the doubles), degenerate triangles are kept, and rtcCollide (the self-intersection broad
     * phase) accepts only user geometry in Embree 3. */
    RTCGeometry g = rtcNewGeometry(b->device, RTC_GEOMETRY_TYPE_USER);
    if (g) {
      rtcSetGeometryUserPrimitiveCount(g, (unsigned)ntri);
      rtcSetGeometryUserData(g, b);
      rtcSetGeometryBoundsFunction(g, bounds_cb, b);
      rtcCommitGeometry(g);
      rtcAttachGeometry(b->scene, g);
      rtcReleaseGeometry(g);
    }
    if ((s = take_embree_error(e, "creating the triangle geometry", err)) || !g) {
      if (!s) s = pm_error_setf(err, PM_ERR_BACKEND, "Embree failed creating a geometry");
      pm_bvh_destroy(b);
      return s;
    }
  }
  rtcCommitScene(b->scene);
  if ((s = take_embree_error(e, "building the BVH", err))) {
    pm_bvh_destroy(b);
    return s;
  }
  *out = b;
  return PM_OK;
}

void pm_bvh_destroy(pm_bvh *b) {
  if (!b) return;
  if (b->scene) rtcReleaseScene(b->scene);
  if (b->device) rtcReleaseDevice(b->device);
  if (b->errs) {
    pthread_mutex_destroy(&b->errs->lock);
    free(b->errs);
  }
  free(b->xyz);
  free(b->tri);
  free(b);
}

int32_t pm_bvh_ntri(const pm_bvh *b) { return b->ntri; }

/* ---- queries --------------------------------------------------------------------------------- */

typedef struct query_ctx {
  const pm_bvh *b;
  double p[3];
  double margin;   /* absolute part of the sphere margin for this query point */
  double limit;    /* accept distances <= limit */
  /* closest */
  pm_bvh_hit *hit;
  /* visit */
  pm_bvh_visit_fn fn;
  void *user;
  double radius;
} query_ctx;

/* The float radius that safely covers every point within r of the double query point. */
static float sphere_radius(const query_ctx *q, double r) {
  if (!(r < INFINITY)) return INFINITY;
  return round_up((r + q->margin) * SPHERE_SCALE);
}

static void query_init(query_ctx *q, const pm_bvh *b, const double p[3],
                       struct RTCPointQuery *rq) {
  q->b = b;
  pm_v3_copy(q->p, p);
  double pmax = fmax(fabs(p[0]), fmax(fabs(p[1]), fabs(p[2])));
  q->margin = SPHERE_MARGIN * (b->coord_max + pmax);
  rq->x = (float)p[0], rq->y = (float)p[1], rq->z = (float)p[2];
  rq->time = 0;
}

static bool closest_cb(struct RTCPointQueryFunctionArguments *args) {
  query_ctx *q = args->userPtr;
  const pm_bvh *b = q->b;
  int32_t t = (int32_t)args->primID;
  const int32_t *v = &b->tri[3 * (size_t)t];
  double pt[3], w[3];
  double d = pm_point_triangle_closest(q->p, &b->xyz[3 * (size_t)v[0]], &b->xyz[3 * (size_t)v[1]],
                                       &b->xyz[3 * (size_t)v[2]], pt, w);
  /* Among triangles at the same distance the lowest index wins, as in a search of the
   * triangles in index order: the answer does not depend on how the hierarchy was built or in
   * which order it is traversed. (The radius keeps a margin above d, so the others at d are
   * still visited.) */
  if ((d < q->hit->dist || (d == q->hit->dist && t < q->hit->tri)) && d <= q->limit) {
    pm_bvh_hit *h = q->hit;
    h->tri = t, h->dist = d;
    pm_v3_copy(h->point, pt);
    pm_v3_copy(h->bary, w);
    args->query->radius = sphere_radius(q, d);
    return true;
  }
  return false;
}

int pm_bvh_closest(const pm_bvh *b, const double p[3], double max_radius, pm_bvh_hit *hit) {
  hit->tri = -1;
  hit->dist = INFINITY;
  pm_v3_zero(hit->point);
  pm_v3_zero(hit->bary);
  if (b->ntri == 0 || !(isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2])) ||
      !(max_radius >= 0))
    return 0;
  query_ctx q = {0};
  struct RTCPointQuery rq;
  query_init(&q, b, p, &rq);
  q.hit = hit;
  q.limit = max_radius;
  rq.radius = sphere_radius(&q, max_radius);
  struct RTCPointQueryContext ctx;
  rtcInitPointQueryContext(&ctx);
  rtcPointQuery(b->scene, &rq, &ctx, closest_cb, &q);
  return hit->tri >= 0;
}

static bool visit_cb(struct RTCPointQueryFunctionArguments *args) {
  query_ctx *q = args->userPtr;
  double r = q->fn(q->user, (int32_t)args->primID, q->radius);
  if (r < q->radius) {
    q->radius = r;
    args->query->radius = sphere_radius(q, r);
    return true;
  }
  return false;
}

double pm_bvh_visit(const pm_bvh *b, const double p[3], double radius, pm_bvh_visit_fn fn,
                    void *user) {
  if (b->ntri == 0 || !(isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2])) || !(radius >= 0))
    return radius;
  query_ctx q = {0};
  struct RTCPointQuery rq;
  query_init(&q, b, p, &rq);
  q.fn = fn, q.user = user, q.radius = radius;
  rq.radius = sphere_radius(&q, radius);
  struct RTCPointQueryContext ctx;
  rtcInitPointQueryContext(&ctx);
  rtcPointQuery(b->scene, &rq, &ctx, visit_cb, &q);
  return q.radius;
}

/* ---- overlapping pairs (rtcCollide) ------------------------------------------------------------ */

typedef struct collide_ctx {
  const pm_bvh *b;
  pm_bvh_pair_fn fn;
  void *user;
  pthread_mutex_t lock;
} collide_ctx;

/* Pairs handed to fn per call (a stack buffer). */
#define PAIR_BATCH 512

static int boxes_touch(const pm_bvh *b, int32_t s, int32_t t) {
  double lo0[3], hi0[3], lo1[3], hi1[3];
  tri_box(b, s, lo0, hi0);
  tri_box(b, t, lo1, hi1);
  for (int k = 0; k < 3; ++k)
    if (lo0[k] > hi1[k] || lo1[k] > hi0[k]) return 0;
  return 1;
}

static void collide_cb(void *user, struct RTCCollision *c, unsigned int n) {
  collide_ctx *cc = user;
  int32_t buf[2 * PAIR_BATCH];
  int32_t m = 0;
  for (unsigned int k = 0; k < n; ++k) {
    /* A scene collided with itself reports every pair in both orders (and never a primitive with
     * itself): keep the ordered one. Embree's pairs are a broad phase on float boxes; the exact
     * box test keeps the promise of the header. */
    int32_t s = (int32_t)c[k].primID0, t = (int32_t)c[k].primID1;
    if (s >= t || !boxes_touch(cc->b, s, t)) continue;
    buf[2 * m] = s, buf[2 * m + 1] = t;
    if (++m == PAIR_BATCH) {
      pthread_mutex_lock(&cc->lock);
      cc->fn(cc->user, buf, m);
      pthread_mutex_unlock(&cc->lock);
      m = 0;
    }
  }
  if (m) {
    pthread_mutex_lock(&cc->lock);
    cc->fn(cc->user, buf, m);
    pthread_mutex_unlock(&cc->lock);
  }
}

pm_status pm_bvh_overlapping_pairs(const pm_bvh *b, pm_bvh_pair_fn fn, void *user,
                                   pm_error *err) {
  if (b->ntri < 2) return PM_OK;
  collide_ctx cc = {.b = b, .fn = fn, .user = user};
  pthread_mutex_init(&cc.lock, NULL);
  rtcCollide(b->scene, b->scene, collide_cb, &cc);
  pthread_mutex_destroy(&cc.lock);
  return take_embree_error(b->errs, "finding overlapping boxes", err);
}
