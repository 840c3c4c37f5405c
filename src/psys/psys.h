/* psys: Bronson, Levine & Whitaker's particle system for adaptive, isotropic meshing of CAD
 * models (papers/001), as the `--method psys` mesher.
 *
 * Particles live on the cells of a model (vertices, curves, faces), carry a ball radius sigma_i
 * and minimize the modified cotangent energy of papers/001 eq. 1-2 in world space while moving
 * in the parameter space of their cell (eq. 7-10, through the shared geom.h displacement rule).
 * Splits and deletes (eq. 3-6) control the density; sigma is either inferred while the particles
 * move (curvature, gap size and a Lipschitz bound, eq. 11-15, Algorithm 2) or follows a given
 * edge-length field. The optimization runs in the three phases of section 4.1 (vertices and
 * curves; the same with the gap size outside corner balls; faces with the curves fixed), and the
 * particles are connected by the shared pm_connect (eq. 16 affine scaling, section 4.3 flips,
 * TetGen quality refinement for volumes, section 4.4).
 *
 * Files: psys_params.c (the parameter table), psys_energy.c (eq. 1-2, 6, 8), psys_system.c
 * (particles, grids, cell adjacency), psys_sizing.c (eq. 11-15, Algorithm 2), psys_move.c
 * (Algorithm 1), psys_population.c (eq. 3-5), psys_phases.c (section 4.1-4.2), psys_run.c (the
 * method and psys_infer_size). psys_private.h holds the internal interface the tests use.
 */
#ifndef PSYS_H
#define PSYS_H

#include <packmesh/packmesh.h>

#include <stdint.h>

#include "common/geom/geom.h"
#include "common/method/method.h"
#include "common/base/params.h"
#include "common/sizing/sizing.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The parameters of the method. Every field is described once, with its default, range, unit
 * and source, in the table of psys_params.c (psys_param_table): `--set NAME=VALUE` and `--help`
 * are generated from it. Lengths are model units. */
typedef struct psys_params {
  /* ---- inferred sizing field (papers/001 section 3.1, eq. 11-15) ---- */
  double s_kappa;       /* curvature scaling s_kappa: sigma_kappa = 1 / (s_kappa kappa); 2 */
  double s_tau;         /* gap-size scaling s_tau: sigma_tau = s_tau x gap; 0.5 */
  double lipschitz;     /* Lipschitz constant L of eq. 14-15 ("L" on the command line); 0.3 */
  double kappa_min;     /* smallest curvature considered (straight edges, planes), 1/length;
                           sigma_max = 1 / (s_kappa kappa_min) (eq. 13). 0: 5 / model diagonal */
  double kappa_max;     /* largest curvature considered, 1/length; sigma_min = 1 / (s_kappa
                           kappa_max) (eq. 12). 0: 500 / model diagonal */
  double sigma_grow;    /* largest factor by which a particle's sigma may rise in one update;
                           1.5 (the paper is silent; bounds the gap search radius) */
  double kappa_refresh; /* re-evaluate a particle's curvature after it moved this many sigma;
                           0.25 */
  int feature_width;    /* 1: sigma <= s_tau x the width of the model's narrow places where the
                           gap of the paper does not look, wedges and cusps between curves that
                           meet at a vertex included (sizing_features.h), down to the shared
                           feature floor, below sigma_min; 0: the paper's field; 1 (ours) */
  /* ---- energy, movement (eq. 1-2, 7-10, Algorithm 1) ---- */
  double lambda_init;   /* initial step scale lambda_i of a new particle (step = lambda x the
                           Newton step of E_i in the cell's tangent space); 1 */
  double lambda_min;    /* Algorithm 1's lambda_min; 1e-4 */
  double lambda_max;    /* cap of lambda_i; 1 */
  double lambda_max_faces; /* phase 3's cap of lambda_i (over-relaxation above 1); 0: lambda_max; 1.8 */
  double lambda_grow;   /* lambda_i is multiplied by this after an accepted step (the paper
                           only divides by 10); 2 */
  int pair_sigma;       /* sigma_ij of a pair: 0 max(sigma_i, sigma_j) (eq. 1), 1 their mean
                           (our default: psys_energy.c); 1 */
  double step_max;      /* longest world-space step, in units of sigma_i; 0.5 */
  double frame_tol;     /* faces evaluated by gmsh: a particle keeps the surface derivatives of
                           its last frame until it has moved this many sigma from it; 0.05
                           (0: new derivatives at every trial point, as eq. 7-9) */
  /* ---- population (eq. 3-6) ---- */
  double split_ratio;   /* split when E* < split_ratio E_ideal (eq. 4); 0.35 */
  double delete_ratio;  /* delete when E* > delete_ratio E_ideal (eq. 5); 1.75 */
  double ring_curve;    /* one-ring count of E_ideal for curve particles: E_ideal = sigma
                           ring_curve E(beta) (eq. 6 has 6, the hexagonal one-ring of a face;
                           a curve's lattice has two neighbours; 0.7 gives the curves the
                           faces' spacing, see psys_population.c); 0.7 */
  int delete_grace;     /* particles around a split or delete are not deleted for this many
                           iterations; 3 */
  int seeds_per_face;   /* k random particles per face at the start of phase 3; 8 */
  int seeding;          /* phase 3's seeds: 0 k random per face (the paper), 1 a front filling
                           each face in its field from its boundary (psys_seed.c); 1 */
  /* ---- convergence and annealing (section 3, 4.1) ---- */
  double pop_tol;       /* annealing starts once the particle count moved by at most
                           max(2, pop_tol n) over the last 10 iterations; 0.005 */
  int anneal_after;     /* ... or after this many iterations of a phase; 150 */
  double anneal_rate;   /* per-iteration factor of the annealing weight a (bias amplitude and
                           threshold widening); 0.75 */
  double anneal_off;    /* population control stops when a falls below this; 0.02 */
  double move_tol;      /* a phase ends when population control is off and the mean move is
                           below this many sigma; 2e-3 */
  double move_tol_faces; /* phase 3's move_tol (the faces); 0: move_tol; 1.8e-3 */
  int max_iter;         /* iteration cap per phase; 1500 */
  int hold_sigma;       /* 1: phase 3 holds sigma once population control is off; 1 */
  int hungry_curves;    /* 1: hungry curve particles also keep population control on; 0 */
  double hungry_tol;    /* the count has settled with up to this share of the particles hungry
                           (rounded down); 0: only with none; 1e-4 */
  int colour_mend;      /* 1: a kept colouring with a few conflicts gives the particles in them
                           new colours alone (psys_move.c); 0: every particle is coloured again; 1 */
  double max_memory_gb; /* the particle system stops (PM_ERR_LIMIT) before its estimated memory
                           exceeds this many GB, checked before a run and before arrays grow;
                           0: the machine's physical memory */
  /* ---- output ---- */
  double edge_per_sigma; /* mean edge length over sigma of the final packing: the calibration
                            between a size field d (edge length) and sigma = d / edge_per_sigma;
                            0.66 (measured: mean edge / d = 1.009 .. 1.020 on uniform fields) */
  int frame_every;      /* --frames: a snapshot every this many iterations; 10 */
  int affine;           /* connection: affine scaling of eq. 16; on */
  int flips;            /* connection: diametric-ball edge flips of section 4.3; on */
  int metric_flips;     /* connection: parameter-space flips under the surface's local metric
                           (connect.c; our addition); on */
  int drop_crossed;     /* connection: face nodes beyond a boundary segment in 3D but inside it
                           in (u, v) dropped (connect.c, step 1b; our addition); on */
  int smooth;           /* connection: sweeps of interior-node smoothing per face
                           (face_smooth.h; our addition); 0 = the paper's nodes as placed; 4 */
  int needle_moves;     /* connection: the smoothing also moves a face node with an angle below
                           10 degrees in its ring towards the edge opposite it (face_smooth.h;
                           ours); 0 = Laplacian moves only, the meshes of before; 1 */
  double tet_radius_edge; /* --volume: TetGen radius-edge bound (-q); 1.5 */
} psys_params;

