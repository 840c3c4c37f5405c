/* Edge removal in a tetrahedral mesh: the n-to-m flip that replaces the k tets around an interior
 * edge (p, q) by the 2 (k - 2) tets joining p and q to a triangulation of the ring of vertices
 * around the edge (k = 3: the 3-2 flip; k = 4: the 4-4 flip; up to k = 7).
 *
 * Used to remove tets of (near) zero volume that a Delaunay tetrahedralization leaves where nodes
 * are nearly coplanar and cospherical (the four corners of a rectangle through a thin plate, for
 * instance): TetGen's own flips give up on them, and they cannot be split without adding a
 * point. A flip is made only when every new tet is positive by the exact orient3d and the worst
 * new tet is better than the worst removed one and not flat itself; faces listed as constrained (the surface
 * triangles, internal faces) and edges listed as constrained (kept segments) are never removed.
 */
#ifndef PM_TET_FLIP_H
#define PM_TET_FLIP_H

#include <packmesh/packmesh.h>

#include <stdint.h>

typedef struct pm_tet_flip_input {
  const double *xyz;         /* [3 * npts] (borrowed) */
  int32_t npts;
  int32_t ntri;
  const int32_t *tri;        /* [3 * ntri] constrained faces (borrowed) */
  int32_t nseg;
  const int32_t *seg;        /* [2 * nseg] constrained edges (borrowed) */
  double flat_rel;           /* a tet is flat when 6 |V| <= flat_rel * l_max^3 */
  int32_t max_flips;         /* cap on flips */
} pm_tet_flip_input;

/* Remove the flat tets of tet[4 * *ntet] (positively oriented; tag[*ntet] their region tags) by
 * edge removal, in place: the arrays are reallocated as needed (*tet and *tag may move). Flat
 * tets that no flip removes stay. Writes how many flat tets remain to *remaining and the number
 * of flips made to *flips. */
pm_status pm_tet_remove_flat(const pm_tet_flip_input *in, int32_t **tet, int32_t **tag,
                             int32_t *ntet, int32_t *remaining, int32_t *flips, pm_error *err);

/* Whether tets tile their space: no face shared by more than two tets, never two tets on one side
 * of a face (tets positively oriented). Only tets with keep[t] set count (keep NULL: all). When
 * they do not tile, writes a tet on an offending face to *tet_at, a corner of that face to
 * *node_at and the number of tets on the face to *count, and sets *found = 1; otherwise
 * *found = 0. PM_ERR_NOMEM on failure. */
pm_status pm_tet_find_overlap(int32_t npts, const int32_t *tet, const uint8_t *keep, int32_t ntet,
                              int *found, int32_t *tet_at, int32_t *node_at, int32_t *count,
                              pm_error *err);

#endif /* PM_TET_FLIP_H */
