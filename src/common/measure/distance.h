/* The two-sided distance between a mesh and the model it discretizes: the "distance to the true
 * geometry" of DESIGN.md (quality measures, and the --stats key "distance": mean, max and the
 * model's bounding-box diagonal), computed through the Embree closest-point queries of
 * closest_embree.h.
 *
 * What is compared. The surface part: the mesh's triangles against the model's faces (with their
 * boundary curves). The wire part: the mesh's segments that discretize dangling curves (curves
 * that bound no face: a wire model, or the dangling edge of papers/003 Fig. 11) against those
 * curves; when the model has no face at all, every segment of the mesh belongs to the wire part.
 * Segments on face boundaries are edges of triangles and add nothing. Tets are ignored (their
 * boundary triangles are the mesh's triangles).
 *
 * Both directions are sampled and every reported distance is from an exact point of one side to
 * the other side:
 *   model -> mesh: each face is sampled on a grid of its parameter box, kept where pm_face_inside
 *     says the point is in the trimmed region, with a 3D spacing of `spacing` times the local edge
 *     length of the mesh (the 5th percentile of the edge lengths of the face's triangles, or of
 *     all triangles when the mesh is not classified); the boundary curves are sampled at the same
 *     spacing, at most model_per_tri points per mesh segment on the curve (this is where a
 *     polygonal boundary cuts corners: the sagitta). Each point S(u, v)
 *     or C(t) is queried against a BVH of the mesh's triangles: the exact distance to the mesh.
 *   mesh -> model: each triangle is sampled on the barycentric lattice of level `tri_level`
 *     (vertices, points on the edges, interior points), each segment at tri_level + 1 points. The
 *     distance of a point x to the model is the smallest of these candidates, each the distance
 *     from x to an actual model point:
 *       - when the element is classified on a face (or a dangling curve) and its nodes carry
 *         parameters on it: Gauss-Newton projection onto that cell started from the element's
 *         interpolated parameters (unwrapped across the seam of a periodic face), kept when the
 *         foot lies in the trimmed region. A node's parameters count only when the cell's point
 *         at them is the node (within 1e-6 of the diagonal): a file read without parameters
 *         has zeros there, and a projection started from them can stop at a local minimum far
 *         from the foot;
 *       - a reference tessellation of the faces (per face, a grid of inside (u, v) points and the
 *         trimming polylines, triangulated in (u, v) and lifted: the grid's quads that lie
 *         inside, away from the polylines, are split directly, the band along the polylines by
 *         the constrained Delaunay triangulation of cdt_cgal.h (ref_split); its chordal error is at most ref_tol x diagonal and
 *         at most ref_spacing^2 = 1/4 of the mesh's own chordal error): the closest reference
 *         triangle names a face and a starting (u, v), from which Gauss-Newton finds the foot
 *         on that face;
 *       - a reference polyline of the curves (chordal error ref_tol x diagonal): the closest
 *         reference segment names a curve and a starting t, refined by Newton on the curve (the
 *         closest point of a trimmed face lies inside it or on its boundary curves).
 *     So the reference tessellation never limits the accuracy directly: it only picks the face or
 *     curve and the starting point. Whether a foot lies in the trimmed region is decided by
 *     pm_face_inside, except within 1e-3 x diagonal of a boundary curve, where the trimming
 *     polyline (which cuts the corners of curved boundaries) would misjudge it: there the side of
 *     the curve itself decides (the same rule keeps the model -> mesh samples on the face). Where two faces are within the reference tolerance of being
 *     equally close the pick may be the wrong one, which costs at most about that tolerance. If no
 *     candidate is available (every projection left the trim and there is no curve), the distance
 *     to the reference tessellation itself is used and counted in `nfallback`.
 * Searches that cannot find anything are skipped (prune = 1, the default; no figure changes):
 *   - mesh -> model: per mesh triangle, the distances from its centroid to the boundary curves'
 *     polylines and to the reference of the other faces (less how far that reference may lie from
 *     its face) are measured once; a sample x of the triangle skips the search of the other
 *     faces when they are farther than the hint's foot plus |x - centroid|, and the search of the
 *     curves likewise. Where a search remains, it stops at the hint's foot distance plus how far
 *     the reference may lie from its faces (its chordal bound with a margin, at least eps).
 *   - model -> mesh: a face's samples are evaluated in batches of one grid row segment; each
 *     starts its search of the mesh from the previous sample's distance plus the distance between
 *     them, and skips the search of the curves while the last one shows them out of reach.
 *   Projections stop when the step's image in 3D (the tangential part t of x - S) is below 1e-10
 *   of the diagonal, or when it would lower the distance d by less than 1e-12 of the diagonal
 *   (|t|^2 / 2d: the distance is stationary at the foot), before evaluating it.
 * Each direction then refines its `refine` largest distances (one per element, or per 1/64 of a
 * face or curve) by a pattern search over the element's parameters, so that the maximum is the
 * local maximum of the distance function and not just the best sample.
 *
 * Reported: the largest distance (the Hausdorff distance of the samples), and the mean weighted
 * by area (by length for the wire part) over both surfaces together:
 *   mean = (int_mesh d dA + int_model d dA) / (area_mesh + area_model).
 * The mesh side's integral is the lattice's composite rule exact for quadratics (quadrature): a
 * chordal deviation vanishes at the nodes and is nearly quadratic on a triangle, which the equal
 * weights of the previous code path put low by a quarter (bspline_sphere.brep's bubble mesh:
 * 8.56e-3 against 1.142e-2 from a level-16 lattice; now 1.1419e-2, and the model side's 1.1422e-2).
 * Where the distance is not smooth (spikes at a few points: a healed model whose pcurves stray)
 * no rule at level 4 is good: step__mesh_T106_V3's mean is 0.035 by rule 2, 0.034 by rule 1 and
 * 0.023 by rule 0 against 0.027 at level 16.
 * Each direction is reported too. With a size field d(x), the same for distance / d(x) at the
 * sampled point. Deterministic: no randomness; samples are evaluated in parallel (OpenMP) and
 * reduced in index order, so the thread count does not change any figure.
 */
