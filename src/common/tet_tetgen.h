/* Tetrahedralization of a closed surface mesh through TetGen 1.5 (libtet, built with
 * TETLIBRARY). Plain C header; C++ lives in tet_tetgen.cpp only.
 *
 * Input: a piecewise linear complex given as triangles (the surface mesh of every volume, plus
 * internal faces, each triangle tagged with its face index), optional dangling segments that
 * must appear as tet edges, interior points, and one seed point per region (volume) so that
 * output tets carry their volume's tag. The surface triangles are kept as they are: no Steiner
 * point is ever put on the boundary (TetGen's -Y).
 *
 * Two modes:
 *   PM_TET_GIVEN_POINTS  tetrahedralize with exactly the given interior points and no Steiner
 *                        points at all (the bubble method's volume mode, papers/003 section 3);
 *                        when TetGen cannot recover the boundary without adding points, that is
 *                        an error, not a silent Steiner point;
 *   PM_TET_REFINE        TetGen's quality refinement (-q with the radius-edge bound, -a with the
 *                        volume bound when > 0), interior Steiner points allowed, boundary kept
 *                        (the psys pipeline of papers/001 section 4.4).
 * TetGen's failures (self-intersecting input, its `int` exceptions) come back as PM_ERR_BACKEND
 * with TetGen's reason; the process never exits.
 */
#ifndef PM_TET_TETGEN_H
#define PM_TET_TETGEN_H

#include <packmesh/packmesh.h>

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum pm_tet_mode { PM_TET_GIVEN_POINTS = 0, PM_TET_REFINE = 1 } pm_tet_mode;

typedef struct pm_tet_input {
  int32_t npts;
  const double *xyz;      /* [3*npts] surface nodes first, then interior nodes (borrowed) */
  int32_t nsurf;          /* the first nsurf points are on the surface; the rest are interior */
  int32_t ntri;
  const int32_t *tri;     /* [3*ntri] facets (borrowed) */
  const int32_t *tri_tag; /* [ntri] face index of each facet, may be NULL (borrowed) */
  int32_t nseg;
  const int32_t *seg;     /* [2*nseg] segments to keep as tet edges, may be NULL (borrowed) */
  int32_t nregion;
  const double *region;   /* [4*nregion] x, y, z of a point inside the region, then its tag */
  pm_tet_mode mode;
  double radius_edge;     /* PM_TET_REFINE: bound on circumradius / shortest edge (TetGen -q), > 1 */
  double max_volume;      /* PM_TET_REFINE: bound on tet volume (-a), <= 0 for none */
  int32_t max_points;     /* cap on the output point count (refinement stops with an error
                             beyond it), <= 0 for no cap */
} pm_tet_input;

typedef struct pm_tet_result {
  int32_t npts;
  double *xyz;            /* [3*npts] input points first (same indices), then Steiner points */
  int32_t ntet;
  int32_t *tet;           /* [4*ntet] positively oriented (see mesh.h) */
  int32_t *tet_tag;       /* [ntet] the region tag of each tet, -1 outside every region seed */
  int32_t nsteiner;       /* points added by TetGen (0 in PM_TET_GIVEN_POINTS mode) */
} pm_tet_result;

pm_status pm_tet_tetrahedralize(const pm_tet_input *in, pm_tet_result *out, pm_error *err);

/* Free the arrays of a result and zero it. Accepts NULL. */
void pm_tet_result_free(pm_tet_result *out);

#ifdef __cplusplus
}
#endif

#endif /* PM_TET_TETGEN_H */
