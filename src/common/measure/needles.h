/* Needles: the triangles of a mesh with an angle below a limit (10 degrees by default), each
 * told forced or unforced by the model it discretizes.
 *
 * A needle is forced when the geometry leaves no room for a better triangle there:
 *   - corner: one of its nodes is on a model vertex, and it lies in a corner of its face at that
 *     vertex whose CAD angle is below the limit. The angle is that between the boundary curves
 *     leaving the vertex, seen at the triangle's size (the chords to their points at that
 *     distance, in the face's tangent plane), inside the face: a sharp corner, or a cusp where
 *     two curves meet tangentially. Every triangle that small in such a corner has an angle
 *     below the limit at the vertex, whatever the mesher does. A triangle whose own angle at
 *     the vertex is below the limit and overlaps such a corner counts too (its bisector may
 *     lie a hair outside: nodes on a curve of the corner that bows towards the other). Where
 *     the vertex is the image of a collapsed side of the face's (u, v) box, the face's normal
 *     is taken at the triangle's centroid, not at the vertex;
 *   - feature: its shortest edge is shorter than the model's feature floor
 *     (PM_FEATURE_FLOOR x the model's bounding-box diagonal) and joins nodes on two different
 *     model cells of lower dimension than the face (two curves, a curve and a vertex): a sliver
 *     face, a gap or an edge of that size is below the resolution of the CAD data itself
 *     (OpenCASCADE's confusion tolerance is 1e-7 model units; exporters leave gaps of 1e-6 of the
 *     diagonal), and no mesher is asked to resolve it. Likewise when all its nodes are on
 *     curves and vertices, not all on one curve and its ends, and one node is nearer than the
 *     floor to the line through the other two, on other cells: two model cells come closer than
 *     the floor there (a strip face that tapers below it), whatever the staggering of the nodes
 *     along them. Likewise when it stands on an edge between nodes of one curve (or its ends)
 *     and its third corner is held off the curve by a CAD gap g wider than the floor (the face's
 *     surface passes g from its own boundary curve, or the curve's end misses its vertex by g),
 *     and the edge is shorter than 2 g tan(limit / 2): every corner there has an angle below the
 *     limit, at the spacing the curve's other faces ask for; or when the curve misses one of its
 *     end vertices by g wider than the floor, the third corner is on another curve ending at
 *     that vertex, and the whole triangle lies within 2 g of the vertex (the face's boundary
 *     jumps g there, and a triangle spanning the jump cannot be judged by its angles); or,
 *     for the same reason, when one corner is that vertex, another is on a curve that ends
 *     there and misses it by g wider than the floor, and the whole triangle lies within 2 g of
 *     the vertex.
 * Every other needle is unforced: a finer node spacing at the feature would have avoided it (a
 * face narrower than the local size, an edge shorter than it, a corner sharper than the size's
 * angular resolution but not below the limit). A mesh with unforced needles is a defect of the
 * mesher.
 *
 * Triangles without a model (a mesh read alone) or without classification (node_dim -1) cannot
 * be judged: their needles count as unforced.
 */
#ifndef PM_NEEDLES_H
#define PM_NEEDLES_H

#include <packmesh/packmesh.h>

#include <stdint.h>

#include "common/geom/geom.h"
#include "common/mesh/mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

#define PM_NEEDLE_DEG 10.0     /* the default limit, in degrees */

typedef enum pm_needle_kind {
  PM_NEEDLE_NONE = 0,     /* not a needle */
  PM_NEEDLE_UNFORCED = 1,
  PM_NEEDLE_CORNER = 2,   /* forced by a sharp CAD corner */
  PM_NEEDLE_FEATURE = 3   /* forced by a CAD feature below the floor */
} pm_needle_kind;

typedef struct pm_needles {
  int64_t count;     /* triangles with an angle below the limit */
  int64_t corner;    /* ... forced by a sharp corner */
  int64_t feature;   /* ... forced by a feature below the floor */
  int64_t unforced;  /* count - corner - feature */
  int32_t first_unforced; /* the first unforced needle's triangle index, -1 when none */
  double min_angle;  /* the smallest angle of any triangle, degrees (180 for a mesh without) */
} pm_needles;

/* Classify the needles of `mesh`.
 * [in]  mesh   triangles with classification (node_dim, node_cell, tri_cell); borrowed
 * [in]  model  the model the mesh discretizes; borrowed; NULL: every needle is unforced
 * [in]  limit  the angle limit in degrees, in (0, 60]
 * [out] out    the counts
 * [out] kind   may be NULL, else [mesh->ntri]: each triangle's pm_needle_kind
 * Errors: PM_ERR_ARG (a bad limit, an element index out of range), PM_ERR_NOMEM. */
pm_status pm_needles_classify(const pm_mesh *mesh, const pm_model *model, double limit,
                              pm_needles *out, uint8_t *kind, pm_error *err);

#ifdef __cplusplus
}
#endif

#endif /* PM_NEEDLES_H */
