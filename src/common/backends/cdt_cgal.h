/* 2D constrained Delaunay triangulation through CGAL (Constrained_Delaunay_triangulation_2 with
 * the exact-predicates kernel). Plain C header; C++ lives in cdt_cgal.cpp only.
 *
 * The connection layer triangulates each face's nodes in its parameter space with the face's
 * boundary node chains as constraint edges; `remove_exterior` then keeps only the triangles
 * enclosed by the constraints (nesting parity: a triangle reached from the unbounded region by
 * crossing an odd number of constraint edges is inside), which removes both the outside of the
 * outer loop and the holes.
 *
 * No point is ever added: the output triangles index the input points. Constraint edges that
 * cross each other (other than at shared end points) make the triangulation fail with
 * PM_ERR_GEOM naming the two edges, instead of inserting an intersection point. Points equal to
 * an earlier point are merged: `merged_into` (optional) reports, for each input point, the index
 * of the point that represents it (itself when not merged).
 *
 * Details of the contract:
 *   - a constraint that passes through an input point, or meets another constraint at an input
 *     point (a T, an X through a given point, collinear overlaps), is split at that point: no
 *     error, no new point; the pieces are edges of the output;
 *   - equal points (exactly equal coordinates) are represented by the smallest index among them;
 *     a constraint whose two ends are merged into one point is ignored;
 *   - fewer than 3 distinct points, or all points collinear: PM_OK with ntri = 0;
 *   - PM_ERR_ARG: npts or ncons negative, NULL arrays with positive counts, a non-finite
 *     coordinate, a constraint index outside [0, npts) or a constraint joining a point to itself;
 *   - PM_ERR_NOMEM / PM_ERR_BACKEND: allocation failure / any other CGAL exception.
 * Cost: about a second for 10^6 points (bench/bench_cdt.c).
 */
#ifndef PM_CDT_CGAL_H
#define PM_CDT_CGAL_H

#include <packmesh/packmesh.h>

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct pm_cdt_result {
  int32_t ntri;
  int32_t *tri;          /* [3*ntri] counter-clockwise, input point indices; malloc'ed, caller frees */
  int32_t *merged_into;  /* [npts] or NULL when not requested; malloc'ed, caller frees */
  int32_t nmerged;       /* how many input points were merged into an earlier one */
} pm_cdt_result;

/* Triangulate npts points xy[2*npts] with ncons constraint edges cons[2*ncons].
 * want_merge_map: fill result->merged_into. On failure result is zeroed. */
pm_status pm_cdt_triangulate(const double *xy, int32_t npts, const int32_t *cons, int32_t ncons,
                             int remove_exterior, int want_merge_map, pm_cdt_result *result,
                             pm_error *err);

/* Free the arrays of a result and zero it. Accepts NULL. */
void pm_cdt_result_free(pm_cdt_result *result);

#ifdef __cplusplus
}
#endif

#endif /* PM_CDT_CGAL_H */
