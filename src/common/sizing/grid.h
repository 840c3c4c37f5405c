/* pm_grid: neighbour search for points with varying radii.
 *
 * Both meshers ask, every step and for every particle, which particles lie near it: the bubble
 * method wants the bubbles j with |x_i - x_j| < 1.5 l0, l0 = (d_i + d_j) / 2 (papers/003 eq. 11:
 * the inter-bubble force vanishes beyond 1.5 l0), the particle system wants the j with
 * |x_i - x_j| < max(sigma_i, sigma_j) (papers/001 section 3: p_i and p_j are neighbours when
 * either lies in the other's ball; its timing section asks for a binning structure that stays
 * cheap while sigma refines and coarsens). The sampled sizing field and the connection layer
 * ask for nearest points. Radii vary by orders of magnitude
 * (psys adapts sigma over about three decades, bubble sizes over about one), so a single cell
 * size cannot serve all points: a cell sized for the largest radius holds thousands of small
 * points, a cell sized for the smallest makes a query around a large point scan thousands of
 * empty cells.
 *
 * Structure: a hashed, pointer-linked octree of dyadic cells.
 * - A cell of level l is the half-open cube [i 2^l, (i+1) 2^l) x [j 2^l, ...) x [k 2^l, ...)
 *   with integer (i, j, k). Cells live in one hash table keyed by (l, i, j, k); each cell also
 *   links to its parent (the level l+1 cube that contains it) and to its up-to-8 children.
 * - A point of radius r is filed at level l(r) = ceil(log2 r) - 1, so that 2^l < r <= 2^(l+1):
 *   cells are between half the radius and the radius wide. Radii below `hmin` (pm_grid_create)
 *   are filed as if they were hmin, and a point is never filed below 2^-50 of its largest
 *   coordinate (finer cells than that would be below double precision). It lives in the one
 *   cell of that level that contains its position.
 * - Queries enter the tree at level T, two levels above the highest level in use: a handful of
 *   hash lookups, then child links. T follows the largest radius up at once and down with a lag
 *   of three levels. Above T the tree goes on to the apex level, raised until at most 16 apex
 *   cells remain: k-nearest searches descend from there (nearest child first, pruned by the k-th
 *   distance found), and so do queries too wide for hash lookups at T.
 * - Point records live in slots the grid owns; every so often (after about n/2 inserts and moves
 *   to another cell) they and the cells are rewritten in depth-first (Morton) order, so that
 *   points close in space are close in memory whatever the caller's ids. The cost is O(n),
 *   spread over the updates that called for it.
 *
 * Invariants (pm_grid_validate checks them all):
 *   (I0) every id in the grid maps to one slot holding its record, in its cell's list;
 *   (I1) a cell exists if and only if its subtree holds at least one point; every cell below the
 *        apex level is linked from its parent, every apex cell is in the apex list;
 *   (I2) every point lies inside the cube of its cell, hence inside the cube of every ancestor;
 *   (I3) count(C) is the number of points in C's subtree, maxlev(C) the highest level filed in
 *        it;
 *   (I4) per level, a histogram of radii in eighth-of-an-octave bins gives bound[l] >= every
 *        radius filed at level l, and bound[] increases with l over the levels in use.
 * Hence every point of C's subtree lies in C's cube and has a radius <= bound[maxlev(C)]: a query
 * skips C when the distance from the query point to C's cube exceeds the largest distance at
 * which any point of the subtree could still be an answer. The skip test carries a relative
 * margin of 1e-12 so that rounding never drops an answer; the answer test itself is exact
 * (below). Queries are therefore exact: they return the same set as a brute-force scan.
 *
 * Cost: insert, remove and move walk from the point's cell up to the first ancestor whose
 * state does not change; a move that stays in its cell touches nothing else. All are O(1)
 * expected (amortized over compactions) with a constant bounded by the number of levels in use
 * (about 10 for radii spread over three decades). A query visits the cells whose cubes are
 * within reach; with radii that vary smoothly in space (as both methods keep them) the work per
 * query does not grow with the number of points. Memory latency does: queries issued in an order
 * that follows space (ids that follow space) run several times faster at 10^6 points than
 * queries in random order. bench/bench_grid.c measures both.
 *
 * Distances: d2 = dx*dx + dy*dy + dz*dz in double precision, compared with the squared radius
 * of the query. Callers that check the result against their own brute force must compute it the
 * same way.
 *
 * Ids: the caller chooses them, non-negative int32_t, meant to be dense (0..n-1, with holes
 * after removals): storage is an array indexed by id, so the largest id sets the memory used.
 *
 * Results: every query that fills a pm_idbuf returns the ids SORTED in increasing order, so a
 * sum over neighbours has the same order, hence the same rounding, whatever the insertion
 * history or the thread schedule. A query point that is itself in the grid finds itself (at
 * distance 0) whenever the query's test admits distance 0.
 *
 * Thread safety: queries never modify the grid; any number of threads may query at once while
 * no thread inserts, removes, moves or clears. Each thread needs its own pm_idbuf.
 */
