/* The classic peers: meshers packmesh compares its particle methods with, run through the same
 * pm_method interface (method.h) on the same model and size field, measured by the same quality
 * module and judged by the same checker.
 *
 *   gmsh-meshadapt   gmsh's MeshAdapt surface algorithm        (Mesh.Algorithm = 1)
 *   gmsh-delaunay    gmsh's Delaunay surface algorithm         (Mesh.Algorithm = 5)
 *   gmsh-frontal     gmsh's Frontal-Delaunay surface algorithm (Mesh.Algorithm = 6)
 *   cgal             CGAL's 2D Delaunay refinement (Mesh_2), planar domains only, optionally
 *                    smoothed by CGAL's Lloyd move or an optimal Delaunay triangulation (ODT)
 *                    move (CGAL 5.5 has no 2D ODT of its own; see cgal_mesh2.h)
 *
 * gmsh peers mesh a CAD model's own gmsh model, and a planar analytic domain (geom_analytic:
 * the built-in planar cases and JSON planar domains) as an equivalent OpenCASCADE geometry whose
 * points, curves and face correspond one-to-one to the model's cells. The size field governs
 * through gmsh's size callback, with every other size source off (Mesh.MeshSizeFromPoints,
 * Mesh.MeshSizeFromCurvature, Mesh.MeshSizeExtendFromBoundary = 0). With --volume, the gmsh
 * peers tetrahedralize the model's volumes with gmsh's 3D Delaunay (Mesh.Algorithm3D = 1) or,
 * with volume=tetgen, with TetGen's quality refinement of gmsh's surface mesh (the volume step
 * our methods use, papers/001 section 4.4), so a study can hold the volume mesher fixed and vary
 * only the surface mesher.
 *
 * Output meshes are classified like ours: every node names its model cell and its parameters
 * there (curve t, face (u, v)), elements carry cell indices, a face's triangles follow
 * pm_face_mesh_sign, so pm_mesh_check (with the model), the quality module and the distance
 * module treat them exactly like the meshes of bubble and psys.
 *
 * Default size (in->size == NULL): a constant edge length of 1/30 of the model's bounding-box
 * diagonal, for every peer (the peers have no size rule of their own; DESIGN.md lets each
 * method use its own default, and this plain rule is the peers').
 */
#ifndef PM_PEERS_H
#define PM_PEERS_H

#include "common/method/method.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Parameters shared by the three gmsh peers (their tables differ only in the owner name). */
typedef enum peer_gmsh_volume { PEER_GMSH_VOLUME_GMSH = 0, PEER_GMSH_VOLUME_TETGEN = 1 } peer_gmsh_volume;

typedef struct peer_gmsh_params {
  int smoothing;      /* Mesh.Smoothing: Laplacian smoothing passes on the surface mesh;
                         [0, 100], default 1 (gmsh's default) */
  int optimize;       /* Mesh.Optimize: gmsh's tet optimizer after the 3D Delaunay (volume=gmsh
                         only); on|off, default on (gmsh's default) */
  int volume;         /* peer_gmsh_volume: which mesher makes the tets with --volume;
                         gmsh|tetgen, default gmsh */
  double radius_edge; /* volume=tetgen: TetGen -q radius-edge bound; (1, 10], default 1.5 (the
                         connection step's default) */
  int flip_flat;      /* flip gmsh's triangles of no 3D area with their neighbour
                         (peer_flip_flat_triangles) on the surface mesh, unless gmsh's 3D
                         Delaunay meshes the volumes from it; on|off, default on (off: gmsh's
                         triangles as they come) */
} peer_gmsh_params;

void peer_gmsh_params_init(void *params);

/* CGAL Mesh_2 parameters. */
typedef enum peer_cgal_optimizer {
  PEER_CGAL_OPT_NONE = 0,
  PEER_CGAL_OPT_LLOYD = 1,
  PEER_CGAL_OPT_ODT = 2
} peer_cgal_optimizer;

typedef struct peer_cgal_params {
  double shape_bound;  /* B: a triangle is bad when the squared sine of its smallest angle is
                          below B (Delaunay_mesh_criteria_2); (0, 0.125], default 0.125 (about
                          20.7 degrees, CGAL's default and the largest bound with guaranteed
                          termination) */
  double size_factor;  /* a triangle is bad when its longest edge exceeds size_factor x d at its
                          centroid; [0.5, 4], default 1.45, calibrated so that the mean edge length
                          over d is about 1 on uniform fields (Delaunay refinement leaves edges
                          between about half the bound and the bound) */
  int optimizer;       /* peer_cgal_optimizer: smoothing after refinement, boundary nodes fixed;
                          none|lloyd|odt, default none */
  int opt_iterations;  /* smoothing iterations at most (it stops earlier on convergence);
                          [1, 1000], default 10 (the count CGAL's examples use) */
} peer_cgal_params;

void peer_cgal_params_init(void *params);

extern const pm_method peer_gmsh_meshadapt, peer_gmsh_delaunay, peer_gmsh_frontal, peer_cgal;

#ifdef __cplusplus
}
#endif

#endif /* PM_PEERS_H */