#ifndef PM_DISTANCE_H
#define PM_DISTANCE_H

#include <packmesh/packmesh.h>

#include "common/geom/geom.h"
#include "common/mesh/mesh.h"
#include "common/sizing/sizing.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Sampling parameters. Defaults are set by pm_distance_params_init only. */
typedef struct pm_distance_params {
  double spacing;        /* model -> mesh sample spacing, as a fraction of the local edge length
                            of the mesh; (0, 1], default 0.25 */
  int32_t tri_level;     /* mesh -> model barycentric lattice level: (L+1)(L+2)/2 points per
                            triangle, L+1 per segment; 1..32, default 4 (15 points). Lowered
                            automatically (not below 1) to keep the samples under max_samples */
  int32_t quadrature;    /* how the lattice points are weighted in the mesh -> model mean:
                            2, per triangle the composite rule exact for quadratics (level even;
                            rule 1 for odd levels), Simpson's rule on segments; 1, the
                            piecewise-linear rule (the trapezoidal one on segments); 0, every
                            point of an element weighs the same (the previous code path). On the
                            bubble meshes of both CAD folders, against a level-16 lattice: median
                            error 0.4% (2), -6% (1), -25% (0); 0..2, default 2 */
  int32_t refine;        /* per direction, how many of the largest distances are refined by a
                            pattern search; 0..256, default 16 */
  int32_t refine_fit;    /* 1: where the pattern search finds no better neighbour, it jumps to the
                            vertex of the quadratic through the nine values around it when that is
                            better, and cuts its step by 8 (fewer evaluations to the same local
                            maximum); 0: it only halves its step (the previous code path); 0..1,
                            default 1 */
  int64_t max_face_samples; /* cap on the grid points of one face (model -> mesh);
                            >= 16, default 250000 */
  int64_t max_samples;   /* cap on the samples of one direction; the model -> mesh spacing
                            grows to meet it; >= 1000, default 4000000 */
  double ref_tol;        /* chordal tolerance of the reference tessellation and polylines,
                            relative to the model's bounding-box diagonal; [1e-7, 1e-2],
                            default 1e-4 */
  double ref_spacing;    /* the reference grid spacing is also at most this fraction of the
                            local edge length of the mesh, so that its chordal error stays below
                            (ref_spacing)^2 of the mesh's; (0, 1], default 0.5 (0.25 before: the
                            same figures to 7 digits on five CAD meshes, and a quarter of the
                            reference; it only picks faces and starts) */
  int64_t ref_max_points; /* cap on the reference grid points of one face (the tolerances are then
                            not met and `ref_chord` says what was); >= 100, default 100000 */
  int32_t ref_per_tri;   /* ... and at most this many per triangle of the face's mesh (at least
                            256 a face): the reference only picks a face and a start for the exact
                            projection, so its chordal error need only be a small fraction of the
                            mesh's (16 gives 1/20 on a sphere); 1..1e6, default 16 */
  int32_t model_per_tri; /* model -> mesh samples of one face: at most this many per triangle of
                            the face's mesh (at least 256 a face), so that the cost follows the
                            mesh, not the parametrization; and of one boundary curve, at most
                            this many per mesh segment on it (at least 256); 1..1e6, default 16 */
  int32_t prune;         /* 1: skip the searches that bounds show cannot find anything (per mesh
                            triangle, the distance from its centroid to the boundary curves and to
                            the reference of the other faces; along a row of model samples, the
                            previous sample's answers), which leaves every figure as it is;
                            0: search everywhere (the previous code path, kept for tests and
                            benchmarks); 0..1, default 1 */
  int32_t ref_split;     /* 1: the reference grid's quads that lie inside a face, away from its
                            trimming polylines, are split into two triangles directly, and only
                            the band along the polylines goes through the constrained
                            triangulation (the same points, the same covered region, the same
                            number of triangles); 0: every point goes through the constrained
                            triangulation (the previous code path, kept for tests and
                            benchmarks); 0..1, default 1 */
} pm_distance_params;

