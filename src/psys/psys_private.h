/* The internal interface of the particle system (papers/001): the particle arrays, the pieces of
 * one iteration and the phase driver. psys_run.c builds the method from them; the tests call them
 * one by one (energy against finite differences, lattices, splits and deletes, the Lipschitz
 * closure, the inferred field on a sphere and on a thin flange).
 *
 * One iteration (psys_iterate) is, in this order:
 *   1. psys_sigma_update: every free particle's sigma from the inferred field (eq. 11-15,
 *      Algorithm 2) or from the given size field;
 *   2. psys_move_pass: Algorithm 1, every movable particle one step down its energy;
 *   3. psys_population_pass: splits and deletes (eq. 3-5), sequential in index order.
 *
 * Determinism. Step 1 is a Jacobi iteration: every particle's new sigma is computed from the same
 * snapshot of all particles, then the Lipschitz closure runs in one thread. Step 2 is a
 * Gauss-Seidel sweep over colour classes fixed in index order (psys_move.c): the particles of a
 * colour step in parallel but never see each other, and each colour sees the colours before it.
 * Sums are formed per particle over neighbours sorted by index, and totals are summed in index
 * order after the parallel loops. Step 3 runs in one thread in index order, and every random
 * number comes from a stream seeded by (seed, particle serial number, iteration), never from a
 * shared generator. So a run gives the same particles, to the bit, with any number of
 * threads.
 */
#ifndef PSYS_PRIVATE_H
#define PSYS_PRIVATE_H

#include <stdint.h>

#include "common/sizing/grid.h"
#include "common/sizing/sizing_features.h"
#include "psys/psys.h"

