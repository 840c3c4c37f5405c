/* Relocating the interior nodes of one face's triangulation (connect.h, step 2, `smooth`).
 *
 * A node-placement method leaves its nodes where its own equilibrium put them; the connection
 * then joins them as they are. Where two lattices meet or the size field grades, the triangles
 * around a node are uneven even though every node is where the method wanted it. This pass moves
 * each interior node of a face, one at a time in index order (the result depends on nothing
 * else), towards the centroid of its neighbours (Laplacian smoothing, as gmsh's Mesh.Smoothing
 * does), projected back onto the surface, and keeps the move only when its ring gets better:
 * the largest R / l_min of the ring does not grow and their sum falls ("smart" Laplacian, after
 * Freitag's acceptance test). A move is tried whole, then halved once. A node whose ring would
 * hold a triangle that is degenerate or turned against the surface's normal stays put, and so
 * does a node whose new position leaves the face's trimmed region.
 *
 * The nodes move on the surface: each position is S(u, v) for the node's new (u, v), its old
 * (u, v) plus the least-squares parameter step of the move (one Gauss-Newton step from the
 * node's tangent plane, pm_cell_param_delta), not the closest point to the aim: the aim is a
 * heuristic and the exact point is what the test measures. Boundary nodes (curves, vertices,
 * poles) never move, so the face's boundary and its neighbours are untouched. */
#ifndef PM_FACE_SMOOTH_H
#define PM_FACE_SMOOTH_H

#include <stdint.h>

#include "common/geom/geom.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The connection's surface normals (the flips' and the smoothing's test that a triangle agrees
 * with the surface): a point where Su and Sv are closer to parallel than 8.6 degrees (sine
 * 0.15) has none (pm_face_point_normal). The normal there is the cross product of two almost
 * collinear vectors, and the surface turns fast around it, so it says little about the
 * triangles that meet there. robust/statreport__A319.brep's face 5 has such a corner, where
 * two of its curves meet at 173 degrees: Su and Sv 5.4 degrees apart, the normal (1, 0, 0)
 * there against (0.1, -0.65, 0.75) at the curves' next nodes 30 away; tested against it, the
 * flip of the corner's flat triangle (its two curve segments and the chord between them, a
 * 3-degree needle) to the face node beside it was refused. */
#define PM_CONNECT_NORMAL_MIN_SIN 0.15

/* One face's triangulation over nv local nodes: xyz [3*nv] positions, uv [2*nv] parameters on
 * face f (read and written for movable nodes only), nrm [3*nv] unit surface normals (zero where
 * the surface has none; written for the nodes that move), movable [nv] 1 for a node that may move,
 * tri [3*ntri] triangles in local nodes, oriented along nrm. One sweep over the movable nodes;
 * returns the number of nodes moved, -1 when out of memory.
 * dirty [nv], or NULL for every node: the nodes to try (read and written). A node's try is a
 * function of its position and of its ring (the ring's triangles, their nodes' positions and
 * normals) alone, so a node that was tried and stayed, and whose ring has not changed since, would
 * stay again: the sweep tries only the dirty nodes, clears each one it tries, and marks a node
 * that moves, and every node of its ring, dirty. The caller marks the nodes of triangles it
 * changes (flips). Sweeps with dirty flags give the mesh of sweeps over every node, to the bit.
 * needle_deg > 0: a node whose ring has an angle below needle_deg at the node first tries a step
 * towards the edge opposite that angle, and the Laplacian step only when that is refused (the
 * other way round, a Laplacian step that improves the ring a hair each sweep kept the needle step
 * from ever being tried). The step goes to where an isoceles triangle on the edge would have
 * 1.25 needle_deg (whole or halved; for a node already that near the edge's nearer end, beside
 * the edge, to that triangle's apex), and is kept when the
 * ring's largest R / l_min falls and no more of its corners away from the node have an angle
 * below needle_deg (the sum may rise a hair: face_smooth.c, try_move): a face node
 * standing far above a run of short boundary segments (curve nodes far finer than the face's)
 * makes thin triangles with them, and the centroid of its ring, half of it the curve's nodes and
 * half the face's farther ones, need not lie any nearer the curve. A kept needle step is
 * followed by another, up to 8 in a node's try, while an angle below needle_deg remains: where
 * the node stands beside the edge rather than above it, a step gains less than it aims at
 * (robust/step__SampleCrankshaft4A.stp with psys: a face node 0.13 from curve nodes 0.023 apart
 * gained 0.012, 0.008, 0.006, 0.005 in four sweeps, one step each, and kept a 9.9-degree
 * needle). A node without such an angle whose ring has an obtuse triangle with an angle below
 * needle_deg at an end of the edge opposite the node (a face node too near a long boundary
 * segment: box_sides.step with psys, 161 degrees at a node 0.10 from a segment 1.28 long)
 * first tries a flat move: to the height above its foot on that edge where the smaller end
 * angle is 1.25 needle_deg, kept by the same rule. 0: Laplacian steps only. */
int32_t pm_face_smooth_sweep(const pm_cell *f, int32_t nv, double *xyz, double *uv, double *nrm,
                             const uint8_t *movable, int32_t ntri, const int32_t *tri,
                             double needle_deg, uint8_t *dirty);

#ifdef __cplusplus
}
#endif

#endif /* PM_FACE_SMOOTH_H */
