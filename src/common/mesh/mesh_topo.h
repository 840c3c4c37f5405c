/* Mesh topology tables: node-to-element incidence, unique edges and unique tet faces, each with
 * the elements that use them.
 *
 * Shared by the quality measures (node degrees for eps_t, unique edges for size conformity) and
 * the validity checker (orientation, conformity, closed shells). Every table is built in
 * O(n log d) time (d: the largest number of elements at a node) by walking the node-to-element
 * incidence, never by comparing elements pairwise, so that 10^6 elements take a fraction of a
 * second. Elements with an index outside [0, nnode) are skipped (the checker reports them).
 *
 * Everything here is internal to the shared layer; the tables are plain data freed with their
 * _free function (which accepts a zeroed table).
 */
#ifndef PM_MESH_TOPO_H
#define PM_MESH_TOPO_H

#include <packmesh/packmesh.h>

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* For every node, the elements that use it: elem[off[v] .. off[v+1]) (an element that repeats a
 * node appears once per occurrence). */
typedef struct pm_incidence {
  int32_t nnode;
  int64_t *off;  /* [nnode + 1], owned */
  int32_t *elem; /* [off[nnode]], owned */
} pm_incidence;

/* conn holds nelem elements of `per` nodes each ([per * nelem]). */
pm_status pm_incidence_build(int32_t nnode, const int32_t *conn, int32_t nelem, int per,
                             pm_incidence *out, pm_error *err);
void pm_incidence_free(pm_incidence *inc);

/* The unique edges of a set of elements (segments, triangles or tets), sorted by (a, b) with
 * a < b, and for each edge the elements having it: elem[off[e] .. off[e+1]). For triangles,
 * dir[k] is +1 when the triangle runs a -> b and -1 when it runs b -> a (its orientation seen from
 * the edge); for segments likewise; for tets dir is 0. first[v] .. first[v+1] are the edges whose
 * smaller end is v. */
typedef struct pm_edges {
  int32_t nnode;
  int64_t nedge;
  int32_t *ends;  /* [2 * nedge], owned */
  int64_t *off;   /* [nedge + 1], owned */
  int32_t *elem;  /* [off[nedge]], owned */
  int8_t *dir;    /* [off[nedge]], owned */
  int64_t *first; /* [nnode + 1], owned */
} pm_edges;

pm_status pm_edges_build(int32_t nnode, const int32_t *conn, int32_t nelem, int per,
                         pm_edges *out, pm_error *err);
void pm_edges_free(pm_edges *e);

/* Index of edge {a, b} (either order), or -1. */
int64_t pm_edges_find(const pm_edges *e, int32_t a, int32_t b);

/* The unique triangular faces of a set of tets, sorted by (a, b, c) with a < b < c, and for each
 * face the tets having it: tet[off[f] .. off[f+1]) with side[k] = +1 when that tet's outward
 * normal of the face is (b - a) x (c - a) for a positive tet, -1 when it is the opposite (so two
 * tets glued properly along a face have opposite sides). */
typedef struct pm_faces {
  int32_t nnode;
  int64_t nface;
  int32_t *abc;   /* [3 * nface], owned */
  int64_t *off;   /* [nface + 1], owned */
  int32_t *tet;   /* [off[nface]], owned */
  int8_t *side;   /* [off[nface]], owned */
  int64_t *first; /* [nnode + 1], owned */
} pm_faces;

pm_status pm_faces_build(int32_t nnode, const int32_t *tet, int32_t ntet, pm_faces *out,
                         pm_error *err);
void pm_faces_free(pm_faces *f);

/* Index of face {a, b, c} (any order), or -1. When `parity` is not NULL it receives +1 if
 * (a, b, c) is an even permutation of the stored sorted triple, -1 if odd. */
int64_t pm_faces_find(const pm_faces *f, int32_t a, int32_t b, int32_t c, int *parity);

#ifdef __cplusplus
}
#endif

#endif /* PM_MESH_TOPO_H */