/* The parameter table (defaults, ranges, documentation). */
extern const pm_param_table psys_param_table;

/* Write the defaults into p. */
void psys_params_init(psys_params *p);

/* Check every field against its range (PM_ERR_ARG naming the field), and the pairs that must be
 * ordered (lambda_min <= lambda_init <= lambda_max, split_ratio < delete_ratio). */
pm_status psys_params_check(const psys_params *p, pm_error *err);

/* The method (name "psys"): pm_run_input.size NULL infers the field, else sigma follows the
 * given edge length d as sigma = d / edge_per_sigma. Reports to in->observer (when not NULL): times
 * "phase1", "phase2", "phase3", "connect"; numbers "psys.iterations.phase1..3", "psys.particles",
 * "psys.sigma_min", "psys.sigma_max", "psys.splits", "psys.deletes". */
extern const pm_method psys_method;

/* The method's run (psys_method.run) that also returns, when field is not NULL, the field the
 * particles' sigma describe: the sigma converted to an edge length with p->edge_per_sigma,
 * sampled (pm_sizing_sampled) on the nodes and triangles of the output mesh, each node taking the
 * sigma of the nearest particle. With the inferred field (in->size NULL) this is the field
 * psys_infer_size returns, so a benchmark can run the peers on it without running psys twice.
 * [out] field  free with pm_sizing_destroy; NULL on failure. */
pm_status psys_run_with_field(const pm_run_input *in, const psys_params *p, pm_run_output *out,
                              pm_sizing **field, pm_error *err);

/* The sizing inference alone, for `--size inferred` of other methods (the bubble mesher).
 * Runs the three phases of the particle system on model m with the inferred field (phases 1-3
 * of section 4.1), connects the particles into a surface triangle mesh and returns the field as
 * a sampled field (pm_sizing_sampled) on that mesh, whose node values are the particles' sigma
 * converted to an edge length with p->edge_per_sigma.
 * [in]  m        the model (borrowed; it must outlive nothing: the field copies what it needs)
 * [in]  p        parameters, NULL for the defaults
 * [in]  seed     fixes every random choice
 * [in]  threads  >= 1; the field does not depend on it
 * [out] out      the field (free with pm_sizing_destroy), NULL on failure.
 * Inside a volume the field is the sampled field's nearest-node fallback (sizing.h). */
pm_status psys_infer_size(const pm_model *m, const psys_params *p, uint64_t seed, int threads,
                          pm_sizing **out, pm_error *err);

#ifdef __cplusplus
}
#endif

#endif /* PSYS_H */