#ifdef __cplusplus
extern "C" {
#endif

/* papers/001 eq. 6: the ideal lattice distance over sigma, 0.5 / cos(pi / 6) = 1 / sqrt(3). */
#define PSYS_BETA 0.57735026918962576

/* ---- energy (psys_energy.c) ------------------------------------------------------------ */

/* eq. 1: E(r) = sigma [cot(r/sigma pi/2) + r/sigma pi/2 - pi/2] for 0 < r < sigma, 0 beyond. */
double psys_pair_energy(double r, double sigma);

/* eq. 2: dE/dr = pi/2 [1 - sin^-2(r/sigma pi/2)] for 0 < r < sigma (negative: repulsive),
 * 0 beyond. */
double psys_pair_denergy(double r, double sigma);

/* d2E/dr2, the derivative of eq. 2: pi^2 / (2 sigma) cos / sin^3 (x = r/sigma pi/2), > 0 inside
 * the ball, 0 beyond. */
double psys_pair_d2energy(double r, double sigma);

/* eq. 6: E_ideal = sigma 6 E(beta) with E the energy of unit sigma. */
double psys_ideal_energy(double sigma);

/* ---- time per step (the time_s.psys.* keys of --stats) ------------------------------------ */

/* The steps of an iteration whose wall time is kept, per phase. Where one parallel loop does the
 * work of several steps, its wall time is split between them in proportion to the time each
 * took on the threads (psys_clock_split). */
typedef enum psys_step {
  PSYS_T_NEIGHBOURS = 0, /* neighbour search, upkeep of the neighbour structures */
  PSYS_T_COLOURING,      /* the colouring's check and, when it fails, the colouring again */
  PSYS_T_ENERGY,         /* E_i, its gradient and Hessian at the particles (eq. 1-2, 8) */
  PSYS_T_STEP,           /* the tangent Newton step, the energy check of trial points, the
                            boundary-distance rule (Algorithm 1) */
  PSYS_T_SURFACE,        /* parameter steps (eq. 7, 9-10), surface and curve evaluation */
  PSYS_T_CURVATURE,      /* sizing: the curvature bound (section 3.1) */
  PSYS_T_GAP,            /* sizing: the gap size */
  PSYS_T_LIPSCHITZ,      /* sizing: the Lipschitz closure (eq. 14-15) and sigma's commit */
  PSYS_T_FIELD,          /* sizing: a given size field's values (instead of the three above) */
  PSYS_T_POPULATION,     /* splits, deletes, refills (eq. 3-6) */
  PSYS_T_SEEDING,        /* seeding at the start of a phase */
  PSYS_T_COUNT
} psys_step;

/* The key of each step under time_s.psys (and time_s.psys.phaseK). */
extern const char *const psys_step_names[PSYS_T_COUNT];

/* ---- the system (psys_system.c) --------------------------------------------------------- */

/* A growable sorted list of particle indices (a neighbour or gap list, psys_nbr.c). */
typedef struct psys_list {
  int32_t n, cap;
  int32_t *ids; /* [cap] owned, increasing */
} psys_list;

/* One kind of list of the neighbour structure (psys_nbr.c): for every particle that holds one,
 * the particles j with |x0_i - x0_j| < f max(s0_i, s0_j) that the kind's relation admits, where
 * x0_i and s0_i are particle i's point and sigma when its list was made. */
typedef struct psys_vl {
  double f;           /* list radius over s0 */
  double move, grow;  /* budget: a list is made again once its particle moved move s0 from x0
                         or its sigma rose above (1 + grow) s0 */
  int on;             /* the lists are kept */
  int32_t n;          /* particles 0 .. n-1 are listed; later ones are new */
  pm_grid *grid;      /* (x0_i, f s0_i) of the listed particles, id = index */
  double *x0;         /* [3 cap] */
  double *s0;         /* [cap] */
  psys_list *l;       /* [cap] the lists (empty for a particle that holds none) */
  uint8_t *mark;      /* [cap] scratch */
  int64_t renewed;    /* lists made again one by one, all updates */
  int64_t rebuilds;   /* updates that made every list again */
} psys_vl;

/* The neighbour structure: the neighbour lists (every particle) and the gap lists (the particles
 * the gap size applies to), kept valid as particles move, sigma changes and the population
 * changes, by making again only the lists of the particles that left their budget. */
typedef struct psys_nbr {
  psys_vl nb, gp;
  int rebuild;        /* 1: rebuild every list at the next update (a phase changed) */
  int held;           /* 1: sigma is held (phase 3 after population control, hold_sigma): the
                         neighbour lists need no growth budget and the gap lists are not kept */
  int always;         /* 1: rebuild every list at every update (tests: results must not change) */
  int never_hold;     /* 1: psys_nbr_hold does nothing (tests: results must not change) */
} psys_nbr;

typedef struct psys_sys {
  const pm_model *model;   /* borrowed */
  psys_params p;           /* copy */
  const pm_sizing *size;   /* borrowed; NULL: the inferred field */
  uint64_t seed;
  int threads;
  int64_t max_particles;   /* PM_ERR_LIMIT beyond */
  double max_bytes;        /* the memory cap (max_memory_gb, or the physical memory) */
  double kappa_min, kappa_max; /* resolved (the 0 defaults made absolute) */
  double sigma_min, sigma_max; /* eq. 12-13 */
  pm_feature_size *width;  /* feature_width: the narrow places of the model (PM_FEATURE_WIDTH,
                              grade L / s_tau); NULL when off or with a given field */

  /* particles, index 0 .. n-1; arrays of capacity cap */
  int32_t n, cap;
  int8_t *dim;             /* cell dimension 0, 1, 2 */
  int32_t *cell;           /* cell index in its dimension */
  double *par;             /* [2 cap] t or (u, v) */
  double *xyz;             /* [3 cap] */
  double *xs;              /* [4 cap] x, y, z, sigma again, packed for the loops over
                              neighbours (one cache line per neighbour); written with xyz and
                              sigma by psys_set_point / psys_set_sigma and the creation code */
  double *deriv;           /* [6 cap] first derivatives: C' (curves), Su and Sv (faces), at fxyz */
  double *fxyz;            /* [3 cap] where deriv was evaluated (frame_tol, psys_move.c) */
  double *sigma;           /* ball radius sigma_i */
  double *lambda;          /* Algorithm 1's step scale lambda_i */
  double *energy;          /* E_i at the last move pass */
  double *force;           /* [3 cap] the descent direction -dE_i/dx_i at the last move pass */
  double *sig_curv;        /* the geometry's bound psys_geometry_sigma: the curvature bound
                              clamp(1 / (s_kappa kappa), sigma_min, sigma_max), and the width of
                              narrow places (feature_width) */
  double *kxyz;            /* [3 cap] where sig_curv was evaluated */
  double *bdist;           /* phase 3: a face particle's distance to its face's boundary
                              polylines after the last move pass (INFINITY when far) */
  uint64_t *serial;        /* creation number: names the particle's random streams */
  int64_t *grace;          /* not deleted before this iteration (psys_population.c) */
  uint8_t *fixed;          /* 1: does not move (vertices; curves and vertices in phase 3) */
  uint8_t *frozen;         /* 1: sigma is not updated (curves and vertices in phase 3) */
  uint64_t next_serial;
  uint64_t ordered_serial; /* next_serial at the last psys_reorder */
  int unsized;             /* 1: a particle took its curvature bound for sigma, not updated yet */

  psys_nbr nbr;            /* the neighbour structure */

  /* cell adjacency: cells of dimension 0..2 numbered key = koff[dim] + index */
  int32_t koff[3];
  int32_t nkey;
  int32_t *clo_off, *clo;  /* closure of each cell (itself, its boundary, embedded cells and
                              their closures), sorted keys */
  int32_t *vert_off, *vert; /* the vertices of that closure, sorted vertex indices */
  double *corner;          /* [vertices] corner-ball radius (section 4.2), 0 before phase 2 */
  double *extent;          /* [curves + faces] arc length of a curve, 3D box diagonal of a face */
  uint8_t *slow_face;      /* [faces] 1 when evaluated by gmsh (batched) */

  /* phase 3: the frozen particles of each curve in order, end vertices included (the
   * polylines whose distance measures a face's width, psys_sizing.c) */
  int32_t nfrozen;         /* particles 0 .. nfrozen-1 are the frozen ones */
  int32_t *chain_off;      /* [curves + 1] */
  int32_t *chain;          /* particle indices, chain c at chain_off[c] .. chain_off[c+1] */
  int32_t *chain_pos;      /* [nfrozen] a curve particle's place in its chain, else -1 */
  int32_t *vpart;          /* [vertices] the particle on each vertex, -1 when none */
  uint8_t *face_on;        /* [faces] the faces phase 3 optimizes */

  int phase;               /* 1, 2, 3 */
  int gap_curves;          /* sigma_tau on vertex and curve particles (phase 2 on) */
  int gap_faces;           /* sigma_tau on face particles (phase 3) */
  int64_t iter;            /* iterations run so far, all phases (random streams) */
  int32_t splits_total, deletes_total;
  double tstep[3][PSYS_T_COUNT]; /* wall seconds per phase and step (psys_step) */

  /* scratch of the sigma update */
  double *target;          /* [cap] the bounds of eq. 11 before the Lipschitz closure */
  double *key;             /* [cap] the closed field */

  /* the colouring of the move pass (psys_move.c), kept from pass to pass while it holds */
  int32_t *colour;         /* [colour_cap] colour of particle i, -1 when fixed */
  int32_t *colour_order;   /* [colour_cap] the movable particles colour by colour */
  int32_t *colour_start;   /* [colour_cap + 1] colour c at colour_start[c] .. [c + 1] - 1 */
  double *colour_x0;       /* [4 colour_cap] each particle's point and sigma when coloured */
  uint8_t *colour_mark;    /* [colour_cap] scratch: in a conflict found by the pass's check */
  uint8_t *colour_mended;  /* [colour_cap] coloured alone since the last colouring (colour_mend) */
  int32_t colour_cap;
  int32_t colour_n;        /* particles coloured; 0: no colouring */
  int32_t ncolour;
  int32_t colour_nmended;  /* particles with colour_mended set */
  int64_t recolours;       /* move passes that coloured the particles again */
  int64_t colour_mends;    /* particles coloured alone (colour_mend) */
} psys_sys;

/* A system on model m with parameters p (copied, must have passed psys_params_check), a given
 * size field (borrowed, NULL: infer), seed, threads (>= 1) and a particle cap (> 0). */
pm_status psys_sys_create(const pm_model *m, const psys_params *p, const pm_sizing *size,
                          uint64_t seed, int threads, int64_t max_particles, psys_sys **out,
                          pm_error *err);
void psys_sys_destroy(psys_sys *s);

/* The memory a particle takes at most, all structures counted (arrays of the system, neighbour
 * and gap lists, the lists' grids, the scratch of an iteration), with room for the doubling of
 * the arrays: measured at 1.7 kB per particle on case:sphere with 95535 particles
 * (bench_psys throughput, peak resident memory less the program's before the run), rounded up. */
#define PSYS_BYTES_PER_PARTICLE 2048.0

/* Estimated particles on the curves and the faces for the given field (for the inferred field:
 * at its largest sigma, a lower bound of what it will need). */
void psys_estimate_count(const psys_sys *s, double *curves, double *faces);

/* Before any particle is placed: PM_ERR_LIMIT when the estimate exceeds the particle cap or the
 * memory cap, naming the cap and the size that would fit. */
pm_status psys_check_caps(const psys_sys *s, pm_error *err);

/* Add a particle on cell (dim, cell) at par (curves: t, faces: (u, v); vertices: ignored) with
 * radius sigma (<= 0: the field's value there). Evaluates its point and derivatives, its
 * curvature bound, and files it in the grid. *index (may be NULL) receives its index. */
pm_status psys_add(psys_sys *s, int dim, int32_t cell, const double *par, double sigma,
                   int32_t *index, pm_error *err);

/* Add a split child of particle `parent` on its cell at par, with the parent's sigma and its
 * curvature bound (refreshed once the child has moved). */
pm_status psys_add_child(psys_sys *s, int32_t parent, const double *par, int32_t *index,
                         pm_error *err);

/* Remove the particles flagged in dead[n] (order of the others kept; their lists follow). */
pm_status psys_compact(psys_sys *s, const uint8_t *dead, pm_error *err);

/* Renumber the movable particles (all in phases 1-2, those after the frozen ones in phase 3) in
 * the Morton order of their points, so that particles near in space are near in memory: the
 * loops over neighbours read one cache line per neighbour, which for particles numbered in the
 * order splits created them is a miss nearly every time. A permutation of the same particles:
 * serial numbers, hence random streams, go with them, and so do the neighbour lists. */
pm_status psys_reorder(psys_sys *s, pm_error *err);

/* Set particle i's sigma. */
static inline void psys_set_sigma(psys_sys *s, int32_t i, double sigma) {
  s->sigma[i] = sigma;
  s->xs[4 * i + 3] = sigma;
}

/* Set particle i's point. */
static inline void psys_set_xyz(psys_sys *s, int32_t i, const double x[3]) {
  for (int k = 0; k < 3; ++k) s->xyz[3 * i + k] = x[k], s->xs[4 * i + k] = x[k];
}

/* Squared distance between two points, computed the one way every relation of the system uses
 * (so that a pair tested from either side, or from a list and from a grid, gives one answer). */
static inline double psys_d2(const double *a, const double *b) {
  double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
  return dx * dx + dy * dy + dz * dz;
}

/* ---- the neighbour structure (psys_nbr.c) ----------------------------------------------- */

/* The lists of particle i. */
static inline const psys_list *psys_nb(const psys_sys *s, int32_t i) { return &s->nbr.nb.l[i]; }
static inline const psys_list *psys_gp(const psys_sys *s, int32_t i) { return &s->nbr.gp.l[i]; }

/* q of psys_nbr.c: the neighbour list of i holds every particle j with |x_i - x_j| < q
 * max(sigma_i, sigma_j) (the largest reach of the lists' uses). */
double psys_nbr_reach(const psys_params *p);

pm_status psys_nbr_init(psys_sys *s, pm_error *err);
void psys_nbr_free(psys_sys *s);
/* Room for cap particles. */
pm_status psys_nbr_reserve(psys_sys *s, int32_t cap, pm_error *err);
/* Make every list valid for the current particles, points and sigma: lists of new particles,
 * of particles that left their budget, and the entries of the others that these change. */
pm_status psys_nbr_update(psys_sys *s, pm_error *err);
/* After psys_compact: particle i became map[i] (-1: gone), n_old particles before. */
pm_status psys_nbr_compact(psys_sys *s, const int32_t *map, int32_t n_old, pm_error *err);
/* After psys_reorder: the particle at lo + k was perm[k] (k < m), the others kept their index. */
pm_status psys_nbr_permute(psys_sys *s, int32_t lo, int32_t m, const int32_t *perm,
                           pm_error *err);
/* A phase changed (the gap relation, the radii): every list is made again at the next update. */
void psys_nbr_reset(psys_sys *s);
/* Sigma is held from now on (psys_phases.c, hold_sigma) until the next phase or sigma update:
 * the neighbour lists are made again at the next update without the budget for sigma's growth,
 * and the gap lists, which only the sigma update reads, are dropped. */
void psys_nbr_hold(psys_sys *s);
/* Whether the lists hold every pair they must (PM_ERR_INTERNAL naming the first missing or
 * extra pair): against a brute-force scan over all pairs, O(n^2), for tests. */
pm_status psys_nbr_check(const psys_sys *s, pm_error *err);
/* Whether the gap applies to particle i now (it then has a gp list). */
int psys_gap_active(const psys_sys *s, int32_t i);
/* Whether particle j may bound the gap of particle i (cells only; see psys_sizing.c). */
int psys_gap_pair(const psys_sys *s, int32_t i, int32_t j);

/* Cell keys and relations. */
static inline int32_t psys_key(const psys_sys *s, int dim, int32_t cell) {
  return s->koff[dim] + cell;
}
/* 1 when one cell lies in the other's closure (papers/001: "adjacent if one is on the boundary
 * of the other"; embedded cells count as on the boundary). */
int psys_adjacent(const psys_sys *s, int32_t ka, int32_t kb);
/* 1 when the closures of the two cells share a vertex. */
int psys_touch(const psys_sys *s, int32_t ka, int32_t kb);

/* Whether a particle on the cell of key ki feels particle j (psys_energy.c explains phase 1). */
static inline int psys_interacts(const psys_sys *s, int32_t ki, int32_t j) {
  if (s->phase != 1) return 1;
  int32_t kj = psys_key(s, s->dim[j], s->cell[j]);
  return kj == ki || psys_adjacent(s, ki, kj);
}

/* Add wall seconds to step k of the current phase. */
static inline void psys_clock_add(psys_sys *s, psys_step k, double seconds) {
  s->tstep[(s->phase >= 1 && s->phase <= 3 ? s->phase : 1) - 1][k] += seconds;
}

/* Split the wall time `wall` of a parallel loop between the m steps ks[] in proportion to the
 * seconds cpu[] each took summed over the threads. */
void psys_clock_split(psys_sys *s, double wall, int m, const psys_step *ks, const double *cpu);

/* The random number in [0, 1) that particle i draws for `purpose` at the current iteration. */
double psys_random(const psys_sys *s, int32_t i, int purpose);

/* ---- the sizing field (psys_sizing.c) --------------------------------------------------- */

/* The geometry's bound at a point of a cell: the curvature bound clamp(1 / (s_kappa kappa),
 * sigma_min, sigma_max), with kappa the largest principal curvature on a face, the larger of the
 * curve's curvature and its faces' largest principal curvatures on a curve, the largest of those
 * over its curves at a vertex (section 3.1, Curvature); with feature_width, the lesser of that
 * and s_tau x the width of the model's narrow places there (s->width), which may be below
 * sigma_min. */
double psys_geometry_sigma(const psys_sys *s, int dim, int32_t cell, const double *par,
                           const double xyz[3]);

/* The gap distance of particle i (before s_tau) from the particles within R_i = sigma_grow
 * sigma_i / s_tau of it (psys_sizing.c for the rules), from its gap list; INFINITY when none
 * applies within R_i. */
double psys_gap_distance(const psys_sys *s, int32_t i);

/* 1 when cell kb lies in the closure of cell ka. */
int psys_in_closure(const psys_sys *s, int32_t ka, int32_t kb);

/* Phase 3: the distance from point x to the boundary polylines (chains) of the face of particle
 * i near the frozen particles among ids[m] (sorted) within max((1 + step_max) sigma_i, sigma_j)
 * of particle i; INFINITY when none is near (or i is not on a face, or there are no chains). */
double psys_boundary_distance(const psys_sys *s, int32_t i, const double x[3], const int32_t *ids,
                              int32_t m);

/* Face particles keep this fraction of their sigma from their face's boundary polylines
 * (psys_move.c, psys_population.c). */
#define PSYS_BOUNDARY_CLEARANCE 0.15

/* The curves' chains of the current particles: curve c's particles by increasing t (ties by
 * index) between the particles of its start and end vertices (where they have one), in
 * chain[off[c] .. off[c+1]); vpart[v] is vertex v's particle or -1. Arrays malloc'd, the
 * caller's to free. */
pm_status psys_curve_chains(const psys_sys *s, int32_t **off, int32_t **chain, int32_t **vpart,
                            pm_error *err);

/* Phase 3: build the curve chains (above) from the frozen particles. */
pm_status psys_build_chains(psys_sys *s, pm_error *err);

/* Step 1 of an iteration: every free particle's sigma (eq. 11 with the Lipschitz closure of
 * eq. 15 over the neighbour pairs, or d / edge_per_sigma of the given field). */
pm_status psys_sigma_update(psys_sys *s, pm_error *err);

/* The sigma that psys_sigma_update would set, computed from scratch: gap candidates and
 * Lipschitz pairs from a fresh grid of the particles, the closure by Dijkstra over every
 * particle. out[n]. The reference the incremental update is tested against. */
pm_status psys_sigma_reference(const psys_sys *s, double *out, pm_error *err);

/* ---- movement (psys_move.c) ------------------------------------------------------------- */

typedef struct psys_move_info {
  double energy;     /* sum of E_i over all particles after the pass */
  double mean_move;  /* mean world-space displacement over movable particles */
  double max_move;
  double mean_rel;   /* mean displacement / sigma over movable particles */
  int32_t movable;   /* particles allowed to move */
  int32_t colours;   /* colour classes of the sweep */
} psys_move_info;

/* Energy of a particle of radius si on the cell of key ki at point x against the current
 * positions of the candidates ids[m] (sorted; `self` skipped, -1 for none): the pairs with
 * |x - x_j| < max(si, sigma_j) (eq. 1 with sigma_ij = max); grad (may be NULL) receives
 * dE/dx; hess (may be NULL) the Hessian as xx, xy, xz, yy, yz, zz and, in hess[6], the sum of the
 * pairs' d2E/dr2 (psys_move.c's Newton step). */
double psys_energy_at(const psys_sys *s, int32_t self, int32_t ki, double si, const double x[3],
                      const int32_t *ids, int32_t m, double grad[3], double hess[7]);

/* The same for particle i itself (its radius and cell) at x: its own point or a trial point. */
static inline double psys_particle_energy(const psys_sys *s, int32_t i, const double x[3],
                                          const int32_t *ids, int32_t m, double grad[3],
                                          double hess[7]) {
  return psys_energy_at(s, i, s->koff[s->dim[i]] + s->cell[i], s->sigma[i], x, ids, m, grad,
                        hess);
}

/* Step 2: Algorithm 1 for every movable particle (a coloured Gauss-Seidel sweep, see above);
 * energies and forces of every particle are refreshed. */
pm_status psys_move_pass(psys_sys *s, psys_move_info *info, pm_error *err);

/* 1 when the kept colouring (psys_move.c) surely has no two movable particles of one colour in
 * conflict, judged from each particle's move and sigma growth since it was coloured; 0 when
 * that cannot be told without checking pairs. Requires a colouring of the current count. */
int psys_colouring_surely_holds(const psys_sys *s);

/* ---- population (psys_population.c) ----------------------------------------------------- */

/* Step 3: splits and deletes of eq. 3-5 with the annealing weight a in (0, 1]: a particle with
 * E* = E_i (1 + a eps), eps uniform in [0, 1), splits when E* < split_ratio a E_ideal and is
 * deleted when E* > delete_ratio E_ideal / a. */
pm_status psys_population_pass(psys_sys *s, double a, int32_t *splits, int32_t *deletes,
                               pm_error *err);

/* The movable particles that eq. 4 splits whatever their eps: E_i below half the split threshold
 * (a front of particles still growing into an empty stretch of its cell); face particles only
 * unless hungry_curves (psys_phases.c). */
int32_t psys_hungry_count(const psys_sys *s);

/* ---- phases (psys_phases.c) ------------------------------------------------------------- */

/* Whether the particle count has settled (psys_phases.c): n particles now, `then` POP_WINDOW
 * iterations ago (-1: not that many iterations yet), `hungry` of them hungry; it moved by at most
 * max(2, pop_tol n) and at most floor(hungry_tol n) are hungry. */
int psys_count_settled(int32_t n, int32_t then, int32_t hungry, double pop_tol, double hungry_tol);

typedef struct psys_phase_report {
  int64_t iterations;
  double seconds;
  int converged;     /* 1: converged, 0: stopped by the iteration cap */
  int32_t particles; /* at the end */
} psys_phase_report;

typedef struct psys_observer {
  const pm_run_observer *run; /* borrowed, may be NULL; psys_optimize sends the trace columns */
} psys_observer;

/* Seed phase 1: a particle on every vertex that bounds or lies in something, and one at the
 * middle of every non-degenerate curve. */
pm_status psys_seed_curves(psys_sys *s, pm_error *err);

/* Seed phase 3 on face f: k random points of its trimmed region. */
pm_status psys_seed_face(psys_sys *s, int32_t f, int k, pm_error *err);

/* Bootstrap seeding of face f (psys_seed.c): the (u, v) and sigma of the particles an advancing
 * front in the face's field places, from the frozen particles of its boundary; with a hint (may
 * be NULL), sigma at most hint sigma + L r from the hint's points. Reads the
 * system only (faces may be seeded in parallel). out_uv[2 count], out_sigma[count] malloc'd,
 * the caller's to free (NULL when count is 0). */
typedef struct psys_hint {
  pm_grid *grid;        /* the points, id = index */
  const double *xyz;    /* [3 n] */
  const double *sigma;  /* [n] */
} psys_hint;
pm_status psys_seed_front(const psys_sys *s, int32_t f, const psys_hint *hint, double **out_uv,
                          double **out_sigma, int32_t *count, pm_error *err);

/* Run one phase (1, 2 or 3: sets the flags, fixes and freezes what the phase holds still) until
 * it converges or reaches the cap. Phase 3 seeds only the faces with faces[f] != 0 (NULL: all). */
/* The trace's last row (psys_phases.c, trace columns): the mesh of `particles` particles has
 * `nodes` nodes after the connection; `iterations` of the three phases in all. */
pm_status psys_trace_mesh(const psys_observer *obs, int64_t iterations, int32_t particles,
                          int32_t nodes, pm_error *err);

pm_status psys_run_phase(psys_sys *s, int phase, const uint8_t *faces, const psys_observer *obs,
                         psys_phase_report *rep, pm_error *err);

/* All three phases (phase 2 only with the inferred field). */
pm_status psys_optimize(psys_sys *s, const psys_observer *obs, psys_phase_report rep[3],
                        pm_error *err);

/* The particles as mesh nodes (classified on their cells), ready for pm_connect. */
pm_status psys_to_mesh(const psys_sys *s, pm_mesh **out, pm_error *err);

#ifdef __cplusplus
}
#endif

#endif /* PSYS_PRIVATE_H */