#ifndef PM_GRID_H
#define PM_GRID_H

#include <packmesh/packmesh.h>

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ---- id buffer ------------------------------------------------------------------------- */

/* A growable array of ids, owned by the caller. Start it zeroed (PM_IDBUF_INIT or {0}); queries
 * overwrite its content and grow it as needed; release with pm_idbuf_free. */
typedef struct pm_idbuf {
  int32_t n;     /* ids held */
  int32_t cap;   /* allocated length of ids */
  int32_t *ids;  /* [cap] owned, freed by pm_idbuf_free */
} pm_idbuf;

#define PM_IDBUF_INIT {0, 0, NULL}

/* Make room for at least cap ids (content kept). */
pm_status pm_idbuf_reserve(pm_idbuf *b, int32_t cap, pm_error *err);

/* Append one id. */
pm_status pm_idbuf_push(pm_idbuf *b, int32_t id, pm_error *err);

/* Release the array and reset to empty. Accepts NULL. */
void pm_idbuf_free(pm_idbuf *b);

/* Sort n ids increasingly, in place (the order every query returns; n <= 0 is a no-op). */
void pm_sort_ids(int32_t *a, int32_t n);

/* ---- the grid ---------------------------------------------------------------------------- */

typedef struct pm_grid pm_grid;

/* A new empty grid. hmin > 0 (finite) is the smallest radius the grid distinguishes: points
 * with a smaller radius (including 0) are filed like points of radius hmin. It only affects
 * speed, never results: choose it near the smallest spacing expected (for instance 1e-3 times
 * the smallest size of the field); too small a value makes zero-radius points sit in very small
 * cells. */
pm_status pm_grid_create(double hmin, pm_grid **out, pm_error *err);

/* Release. Accepts NULL. */
void pm_grid_destroy(pm_grid *g);

/* Remove every point, keeping the allocated memory. */
void pm_grid_clear(pm_grid *g);

/* Number of points in the grid. */
int32_t pm_grid_count(const pm_grid *g);

/* Make room for ids 0..max_id without reallocation during later inserts (optional). */
pm_status pm_grid_reserve(pm_grid *g, int32_t max_id, pm_error *err);

/* Add point `id` (>= 0, not already present) at xyz with radius r (>= 0). Coordinates and radius
 * must be finite with magnitude <= 1e150 (so that squared distances cannot overflow). */
pm_status pm_grid_insert(pm_grid *g, int32_t id, const double xyz[3], double r, pm_error *err);

/* Remove point `id` (must be present). */
pm_status pm_grid_remove(pm_grid *g, int32_t id, pm_error *err);

/* Set the position and radius of point `id` (must be present); same rules as insert. */
pm_status pm_grid_move(pm_grid *g, int32_t id, const double xyz[3], double r, pm_error *err);