/* Set the defaults above. */
void pm_distance_params_init(pm_distance_params *p);

/* PM_ERR_ARG naming the first field outside its range. */
pm_status pm_distance_params_check(const pm_distance_params *p, pm_error *err);

/* The result (plain data, no pointers). Distances in model units. */
typedef struct pm_distance {
  double mean, max;                 /* two-sided: area-weighted mean over both sides, largest */
  double mesh_to_model_mean, mesh_to_model_max;
  double model_to_mesh_mean, model_to_mesh_max;
  double bbox_diagonal;             /* the model's bounding-box diagonal */
  int has_size;                     /* 1 when a size field was given */
  double rel_mean, rel_max;         /* two-sided distance / d(x), when has_size (else 0) */
  double max_at[3];                 /* a point where the largest distance was found */
  int max_from_model;               /* 1 when that point is on the model (model -> mesh), 0 on
                                       the mesh */
  int64_t nsamples_mesh;            /* points sampled on the mesh (mesh -> model) */
  int64_t nsamples_model;           /* points sampled on the model (model -> mesh) */
  int32_t tri_level;                /* the lattice level used */
  double ref_chord;                 /* the largest chordal error bound of the reference
                                       tessellation (model units) */
  int64_t nfallback;                /* mesh points measured against the reference tessellation
                                       because no exact candidate was found */
  int64_t nhintless;                /* mesh points on triangles that gave no start for the
                                       projection (no node on the face, or on one of its
                                       boundary curves, with parameters that put it there):
                                       those are searched from the reference and the curves */
  int32_t ref_faces_degraded;       /* faces whose reference triangulation fell back to grid
                                       cells (the constrained triangulation failed) */
  int64_t ref_triangles;            /* triangles of the faces' reference tessellation */
  int64_t ref_cdt_points;           /* points of it that went through the constrained
                                       triangulation (ref_split) */
  int ref_tree_built;               /* 1 when a search needed the reference's hierarchy, which is
                                       built at its first use (a one-face model whose samples all
                                       find their foot from their own element needs none) */
} pm_distance;

/* The two-sided distance between mesh and model (see above).
 * [in]  mesh   triangles (and segments) with optional classification; borrowed
 * [in]  model  the model the mesh discretizes; borrowed
 * [in]  size   may be NULL; when given, the relative figures are filled
 * [in]  p      may be NULL for the defaults
 * [out] out    the result (zeroed first)
 * Errors: PM_ERR_ARG (bad parameters, a mesh with nothing to compare: no triangles while the
 * model has faces, or neither triangles nor wire segments; a non-finite coordinate), PM_ERR_GEOM
 * (the model has neither faces nor curves), PM_ERR_NOMEM, PM_ERR_BACKEND (Embree). */
pm_status pm_mesh_distance(const pm_mesh *mesh, const pm_model *model, const pm_sizing *size,
                           const pm_distance_params *p, pm_distance *out, pm_error *err);

#ifdef __cplusplus
}
#endif

#endif /* PM_DISTANCE_H */
