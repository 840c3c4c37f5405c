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
 *                        (the psys pipeline of papers/001 section 4.4). Because the boundary is
 *                        kept, TetGen rejects points that would encroach on it: the bounds are
 *                        met only as far as the surface mesh is fine enough (a unit cube with 2
 *                        triangles per face keeps a tet of volume 1/6 under a bound of 0.01; with
 *                        5 x 5 squares per face the bound holds). Neither bound is re-checked.
 * TetGen's failures (self-intersecting input, its `int` exceptions) come back as PM_ERR_BACKEND
 * with TetGen's reason; the process never exits.
 *
 * Failures, by code:
 *   PM_ERR_ARG      bad arguments: fewer than 4 points, no triangles, an index out of range, a
 *                   triangle or segment repeating a point, non-finite numbers, radius_edge <= 1
 *                   in PM_TET_REFINE mode;
 *   PM_ERR_GEOM     two points coincide, a triangle is degenerate, an input point ends up in no
 *                   tet (outside every closed volume), TetGen produced no tet, or (GIVEN_POINTS)
 *                   the boundary needs Steiner points;
 *   PM_ERR_BACKEND  the surface self-intersects (two triangles, segments or a point on another
 *                   item meeting away from common vertices; checked with exact predicates before
 *                   TetGen, which may crash on such input), TetGen threw, or TetGen did not keep
 *                   an input triangle / segment;
 *   PM_ERR_LIMIT    PM_TET_REFINE needs more than max_points points (or max_points < npts).
 * Triangles repeated in the input (the same three points) are used once, with the first one's tag.
 * Interior points are plain points of the complex (TetGen's input points, not -i): every one
 * becomes a vertex; `nsurf` is informational. A program that links libgmsh must list libtet
 * before it (libgmsh exports another TetGen under the same symbol names); otherwise every call
 * fails with PM_ERR_BACKEND saying so instead of running TetGen.
 * TetGen runs in a child process (fork): TetGen 1.5.0 ends its process on some inputs (failed
 * assertions, segmentation faults), which then comes back as PM_ERR_BACKEND ("TetGen crashed");
 * the child's stdout is discarded (TetGen prints some errors even when quiet), the caller's is
 * never touched, and calls from several threads run in parallel.
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
  int allow_recovery_points; /* PM_TET_GIVEN_POINTS: accept the interior points TetGen adds to
                             recover the boundary (counted in nsteiner) instead of failing; no
                             quality refinement is done either way. 0 (the default of a zeroed
                             input) keeps the strict no-Steiner-point contract. */
} pm_tet_input;

typedef struct pm_tet_result {
  int32_t npts;
  double *xyz;            /* [3*npts] input points first (same indices), then Steiner points */
  int32_t ntet;
  int32_t *tet;           /* [4*ntet] positively oriented (see mesh.h) */
  int32_t *tet_tag;       /* [ntet] the region tag of each tet, -1 outside every region seed */
  int32_t nsteiner;       /* points added by TetGen (0 in PM_TET_GIVEN_POINTS mode) */
  int32_t lost_tri;       /* on a failure because TetGen did not keep an input triangle: its
                             index in the input (the only field set then); else -1 */
} pm_tet_result;

pm_status pm_tet_tetrahedralize(const pm_tet_input *in, pm_tet_result *out, pm_error *err);

/* Free the arrays of a result and zero it. Accepts NULL. */
void pm_tet_result_free(pm_tet_result *out);

/* Diagnostics (tests, debugging): run the same tetrahedralization as pm_tet_tetrahedralize with
 * TetGen's own consistency checks (-C: tet connectivity and orientation, boundary shells,
 * segments) and store in *problems how many problems they report (0: consistent). TetGen prints
 * these checks on stdout; the child process's report is read back, never printed. */
pm_status pm_tet_check_with_tetgen(const pm_tet_input *in, int32_t *problems, pm_error *err);

#ifdef __cplusplus
}
#endif

#endif /* PM_TET_TETGEN_H */
