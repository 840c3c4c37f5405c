/* Internal interface of the bubble method: the state of a run (the bubbles and their
 * neighbour lists) and the functions of each stage, one file per concern:
 *   bub_force.c       the inter-bubble force (003 eq. 10-11, 004 eq. 2.1) and its potential
 *   bub_state.c       the bubble arrays, the cell relations of 000 section 4.2.2, the grid
 *   bub_place.c       initial placement by hierarchical spatial subdivision (003 section 3.2,
 *                     000 section 4.1.1, 004 section 2.3)
 *   bub_volume.c      the volume phase: the surface mesh as the volumes' walls, the octree of
 *                     rhombohedra in volumes, the rule for a volume bubble's step
 *   bub_neighbors.c   the per-bubble neighbour lists (Verlet lists over the shared grid)
 *   bub_dynamics.c    the equation of motion, RK4 / RK2 with per-stage confinement
 *                     (003 eq. 12-15, 000 section 5.5, 004 section 2.2)
 *   bub_overlap.c     the overlap ratio (003 eq. 16, 000 section 3.1.3) and the layer of outside
 *                     bubbles (000 section 4.2.1)
 *   bub_population.c  adaptive population control (000 sections 4.2.3-4.2.5)
 *   bub_size.c        the default size rule
 *   bub_run.c         the run: relaxation rounds, stopping, trace, frames, connection
 * Tests include this header to drive the stages on hand-made configurations.
 */
#ifndef BUB_PRIVATE_H
#define BUB_PRIVATE_H

#include "bubble/bubble.h"
#include "common/sizing/grid.h"
#include "common/mesh/mesh.h"
#include "common/mesh/volume_inside.h"

#include <math.h>
#include <stdint.h>

/* What a bubble lives on. Bubbles are kept sorted by (kind, cell) outside population control,
 * so the bubbles of one kind, and of one cell, are contiguous. */
enum {
  BUB_KVERTEX = 0, /* on a vertex: fixed (000 section 4.2.2 a) */
  BUB_KCURVE = 1,  /* on a curve, parameter t */
  BUB_KFACE = 2,   /* on a face, parameters (u, v) */
  BUB_KVOLUME = 3, /* in a volume, free in 3D (bub_volume.c); no parameters */
  BUB_KOUT = 4     /* outside-layer bubble of face `cell`: overlap only (000 section 4.2.1) */
};

/* Per-bubble flags. */
enum {
  BUB_FDEAD = 1, /* removed during the current population control */
  BUB_FNEW = 2,  /* inserted during the current population control */
  BUB_FODD = 4,  /* next to an insertion or deletion: damped with zeta_odd for a round (004) */
  BUB_FDONE = 8, /* open bubble already given its insertion attempt in this control */
  BUB_FHOLD = 16 /* held where the lattice placed it (hold_rings, bub_lattice.c) */
};

/* ---- the force (bub_force.c) ---------------------------------------------------------------- */

/* Qi et al.'s normalized force f(lambda) = k0 (5/4 lambda^3 - 19/8 lambda^2 + 9/8) for
 * 0 <= lambda <= 1.5, 0 beyond (004 eq. 2.1). */
double bub_force_normalized(double k0, double lambda);

/* The force between two bubbles at distance l with stable distance l0 (003 eq. 10-11), positive
 * when repulsive: F(l) = l0 f(l / l0). In these units F(l0) = F(1.5 l0) = 0, F'(0) = 0 and
 * F'(l0) = -k0 exactly as 003 eq. 11 states them, so k0 is a spring constant in force per length
 * for every bubble size. */
double bub_force(double k0, double l, double l0);

/* The potential of the pair: U(l) = integral from l to 1.5 l0 of F, 0 beyond 1.5 l0. */
double bub_potential(double k0, double l, double l0);

/* ---- the state (bub_state.c) ---------------------------------------------------------------- */

