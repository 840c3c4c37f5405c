/* Points and segments against the surface mesh of a volume: is a point inside the volume, does a
 * segment cross its boundary (or a face embedded in it), how far is a point from them.
 *
 * A mesher that places nodes inside a volume (the bubble method's volume bubbles, papers/003
 * section 3.2) needs these answers thousands of times per step, robustly: the volume is given by
 * the closed triangle mesh that the volume step (connect.h) will hand to TetGen anyway, so a node
 * judged inside here is inside the tetrahedralized region.
 *
 *   - Crossing: the sign tests of a segment against a triangle are exact (orient3d, predicates.h);
 *     candidate triangles come from an Embree BVH (closest_embree.h) queried with the ball around
 *     the segment, so the cost is that of the triangles near the segment.
 *   - Inside: a point p is inside when the point just inside a triangle t of the shell, on p's
 *     side, is inside (p on the inward side of t's plane) XOR the open segment from p to an
 *     interior point of t crosses the rest of the shell an odd number of times. t is the shell
 *     triangle nearest to p, so the segment is short and few triangles are tested; every test is
 *     exact. When every choice touches an edge or vertex exactly (a degenerate ray), other
 *     interior points and triangles are tried, then long rays over the whole shell.
 * Orientation: a face's triangles point out of the first volume it bounds (pm_face_mesh_sign), so
 * seen from volume v they point out of v when pm_face_mesh_sign(f) x sense(f in v) = +1 (geom.h).
 *
 * Thread safety: queries are read-only and may run concurrently on one shell.
 */
#ifndef PM_VOLUME_INSIDE_H
#define PM_VOLUME_INSIDE_H

#include <packmesh/packmesh.h>

#include <stdint.h>

#include "common/geom/geom.h"
#include "common/mesh/mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Does the closed segment [p, q] cross the triangle (a, b, c)? 1 when it passes through the
 * triangle's interior, 0 when it misses it, -1 when the answer is degenerate: it touches an edge
 * or a vertex, or p or q lies in the triangle's plane (with the other off it, or both in it).
 * Exact (orient3d). */
int pm_segment_triangle_cross(const double p[3], const double q[3], const double a[3],
                              const double b[3], const double c[3]);

typedef struct pm_volume_shell pm_volume_shell;

/* The shell of volume `volume` of `model` in `mesh` (triangles tagged with face indices, oriented
 * as connect.h leaves them): the triangles of the faces bounding the volume (the inside test) and
 * of the faces embedded in it (with the others, barriers for segments and distances). The mesh's
 * coordinates and triangles are copied. Errors: PM_ERR_ARG for a volume index out of range,
 * PM_ERR_GEOM when the volume has no boundary triangle, PM_ERR_NOMEM, PM_ERR_BACKEND (Embree).
 * [out] out: free with pm_volume_shell_destroy. */
pm_status pm_volume_shell_create(const pm_model *model, const pm_mesh *mesh, int32_t volume,
                                 pm_volume_shell **out, pm_error *err);

/* Release. Accepts NULL. */
void pm_volume_shell_destroy(pm_volume_shell *s);

/* Triangles held: bounding and embedded. */
int32_t pm_volume_shell_ntri(const pm_volume_shell *s);

/* 1 when x lies inside the volume (strictly inside its bounding shell; a point on an embedded
 * face counts as inside), 0 outside or on the boundary, -1 undecided (every ray degenerate:
 * does not happen for a point off the shell in practice). */
int pm_volume_shell_inside(const pm_volume_shell *s, const double x[3]);

/* The distance from x to the nearest triangle (bounding or embedded), or +infinity when none lies
 * within max_radius. */
double pm_volume_shell_distance(const pm_volume_shell *s, const double x[3], double max_radius);

/* 1 when the closed segment [p, q] meets a triangle (bounding or embedded), touching included
 * (degenerate contacts count as crossing: a mover that respects this never reaches the
 * boundary), else 0. */
int pm_volume_shell_segment_meets(const pm_volume_shell *s, const double p[3], const double q[3]);

#ifdef __cplusplus
}
#endif

#endif /* PM_VOLUME_INSIDE_H */
