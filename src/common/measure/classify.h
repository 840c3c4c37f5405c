/* Classification of a mesh read from a file without entity tags (.stl, .mesh, .obj, or a .msh,
 * .vtk or .vtu of another tool) onto the cells of the model it discretizes, so that the measures that
 * depend on where a node lies -- eps_t's interior nodes, the by-site split of the triangles, the
 * checker's per-face patches -- are the same as for the mesh packmesh wrote with its tags.
 *
 * Which nodes: those with no cell (node_dim < 0). Each is put on the lowest-dimensional cell it
 * lies on, within a tolerance tol = min(1e-5 x the model's diagonal, 0.05 x the node's shortest
 * edge): a model vertex, else a curve, else (a node of a triangle) the nearest face, else (a
 * node of tets only) the volume of its tets. 1e-5 of the diagonal covers the single-precision
 * coordinates of a binary .stl (about 6e-8 of the coordinates) with a wide margin; the edge
 * bound keeps a face node next to a curve (a sliver's) off the curve. A triangle node farther
 * than 1e-3 x the diagonal from every face is left unclassified and counted: the mesh does not
 * discretize the model there.
 *
 * Which elements: every element with an unclassified node gets its cell again, since a file's
 * own tag (an .stl solid, a gmsh entity tag) does not name a model cell: a segment the curve
 * its nodes share (or the nearest curve to its midpoint), a triangle the face of its face nodes
 * (or the nearest face to its centroid when all three lie on curves), a tet the volume of its
 * region: tets joined across faces that are no triangle of the mesh form a region, and the
 * region takes the volume bounded by most of its boundary triangles' faces (a face between two
 * volumes counts for both; the outer faces decide).
 *
 * Nodes get their parameters on their cell (pm_cell_project). Deterministic: nodes are
 * classified independently (in parallel) and elements in index order.
 */
#ifndef PM_CLASSIFY_H
#define PM_CLASSIFY_H

#include <packmesh/packmesh.h>

#include "common/geom/geom.h"
#include "common/mesh/mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

/* What pm_classify_mesh did (out). */
typedef struct pm_classify_counts {
  int32_t nodes;        /* nodes classified */
  int32_t by_dim[4];    /* of them, on vertices, curves, faces, volumes */
  int32_t unmatched;    /* nodes of triangles or segments on no cell within reach */
  int32_t elements;     /* segments, triangles and tets given a cell */
} pm_classify_counts;

/* Classify m's unclassified nodes and their elements onto model's cells (both in; m in-out).
 * A mesh whose nodes are all classified is left as it is (counts zero). counts (out) may be
 * NULL. PM_ERR_NOMEM; PM_ERR_ARG for element indices out of range. */
pm_status pm_classify_mesh(pm_mesh *m, const pm_model *model, pm_classify_counts *counts,
                           pm_error *err);

#ifdef __cplusplus
}
#endif

#endif /* PM_CLASSIFY_H */