typedef struct bub_state {
  const pm_model *model; /* borrowed */
  const pm_sizing *size; /* borrowed */
  bub_params p;
  int threads;           /* >= 1 */
  uint64_t seed;

  int32_t n, cap;        /* bubbles held, allocated */
  double *x;             /* [3n] position */
  double *v;             /* [3n] velocity (object space, kept tangent to the cell) */
  double *par;           /* [2n] parameters on the cell (curve: t; face: u, v) */
  double *der;           /* [6n] first derivatives at par (curve: C'; face: Su, Sv) */
  double *d;             /* [n] diameter d(x) (the desired edge length at x) */
  double *dmoved;        /* [n] distance moved since d was last evaluated (bub_dynamics.c) */
  double *alpha;         /* [n] overlap ratio (valid during population control) */
  int8_t *kind;          /* [n] BUB_K* */
  int32_t *cell;         /* [n] index of the cell in its dimension */
  uint8_t *flags;        /* [n] BUB_F* */
  double *wall;          /* [n] volume bubbles: a lower bound on the distance to the walls of
                            their volume (bub_volume.c), 0 when unknown */

  /* Ranges of the sorted arrays: vertices [0, nv), curves [nv, nc), faces [nc, nf), volume
   * bubbles [nf, nw), outside bubbles [nw, n) (only during population control). */
  int32_t nv, nc, nf, nw;

  /* The volume phase (bub_volume.c): once the vertex, curve and face bubbles have settled they
   * are frozen, the surface mesh is connected from them, and only volume bubbles move and are
   * controlled. shell[v] (owned) are the walls of volume v, from that surface mesh. */
  int volume_phase;
  pm_volume_shell **shell;       /* [count[PM_VOLUME]] owned, NULL before the phase */
  int64_t round0;        /* rounds done before the phase began (the saw-tooth restarts) */

  pm_grid *grid;         /* every bubble, radius grid_factor d (the overlap boundary of 000
                            section 3.1.3, or the list reach when that is larger) */
  int grid_valid;        /* the grid holds ids 0..n-1 at the current x, d */
  double grid_factor;    /* a bubble of diameter d has radius grid_factor d in the grid */

  /* Neighbour lists of the moving bubbles (bub_neighbors.c), two levels: the outer lists
   * nbo[nb_off[i] .. nb_off[i+1]) (reach list_outer, from the grid), and the lists the forces use,
   * nb[nb_off[i] .. nb_off[i] + nb_cnt[i]) (reach list_skin, filtered from the outer ones). Both
   * are sorted by id. */
  int32_t *nb_off;       /* [n+1] */
  int32_t *nbo;          /* [nb_cap] outer lists */
  int32_t *nb;           /* [nb_cap] lists */
  int32_t *nb_cnt;       /* [n] length of each list */
  int64_t nb_cap;
  double *x_build;       /* [3n] positions at the last build of the lists */
  double *d_build;       /* [n] diameters then */
  double *xo_build;      /* [3n] positions at the last build of the outer lists */
  double *do_build;      /* [n] diameters then */
  int lists_valid;       /* the lists cover the bubbles 0..n-1 as they are now */
  int lists_stale;       /* the skin test of the last step asks for a rebuild */
  int64_t list_builds;   /* statistics: builds of the lists, */
  int64_t outer_builds;  /* and of the outer lists (grid queries) */
  int32_t *nbo_cnt;      /* [n] length of each outer list (its region nb_off[i] .. nb_off[i+1] has
                            room for BUB_OUTER_SLACK more, for partial builds) */
  uint8_t *nb_mark;      /* [n] scratch of partial builds */
  int32_t *nb_moved;     /* [n] the bubbles whose build position the last partial build set */
  int32_t nb_nmoved;     /* their number; -1 after a full build (every bubble's) */
  int64_t partial_builds; /* statistics: partial builds of the lists, */
  int64_t partial_outer;  /* of which with partial outer lists from the grid */
  int32_t nb_build_cap;  /* allocated length of nb_off, x_build, d_build (minus one) */
  struct bub_nbscratch *nbs;  /* [threads] per-thread build buffers, kept across builds */
  struct bub_nbpiece *nb_piece; /* [nb_piece_cap] where each chunk of a build went */
  int64_t nb_piece_cap;

  /* Cell relations (000 section 4.2.2): the sorted keys (bub_key) of the cells in the closure of
   * each curve and face (their boundary cells and embedded cells, recursively). */
  int32_t *clo_off[4];   /* [count[dim] + 1] for dim 1, 2, 3 */
  uint32_t *clo[4];
  uint8_t *seam;         /* [ncurve] 1 when the curve is used twice by one face (a seam) */

  /* Frames (bub_dynamics.c): the second-order Taylor model of its cell around a point where
   * the bubble was last evaluated exactly, so that a bubble that barely moved needs no surface
   * evaluation. frame[BUB_FRAME_LEN i ...]: par (2), S (3), S_u (3), S_v (3), S_uu (3), S_uv (3),
   * S_vv (3) (curves: t, C, C', -, C'', -, -). frame_r[i]: the radius, in units of d, within
   * which the model is used (0: no frame yet). */
  double *frame;         /* [BUB_FRAME_LEN n] */
  double *frame_r;       /* [n] */
  double *clear;         /* [3n] face bubbles: a point (u, v) and a radius r in parameter space such
                            that every point within r of it is inside the trimmed face
                            (pm_trim_clearance): a step that ends there needs no inside test;
                            r = 0: unknown */
  uint8_t *affine;       /* [count[PM_FACE] + count[PM_CURVE]] faces then curves: 1 when the
                            cell is a plane / a line (its Taylor model is exact everywhere) */
  double *normal;        /* [3 count[PM_FACE]] the unit normal of the affine faces */
  double *pinv;          /* [6 count[PM_FACE]] affine faces: M^-1 J, the parameter step of an
                            object-space step (geom.h, pm_cell_param_delta), rows du, dv */
  double *pgain;         /* [count[PM_FACE]] affine faces: an upper bound on |M^-1 J dx| / |dx|
                            (1 / sqrt of the smallest eigenvalue of M), for bub_dynamics.c's room */
  int64_t evals;         /* exact cell evaluations made by the dynamics (statistics) */
  int64_t bubble_steps;  /* moving bubbles summed over the steps taken (statistics) */

  /* Dynamics scratch (bub_dynamics.c), allocated when the count grows (never in a step). */
  double *pos[3];        /* [4n] each: packed (x, y, z, d) at the step start and two stage
                            buffers (the force kernel gathers a neighbour's record at once) */
  double *vs, *sumv, *suma, *ders; /* [3n], [3n], [3n], [6n] */
  double *pot;           /* [n] potential per bubble (half of each pair it feels) */
  double *disp;          /* [n] displacement of the last step, relative to d */
  int32_t *deg;          /* [n] neighbours within 1.3 l0 at the step start (eps_t) */
  double *skin0;         /* [n] the skin test's excess of the step's start point */
  double *room;          /* [n] plane bubbles: an object-space radius around the step's start point
                            within which the face is inside its trimming loops (from the clearance,
                            at the step's start; 0 otherwise) */
  struct bub_chunk *chunks; /* [n / BUB_CHUNK + 1] per-chunk partial sums (fixed order) */
  int scratch_cap;
  int32_t *hist;         /* [BUB_HBINS threads] per-thread displacement histograms */
  double *timers;        /* [3 threads] per-thread stage timers of a step */

  /* Wall-clock seconds per stage of the relaxation (bub_run.c writes them as time_s.bubble.*):
   * the thread-seconds spent in a stage, summed over threads and divided by their number. */
  struct bub_times {
    double neighbors;    /* neighbour lists: grid updates and queries */
    double force;        /* the force sums over the lists */
    double integrate;    /* the RK stages' arithmetic, energies, the size field */
    double project;      /* confinement: parameter steps, trimming, cell evaluation / frames */
    double overlap;      /* overlap ratios and the outside layer of population control */
    double population;   /* the rest of population control: removal, insertion, compaction */
  } t;

  /* Run bookkeeping. */
  int64_t step;          /* steps taken */
  int64_t round;         /* population controls done */
  int steps_in_round;
  int final_phase;       /* population control has ended: the last relaxation steps (bub_run.c) */
  int odd_active;        /* the odd-bubble damping is in use (004 section 2.2) */
  int64_t insertions, deletions; /* totals */
  int64_t failed_insertions;
  int32_t last_ins, last_del; /* of the last control */
} bub_state;

