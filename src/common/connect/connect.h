/* Connecting nodes: nodes that lie on the cells of a model become a conforming mesh
 * (DESIGN.md, "Connecting nodes"). Both methods end with this one step, so a difference between
 * their meshes is a difference in node placement.
 *
 *   1. curves: the nodes of a curve, ordered by parameter between its end-vertex nodes, give its
 *      segments;
 *   2. faces: the face's own nodes and the node chains of its boundary curves, placed in the
 *      face's parameter space through its pcurves (a seam's nodes appear on both sides, a pole's
 *      node once per end of its degenerate pcurve), optionally affinely rescaled (papers/001
 *      eq. 16), are triangulated by CGAL's constrained Delaunay triangulation with the boundary
 *      chains as constraints, whose edges are then flipped in the parameter plane towards the
 *      Delaunay criterion of the surface's local metric (metric_flips); triangles outside the
 *      trimming loops are removed, triangles that collapse onto a pole are dropped, the rest are lifted to 3D and oriented along the face's
 *      outward normal (where it bounds a volume), and edges are flipped in 3D towards triangles
 *      whose diametric balls are empty (papers/001 section 4.3): a constrained edge is never
 *      flipped, no flip creates an inverted, degenerate or duplicate triangle, and the number of
 *      flips is capped, so the step always terminates;
 *   3. volumes (optional): TetGen tetrahedralizes the closed surface mesh, keeping its
 *      triangles, either with the method's own interior nodes and no Steiner points or with
 *      TetGen's quality refinement; internal faces and dangling curves are kept as tet faces and
 *      edges, and tets carry their volume's index.
 * The result is conforming: a curve's segments are edges of the triangles of every face it
 * bounds, a face's triangles are faces of the tets of every volume it bounds.
 */
#ifndef PM_CONNECT_H
#define PM_CONNECT_H

#include "common/geom/geom.h"
#include "common/mesh/mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum pm_flip_rule {
  PM_FLIP_NONE = 0,    /* keep the parameter-space triangulation */
  PM_FLIP_DIAMETRIC = 1 /* flip while the opposite vertex lies in a triangle's diametric ball
                           (papers/001 section 4.3) */
} pm_flip_rule;

typedef enum pm_volume_mode {
  PM_VOLUME_NONE = 0,   /* surface mesh only */
  PM_VOLUME_GIVEN = 1,  /* tets from the surface and the volume nodes, no Steiner point
                           (papers/003 section 3: the bubble hypothesis) */
  PM_VOLUME_REFINE = 2  /* TetGen quality refinement of the surface (papers/001 section 4.4) */
} pm_volume_mode;

typedef struct pm_connect_params {
  int affine;             /* 1: affine scaling of each face's parameter space (001 eq. 16); default 1 */
  int metric_flips;       /* 1: after the parameter-space triangulation, flip its edges towards
                             the Delaunay criterion of the surface's local metric (first
                             fundamental form, averaged per quadrilateral), for faces one affine
                             map cannot straighten; 0: the paper's triangulation; default 1 */
  int drop_crossed;       /* 1: drop the face nodes that lie inside a boundary segment in (u, v)
                             but not in 3D, where the face's pcurve and the curve disagree or
                             the segment's chord sags inside a coarse arc (connect.c, step 1b);
                             0: keep every node, as the papers do; default 1 */
  pm_flip_rule flips;     /* default PM_FLIP_DIAMETRIC */
  int max_flips_per_tri;  /* cap on flips per face, as a multiple of its triangle count; default 20 */
  pm_volume_mode volume;  /* default PM_VOLUME_NONE */
  double radius_edge;     /* PM_VOLUME_REFINE: TetGen -q bound, > 1; default 1.5 */
  double max_volume;      /* PM_VOLUME_REFINE: TetGen -a bound, <= 0 for none; default 0 */
  int32_t max_nodes;      /* cap on the mesh's node count after refinement, <= 0 none; default 0 */
  int check_surface;      /* 1: reject a self-intersecting surface before TetGen; default 1 */
  int recovery_points;    /* PM_VOLUME_GIVEN: when the boundary cannot be recovered from the given
                             nodes alone (a Delaunay tetrahedralization of some node sets lacks a
                             surface triangle, Schoenhardt's prism being the classic case), let
                             TetGen add the interior points it needs for that and report them
                             (pm_connect_report.steiner) instead of failing; default 1 */
  int smooth;             /* sweeps of interior-node smoothing per face after the 3D flips
                             (face_smooth.h), each followed by the flips again; 0: none, the
                             nodes stay where the method put them; default 0 */
  int needle_moves;       /* 1: the smoothing also moves a face node that has an angle below
                             PM_CONNECT_NEEDLE_DEG in its ring towards the edge opposite it
                             (face_smooth.h, needle_deg); default 0 */
} pm_connect_params;

