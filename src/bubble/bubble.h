/* The bubble mesher: Shimada & Gossard's bubble mesh (papers/003), with the details of Saini's
 * thesis (papers/000) and the accelerations of Qi, Nie & Zhang (papers/004), on vertices, curves,
 * faces (planar domains and trimmed CAD surfaces) and, with --volume, volumes (non-manifold models
 * included: embedded faces and dangling curves become triangles and segments inside the tets).
 *
 *   1. bubbles on every vertex, binary subdivision on curves, a rhombic (60 degree) quadtree on
 *      faces (003 section 3.2, 000 section 4.1.1, 004 section 2.3: weights w1, w2);
 *   2. the cubic inter-bubble force (003 eq. 10-11, 004 eq. 2.1);
 *   3. damped dynamics m x'' + c x' = f integrated by RK4 (or the second-order scheme of 004),
 *      every stage confined to the bubble's cell by geom.h's shared displacement rule
 *      (003 eq. 12-15, 000 section 5.5); volume bubbles, once the others have settled, free in 3D
 *      inside their volume, placed by an octree of 60-degree rhombohedra (bub_volume.c);
 *   4. adaptive population control by the overlap ratio (003 eq. 16, 000 sections 3.1.3,
 *      4.1.2, 4.2.1-4.2.6);
 *   5. the accelerations of 004 (saw-tooth viscosity with c_odd, w1/w2, the self-adaptive stop);
 *   6. connection by pm_connect (DESIGN.md, "Connecting nodes").
 *
 * Every parameter is a field of bub_params, described once in bub_params_table (defaults,
 * --set, --help, range checks). The method is exported to the command line as bub_method.
 */
#ifndef BUB_BUBBLE_H
#define BUB_BUBBLE_H

#include <packmesh/packmesh.h>

#include "common/method/method.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Integrators of the equation of motion. */
enum { BUB_RK4 = 0, BUB_RK2 = 1, BUB_SYMPLECTIC = 2 };
/* Viscosity schedules. */
enum { BUB_VISC_CONSTANT = 0, BUB_VISC_SAWTOOTH = 1 };
/* Initial placement of face bubbles. */
enum { BUB_PLACE_QUADTREE = 0, BUB_PLACE_LATTICE = 1 };
/* Where the tets' interior nodes come from with --volume. */
enum { BUB_TETS_BUBBLES = 0, BUB_TETS_TETGEN = 1 };

/* The parameters of the bubble method. Defaults are set in exactly one place, the table in
 * bub_params.c (bub_params_init); the doc line of every field gives its meaning, range, default
 * and source, and `packmesh mesh --method bubble --help` prints the same from the table. */