/* Cell key for the relation tables. */
static inline uint32_t bub_key(int dim, int32_t cell) { return ((uint32_t)dim << 28) | (uint32_t)cell; }

/* The bubbles that move: curve and face bubbles, or volume bubbles in the volume phase. */
static inline void bub_moving(const bub_state *s, int32_t *a, int32_t *b) {
  *a = s->volume_phase ? s->nf : s->nv;
  *b = s->volume_phase ? s->nw : s->nf;
}

/* Threads for a loop over n items: the run's threads, or 1 below BUB_PARALLEL_MIN items (a
 * parallel region costs a few microseconds, more than a small loop, and on a machine with more
 * busy threads than cores a time slice when a thread has been descheduled: qi1 at d = 0.05, 3816
 * bubbles, spent 3.6 of its 5.2 s waiting with two threads on a shared two-core machine). Results
 * never depend on it. */
#define BUB_PARALLEL_MIN 8192
static inline int bub_threads_for(const bub_state *s, int64_t n) {
  return n >= BUB_PARALLEL_MIN ? s->threads : 1;
}

/* Create a state for a model and size field (both borrowed) with checked parameters. */
pm_status bub_state_create(const pm_model *m, const pm_sizing *size, const bub_params *p,
                           int threads, uint64_t seed, bub_state **out, pm_error *err);
