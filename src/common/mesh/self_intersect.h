/* Self-intersection of a triangulated surface: the check that rejects a surface mesh before it is
 * handed to TetGen (connect.c, step 3 of DESIGN.md "Connecting nodes"), and a verdict the mesh
 * checker can report.
 *
 * Two triangles intersect "other than along shared vertices and edges" when their closed point
 * sets meet anywhere except in the vertices and the edge they share. Vertices are shared when they
 * are the same node or two nodes at exactly the same coordinates (an unwelded mesh is judged as
 * if welded). So:
 *   - triangles sharing an edge intersect only when they lie in one plane on the same side of the
 *     edge (folded onto each other);
 *   - triangles sharing one vertex intersect when they meet anywhere else (one pierces the other,
 *     or they overlap in one plane, or an edge of one runs along an edge of the other);
 *   - triangles sharing nothing intersect when they touch at all (a vertex on the other's face or
 *     edge counts: a T-junction is a defect too);
 *   - two triangles with the same three vertices intersect (a duplicated face).
 * Every decision is made by the exact predicates of predicates.h (orient3d, and orient2d on the
 * projection to a coordinate plane for coplanar configurations); no tolerance is involved.
 * Candidate pairs come from Embree (rtcCollide over the triangles' boxes, closest_embree.h).
 *
 * Triangles whose three vertices are collinear (zero area, exactly) are counted apart and take no
 * part in the pair tests: they are a defect of their own kind, and "crossing" is not defined for
 * them the same way.
 */
#ifndef PM_SELF_INTERSECT_H
#define PM_SELF_INTERSECT_H

#include <packmesh/packmesh.h>

#include "common/mesh/mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct pm_selfint_report {
  int64_t count;        /* out: number of intersecting pairs of triangles */
  int32_t nreport;      /* out: pairs listed in `pairs`, min(count, max_report) */
  int32_t *pairs;       /* out: [2*nreport] the pairs (i < j), in increasing order of (i, j), so
                           the first max_report pairs of the sorted list; malloc'ed, freed by
                           pm_selfint_report_free (NULL when nreport = 0) */
  int32_t ndegenerate;  /* out: triangles with collinear vertices (not tested in pairs) */
  int32_t first_degenerate; /* out: the lowest such triangle, -1 when none */
  int64_t ncandidates;  /* out: pairs with touching boxes that went to the exact test */
} pm_selfint_report;

/* Find the intersecting pairs among the triangles tri[3*ntri] of nodes xyz[3*nnode].
 * [in]  max_report  how many pairs to list (>= 0); the count is always complete.
 * [out] out         the report (zeroed first; free with pm_selfint_report_free).
 * Errors: PM_ERR_ARG for a bad index or a non-finite coordinate, PM_ERR_NOMEM, PM_ERR_BACKEND
 * (Embree). */
pm_status pm_triangles_self_intersections(const double *xyz, int32_t nnode, const int32_t *tri,
                                          int32_t ntri, int32_t max_report,
                                          pm_selfint_report *out, pm_error *err);

/* The same on a mesh's triangles (segments and tets are ignored). */
pm_status pm_mesh_self_intersections(const pm_mesh *mesh, int32_t max_report,
                                     pm_selfint_report *out, pm_error *err);

/* The exact pair test alone: 1 when triangles t0 and t1 (index triples into xyz) intersect other
 * than along shared vertices and edges, as defined above; 0 otherwise (and 0 when either is
 * degenerate). */
int pm_triangle_pair_intersects(const double *xyz, const int32_t t0[3], const int32_t t1[3]);

/* Free the pair list and zero the report. Accepts NULL. */
void pm_selfint_report_free(pm_selfint_report *r);

#ifdef __cplusplus
}
#endif

#endif /* PM_SELF_INTERSECT_H */
