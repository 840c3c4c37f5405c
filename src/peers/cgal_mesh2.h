/* CGAL's 2D Delaunay refinement (Mesh_2: Delaunay_mesher_2 on a Constrained_Delaunay_triangulation_2
 * with the exact-predicates kernel) behind a plain C header; C++ lives in cgal_mesh2.cpp only.
 *
 * Input: boundary points and constraint edges (the domain's boundary polylines, holes included),
 * a size function d(x, y) (the desired edge length) and the bounds of the criteria:
 *   - shape: a triangle is bad when the squared sine of its smallest angle is below
 *     shape_bound (CGAL's B; 0.125 is about 20.7 degrees);
 *   - size: a triangle is "imperatively" bad when its longest edge exceeds size_factor x d at its
 *     centroid. CGAL's own Delaunay_mesh_size_criteria_2 takes one constant bound; this criteria
 *     class (a MeshingCriteria_2 model, see the .cpp) follows a variable field instead.
 * The domain is what the constraints enclose by nesting parity (the outer loop minus its holes):
 * a seed point is placed in every bounded region the parity puts outside (each hole), and Mesh_2
 * refines the rest. Mesh_2 may split constraint edges (an encroached edge is split at its
 * midpoint); such points are reported with the input constraint they subdivide.
 * Optional smoothing afterwards, constrained vertices fixed:
 *   PEER_MESH2_LLOYD  CGAL's Lloyd move (Mesh_2::Lloyd_move_2, the move of
 *                     lloyd_optimize_mesh_2): each vertex to the centroid of its constrained
 *                     Voronoi cell;
 *   PEER_MESH2_ODT    optimal Delaunay triangulation smoothing (Chen 2004; Alliez et al. 2005):
 *                     each vertex to the mass-weighted mean of the circumcentres of its
 *                     triangles, mass = area x d^-4 (CGAL 5.5 has no 2D ODT of its own); a move is
 *                     halved until the vertex stays inside its star, so it never leaves the
 *                     domain.
 * Both weigh by the density d^-4 of the caller's field and run the iteration of CGAL's
 * Mesh_global_optimizer_2 (Jacobi moves, a vertex frozen when its move is below 0.001 of its
 * local size, convergence when the largest 1% of moves are below 0.001 of it), but visit the
 * vertices in the triangulation's own order instead of CGAL's address-ordered set, so the result
 * is the same from run to run; they stop at the iteration cap or at convergence.
 *
 * Failures: PM_ERR_ARG for bad input (counts, indices, non-finite coordinates, bounds out of
 * range), PM_ERR_GEOM when two constraint edges cross other than at a shared end point (the
 * boundary polylines of a coarsely sampled curved domain can), PM_ERR_LIMIT when refinement
 * would exceed max_points, PM_ERR_NOMEM, PM_ERR_BACKEND for any other CGAL exception (with its
 * message). No C++ exception crosses this header.
 */
#ifndef PM_CGAL_MESH2_H
#define PM_CGAL_MESH2_H

#include <packmesh/packmesh.h>

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The desired edge length at (x, y); NaN or a value <= 0 means "unknown here" (the triangle is
 * then judged by its shape only; the caller records and reports such values). Called from the
 * calling thread only. */
typedef double (*peer_mesh2_size_fn)(const double xy[2], void *user);

typedef enum peer_mesh2_optimizer {
  PEER_MESH2_NONE = 0,
  PEER_MESH2_LLOYD = 1,
  PEER_MESH2_ODT = 2
} peer_mesh2_optimizer;

typedef struct peer_mesh2_input {
  int32_t npts;
  const double *xy;          /* [2*npts] boundary points, pairwise distinct (borrowed) */
  int32_t ncons;
  const int32_t *cons;       /* [2*ncons] constraint edges (borrowed) */
  peer_mesh2_size_fn size;   /* desired edge length */
  void *user;                /* passed to size (borrowed) */
  double shape_bound;        /* B, in (0, 0.125] */
  double size_factor;        /* longest edge <= size_factor x d, > 0 */
  peer_mesh2_optimizer optimizer;
  int32_t opt_iterations;    /* >= 1 when an optimizer is chosen */
  int32_t max_points;        /* cap on the vertex count, > 0 */
} peer_mesh2_input;

typedef struct peer_mesh2_result {
  int32_t npts;
  double *xy;                /* [2*npts] input points first (same indices), then added points */
  int32_t *on_cons;          /* [npts] for an added point on a constraint edge: the index of the
                                input constraint it subdivides; -1 otherwise */
  int32_t ntri;
  int32_t *tri;              /* [3*ntri] counter-clockwise, the triangles of the domain */
  int32_t nseg;
  int32_t *seg;              /* [2*nseg] the constraint edges of the output, in input order */
  int32_t *seg_cons;         /* [nseg] the input constraint each one subdivides */
  int32_t nseeds;            /* hole seeds used */
  int32_t opt_iterations;    /* smoothing iterations that moved vertices (0 without smoothing) */
  const char *opt_stop;      /* static text: why the optimizer stopped, "" when none ran */
  double time_refine, time_optimize; /* seconds */
} peer_mesh2_result;

/* Mesh the domain. Every array of the result is malloc'ed; free with peer_mesh2_result_free.
 * On failure the result is zeroed. */
pm_status peer_mesh2_run(const peer_mesh2_input *in, peer_mesh2_result *out, pm_error *err);

/* Free the arrays of a result and zero it. Accepts NULL. */
void peer_mesh2_result_free(peer_mesh2_result *r);

#ifdef __cplusplus
}
#endif

#endif /* PM_CGAL_MESH2_H */