void bub_state_destroy(bub_state *s);

/* Append a bubble on cell (kind, cell) at parameters par (NULL for a vertex; ignored for an
 * outside bubble, which is placed at xyz with diameter d, and for a volume bubble, placed at xyz).
 * Evaluates position, derivatives and diameter (except for outside bubbles). Writes the new index
 * to *id when not NULL. Does not touch the grid. */
pm_status bub_state_add(bub_state *s, int kind, int32_t cell, const double *par,
                        const double *xyz, double d, int32_t *id, pm_error *err);

/* Evaluate position and derivatives of bubble i at its par (curves, faces). */
void bub_state_eval(const bub_state *s, int32_t i);

/* The diameter d(x) at a point, checked: PM_ERR_ARG when not finite and > 0. */
pm_status bub_size_at(const bub_state *s, const double x[3], double *d, pm_error *err);

/* Remove dead bubbles (BUB_FDEAD) and outside bubbles, clear the per-control flags, sort by
 * (kind, cell, old index) and recompute the ranges. Invalidates grid and lists. */
pm_status bub_state_compact(bub_state *s, pm_error *err);

/* The same, the bubbles of each cell then in the Morton order of their positions (ties: the
 * previous order), so that neighbours in space are neighbours in memory (bub_state.c). */
pm_status bub_state_order(bub_state *s, pm_error *err);

/* Put every bubble into the grid at its x with radius d (rebuilding it). */
pm_status bub_state_grid_rebuild(bub_state *s, pm_error *err);

/* 1 when bubble i (a curve, face or volume bubble) feels bubble j in its dynamics and overlap
 * ratio: j is on the same cell or on a cell of the closure of i's cell (000 section 4.2.2: curve
 * bubbles feel vertex and curve bubbles, face bubbles all of them, each only those of its own
 * cell and of that cell's boundary; carried up one dimension, volume bubbles feel the bubbles of
 * their volume and of its bounding and embedded faces, curves and vertices, which never feel
 * them). Outside bubbles are never related here. */
int bub_related(const bub_state *s, int32_t i, int32_t j);

/* The same test for a hypothetical bubble on (kind, cell) against bubble j. */
int bub_related_cell(const bub_state *s, int kind, int32_t cell, int32_t j);

/* ---- placement (bub_place.c) ---------------------------------------------------------------- */

/* Bubbles on every vertex, every curve, every face (003 section 3.2, 000 section 4.1.1). */
pm_status bub_place(bub_state *s, pm_error *err);

/* Face bubbles of every face by lattice growth from the border (bub_lattice.c); the vertex and
 * curve bubbles are placed and in the grid. cap limits the bubbles. */
pm_status bub_place_lattice(bub_state *s, int64_t cap, pm_error *err);

/* The curve bubbles of place = lattice (bub_lattice.c): round(integral of ds / d) segments of
 * equal integral; their parameters, sorted, in a malloc'ed *t (count *nt). */
pm_status bub_place_curve_lattice(const bub_state *s, int32_t curve, int64_t cap, double **t,
                                  int32_t *nt, pm_error *err);

