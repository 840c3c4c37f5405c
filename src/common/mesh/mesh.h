/* The output mesh: nodes, segments, triangles and tetrahedra, each tagged with the model cell it
 * discretizes (papers/003 eq. 6: M = (M0, M1, M2, M3)).
 *
 * Plain data with flat arrays, owned by the mesh and freed by pm_mesh_destroy(). Indices are
 * 0-based int32_t. Classification of a node: (node_dim, node_cell) names the model cell the node
 * lies on (see geom.h), node_par its parameters there (curve: t; face: u, v); a node of a mesh
 * read from a file that carries no classification has node_dim = -1, node_cell = -1.
 * Element tags (seg_cell, tri_cell, tet_cell) are cell indices of dimension 1, 2, 3, or the
 * file's entity tags for external meshes (-1 when unknown).
 *
 * Orientation: a triangle (a, b, c) has normal (b - a) x (c - a); the connection layer orients a
 * face's triangles along the face's outward normal where the face bounds a volume. A tet
 * (a, b, c, d) is positive: ((b - a) x (c - a)) . (d - a) > 0.
 */
#ifndef PM_MESH_H
#define PM_MESH_H

#include <packmesh/packmesh.h>

#include <stdint.h>

#include "common/base/vec3.h" /* PM_COORD_MAX */

#ifdef __cplusplus
extern "C" {
#endif


typedef struct pm_mesh {
  int32_t nnode, cap_node;
  double *xyz;          /* [3*nnode] */
  int8_t *node_dim;     /* [nnode] dimension of the node's cell, -1 unknown */
  int32_t *node_cell;   /* [nnode] index of the node's cell in its dimension, -1 unknown */
  double *node_par;     /* [2*nnode] parameters on that cell (unused entries 0) */

  int32_t nseg, cap_seg;
  int32_t *seg;         /* [2*nseg] */
  int32_t *seg_cell;    /* [nseg] curve index (or entity tag), -1 unknown */

  int32_t ntri, cap_tri;
  int32_t *tri;         /* [3*ntri] */
  int32_t *tri_cell;    /* [ntri] face index (or entity tag), -1 unknown */

  int32_t ntet, cap_tet;
  int32_t *tet;         /* [4*ntet] */
  int32_t *tet_cell;    /* [ntet] volume index (or entity tag), -1 unknown */
} pm_mesh;

/* A new empty mesh; NULL when out of memory. */
pm_mesh *pm_mesh_create(void);

/* Release a mesh and its arrays. Accepts NULL. */
void pm_mesh_destroy(pm_mesh *m);

/* Remove every node and element, keeping the allocated capacity. */
void pm_mesh_clear(pm_mesh *m);

/* Grow capacities to at least the given counts (existing content kept). */
pm_status pm_mesh_reserve(pm_mesh *m, int32_t nnode, int32_t nseg, int32_t ntri, int32_t ntet,
                          pm_error *err);

/* Append a node; par may be NULL (zeros). Writes its index to *id when id is not NULL. */
pm_status pm_mesh_add_node(pm_mesh *m, const double xyz[3], int dim, int32_t cell,
                           const double *par, int32_t *id, pm_error *err);
pm_status pm_mesh_add_seg(pm_mesh *m, int32_t a, int32_t b, int32_t cell, pm_error *err);
pm_status pm_mesh_add_tri(pm_mesh *m, int32_t a, int32_t b, int32_t c, int32_t cell,
                          pm_error *err);
pm_status pm_mesh_add_tet(pm_mesh *m, int32_t a, int32_t b, int32_t c, int32_t d, int32_t cell,
                          pm_error *err);

/* A deep copy; NULL when out of memory. */
pm_mesh *pm_mesh_copy(const pm_mesh *m);

/* The number of distinct nodes of the mesh's triangles into *count: its surface nodes (a volume
 * mesh's interior nodes are not among them; on a surface mesh every node of a face is). Triangle
 * indices must be in range. */
pm_status pm_mesh_surface_nodes(const pm_mesh *m, int32_t *count, pm_error *err);

#ifdef __cplusplus
}
#endif

#endif /* PM_MESH_H */
