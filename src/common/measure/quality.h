/* Element and mesh quality measures: one implementation for every mesh, whichever mesher made
 * it (bubble, psys, a peer, or a file read by mesh_io).
 *
 * Per triangle (papers/004 section 2.5 for q; papers/001 Fig. 11 for R / l_min):
 *   radius ratio  q = 2 r_in / R            1 for an equilateral triangle, 0 when flat
 *   aspect ratio  R / l_min                 1/sqrt(3) = 0.577 for an equilateral triangle
 *   min and max angle, in degrees
 * Per tetrahedron:
 *   radius ratio  q = 3 r_in / R            1 for a regular tet, 0 when flat
 *   aspect ratio  R / l_min                 sqrt(6)/4 = 0.612 for a regular tet
 *   min and max dihedral angle, in degrees  acos(1/3) = 70.53 for a regular tet
 * (r_in: inscribed radius, R: circumscribed radius, l_min: shortest edge.)
 *
 * Per mesh (papers/003 section 2.5):
 *   eps_t = (1/n) sum |degree_i - D| over the n interior nodes, D = 6 (triangles), 12 (tets)
 *           (eq. 8). The degree is the number of distinct nodes joined to node i by an edge of
 *           the triangles (tets). "Interior": a node classified on a face (dim 2) for the triangle
 *           measure, in a volume (dim 3) for the tet measure; a node without classification
 *           (node_dim = -1) is interior when no edge at it is a boundary or non-manifold edge
 *           (an edge of exactly two triangles) for triangles, and when no face at it is a
 *           boundary face (a face of one tet) for tets. Nodes used by no element of the kind do
 *           not count.
 *   eps_g = (1/m) sum (A - r_i / R_i) over the m elements, A = 0.5 (triangles), sqrt(2/11)
 *           (tets) (eq. 9), exactly as the paper states it.
 *   size conformity: for every unique edge, its length over d at its midpoint; mean and
 *           population standard deviation (divide by the number of edges). Needs a size field;
 *           skipped without one.
 *   angle counts (triangles): by min angle in [0,10), [10,20), [20,30), [30,40), [40,50),
 *           [50,60] degrees, and by max angle > 90, > 120, > 150 degrees (each count is
 *           cumulative: a 160-degree triangle is in all three).
 *   triangles by site (ours): R / l_min of the triangles with a corner that is not interior (in
 *           the sense of eps_t: on a curve or vertex, or on the mesh's boundary), of the others
 *           with a corner of degree other than 6 (around a defect of the hexagonal lattice), and
 *           of the rest, the regular triangles (three corners of degree 6). It tells where a
 *           mesh's worse triangles sit: along the curves, at lattice defects, or in a lattice
 *           that is itself distorted (a graded field).
 *
 * Summaries are those of base/summary.h; the element measures and the degenerate elements are
 * those of mesh/element_measure.h.
 */
#ifndef PM_QUALITY_H
#define PM_QUALITY_H

#include <packmesh/packmesh.h>

#include <stddef.h>
#include <stdint.h>

#include "common/base/summary.h"
#include "common/mesh/element_measure.h"
#include "common/mesh/mesh.h"
#include "common/sizing/sizing.h"

#ifdef __cplusplus
extern "C" {
#endif


/* Shimada's A of papers/003 eq. 9: the largest r/R of a triangle (0.5) and, as the paper states
 * it, of a tetrahedron (sqrt(2/11)). For a regular tetrahedron r/R is in fact 1/3 = 0.3333 while
 * sqrt(2/11) = 0.4264, so the tet eps_g cannot reach 0 with the paper's A; we keep the paper's
 * value so that figures compare with its Table 1 definition. */
#define PM_EPS_G_A_TRI 0.5
#define PM_EPS_G_A_TET 0.42640143271122088 /* sqrt(2/11) */

/* ---- a whole mesh ------------------------------------------------------------------------- */

/* The measures of one element kind (triangles or tets). For tets, min_angle / max_angle hold the
 * dihedral angles. Per-element arrays are in element order, owned, freed by pm_quality_clear. */
typedef struct pm_kind_quality {
  int32_t n;              /* elements measured (mesh->ntri or mesh->ntet) */
  double *radius_ratio;   /* [n] */
  double *aspect_ratio;   /* [n] */
  double *min_angle;      /* [n] degrees */
  double *max_angle;      /* [n] degrees */
  pm_summary s_radius_ratio, s_aspect_ratio, s_min_angle, s_max_angle;
  int32_t degenerate;     /* elements given the degenerate values above */

  double eps_t;           /* papers/003 eq. 8 (0 when eps_t_nodes == 0) */
  int32_t eps_t_nodes;    /* interior nodes it averages over */
  double eps_g;           /* papers/003 eq. 9 (0 when n == 0) */

  int has_size;           /* size conformity computed */
  int64_t nedge;          /* unique edges */
  pm_summary size_ratio;  /* edge length / d(midpoint) over the unique edges */
  double size_ratio_std;  /* population standard deviation */
} pm_kind_quality;

/* The sites of triangles (see above). */
typedef enum pm_tri_site {
  PM_TRI_BOUNDARY,  /* a corner that is not interior */
  PM_TRI_IRREGULAR, /* interior corners, one of degree other than 6 */
  PM_TRI_REGULAR,   /* three interior corners of degree 6 */
  PM_TRI_SITES
} pm_tri_site;

typedef struct pm_quality {
  pm_kind_quality tri, tet;
  int64_t tri_min_angle_bins[6]; /* [0,10) [10,20) [20,30) [30,40) [40,50) [50,60] */
  int64_t tri_max_angle_over[3]; /* > 90, > 120, > 150 */
  pm_summary tri_site_aspect[PM_TRI_SITES]; /* R / l_min by site; .n the triangles there */
} pm_quality;

/* The name of a site in the stats ("boundary", "irregular", "regular"). */
const char *pm_tri_site_name(pm_tri_site site);

/* Measure every triangle and tet of m. The size field is given as a callback d = fn(xyz, user),
 * the desired edge length (fn may be NULL: no size conformity); a value that is not finite and
 * > 0 at an edge midpoint is PM_ERR_ARG naming the point. fn is called from several threads at
 * once. Element indices must be in range (PM_ERR_ARG otherwise). On success q owns its arrays
 * (pm_quality_clear); on failure q is left cleared. */
pm_status pm_quality_compute_fn(const pm_mesh *m, pm_sizing_fn fn, void *user, pm_quality *q,
                                pm_error *err);

/* The same with a size field (may be NULL: no size conformity). */
pm_status pm_quality_compute(const pm_mesh *m, const pm_sizing *size, pm_quality *q,
                             pm_error *err);

/* Release the arrays and zero q. Accepts a zeroed q. */
void pm_quality_clear(pm_quality *q);

#ifdef __cplusplus
}
#endif

#endif /* PM_QUALITY_H */