/* Binary subdivision of one curve: the parameters of its interior bubbles, sorted, written to a
 * malloc'ed *t (count *nt). */
pm_status bub_place_curve(const bub_state *s, int32_t curve, double **t, int32_t *nt,
                          pm_error *err);

/* Whether a lattice point x (diameter d) of the placement on (kind, cell) is crowded: closer than
 * a quarter of l0 to a bubble of the same cell, or half of l0 to one of a related cell (their
 * bubbles came first). `buf` is scratch for the grid query. */
pm_status bub_place_crowded(const bub_state *s, int kind, int32_t cell, const double x[3], double d,
                            pm_idbuf *buf, int *crowded, pm_error *err);


/* ---- neighbour lists (bub_neighbors.c) ------------------------------------------------------ */

/* The reach of the lists: a pair is listed within 0.75 (1 + list_skin) (d_i + d_j), i.e. (1 +
 * skin) x 1.5 l0, and in the outer lists within 0.75 (1 + list_outer) (d_i + d_j). The grid
 * radius of a bubble is max(1, 0.75 (1 + list_outer)) d (grid_factor): every query asks for a
 * superset of what it needs with it (the overlap ratio needs dist < d_i + d_j / 2: query radius
 * d_i; the outer lists dist < 0.75 (1 + list_outer)(d_i + d_j): query radius
 * 0.75 (1 + list_outer) d_i). */
static inline double bub_list_reach(const bub_params *p) { return 0.75 * (1 + p->list_skin); }
static inline double bub_outer_reach(const bub_params *p) { return 0.75 * (1 + p->list_outer); }

/* Build the lists at the packed positions pos4 ((x, y, z, d) per bubble; NULL: the bubbles' x
 * and d) if they are invalid or stale (the skin test, bub_skin_excess, failed). */
pm_status bub_neighbors_update(bub_state *s, const double *pos4, pm_error *err);

/* Release the lists' build buffers (bub_state_destroy). */
void bub_neighbors_free(bub_state *s);

/* The skin test of one bubble at position x with diameter d: e = |x - x_build| + 0.75 |d -
 * d_build| - 0.75 skin d_build. A pair missing from the lists can have come within the force's
 * range 1.5 l0 only if e_i + e_j > 0, so the lists stay exact while the two largest e of all
 * bubbles sum to at most 0 (bub_neighbors.c). */
static inline double bub_skin_excess(const bub_state *s, int32_t i, const double x[3], double d) {
  const double *xb = &s->x_build[3 * i];
  double dx = x[0] - xb[0], dy = x[1] - xb[1], dz = x[2] - xb[2];
  double dd = d - s->d_build[i];
  return sqrt(dx * dx + dy * dy + dz * dz) + 0.75 * (dd < 0 ? -dd : dd) -
         0.75 * s->p.list_skin * (1 - 1e-9) * s->d_build[i];
}

/* The largest two values of a set, for the skin test. */
typedef struct bub_top2 {
  double e1, e2; /* e1 >= e2 */
} bub_top2;
static inline void bub_top2_add(bub_top2 *t, double e) {
  if (e > t->e1)
    t->e2 = t->e1, t->e1 = e;
  else if (e > t->e2)
    t->e2 = e;
}

/* ---- dynamics (bub_dynamics.c) -------------------------------------------------------------- */

/* Doubles per bubble in s->frame. */
#define BUB_FRAME_LEN 20

/* Bubbles per work item of the dynamics' parallel loops: sums over a chunk are formed in index
 * order and chunks are combined in chunk order, so no sum depends on the thread count. */
#define BUB_CHUNK 256

/* The histogram of the steps' relative displacements (for the quantile of bub_step_info): bins
 * of an eighth of an octave from 2^-60 to 2^4 (a displacement of 0 in the first, one beyond in
 * the last). */
#define BUB_HBINS 512

/* Per-chunk partial results of a step. */
typedef struct bub_chunk {
  double kinetic, potential, edev, sum_disp, max_disp, max_rel;
  int32_t nface;
  int32_t evals;  /* exact cell evaluations */
  int32_t held;   /* held bubbles (BUB_FHOLD): not in the displacement histogram */
  int bad_size;  /* the size field was not finite and > 0 at a new position */
  bub_top2 skin; /* the skin test of the chunk's bubbles */
} bub_chunk;

