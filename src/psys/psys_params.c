/* The psys parameter table: one description per field of psys_params drives its default,
 * `--set`, `--help` and the range check (params.h). Defaults live here and nowhere else.
 * Where a default changes the method of papers/001, its source says "differs from 001" and gives
 * in parentheses the value that restores the paper's behaviour; "001 is silent" marks a choice
 * the paper leaves open. */
#include <math.h>
#include <stddef.h>

#include "psys/psys.h"

#define F(field) offsetof(psys_params, field)
#define D PM_PARAM_DOUBLE
#define I PM_PARAM_INT
#define B PM_PARAM_BOOL

static const pm_param_desc desc[] = {
    {"s_kappa", D, F(s_kappa), 2.0, 0, 1e6, PM_RANGE_LO_OPEN, "",
     "curvature scaling: sigma_kappa = 1 / (s_kappa kappa); larger fits curved geometry closer",
     "001 sec. 3.1 eq. 12-13, sec. 5.1", NULL},
    {"s_tau", D, F(s_tau), 0.5, 0, 10, PM_RANGE_LO_OPEN, "",
     "gap-size scaling: sigma <= s_tau x the distance to the nearest non-adjacent cell",
     "001 sec. 3.1 (Gap Size), Alg. 2, sec. 5.1", NULL},
    {"L", D, F(lipschitz), 0.3, 0, 10, PM_RANGE_LO_OPEN, "",
     "Lipschitz bound of the sizing field: |sigma_i - sigma_j| <= L |x_i - x_j|",
     "001 eq. 14-15, sec. 5.1", NULL},
    {"kappa_min", D, F(kappa_min), 0, 0, INFINITY, PM_RANGE_HI_OPEN, "1/length",
     "smallest curvature considered; sigma_max = 1/(s_kappa kappa_min); 0 = 5 / model diagonal",
     "001 eq. 13 (default: ours)", NULL},
    {"kappa_max", D, F(kappa_max), 0, 0, INFINITY, PM_RANGE_HI_OPEN, "1/length",
     "largest curvature considered; sigma_min = 1/(s_kappa kappa_max); 0 = 500 / model diagonal",
     "001 eq. 12 (default: ours)", NULL},
    {"feature_width", B, F(feature_width), 1, 0, 1, PM_RANGE_CLOSED, "",
     "1: sigma <= s_tau x the local width of narrow faces, wedges and cusps of the model (the "
     "shared feature field of the narrow places, sizing_features.h, which also sees between "
     "curves that meet at a vertex), down to the feature floor, below sigma_min if need be (0: "
     "the paper's field, whose gap skips adjacent cells)",
     "ours; differs from 001 sec. 3.1 (0)", NULL},
    {"sigma_grow", D, F(sigma_grow), 1.5, 1, 100, PM_RANGE_LO_OPEN, "",
     "largest factor by which a particle's sigma may rise in one update (bounds the gap search)",
     "ours (001 is silent; no cap, the paper's reading: 100)", NULL},
    {"kappa_refresh", D, F(kappa_refresh), 0.25, 0, 100, PM_RANGE_CLOSED, "sigma",
     "re-evaluate a particle's curvature once it moved this far (0: every update)",
     "ours; differs from 001, which evaluates it at every update (0)", NULL},
    {"lambda_init", D, F(lambda_init), 1.0, 0, 100, PM_RANGE_LO_OPEN, "",
     "initial step scale lambda_i (step = lambda_i x the tangent Newton step of E_i)",
     "001 Alg. 1, sec. 3 (Newton-Raphson)", NULL},
    {"lambda_min", D, F(lambda_min), 1e-4, 0, 100, PM_RANGE_LO_OPEN, "",
     "Algorithm 1's lambda_min: below it a rejected step is skipped", "001 Alg. 1", NULL},
    {"lambda_max", D, F(lambda_max), 1.0, 0, 100, PM_RANGE_LO_OPEN, "",
     "cap of lambda_i (1: a full Newton step)", "ours (001 is silent)", NULL},
    {"lambda_grow", D, F(lambda_grow), 2.0, 1, 100, PM_RANGE_CLOSED, "",
     "lambda_i is multiplied by this after an accepted step (1: never grows)",
     "ours; differs from 001 Alg. 1, which only divides by 10 (1)", NULL},
    {"lambda_max_faces", D, F(lambda_max_faces), 1.8, 0, 100, PM_RANGE_CLOSED, "",
     "phase 3 (the faces): cap of lambda_i instead of lambda_max, an over-relaxed sweep above 1 "
     "(with move_tol_faces = 1.8e-3: fewer iterations, better triangles; 0: lambda_max)",
     "ours; differs from 001 Alg. 1, full Newton steps (0 with move_tol_faces=1e-3)", NULL},
    {"pair_sigma", I, F(pair_sigma), 1, 0, 1, PM_RANGE_CLOSED, "",
     "sigma_ij of a pair in eq. 1-2: 0 = max(sigma_i, sigma_j), 1 = their mean",
     "ours; differs from 001 eq. 1 (0)", NULL},
    {"step_max", D, F(step_max), 0.5, 0, 1, PM_RANGE_LO_OPEN, "sigma",
     "longest world-space step of a particle (eq. 2 diverges as r -> 0)",
     "ours (001 is silent: no cap; 1 is the loosest allowed)", NULL},
    {"frame_tol", D, F(frame_tol), 0.05, 0, 10, PM_RANGE_CLOSED, "sigma",
     "faces evaluated by gmsh: an accepted particle keeps its surface derivatives until it has "
     "moved this far from where they were evaluated (0: new ones at every trial point)",
     "ours; differs from 001 eq. 7-9, which take them at the particle (0)", NULL},
    {"split_ratio", D, F(split_ratio), 0.35, 0, 100, PM_RANGE_LO_OPEN, "",
     "split when E_i (1 + eps) < split_ratio E_ideal", "001 eq. 4", NULL},
    {"delete_ratio", D, F(delete_ratio), 1.75, 0, 100, PM_RANGE_LO_OPEN, "",
     "delete when E_i (1 + eps) > delete_ratio E_ideal", "001 eq. 5", NULL},
    {"ring_curve", D, F(ring_curve), 0.7, 0.5, 6, PM_RANGE_CLOSED, "",
     "E_ideal of curve particles is sigma ring_curve E(beta) (6: eq. 6 as printed, the hexagonal "
     "one-ring of a face; 0.7 gives the curves the faces' spacing)",
     "001 eq. 6; differs from it on curves (as printed: 6)", NULL},
    {"delete_grace", I, F(delete_grace), 3, 0, 1000, PM_RANGE_CLOSED, "iterations",
     "particles around a split or a delete are not deleted for this many iterations",
     "ours; differs from 001, which has no grace (0)", NULL},
    {"seeds_per_face", I, F(seeds_per_face), 8, 1, 100000, PM_RANGE_CLOSED, "",
     "k: random particles seeded per face at the start of phase 3", "001 sec. 4.1", NULL},
    {"seeding", I, F(seeding), 1, 0, 1, PM_RANGE_CLOSED, "",
     "phase 3's seeds: 0 = seeds_per_face random particles per face (the paper), 1 = each face "
     "filled by a front in its field from its boundary, a hexagonal lattice along the curves",
     "ours, after 001 sec. 5.2.1's 'bootstrap initial samplings'; differs from 001 sec. 4.1 "
     "(0)", NULL},
    {"pop_tol", D, F(pop_tol), 0.005, 0, 1, PM_RANGE_CLOSED, "",
     "annealing starts once the particle count moved by at most max(2, pop_tol n) over 10 "
     "iterations",
     "ours (001 sec. 3: 'this bias can be adjusted to stop splits and deletes')", NULL},
    {"anneal_after", I, F(anneal_after), 150, 1, 10000000, PM_RANGE_CLOSED, "iterations",
     "annealing starts at the latest after this many iterations of a phase", "ours", NULL},
    {"anneal_rate", D, F(anneal_rate), 0.75, 0, 1, PM_RANGE_LO_OPEN | PM_RANGE_HI_OPEN, "",
     "per-iteration factor of the annealing weight (bias amplitude, threshold widening)", "ours",
     NULL},
    {"anneal_off", D, F(anneal_off), 0.02, 0, 1, PM_RANGE_LO_OPEN | PM_RANGE_HI_OPEN, "",
     "splits and deletes stop once the annealing weight falls below this", "ours", NULL},
    {"move_tol", D, F(move_tol), 2e-3, 0, 1, PM_RANGE_LO_OPEN, "sigma",
     "a phase ends when population control is off and the mean move is below this",
     "001 sec. 4.1 ('change ... below some threshold'; value ours)", NULL},
    {"move_tol_faces", D, F(move_tol_faces), 1.8e-3, 0, 1, PM_RANGE_CLOSED, "sigma",
     "phase 3 (the faces) ends when the mean move is below this instead (0: move_tol); with "
     "lambda_max_faces = w, w x 1e-3 ends it where 1e-3 ends a sweep of full Newton steps",
     "001 sec. 4.1 ('change ... below some threshold'; value ours; 0 ends it as phases 1-2)",
     NULL},
    {"hold_sigma", I, F(hold_sigma), 1, 0, 1, PM_RANGE_CLOSED, "",
     "1: in phase 3, sigma is no longer updated once population control is off",
     "ours; differs from 001, which updates sigma at every iteration (0)", NULL},
    {"max_memory_gb", D, F(max_memory_gb), 0, 0, 1e6, PM_RANGE_CLOSED, "GB",
     "memory cap of the particle system, checked before the run (estimated count) and before "
     "its arrays grow (0: the physical memory)",
     "ours", NULL},
    {"hungry_curves", I, F(hungry_curves), 0, 0, 1, PM_RANGE_CLOSED, "",
     "1: a curve particle below half the split threshold keeps population control on, like a "
     "face particle (0: faces only; curves are grown by halving their gaps)",
     "ours (001 has no hungry rule: the end of a phase is ours, see psys_phases.c)", NULL},
    {"hungry_tol", D, F(hungry_tol), 1e-4, 0, 1, PM_RANGE_CLOSED, "",
     "the particle count has settled while at most this share of the particles (rounded down) "
     "is hungry (0: only when none is; below 10^4 particles 1e-4 allows none either)",
     "ours (001 has no hungry rule; 0 is the rule of before)", NULL},
    {"colour_mend", B, F(colour_mend), 1, 0, 1, PM_RANGE_CLOSED, "",
     "1: when the sweep's kept colouring has a few conflicts, only the particles in them get new "
     "colours (0: every particle is coloured again)",
     "ours (psys_move.c; 001 updates one particle after the other)", NULL},
    {"max_iter", I, F(max_iter), 1500, 1, 10000000, PM_RANGE_CLOSED, "iterations",
     "iteration cap of each phase", "ours", NULL},
    {"edge_per_sigma", D, F(edge_per_sigma), 0.66, 0.05, 2, PM_RANGE_CLOSED, "",
     "mean edge length / sigma of the converged packing (a given size d gives sigma = "
     "d / edge_per_sigma); calibrated on uniform fields",
     "001 eq. 6 (beta = 0.577) and our calibration", NULL},
    {"frame_every", I, F(frame_every), 10, 1, 10000000, PM_RANGE_CLOSED, "iterations",
     "--frames: a snapshot every this many iterations (and at the end of each phase)", "ours",
     NULL},
    {"affine", B, F(affine), 1, 0, 1, PM_RANGE_CLOSED, "",
     "connection: affine scaling of each face's parameter space", "001 eq. 16", NULL},
    {"metric_flips", B, F(metric_flips), 1, 0, 1, PM_RANGE_CLOSED, "",
     "connection: flip each face's parameter-space triangulation towards the Delaunay criterion "
     "of the surface's local metric (0: eq. 16's one affine map per face alone)",
     "ours (connect.c)", NULL},
    {"drop_crossed", B, F(drop_crossed), 1, 0, 1, PM_RANGE_CLOSED, "",
     "connection: drop the face nodes that lie beyond a boundary segment in 3D but inside it in "
     "(u, v) -- a pcurve off its curve, a chord sagging inside a coarse arc (0: keep every node, "
     "as the paper does)",
     "ours (connect.c, step 1b)", NULL},
    {"flips", B, F(flips), 1, 0, 1, PM_RANGE_CLOSED, "",
     "connection: flip edges towards empty diametric balls", "001 sec. 4.3", NULL},
    {"smooth", I, F(smooth), 4, 0, 100, PM_RANGE_CLOSED, "sweeps",
     "connection: sweeps of smart Laplacian smoothing of each face's interior nodes after the "
     "flips, each move kept only when its ring's R/l_min improves (0: the nodes as placed)",
     "ours (connect/face_smooth.h); differs from 001 sec. 4.3 (0)", NULL},
    {"needle_moves", B, F(needle_moves), 1, 0, 1, PM_RANGE_CLOSED, "",
     "connection: the smoothing first tries to move a face node with an angle below 10 degrees in "
     "its ring towards the edge opposite that angle, then the Laplacian move (a face node far "
     "above curve nodes spaced finer than the face's; 0: Laplacian moves only)",
     "ours (connect/face_smooth.h); differs from 001 sec. 4.3 (0)", NULL},
    {"tet_radius_edge", D, F(tet_radius_edge), 1.5, 1, 100, PM_RANGE_LO_OPEN, "",
     "--volume: TetGen's radius-edge quality bound (-q)", "001 sec. 4.4", NULL},
};