/* The angle below which the smoothing's needle moves act: the needle limit of the quality
 * module (needles.h, PM_NEEDLE_DEG). */
#define PM_CONNECT_NEEDLE_DEG 10.0

/* Defaults, in one place. */
void pm_connect_params_init(pm_connect_params *p);

typedef struct pm_connect_report {
  int32_t added_nodes;         /* nodes added on vertices without one and on closed curves with
                                  fewer than 3 nodes */
  int32_t dropped_nodes;       /* face nodes outside their face's trimmed region, nodes of stray
                                  CAD points on another vertex, and curve nodes that repeat a
                                  node (at the parameter of the one before them or of the curve's
                                  end, or within 1e-7 of the diagonal of a vertex or an earlier
                                  curve node: connect.c, step 1a), removed */
  int32_t crossed_nodes;       /* face nodes dropped for lying inside a boundary segment in (u, v)
                                  but outside it in 3D, where the face's pcurve and the curve
                                  disagree (connect.c, step 1b) */
  int32_t chord_nodes;         /* curve nodes added in the middle of boundary segments whose
                                  chords crossed another in a face's (u, v) (connect.c, step 1c) */
  int32_t pole_triangles;      /* parameter-space triangles collapsed onto a pole, dropped */
  int32_t repair_nodes;        /* face nodes added where two triangles had the same three nodes
                                  (a pole with two neighbours, two faces sharing both curves of
                                  a corner: see connect.c) */
  int32_t metric_flips;        /* parameter-space edge flips under the local metric performed */
  int32_t flips;               /* 3D edge flips performed */
  int32_t smooth_moves;        /* accepted node moves of the smoothing, over all sweeps */
  int32_t flip_cap_hits;       /* faces where the flip cap stopped the flips */
  double aspect_before;        /* mean R/l_min of the triangles of curved faces before flips */
  double aspect_after;         /* ... and after */
  int32_t degenerate_before;   /* zero-area triangles of curved faces before flips (left out of
                                  the means) */
  int32_t degenerate_after;    /* ... and after */
  double aspect_max_before;    /* the worst R/l_min among them before flips */
  double aspect_max_after;     /* ... and after */
  int32_t curved_triangles;    /* how many triangles those figures are over */
  int32_t steiner;             /* interior points TetGen added (PM_VOLUME_REFINE) */
  int32_t flat_tet_flips;      /* edge removals that cleared zero-volume tets inside volumes */
  int32_t retagged_tets;       /* tets TetGen left without a region that lie inside a volume
                                  (tagged by flood fill from their neighbours) */
  int32_t flat_tets_repaired;  /* zero-volume tets under a planar face removed by flipping that
                                  face's diagonal */
  double time_curves, time_faces, time_volumes; /* seconds */
} pm_connect_report;

/* Connect the nodes of `mesh` (each classified on a cell of `model` through node_dim,
 * node_cell, node_par; elements are replaced) into a conforming mesh. `rep` may be NULL.
 * Errors: an unclassified node or one on a cell the model lacks (PM_ERR_ARG), two nodes on one
 * vertex, a face whose boundary chains cross in parameter space (PM_ERR_GEOM, naming the face),
 * a self-intersecting surface or a TetGen failure (PM_ERR_BACKEND), a node cap exceeded
 * (PM_ERR_LIMIT). On failure the mesh's elements are cleared. */
pm_status pm_connect(const pm_model *model, pm_mesh *mesh, const pm_connect_params *p,
                     pm_connect_report *rep, pm_error *err);

/* The volume step alone, for a mesh that already holds a conforming surface mesh classified on
 * `model` (any mesher's: triangles tagged with face indices and oriented by pm_face_mesh_sign,
 * segments tagged with curve indices, nodes classified, the volumes' own nodes with node_dim 3
 * for PM_VOLUME_GIVEN): adds the tets of every volume (p->volume picks the mode; p->max_nodes
 * caps the node count). Each group of volumes joined by shared or embedded faces is one TetGen
 * run; groups that share nothing (the solids of an assembly) are separate runs. rep (may be
 * NULL) receives the Steiner points, flat-tet repairs and time. On failure the mesh keeps its
 * surface and no tet or added node. */
pm_status pm_connect_volumes(const pm_model *model, pm_mesh *mesh, const pm_connect_params *p,
                             pm_connect_report *rep, pm_error *err);

#ifdef __cplusplus
}
#endif

#endif /* PM_CONNECT_H */