/* Give every point a new id: the point of id k (< nmap) becomes point new_id[k]. Every point in
 * the grid must get an id >= 0, no two the same (PM_ERR_ARG otherwise, the grid unchanged); ids
 * of absent points are ignored. Positions, radii and cells do not change, so this costs one pass
 * over the ids: for callers whose ids are indices that shift when some are dropped (the
 * particles of a compacted array) it replaces clearing the grid and inserting every point
 * again. */
pm_status pm_grid_renumber(pm_grid *g, int32_t nmap, const int32_t *new_id, pm_error *err);

/* 1 if `id` is in the grid (then xyz and r, when not NULL, receive its data), else 0. */
int pm_grid_get(const pm_grid *g, int32_t id, double xyz[3], double *r);

/* ---- queries (const; safe to run concurrently) ------------------------------------------- */

/* What a query accepts, for a query point x with radius r and a grid point j (x_j, r_j):
 *   PM_GRID_BALL     d2 <= r^2                 (the closed ball of radius r around x)
 *   PM_GRID_MUTUAL   d2 <  max(r, r_j)^2       (either point lies in the other's open ball;
 *                                               psys's neighbour relation)
 *   PM_GRID_OVERLAP  d2 <  (r + r_j)^2         (the two open balls overlap; with radii 0.75 d
 *                                               this is the bubble method's 1.5 l0 range) */
typedef enum pm_grid_kind { PM_GRID_BALL = 0, PM_GRID_MUTUAL = 1, PM_GRID_OVERLAP = 2 } pm_grid_kind;

/* All ids accepted by `kind` around xyz with radius r (finite or +inf, >= 0), sorted by id,
 * into out (overwritten). */
pm_status pm_grid_query(const pm_grid *g, const double xyz[3], double r, pm_grid_kind kind,
                        pm_idbuf *out, pm_error *err);

/* Shorthands for the three kinds. */
pm_status pm_grid_query_ball(const pm_grid *g, const double xyz[3], double r, pm_idbuf *out,
                             pm_error *err);
pm_status pm_grid_query_mutual(const pm_grid *g, const double xyz[3], double r, pm_idbuf *out,
                               pm_error *err);
pm_status pm_grid_query_overlap(const pm_grid *g, const double xyz[3], double r, pm_idbuf *out,
                                pm_error *err);

/* Call fn(id, d2, user) for every id accepted by `kind`, in no particular order, without
 * allocating. fn returns 0 to go on, non-zero to stop the visit. For hot loops whose result does
 * not depend on the order (a minimum, a count, a flag); use pm_grid_query for sums. Returns the
 * number of calls made; a bad xyz or r (not finite, negative) makes no call. */
typedef int (*pm_grid_visit_fn)(int32_t id, double d2, void *user);
int32_t pm_grid_visit(const pm_grid *g, const double xyz[3], double r, pm_grid_kind kind,
                      pm_grid_visit_fn fn, void *user);

/* The nearest point to xyz (ties: the smallest id); its distance into *dist when not NULL.
 * Returns -1 when the grid is empty (or xyz is not finite). */
int32_t pm_grid_nearest(const pm_grid *g, const double xyz[3], double *dist);

/* The k nearest points to xyz (k >= 1; fewer when the grid holds fewer), ranked by distance
 * with ties broken by the smaller id, written to out sorted by id. */
pm_status pm_grid_knearest(const pm_grid *g, const double xyz[3], int32_t k, pm_idbuf *out,
                           pm_error *err);

/* The same without allocating (unless k > 64 and d2 is NULL): ids[k] and, when not NULL, d2[k]
 * (squared distances) receive the k nearest in increasing (distance, id) order. Returns how many
 * were found (min(k, count)); 0 for a bad xyz or k < 1. */
int32_t pm_grid_knearest_fixed(const pm_grid *g, const double xyz[3], int32_t k, int32_t *ids,
                               double *d2);

/* Check every invariant listed above (expensive: O(points + cells)). PM_ERR_INTERNAL with the
 * first violation. For tests. */
pm_status pm_grid_validate(const pm_grid *g, pm_error *err);

#ifdef __cplusplus
}
#endif

#endif /* PM_GRID_H */