const pm_param_table psys_param_table = {"psys", desc, (int)(sizeof desc / sizeof desc[0])};

void psys_params_init(psys_params *p) { pm_params_defaults(&psys_param_table, p); }

pm_status psys_params_check(const psys_params *p, pm_error *err) {
  pm_status s = pm_params_check(&psys_param_table, p, err);
  if (s) return s;
  if (!(p->lambda_min <= p->lambda_init && p->lambda_init <= p->lambda_max))
    return pm_error_setf(err, PM_ERR_ARG,
                         "psys: need lambda_min <= lambda_init <= lambda_max, got %g, %g, %g",
                         p->lambda_min, p->lambda_init, p->lambda_max);
  if (p->lambda_max_faces > 0 && !(p->lambda_init <= p->lambda_max_faces))
    return pm_error_setf(err, PM_ERR_ARG, "psys: need lambda_init <= lambda_max_faces, got %g and %g",
                         p->lambda_init, p->lambda_max_faces);
  if (!(p->split_ratio < p->delete_ratio))
    return pm_error_setf(err, PM_ERR_ARG, "psys: need split_ratio < delete_ratio, got %g and %g",
                         p->split_ratio, p->delete_ratio);
  if (p->kappa_min > 0 && p->kappa_max > 0 && !(p->kappa_min < p->kappa_max))
    return pm_error_setf(err, PM_ERR_ARG, "psys: need kappa_min < kappa_max, got %g and %g",
                         p->kappa_min, p->kappa_max);
  return PM_OK;
}
