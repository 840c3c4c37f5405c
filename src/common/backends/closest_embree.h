/* Closest-point queries on a triangle mesh through Embree's BVH (Embree 3 C API).
 *
 * The distance checks of the connection layer (distance.c: the two-sided mesh-to-model distance;
 * self_intersect.c: candidate pairs of triangles) need "which triangle is nearest to this point"
 * millions of times. Embree builds the bounding-volume hierarchy and prunes the search; every
 * distance is computed here in double precision from our own copy of the coordinates, so the
 * answers are those of a brute-force search over the triangles (to the last bits of the
 * point-triangle routine), not of Embree's single-precision copy.
 *
 * How exactness survives Embree's floats: each triangle is an Embree user primitive whose box is
 * the double box rounded outwards to floats, so a box always contains its triangle; the query
 * sphere's float radius is the best double distance found so far plus a margin that covers the
 * rounding of the query point and of Embree's own box-sphere test. A triangle that could beat
 * the best one is therefore never pruned.
 *
 * Degenerate triangles are kept: (a, b, b) is the segment ab and (a, a, a) the point a, so one
 * structure serves surface meshes, wire meshes (segments) and point clouds.
 *
 * Threads: Embree builds with one thread of its own (the device is created with threads=1 so
 * that its TBB pool does not compete with the callers' OpenMP threads; bench_closest measures the
 * build). Queries (pm_bvh_closest, pm_bvh_visit) are read-only and may run concurrently from any
 * number of threads on one pm_bvh.
 *
 * Errors: Embree's errors are caught by a device error callback and returned as PM_ERR_BACKEND
 * (PM_ERR_NOMEM when Embree ran out of memory) with Embree's message; nothing is printed.
 */
#ifndef PM_CLOSEST_EMBREE_H
#define PM_CLOSEST_EMBREE_H

#include <packmesh/packmesh.h>

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct pm_bvh pm_bvh;

/* The answer of a closest-point query. */
typedef struct pm_bvh_hit {
  int32_t tri;      /* the closest triangle (index in the input), -1 when none is within reach */
  double point[3];  /* the closest point on it */
  double bary[3];   /* its barycentric coordinates: point = bary[0] a + bary[1] b + bary[2] c */
  double dist;      /* |point - p|; +infinity when tri = -1 */
} pm_bvh_hit;

/* Build the hierarchy over ntri triangles tri[3*ntri] (0-based indices into xyz[3*nnode]).
 * Both arrays are copied; the caller keeps ownership of its own.
 * [out] out  the new structure (free with pm_bvh_destroy), NULL on failure.
 * Errors: PM_ERR_ARG for a negative count, an index outside [0, nnode) (naming the triangle) or a
 * non-finite coordinate of a node a triangle uses (naming the node); PM_ERR_NOMEM;
 * PM_ERR_BACKEND when Embree fails. ntri = 0 is allowed (every query then finds nothing). */
pm_status pm_bvh_create(const double *xyz, int32_t nnode, const int32_t *tri, int32_t ntri,
                        pm_bvh **out, pm_error *err);

/* Release. Accepts NULL. */
void pm_bvh_destroy(pm_bvh *bvh);

/* Number of triangles. */
int32_t pm_bvh_ntri(const pm_bvh *bvh);

/* The closest point of the mesh to p among the triangles within max_radius of p (pass INFINITY
 * for no limit). Returns 1 and fills *hit when one is found; returns 0 with hit->tri = -1 and
 * hit->dist = INFINITY when none lies within max_radius (or p is not finite). Among triangles at
 * the same distance the lowest index wins, so the answer is that of a search in index order,
 * whatever the hierarchy. Thread-safe. */
int pm_bvh_closest(const pm_bvh *bvh, const double p[3], double max_radius, pm_bvh_hit *hit);

/* Visit the triangles that may lie within `radius` of p: fn(user, tri, radius) is called for a
 * superset of them (the BVH prunes by boxes, fn decides) and returns the radius to continue with,
 * which may shrink the search (a value above the current radius is ignored). Returns the final
 * radius. Thread-safe when fn is. */
typedef double (*pm_bvh_visit_fn)(void *user, int32_t tri, double radius);
double pm_bvh_visit(const pm_bvh *bvh, const double p[3], double radius, pm_bvh_visit_fn fn,
                    void *user);

/* Every pair of distinct triangles whose boxes overlap or touch (the broad phase of a
 * self-intersection test, through rtcCollide): fn(user, pairs, npair) receives batches of pairs
 * pairs[2*k] < pairs[2*k+1], each unordered pair exactly once, in no particular order. Calls of fn
 * are serialized (fn need not be thread-safe). Errors: PM_ERR_BACKEND when Embree fails. */
typedef void (*pm_bvh_pair_fn)(void *user, const int32_t *pairs, int32_t npair);
pm_status pm_bvh_overlapping_pairs(const pm_bvh *bvh, pm_bvh_pair_fn fn, void *user,
                                   pm_error *err);

/* The closest point q of triangle (a, b, c) to p, in double precision, with its barycentric
 * coordinates (bary may be NULL); returns |p - q|. Handles degenerate triangles (segments and
 * points). This is the routine the queries use, exposed for brute-force checks. */
double pm_point_triangle_closest(const double p[3], const double a[3], const double b[3],
                                 const double c[3], double q[3], double bary[3]);

#ifdef __cplusplus
}
#endif

#endif /* PM_CLOSEST_EMBREE_H */