/* The force sum of bubble i's list at the packed positions pos4 (bub_kernel.c): f, and when pot
 * or deg is not NULL half the potential of its pairs and its pairs within 1.3 l0. simd selects
 * the AVX2 implementation (bub_kernel_simd()), which gives the same bits as the plain one. */
void bub_force_sum(const bub_state *s, const double *pos4, int32_t i, int simd, double f[3],
                   double *pot, int32_t *deg);

/* 1 when the AVX2 force kernel is in use (the processor has AVX2 and the environment variable
 * PM_BUB_KERNEL is not "c"). */
int bub_kernel_simd(void);

/* A unit direction for a coincident pair, from (seed, pair), pointing from j to i. */
void bub_pair_direction(uint64_t seed, int32_t i, int32_t j, double u[3]);

/* The force on moving bubble i (object space, before the projection onto its cell) from the
 * bubbles of its neighbour list at the packed positions pos4 ((x, y, z, d) per bubble); pot and
 * deg (may be NULL) receive half the potential of its pairs and its neighbours within 1.3 l0. */
void bub_force_on(const bub_state *s, const double *pos4, int32_t i, double f[3], double *pot,
                  int32_t *deg);

/* Evaluate position and derivatives of every curve and face bubble exactly at its parameters
 * and start new frames there (the relaxation ends with it, so that nodes lie on their cells). */
void bub_state_refresh(bub_state *s);

/* The time step in time units: dt x T0 (dt = 0: the automatic choice of the integrator). */
double bub_time_step(const bub_params *p);

/* The damping ratio of the final steps (final_zeta, its automatic choice resolved), 0 when the
 * schedule goes on. */
double bub_final_zeta(const bub_params *p);

/* The damping ratio of a normal bubble of a curved face (not a plane): final_zeta in the surface
 * phase's final steps, else the schedule's (bub_zeta_now). Plane bubbles keep the schedule
 * throughout: there it stops the final steps sooner by the displacement test (qi1 at --size
 * 0.00314: 56 steps, 89 with final_zeta on planes too). */
double bub_zeta_curved(const bub_state *s);

/* The damping ratio of a normal bubble at the current point of the schedule. */
double bub_zeta_now(const bub_state *s);

typedef struct bub_step_info {
  double kinetic, potential;  /* at the start of the step */
  double mean_disp, max_disp; /* object-space displacement of the step */
  double max_rel_disp;        /* max displacement / d */
  double q_rel_disp;          /* the disp_quantile-quantile of displacement / d (the max when
                                 disp_quantile = 1): what the calm and stopping tests read */
  double eps_t;               /* mean |neighbours within 1.3 l0 - 6| over face bubbles (- 12
                                 over volume bubbles in the volume phase) */
} bub_step_info;

/* One step of the equation of motion for every moving bubble (bub_moving). */
pm_status bub_dynamics_step(bub_state *s, bub_step_info *info, pm_error *err);

/* ---- overlap ratio (bub_overlap.c) ---------------------------------------------------------- */

/* The overlap ratio (003 eq. 16) of a bubble of diameter d at x on (kind, cell), against the
 * bubbles in the grid, leaving out bubble `self` (-1: none). Needs a valid grid. */
double bub_alpha_at(const bub_state *s, const double x[3], double d, int kind, int32_t cell,
                    int32_t self);

/* The overlap ratio of bubble i. */
double bub_alpha(const bub_state *s, int32_t i);

/* Compute alpha of every moving bubble (needs a valid grid). */
void bub_alpha_all(bub_state *s);

/* A border chord of a face: consecutive boundary bubbles A, B along one of its loops (in loop
 * order, face on the left in (u, v)), on boundary curve `curve`; e the unit chord direction, w
 * the unit outward direction in the face's tangent plane at uv (the pcurves' midpoint of the
 * chord), len the chord length. */
typedef struct bub_chord {
  int32_t face, A, B, curve;
  double e[3], w[3], len, uv[2];
} bub_chord;

typedef pm_status (*bub_chord_fn)(bub_state *s, const bub_chord *c, void *user, pm_error *err);

/* Call fn for every border chord of every face, face by face, loop by loop, in loop order (seams
 * and degenerate curves are not borders). */
