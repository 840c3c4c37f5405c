/* TetGen quality refinement of a finished surface mesh: the volume step of papers/001 section 4.4
 * (what pm_connect's PM_VOLUME_REFINE does after it has connected a method's nodes), applied to
 * a backend's own triangles, so that the volume mesher can be held fixed while the surface
 * mesher varies. Internal to src/peers.
 */
#ifndef PM_PEER_VOLUME_H
#define PM_PEER_VOLUME_H

#include <packmesh/packmesh.h>

#include <stdint.h>

#include "common/geom.h"
#include "common/mesh.h"

/* Add tets to `mesh` for every volume of m. The mesh holds a conforming surface mesh classified
 * on m: triangles tagged with face indices and oriented by pm_face_mesh_sign, segments tagged
 * with curve indices. For each group of volumes joined by shared or embedded faces (one TetGen
 * run per group, as the connection step does): the triangles of the faces bounding or embedded
 * in the group's volumes and the segments of curves embedded in them go to TetGen, which keeps
 * them as they are and refines the interior (-q radius_edge); one region seed per volume (a
 * point a little inside one of its boundary triangles, confirmed by ray parity against its
 * shell) tags the tets; tets in cavities that are no volume are dropped; flat tets are removed
 * by edge removal (tet_flip.h); TetGen's Steiner points become nodes classified in the volume of
 * their first tet. The surface is first checked for self-intersections (TetGen may crash on
 * such input). max_nodes > 0 caps the node count (PM_ERR_LIMIT). *steiner (may be NULL)
 * receives the number of nodes added, *flat_left (may be NULL) the flat tets no flip removed.
 * On failure the mesh's tets and added nodes are removed again. */
pm_status peer_volume_tetgen(const pm_model *m, pm_mesh *mesh, double radius_edge,
                             int64_t max_nodes, int32_t *steiner, int32_t *flat_left,
                             pm_error *err);

#endif /* PM_PEER_VOLUME_H */
