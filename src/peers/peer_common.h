/* What the peers share: recognising a planar analytic domain, the default size, the map from
 * a backend's entity tags to our cell indices, and the orientation rule of geom.h applied to a
 * backend's triangles. Internal to src/peers.
 */
#ifndef PM_PEER_COMMON_H
#define PM_PEER_COMMON_H

#include <packmesh/packmesh.h>

#include <stdint.h>

#include "common/geom/geom.h"
#include "common/mesh/mesh.h"
#include "common/sizing/sizing.h"

/* 1 when m is a planar analytic domain (geom_analytic.h): no gmsh model behind it, no volume,
 * one face in the plane z = 0 parametrized by S(u, v) = (u, v, 0), curves of the analytic kinds
 * "segment" and "arc". The CGAL peer and the planar path of the gmsh peers take these. */
int peer_is_planar_domain(const pm_model *m);

/* The peers' default size field: 1/30 of the model's bounding-box diagonal, reduced at the
 * model's small features with a grade of 0.3 (sizing_features.h: short curves, narrow faces and
 * sharp wedges, curved faces) -- the rule of the bubble method's default (size_div 30,
 * size_grade 0.3), so that at their defaults the methods mesh the same field, and a constant
 * coarser than a part's features does not hand gmsh faces it can only mesh with needles or
 * inverted shells (occ_large/simple_plane.brep, statreport/918_pump_carter_sup.stp). The
 * signature is pm_method.default_size's. */
#define PEER_DEFAULT_SIZE_FRACTION (1.0 / 30.0)
#define PEER_DEFAULT_SIZE_GRADE 0.3
pm_status peer_default_size(const pm_model *m, const void *params, uint64_t seed, int threads,
                            pm_sizing **out, pm_error *err);

/* Entity tags of a backend (gmsh) to cell indices, per dimension. */
typedef struct peer_tagmap {
  int32_t n[4];
  int *tag[4];      /* [n[d]] sorted ascending, owned */
  int32_t *cell[4]; /* [n[d]] the cell of each tag, owned */
} peer_tagmap;

/* Add a (tag, cell) pair (unsorted); peer_tagmap_finish sorts. PM_ERR_NOMEM on failure. */
pm_status peer_tagmap_add(peer_tagmap *t, int dim, int tag, int32_t cell, pm_error *err);
/* Sort; a tag given twice in one dimension is PM_ERR_INTERNAL. */
pm_status peer_tagmap_finish(peer_tagmap *t, pm_error *err);
/* The cell of (dim, tag), or -1. */
int32_t peer_tagmap_find(const peer_tagmap *t, int dim, int tag);
void peer_tagmap_free(peer_tagmap *t);

/* Orient each face's triangles by geom.h's rule (pm_face_mesh_sign: out of the face's first
 * volume, else along Su x Sv): a face whose triangles mostly disagree with Su x Sv at their
 * nodes classified on the face (times the sign) has all its triangles turned over. A backend
 * orients a face's triangles consistently, so the vote only decides the face's side. A
 * triangle without a node on the face votes with the normal at the foot of its centroid (a
 * small face meshed with boundary nodes only). Returns the number of faces turned. */
int32_t peer_orient_faces(const pm_model *m, pm_mesh *mesh);

/* Flip each triangle of no area in 3D (pm_tri_degenerate: its three nodes on a line) with the
 * triangle of the same face across its longest edge, when the node opposite that edge lies
 * between its ends: the two new triangles then split the neighbour exactly, so the surface is
 * the same and the orientation is kept. A backend meshes a face in its parameter plane, where the
 * nodes of a straight boundary curve are not on a line when the face's pcurve strays from the
 * curve (bottle.brep's face 4: gmsh's Frontal-Delaunay joins three consecutive nodes of curve
 * 11 into a triangle of area 1e-18). Faces are oriented first (peer_orient_faces). A flat
 * triangle whose flip would make another flat one, or an edge the face already has, stays.
 * Returns the number of flips, or -1 when out of memory (the flips made before stand). */
int32_t peer_flip_flat_triangles(pm_mesh *mesh);



#endif /* PM_PEER_COMMON_H */