pm_status bub_for_each_chord(bub_state *s, bub_chord_fn fn, void *user, pm_error *err);

/* Replace the outside layer: remove the outside bubbles (from arrays and grid) and place new
 * ones outside the borders of every face (000 section 4.2.1). Needs a valid grid. */
pm_status bub_outside_layer(bub_state *s, pm_error *err);

/* Before the connection: remove the face bubbles that lie on a border chord of their face (the
 * segment between two consecutive boundary bubbles) or beyond it, within a quarter of the stable
 * distance, and those closer than half the stable distance to a vertex or curve bubble of their
 * face (bub_overlap.c). Such a bubble, squeezed against the border where no force pushes it back
 * inside, would make a flat triangle. *dropped receives their number. */
pm_status bub_border_cleanup(bub_state *s, int32_t *dropped, pm_error *err);

/* ---- population control (bub_population.c) -------------------------------------------------- */

typedef struct bub_control_info {
  int32_t removed, inserted, failed; /* bubbles removed, inserted, insertions that found no place */
  int32_t before, after;             /* curve + face bubbles before and after */
} bub_control_info;

/* One population control (000 section 4.2.5): remove curve excess, remove face excess, insert
 * around open curve bubbles, insert around open face bubbles, remove excess again; then compact.
 * In the volume phase the same for volume bubbles only (the lower dimensions have settled).
 * `cap` limits the total number of bubbles. */
pm_status bub_population_control(bub_state *s, int64_t cap, bub_control_info *info,
                                 pm_error *err);

/* ---- the volume phase (bub_volume.c) --------------------------------------------------------- */

/* A volume bubble's step ends at least BUB_VMARGIN x its diameter from its volume's walls. */
#define BUB_VMARGIN 0.25

/* Start the volume phase: freeze the bubbles placed so far and take the walls of every volume
 * from `surface` (the surface mesh connected from them, classified on the model). */
pm_status bub_volume_begin(bub_state *s, const pm_mesh *surface, pm_error *err);

/* The octree of rhombohedra in every volume (bub_volume.c): volume bubbles. */
pm_status bub_place_volumes(bub_state *s, pm_error *err);

/* The rule for a volume bubble's step from x0 by dx: taken whole, shortened, or not taken
 * (bub_volume.c). Writes the end point to x1; updates s->wall[i]. Returns PM_MOVE_FREE when the
 * whole step was taken, else PM_MOVE_CLIPPED. */
int bub_volume_move(bub_state *s, int32_t i, const double x0[3], const double dx[3], double x1[3]);

/* 1 when a volume bubble of diameter d may sit at x, reached from x0 (a point of the volume)
 * along a straight segment: the segment meets no wall and x is at least BUB_VMARGIN d from
 * them. */
int bub_volume_place_ok(const bub_state *s, int32_t volume, const double x0[3], const double x[3],
                        double d);

/* ---- the run (bub_run.c) ----------------------------------------------------------------------- */

/* Relaxation rounds with population control until a stop (bub_run.c's rules), over the moving
 * bubbles (bub_moving): the surface phase, then the volume phase. in->observer (may be NULL)
 * receives trace rows and snapshots; cap limits the bubbles (a node budget when budget is 1: an
 * error when reached); reason receives the stop. */
pm_status bub_relax(bub_state *s, const pm_run_input *in, int64_t cap, int budget,
                    char reason[128], pm_error *err);

/* The vertex, curve and face bubbles connected by pm_connect: the surface mesh (and segments)
 * only when surface_only, else with TetGen's refined tets when in->volume. *out is the caller's
 * (pm_mesh_destroy). */
pm_status bub_connect_nodes(const bub_state *s, const pm_run_input *in, int surface_only,
                            pm_mesh **out, pm_error *err);

/* ---- default size (bub_size.c) -------------------------------------------------------------- */

/* bub_default_size is declared in bubble.h. The exact rule as a callback field, for bub_run:
 * *rule must be released with bub_size_rule_free after the field is destroyed. */
pm_status bub_size_rule_create(const pm_model *m, const bub_params *p, pm_sizing **field,
                               void **rule, pm_error *err);
void bub_size_rule_free(void *rule);

#endif /* BUB_PRIVATE_H */