typedef struct bub_params {
  /* ---- force and dynamics (003 eq. 10-14, 004 eq. 2.1-2.2) ---- */
  double k0;        /* spring constant of the force at l0: f'(l0) = -k0; (0, 1e6], default 30
                       (000 section 6.4: best near 30 with m = 1, zeta = 0.7) */
  double mass;      /* bubble mass m; (0, 1e6], default 1 (000 section 6.4) */
  double zeta;      /* damping ratio zeta = c / (2 sqrt(m k0)) (003 eq. 14); (0, 10], default 0.7 */
  double dt;        /* time step as a fraction of the natural period T0 = 2 pi sqrt(m / k0);
                       [0, 0.2], default 0 = automatic: 0.1 for rk4 and symplectic, 0.05 for rk2 (our choice,
                       see bub_dynamics.c; bub_params_check rejects an unstable step) */
  int integrator;   /* BUB_RK4 (003 section 3.4), BUB_RK2 (004 section 1, Heun's second-order
                       scheme) or BUB_SYMPLECTIC (semi-implicit Euler with implicit damping, one
                       force sum a step: our addition, bub_dynamics.c); default symplectic
                       (the papers' rk4 is --set integrator=rk4) */
  /* ---- viscosity schedule (004 section 2.2) ---- */
  int viscosity;    /* BUB_VISC_CONSTANT (zeta throughout, classic) or BUB_VISC_SAWTOOTH (zeta
                       rising within and across rounds); default sawtooth */
  double zeta_k1;   /* saw-tooth: rise of the damping ratio per step within a round; [0, 1],
                       default 0.05 */
  double zeta_k2;   /* saw-tooth: rise of the damping ratio per round (0 <= k2 < k1 x steps of a
                       round); [0, 1], default 0.02 */
  double zeta_max;  /* saw-tooth: cap of the damping ratio; [0.1, 10], default 1.5 */
  double final_zeta; /* damping ratio of curved faces' bubbles in the surface phase's relaxation
                        steps after population control has ended (final_steps; planes, curves and
                        the volume phase keep the schedule); -1 = the viscosity schedule goes on (the saw-tooth at its
                        cap, 1.5: overdamped, so the packing's long waves relax slowly, at a rate
                        k / c); 0 = automatic: 0.3 with rk4 and symplectic, the schedule with rk2 (Heun's
                        stability region leaves out the imaginary axis: at dt 0.05 it needs
                        zeta above 0.3); [-1, 10], default 0 (our choice, bub_run.c) */
  double zeta_odd;  /* damping ratio of "odd" bubbles, next to an insertion or deletion, for the
                       round after it (004: c_odd = 1 with m = k0 = 1 is zeta 0.5); (0, 10],
                       default 0.5 */
  double odd_from;  /* the odd-bubble scheme starts once a control changes the count by at most
                       this fraction (004: 0.05%); [0, 1], default 0.0005 */
  /* ---- speed (bub_neighbors.c, bub_dynamics.c: no effect on the papers' equations) ---- */
  double list_skin; /* skin of the neighbour lists: a pair is listed within (1 + list_skin)
                       x 1.5 l0, and the lists are rebuilt (from the outer lists) once two
                       bubbles may have crossed the skin; [0.02, 2], default 0.15 (our choice,
                       bench_bubble: fewer pairs per list against more rebuilds) */
  double list_outer; /* skin of the outer lists, from which the lists are rebuilt: pairs within
                        (1 + list_outer) x 1.5 l0, found through the grid once two bubbles may
                        have crossed it; [list_skin, 3], default 0.6 */
  double list_partial; /* when the skin test fails, only the bubbles that used up half their skin
                          get new lists (with their neighbours, and new outer lists from the grid
                          where those are stale), while they are at most this fraction of the
                          moving bubbles, else every list is built again; [0, 1], 0 = always
                          every list, default 0.125 (our choice, bub_neighbors.c: a few bubbles
                          gliding along a defect would otherwise rebuild every list every few
                          steps) */
  double frame_tol; /* a bubble whose parameters moved less than frame_tol x d from where its
                       cell was last evaluated takes position and tangents from the cell's
                       second-order Taylor model there (exact on planes and lines, error below
                       1e-6 d elsewhere, bub_dynamics.c); [0, 0.5], 0 = exact evaluation at every
                       RK stage (the papers), default 0.05 */
  /* ---- initial placement (003 section 3.2, 000 section 4.1.1, 004 section 2.3) ---- */
  int place;        /* face bubbles: BUB_PLACE_QUADTREE, the rhombic quadtree of the papers (003
                       section 3.2, 000 section 4.1.1, weights w1, w2 of 004 section 2.3), or
                       BUB_PLACE_LATTICE, a hexagonal lattice grown from the border at the stable
                       distance (our addition, bub_lattice.c: one grain, the final count);
                       default lattice */
  int hold_rings;   /* place = lattice, planes: a face bubble with every lattice site within this
                       many rings placed in its grain at its own size is held where it was
                       placed (bub_lattice.c); 0: every bubble relaxes (the papers) */
  int lattice_fit;  /* place = lattice, planes: a grain steps at fit x the stable distance, fit =
                       its seed chord's length over the chord's stable distance when within 1.2% of
                       1 (the border's own spacing, bub_lattice.c "Fit"); 0: fit = 1; default 1 */
  int lattice_apex; /* place = lattice on curved faces: a site next to two placed bubbles goes to
                       the point at the stable distance from both (the apex of the triangle on
                       them) instead of a step from one along the row direction; 0 = the step
                       from one (bub_lattice.c, "two parents"); default 1 */
  double w1;        /* curve insertion weight: split while w1 |P1P2| > r1 + r2; (0, 4],
                       default 1 */
  double w2;        /* face insertion weight (004: 0.5..0.8); (0, 1], default 0.5 (a sparse
                       start that insertions fill ends nearer the ideal count than a dense one
                       that removals thin: see bub_place.c) */
  /* ---- population control (003 eq. 16, 000 sections 4.1.2, 4.2) ---- */
  int population;   /* adaptive population control on/off; default on (003 section 3.5) */
  double face_open;   /* face bubble is open below this overlap ratio; (0, 12], < 6, default 5.6
                         (000 section 4.1.2: 5, for the quadtree's sparse start; our choice with
                         the lattice start, which has the final density already: a narrower
                         window turns a strained patch into a defect instead of spreading the
                         strain over many triangles, bench_bubble compare) */
  double face_excess; /* face bubble is excess above this overlap ratio; (0, 30], > 6, default 7
                         (000 section 4.1.2: 8; the same choice) */
  double curved_open;   /* bubbles of curved faces (not planes) are open below this overlap ratio;
                           [0, 6), 0 = face_open; default 5 (000 section 4.1.2's cut-off: a
                           curved face keeps lattice defects wherever its Gaussian curvature is
                           not 0, and the planes' narrow window exchanges their bubbles at every
                           control; bench_bubble timing) */
  double curved_excess; /* bubbles of curved faces are excess above this; 0 or (6, 30], 0 =
                           face_excess; default 8 (000 section 4.1.2; the same choice) */
  double curve_open;  /* curve bubble open below; (0, 4], < 2, default 5/3 (our choice: the face
                         cut-offs of 000, 5 and 8, scaled by 2/6, the same spacing window;
                         bub_population.c) */
  double curve_excess; /* curve bubble excess above; (0, 10], > 2, default 8/3 (same rule) */
  double volume_open;   /* volume bubble is open below this overlap ratio; (0, 40], < 12, default
                           10 (our choice: two of 12 neighbours missing, the faces' one of 6;
                           bub_population.c) */
  double volume_excess; /* volume bubble is excess above; (0, 60], > 12, default 14 (our
                           choice: a bubble pushed into the close packing reads 13.9-14.7, as
                           the faces' 8 is at a pushed bubble's 7.6-7.95; bub_params.c) */
  double insert_excess; /* a face insertion place is not used when its overlap ratio is above
                           max(face_excess, insert_excess) (a new bubble is not removed in the
                           control that inserted it, 000 section 4.2.4, and relaxes before the
                           next); [0, 30], default 8 (the papers' face_excess) */
  double insert_k;  /* insertion distance factor k (a new face bubble at k r); [0.5, 4],
                       default 1.8 (000 section 4.2.4) */
  int control_steps; /* relaxation steps between two population controls; [1, 100000],
                        default 20 (000 section 4.2.6) */
  double calm;      /* control only when every bubble moved less than calm x its diameter in the
                       last step (003 section 3.5); (0, 1], default 0.02 */
  int outside_layer; /* the layer of overlap-only bubbles outside face borders; default on
                        (000 section 4.2.1) */
  /* ---- stopping (003 section 3.4, 004 section 2.4) ---- */
  int adaptive_stop; /* stop when the count changes by at most stop_change in stop_rounds
                        consecutive rounds (004 section 2.4); default on */
  double stop_change; /* largest relative count change of a settled round; [0, 1], default
                         0.005 (004 section 2.4: 0.5%) */
  int stop_rounds;  /* settled rounds in a row; [1, 1000], default 2 (004: twice) */
  double disp_tol;  /* stop when no bubble moves more than disp_tol x its diameter in a step and
                       the last control changed nothing (003 section 3.4); [0, 1], default 1e-3 */
  double disp_quantile; /* the tests on a step's displacements (calm, disp_tol) read this quantile
                           of the bubbles' displacement / d instead of the largest (our choice: the
                           largest of n values grows with n, and so would the step count);
                           (0, 1], 1 = the largest (003 sections 3.4-3.5), default 0.99 */
  int final_steps;  /* relaxation steps after the population has settled, at most (the
                       displacement test may end them sooner); [0, 1e6], default 50 (our
                       choice: with final_zeta 0.3 as good as 100 were at the saw-tooth's cap,
                       bench_bubble compare) */
  int max_steps;    /* cap on steps; [0, 1e8], default 3000 */
  double max_bubbles; /* cap on bubbles: reached by insertions it ends the run (the run's own
                         node budget, pm_run_input.max_nodes, is an error instead); [1, 2e9],
                         default 1e7 */
  /* ---- default size rule (bub_size.c) ---- */
  double size_div;  /* default size: bounding-box diagonal / size_div; [1, 1e6], default 30 */
  double size_grade; /* growth rate of the default size away from small features; [0.01, 2],
                        default 0.3 */
  /* ---- volumes (with --volume; bub_volume.c) ---- */
  int tets;         /* BUB_TETS_BUBBLES: volume bubbles packed in every volume become the tets'
                       interior nodes, no Steiner point (003 section 3: the bubble hypothesis);
                       BUB_TETS_TETGEN: TetGen's quality refinement of the bubble surface mesh
                       (for comparison); default bubbles */
  double sliver_angle; /* tets=bubbles: a tet with a dihedral angle below this (degrees) drops a
                          volume bubble at its corners (a sliver with only surface corners gets
                          a node at its centroid) and the volume is tetrahedralized again (up
                          to 10 rounds; bub_run.c); [0, 30], 0 = off, default 10 (our
                          addition: slivers are the weakness of Delaunay tets from well-spaced
                          points) */
  /* ---- connection ---- */
  int metric_flips; /* 1: the parameter-space triangulation of each face is flipped towards the
                       Delaunay criterion of the surface's local metric before the 3D flips
                       (connect.c, metric_flips); 0: the affine map of 001 eq. 16 alone;
                       default 1 (our addition) */
  int drop_crossed; /* 1: face nodes beyond a boundary segment in 3D but inside it in (u, v) are
                       dropped before the connection (connect.c, step 1b); 0: every node is kept,
                       as in the papers; default 1 (our addition) */
  int smooth;       /* connection: sweeps of interior-node smoothing per face (face_smooth.h;
                       our addition); 0 = the nodes as placed, as in the papers; 4 */
  int needle_moves; /* connection: the smoothing also moves a face node with an angle below 10
                       degrees in its ring towards the edge opposite it (face_smooth.h; ours);
                       0 = Laplacian moves only, the meshes of before; 1 */
  /* ---- output ---- */
  int frame_every;  /* --frames: a snapshot every this many steps; [1, 1e6], default 10 */
} bub_params;

/* The table that describes every field (params.h). */
extern const pm_param_table bub_params_table;

/* Write the defaults into p. */
void bub_params_init(bub_params *p);

/* Range checks of the table plus the relations between fields (open < excess, the damping cap
 * within the time step's stability bound, ...). PM_ERR_ARG with a one-line message. */
pm_status bub_params_check(const bub_params *p, pm_error *err);

/* The default size field for a model without one: the bounding-box diagonal / size_div, reduced
 * near curves and faces too short, thin or curved for it (rule in bub_size.c). *out is owned by
 * the caller (pm_sizing_destroy). */
pm_status bub_default_size(const pm_model *model, const void *params, uint64_t seed, int threads,
                           pm_sizing **out, pm_error *err);

/* Run the method (the run function of bub_method). */
pm_status bub_run(const pm_run_input *in, const void *params, pm_run_output *out, pm_error *err);

/* The method descriptor for the command line ("bubble"). */
extern const pm_method bub_method;

#ifdef __cplusplus
}
#endif

#endif /* BUB_BUBBLE_H */
