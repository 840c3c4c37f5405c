/* pm_grid: a hashed dyadic octree for neighbour search with varying radii.
 *
 * The structure and its invariants are described in grid.h. This file holds:
 *   - the point records, kept in "slots" that the grid may reorder, and the caller's id -> slot
 *     map;
 *   - the cell pool with its free list, and the open-addressing hash table (linear probing,
 *     backward-shift deletion) that finds a cell from (level, i, j, k);
 *   - the update walks that keep counts, highest levels and the root list right;
 *   - compaction: every so often the point records and the cells are rewritten in depth-first
 *     (Morton) order, so that points close in space are close in memory whatever order the
 *     caller's ids come in. Queries are bound by memory latency: on 10^5 points with random ids
 *     most of a query's time went to cache misses on point records before compaction existed;
 *   - the queries: a recursive descent from the roots that skips a subtree whose cube is out of
 *     reach, and a k-nearest search that reuses it with a shrinking reach.
 */
#include "common/sizing/grid.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Levels a point can be filed at. Radii and coordinates are limited to 1e150 (~2^498) and hmin
 * is clamped to 2^-1000, so every level in use stays in [-1002, 500]. */
#define LVL_LO (-1100)
#define LVL_HI 1100
#define NLVL (LVL_HI - LVL_LO + 1)
#define LVL_NONE (LVL_LO - 1) /* maxlev of nothing */

/* A point of radius r is filed at level ceil(log2 r) - SHIFT: with SHIFT = 1 the cells are
 * between r/2 and r wide, which bench_grid found the best balance between cells visited and
 * points tested per query (SHIFT = 0 tests about twice the points for the same answers). */
#define SHIFT 1

/* Queries enter the tree at level T = TOP_GAP levels above the highest level in use: a handful
 * of hash lookups, then child links (which compaction keeps next to each other in memory)
 * instead of a hash lookup for every cell looked at. */
#define TOP_GAP 2

/* The tree continues above T up to the apex level A, raised until at most APEX_MAX cells remain
 * there (points around the origin need 8: keys -1 and 0 on every axis). k-nearest searches
 * start from the apex and queries too wide for hash lookups at T descend from it. */
#define APEX_MAX 16
/* A query box covering more than this many keys at level T descends from the apex instead. */
#define LOOKUP_MAX 64

/* Radius histogram per level: NBIN bins per octave give each level a radius bound at most
 * 1/16 of an octave above the true largest radius (grid.h, invariant I4). */
#define NBIN 8

/* Coordinates and radii beyond this are rejected: squared distances must not overflow. */
#define COORD_MAX 1e150

/* Relative slack of the subtree skip test: rounding in the cube distance and in a point's
 * distance is a few ulps; 1e-12 keeps every answer while costing nothing measurable. */
#define PRUNE_MARGIN (1.0 + 1e-12)

/* Keys stay below 2^51 in magnitude (points are never filed finer than 2^-50 of their largest
 * coordinate), so a cube corner i * 2^l is exact in double. Query keys are clamped to 2^52. */
#define KEY_CLAMP 4503599627370496.0 /* 2^52 */

/* Compaction runs when the number of point records written out of order (inserts and moves to
 * another cell) since the last one exceeds COMPACT_FRACTION of the points (and at least
 * COMPACT_MIN): its O(n) cost is then spread over Omega(n) updates. */
#define COMPACT_FRACTION 0.5
#define COMPACT_MIN 1024

typedef struct gpoint {
  double x[3];
  double r;
  int32_t next;  /* next slot in the cell's list of own points, -1 */
  int32_t id;    /* the caller's id */
  int32_t cell;  /* -1 for a free slot */
  int32_t prev;  /* previous slot in the list, -1 */
  int16_t level;
  uint8_t bin;
} gpoint;

typedef struct gcell {
  int64_t k[3];
  double maxr;      /* >= every radius in the subtree (grown by updates, made exact by
                       compaction); never below a child's */
  int32_t level;
  int32_t maxlev;   /* highest level filed in the subtree */
  int32_t head;     /* first own point (slot), -1 */
  int32_t child[8]; /* -1 where absent; index = (i & 1) | (j & 1) << 1 | (k & 1) << 2 */
  int32_t parent;   /* -1 for a root */
  int32_t count;    /* points in the subtree; -1 marks a free cell */
  int32_t nown;     /* own points */
  int32_t slot;     /* roots: index in roots[]; free cells: next free cell; else -1 */
  uint32_t hash;
} gcell;

typedef struct hslot {
  uint32_t hash;
  int32_t cell; /* -1: empty */
} hslot;

struct pm_grid {
  double hmin;
  int32_t lmin; /* level of radius hmin */
  int32_t n;    /* points in the grid */

  int32_t *slot_of; /* [id_cap] slot of each id, -1 when absent */
  int32_t id_cap;

  gpoint *pts; /* [slot_cap] */
  int32_t slot_cap, slot_used, free_slot;
  int64_t disorder; /* records written out of order since the last compaction */

  gcell *cells;
  int32_t cells_used; /* high-water mark */
  int32_t cells_cap;
  int32_t free_head;

  hslot *tab;
  uint32_t tab_cap; /* power of two */
  uint32_t tab_used;

  int32_t *roots, *roots2; /* the apex cells; roots2: scratch while the apex level changes */
  int32_t nroots, roots_cap, roots2_cap;

  int32_t top;   /* A: level of the apex cells ("roots", parent -1), meaningful when n > 0 */
  int32_t entry; /* T: where queries enter the tree, M + TOP_GAP <= T <= A */
  int32_t maxl;  /* M: highest level in use (LVL_NONE when empty) */

  int32_t lvl_cnt[NLVL];
  int32_t bin_cnt[NLVL][NBIN];
  double bound[NLVL];
};

/* ---- id buffer ------------------------------------------------------------------------- */

pm_status pm_idbuf_reserve(pm_idbuf *b, int32_t cap, pm_error *err) {
  if (cap <= b->cap) return PM_OK;
  int64_t want = b->cap > 0 ? 2 * (int64_t)b->cap : 32;
  if (want < cap) want = cap;
  if (want > INT32_MAX) want = INT32_MAX;
  int32_t *ids = realloc(b->ids, (size_t)want * sizeof *ids);
  if (!ids)
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory for %lld neighbour ids", (long long)want);
  b->ids = ids;
  b->cap = (int32_t)want;
  return PM_OK;
}

pm_status pm_idbuf_push(pm_idbuf *b, int32_t id, pm_error *err) {
  if (b->n == b->cap) {
    if (b->cap == INT32_MAX)
      return pm_error_setf(err, PM_ERR_LIMIT, "neighbour list longer than %d ids", INT32_MAX);
    pm_status st = pm_idbuf_reserve(b, b->n + 1, err);
    if (st) return st;
  }
  b->ids[b->n++] = id;
  return PM_OK;
}

void pm_idbuf_free(pm_idbuf *b) {
  if (!b) return;
  free(b->ids);
  b->ids = NULL;
  b->n = b->cap = 0;
}

/* Insertion sort for the short lists of most queries, quicksort (median of three, recursing into
 * the smaller part) for long ones. */
void pm_sort_ids(int32_t *a, int32_t n) {
  while (n > 48) {
    int32_t x = a[0], y = a[n / 2], z = a[n - 1];
    int32_t piv = x < y ? (y < z ? y : (x < z ? z : x)) : (x < z ? x : (y < z ? z : y));
    int32_t i = 0, j = n - 1;
    for (;;) {
      while (a[i] < piv) ++i;
      while (a[j] > piv) --j;
      if (i >= j) break;
      int32_t t = a[i];
      a[i] = a[j], a[j] = t;
      ++i, --j;
    }
    /* a[0..j] <= piv <= a[j+1..n-1] */
    int32_t left = j + 1, right = n - left;
    if (left < right) {
      pm_sort_ids(a, left);
      a += left, n = right;
    } else {
      pm_sort_ids(a + left, right);
      n = left;
    }
  }
  for (int32_t i = 1; i < n; ++i) {
    int32_t v = a[i], j = i;
    while (j > 0 && a[j - 1] > v) a[j] = a[j - 1], --j;
    a[j] = v;
  }
}

/* ---- levels, keys, hashing ------------------------------------------------------------- */

/* Bit-level helpers: the queries compute cube corners and keys millions of times per second,
 * and libm's ldexp / floor are calls, not instructions. All levels in use lie in [-1002, 500],
 * so 2^l and 2^-l are normal doubles and scaling by them is exact. */
static inline double pow2i(int32_t l) {
  uint64_t b = (uint64_t)(l + 1023) << 52;
  double d;
  memcpy(&d, &b, sizeof d);
  return d;
}

/* floor for |v| < 2^63 */
static inline int64_t ifloor(double v) {
  int64_t t = (int64_t)v;
  return t - (t > v);
}

/* ceil(log2 r) for r > 0. */
static inline int32_t ceil_log2(double r) {
  uint64_t b;
  memcpy(&b, &r, sizeof b);
  int32_t e = (int32_t)((b >> 52) & 0x7ff);
  if (e == 0) { /* subnormal */
    int ee;
    double f = frexp(r, &ee);
    return f == 0.5 ? ee - 1 : ee;
  }
  return (e - 1023) + ((b & 0xfffffffffffffULL) != 0);
}

/* floor(log2 m) for m > 0, as ilogb. */
static inline int32_t floor_log2(double m) {
  uint64_t b;
  memcpy(&b, &m, sizeof b);
  int32_t e = (int32_t)((b >> 52) & 0x7ff);
  return e == 0 ? ilogb(m) : e - 1023;
}

static inline double max_abs3(const double x[3]) {
  double m = fabs(x[0]);
  if (fabs(x[1]) > m) m = fabs(x[1]);
  if (fabs(x[2]) > m) m = fabs(x[2]);
  return m;
}

static int32_t level_for(const pm_grid *g, const double x[3], double r) {
  int32_t l = r > g->hmin ? ceil_log2(r) - SHIFT : g->lmin;
  double m = max_abs3(x);
  if (m > 0) {
    int32_t lp = floor_log2(m) - 50; /* keys below 2^51 (see KEY_CLAMP) */
    if (l < lp) l = lp;
  }
  return l;
}

/* Eighth-of-an-octave bin of radius r at level l: r / 2^(l+SHIFT) lies in (1/2, 1] for a point
 * filed by its radius; smaller ratios (radii below hmin, coordinate clamp) go to bin 0. */
static inline int bin_for(double r, int32_t l) {
  double y = (r * pow2i(-(l + SHIFT)) - 0.5) * 2 * NBIN; /* in (-8, 8] */
  int t = (int)y;
  int b = t + (t < y) - 1; /* ceil(y) - 1 */
  return b < 0 ? 0 : (b >= NBIN ? NBIN - 1 : b);
}

static inline double bin_edge(int32_t l, int b) {
  return (0.5 + (b + 1) / (2.0 * NBIN)) * pow2i(l + SHIFT);
}

static inline void key_of(const double x[3], int32_t l, int64_t k[3]) {
  double s = pow2i(-l);
  for (int a = 0; a < 3; ++a) k[a] = ifloor(x[a] * s);
}

/* Floor division by 2 for negative keys too (two's complement parity). */
static inline int64_t fdiv2(int64_t k) { return (k - (k & 1)) / 2; }

static inline int child_index(const int64_t k[3]) {
  return (int)((k[0] & 1) | (k[1] & 1) << 1 | (k[2] & 1) << 2);
}

static inline uint32_t key_hash(int32_t l, const int64_t k[3]) {
  uint64_t h = (uint64_t)(uint32_t)l * 0x9E3779B97F4A7C15ULL +
               (uint64_t)k[0] * 0xC2B2AE3D27D4EB4FULL + (uint64_t)k[1] * 0x165667B19E3779F9ULL +
               (uint64_t)k[2] * 0xD6E8FEB86659FD93ULL;
  h ^= h >> 31;
  h *= 0xBF58476D1CE4E5B9ULL;
  h ^= h >> 29;
  return (uint32_t)(h ^ (h >> 32));
}

static int32_t cell_find(const pm_grid *g, int32_t l, const int64_t k[3], uint32_t h) {
  uint32_t mask = g->tab_cap - 1, i = h & mask;
  for (;;) {
    const hslot *s = &g->tab[i];
    if (s->cell < 0) return -1;
    if (s->hash == h) {
      const gcell *c = &g->cells[s->cell];
      if (c->level == l && c->k[0] == k[0] && c->k[1] == k[1] && c->k[2] == k[2]) return s->cell;
    }
    i = (i + 1) & mask;
  }
}

static void hash_put(pm_grid *g, uint32_t h, int32_t cell) {
  uint32_t mask = g->tab_cap - 1, i = h & mask;
  while (g->tab[i].cell >= 0) i = (i + 1) & mask;
  g->tab[i].hash = h;
  g->tab[i].cell = cell;
  g->tab_used++;
}

/* Remove `cell` from the table, shifting later members of its probe run back so that no
 * tombstones are needed. */
static void hash_del(pm_grid *g, int32_t cell) {
  uint32_t mask = g->tab_cap - 1, i = g->cells[cell].hash & mask;
  while (g->tab[i].cell != cell) i = (i + 1) & mask;
  uint32_t j = i;
  for (;;) {
    j = (j + 1) & mask;
    if (g->tab[j].cell < 0) break;
    uint32_t home = g->tab[j].hash & mask;
    /* Move j into the hole at i unless j's home lies cyclically in (i, j]. */
    int stays = (i <= j) ? (home > i && home <= j) : (home > i || home <= j);
    if (!stays) {
      g->tab[i] = g->tab[j];
      i = j;
    }
  }
  g->tab[i].cell = -1;
  g->tab_used--;
}

static void hash_clear(pm_grid *g) {
  for (uint32_t i = 0; i < g->tab_cap; ++i) g->tab[i].cell = -1, g->tab[i].hash = 0;
  g->tab_used = 0;
}

/* Grow the table so that `need` entries keep it at most half full. */
static pm_status hash_grow(pm_grid *g, uint64_t need, pm_error *err) {
  uint64_t cap = g->tab_cap;
  while (need * 2 > cap) cap *= 2;
  if (cap == g->tab_cap) return PM_OK;
  if (cap > (1u << 31)) return pm_error_setf(err, PM_ERR_LIMIT, "neighbour grid: too many cells");
  hslot *t = malloc((size_t)cap * sizeof *t);
  if (!t)
    return pm_error_setf(err, PM_ERR_NOMEM, "neighbour grid: out of memory for %llu hash slots",
                         (unsigned long long)cap);
  hslot *old = g->tab;
  uint32_t oldcap = g->tab_cap;
  g->tab = t;
  g->tab_cap = (uint32_t)cap;
  hash_clear(g);
  for (uint32_t i = 0; i < oldcap; ++i)
    if (old[i].cell >= 0) hash_put(g, old[i].hash, old[i].cell);
  free(old);
  return PM_OK;
}

/* ---- cells ------------------------------------------------------------------------------- */

/* Make sure `extra` more cells (and their hash slots and root slots) can be created without
 * allocating, so that an update never fails half way. */
static pm_status reserve_cells(pm_grid *g, int64_t extra, pm_error *err) {
  int64_t need = (int64_t)g->cells_used + extra;
  if (need > INT32_MAX)
    return pm_error_setf(err, PM_ERR_LIMIT, "neighbour grid: more than %d cells", INT32_MAX);
  if (need > g->cells_cap) {
    int64_t cap = g->cells_cap ? 2 * (int64_t)g->cells_cap : 256;
    if (cap < need) cap = need;
    if (cap > INT32_MAX) cap = INT32_MAX;
    gcell *c = realloc(g->cells, (size_t)cap * sizeof *c);
    if (!c)
      return pm_error_setf(err, PM_ERR_NOMEM, "neighbour grid: out of memory for %lld cells",
                           (long long)cap);
    g->cells = c;
    g->cells_cap = (int32_t)cap;
  }
  pm_status st = hash_grow(g, (uint64_t)g->tab_used + (uint64_t)extra, err);
  if (st) return st;
  int64_t rneed = (int64_t)g->nroots + extra;
  if (rneed > g->roots_cap) {
    int64_t cap = g->roots_cap ? 2 * (int64_t)g->roots_cap : 64;
    if (cap < rneed) cap = rneed;
    int32_t *r = realloc(g->roots, (size_t)cap * sizeof *r);
    if (!r) return pm_error_setf(err, PM_ERR_NOMEM, "neighbour grid: out of memory for roots");
    g->roots = r;
    g->roots_cap = (int32_t)cap;
  }
  return PM_OK;
}

static pm_status reserve_roots2(pm_grid *g, int64_t need, pm_error *err) {
  if (need <= g->roots2_cap) return PM_OK;
  if (need > INT32_MAX) return pm_error_setf(err, PM_ERR_LIMIT, "neighbour grid: too many roots");
  int32_t *r = realloc(g->roots2, (size_t)need * sizeof *r);
  if (!r) return pm_error_setf(err, PM_ERR_NOMEM, "neighbour grid: out of memory for roots");
  g->roots2 = r;
  g->roots2_cap = (int32_t)need;
  return PM_OK;
}

static int32_t cell_alloc(pm_grid *g, int32_t l, const int64_t k[3], uint32_t h) {
  int32_t c;
  if (g->free_head >= 0) {
    c = g->free_head;
    g->free_head = g->cells[c].slot;
  } else {
    c = g->cells_used++;
  }
  gcell *cc = &g->cells[c];
  cc->k[0] = k[0], cc->k[1] = k[1], cc->k[2] = k[2];
  cc->level = l;
  cc->parent = -1;
  for (int i = 0; i < 8; ++i) cc->child[i] = -1;
  cc->count = 0;
  cc->maxlev = LVL_NONE;
  cc->maxr = 0;
  cc->head = -1;
  cc->nown = 0;
  cc->slot = -1;
  cc->hash = h;
  hash_put(g, h, c);
  return c;
}

static void cell_release(pm_grid *g, int32_t c) {
  hash_del(g, c);
  g->cells[c].count = -1;
  g->cells[c].slot = g->free_head;
  g->free_head = c;
}

static void root_add(pm_grid *g, int32_t c) {
  g->cells[c].slot = g->nroots;
  g->roots[g->nroots++] = c;
}

static void root_remove(pm_grid *g, int32_t c) {
  int32_t s = g->cells[c].slot, last = g->roots[--g->nroots];
  g->roots[s] = last;
  g->cells[last].slot = s;
  g->cells[c].slot = -1;
}

/* Unlink an empty cell from its parent (or the root list) and release it. */
static void cell_delete(pm_grid *g, int32_t c) {
  gcell *cc = &g->cells[c];
  if (cc->parent >= 0)
    g->cells[cc->parent].child[child_index(cc->k)] = -1;
  else
    root_remove(g, c);
  cell_release(g, c);
}

/* The cell (l, k), created with its missing ancestors up to an existing one or the top level.
 * Needs reserve_cells(top - l + 1) beforehand; cannot fail then. */
static int32_t cell_get(pm_grid *g, int32_t l, const int64_t k[3]) {
  uint32_t h = key_hash(l, k);
  int32_t c = cell_find(g, l, k, h);
  if (c >= 0) return c;
  c = cell_alloc(g, l, k, h);
  if (l == g->top) {
    root_add(g, c);
  } else {
    int64_t pk[3] = {fdiv2(k[0]), fdiv2(k[1]), fdiv2(k[2])};
    int32_t p = cell_get(g, l + 1, pk);
    g->cells[p].child[child_index(k)] = c;
    g->cells[c].parent = p;
  }
  return c;
}

static int32_t maxlev_of(const pm_grid *g, int32_t c) {
  const gcell *cc = &g->cells[c];
  int32_t m = cc->nown > 0 ? cc->level : LVL_NONE;
  for (int i = 0; i < 8; ++i) {
    int32_t ch = cc->child[i];
    if (ch >= 0 && g->cells[ch].maxlev > m) m = g->cells[ch].maxlev;
  }
  return m;
}

/* Raise the loose radius bound from c upwards until an ancestor already covers r (every
 * ancestor's bound is at least its children's). */
static void raise_maxr(pm_grid *g, int32_t c, double r) {
  for (; c >= 0 && g->cells[c].maxr < r; c = g->cells[c].parent) g->cells[c].maxr = r;
}

/* Recompute maxlev from c upwards, stopping at `stop` or where nothing changes. */
static void fix_maxlev(pm_grid *g, int32_t c, int32_t stop) {
  while (c >= 0 && c != stop) {
    int32_t m = maxlev_of(g, c);
    if (m == g->cells[c].maxlev) return;
    g->cells[c].maxlev = m;
    c = g->cells[c].parent;
  }
}

/* ---- apex and entry levels ------------------------------------------------------------------ */

/* Raise the apex to level l: every apex cell gets a parent one level up, repeatedly. */
static pm_status raise_top(pm_grid *g, int32_t l, pm_error *err) {
  while (g->top < l) {
    pm_status st = reserve_cells(g, g->nroots, err);
    if (!st) st = reserve_roots2(g, g->nroots, err);
    if (st) return st;
    int32_t nn = 0, up = g->top + 1;
    for (int32_t i = 0; i < g->nroots; ++i) {
      int32_t r = g->roots[i];
      int64_t pk[3] = {fdiv2(g->cells[r].k[0]), fdiv2(g->cells[r].k[1]), fdiv2(g->cells[r].k[2])};
      uint32_t h = key_hash(up, pk);
      int32_t p = cell_find(g, up, pk, h);
      if (p < 0) {
        p = cell_alloc(g, up, pk, h);
        g->cells[p].slot = nn;
        g->roots2[nn++] = p;
      }
      gcell *rc = &g->cells[r], *pc = &g->cells[p];
      pc->child[child_index(rc->k)] = r;
      rc->parent = p;
      rc->slot = -1;
      pc->count += rc->count;
      if (rc->maxlev > pc->maxlev) pc->maxlev = rc->maxlev;
      if (rc->maxr > pc->maxr) pc->maxr = rc->maxr;
    }
    int32_t *t = g->roots;
    int32_t tc = g->roots_cap;
    g->roots = g->roots2, g->roots_cap = g->roots2_cap;
    g->roots2 = t, g->roots2_cap = tc;
    g->nroots = nn;
    g->top = up;
  }
  return PM_OK;
}

/* Make room for a point at level l: T at least l + TOP_GAP, the apex at least T. */
static pm_status lift_for(pm_grid *g, int32_t l, pm_error *err) {
  if (l + TOP_GAP <= g->entry) return PM_OK;
  pm_status st = raise_top(g, l + TOP_GAP, err);
  if (!st) g->entry = l + TOP_GAP;
  return st;
}

/* After updates: keep the apex list short (raising merges up to 8 cells into one; optional, so
 * a failed allocation only leaves it longer), bring T down when the largest radius has shrunk
 * (with a lag of 3 levels, so a radius that wobbles across a power of two changes nothing), and
 * drop apex levels that are a single chain (left by a far point that has gone). */
static void settle_levels(pm_grid *g) {
  if (g->n == 0) return;
  while (g->nroots > APEX_MAX && !raise_top(g, g->top + 1, NULL)) {
  }
  if (g->maxl + TOP_GAP + 3 <= g->entry) g->entry = g->maxl + TOP_GAP;
  while (g->top > g->entry && g->nroots == 1) {
    int32_t r = g->roots[0], only = -1, nch = 0;
    for (int c = 0; c < 8; ++c)
      if (g->cells[r].child[c] >= 0) only = g->cells[r].child[c], ++nch;
    if (nch != 1 || g->cells[r].nown > 0) break;
    g->cells[only].parent = -1;
    g->cells[only].slot = 0;
    g->roots[0] = only;
    cell_release(g, r);
    g->top--;
  }
}

/* ---- level statistics -------------------------------------------------------------------- */

static void stats_add(pm_grid *g, int32_t l, int b) {
  int32_t li = l - LVL_LO;
  g->lvl_cnt[li]++;
  g->bin_cnt[li][b]++;
  double e = bin_edge(l, b);
  if (g->lvl_cnt[li] == 1 || e > g->bound[li]) g->bound[li] = e;
  if (g->maxl < l) g->maxl = l;
}

static void stats_remove(pm_grid *g, int32_t l, int b) {
  int32_t li = l - LVL_LO;
  g->lvl_cnt[li]--;
  g->bin_cnt[li][b]--;
  if (g->bin_cnt[li][b] == 0 && g->lvl_cnt[li] > 0) {
    int hb = NBIN - 1;
    while (g->bin_cnt[li][hb] == 0) --hb;
    g->bound[li] = bin_edge(l, hb);
  }
  if (g->lvl_cnt[li] == 0 && l == g->maxl) {
    int32_t m = l;
    while (m >= LVL_LO && g->lvl_cnt[m - LVL_LO] == 0) --m;
    g->maxl = m >= LVL_LO ? m : LVL_NONE;
  }
}

/* ---- compaction ---------------------------------------------------------------------------- */

typedef struct compactor {
  pm_grid *g;
  gpoint *pts;     /* new records */
  gcell *cells;    /* new cells */
  int32_t *map;    /* old cell -> new cell */
  int32_t np, nc;
} compactor;

/* Depth-first copy of cell c and its subtree: own points first, then children in Morton order. */
static void compact_cell(compactor *k, int32_t c) {
  pm_grid *g = k->g;
  int32_t nc = k->nc++;
  k->map[c] = nc;
  gcell *to = &k->cells[nc];
  *to = g->cells[c];
  to->head = to->nown > 0 ? k->np : -1;
  for (int32_t s = g->cells[c].head; s >= 0; s = g->pts[s].next) {
    gpoint *p = &k->pts[k->np];
    *p = g->pts[s];
    p->cell = nc;
    p->prev = k->np == to->head ? -1 : k->np - 1;
    p->next = -1;
    if (p->prev >= 0) k->pts[p->prev].next = k->np;
    g->slot_of[p->id] = k->np;
    k->np++;
  }
  double maxr = 0;
  for (int32_t s = to->head; s >= 0; s = k->pts[s].next) maxr = fmax(maxr, k->pts[s].r);
  for (int i = 0; i < 8; ++i)
    if (g->cells[c].child[i] >= 0) {
      compact_cell(k, g->cells[c].child[i]);
      maxr = fmax(maxr, k->cells[k->map[g->cells[c].child[i]]].maxr);
    }
  k->cells[nc].maxr = maxr; /* exact again: the bound only grew since the last compaction */
}

typedef struct rootkey {
  int64_t k[3];
  int32_t c;
} rootkey;

static int cmp_rootkey(const void *a, const void *b) {
  const rootkey *x = a, *y = b;
  for (int d = 2; d >= 0; --d)
    if (x->k[d] != y->k[d]) return x->k[d] < y->k[d] ? -1 : 1;
  return 0;
}

/* Rewrite points and cells in depth-first order. Optional: on allocation failure nothing
 * changes. */
static void compact(pm_grid *g) {
  compactor k = {g, NULL, NULL, NULL, 0, 0};
  k.pts = malloc((size_t)(g->slot_cap > 0 ? g->slot_cap : 1) * sizeof *k.pts);
  k.cells = malloc((size_t)(g->cells_cap > 0 ? g->cells_cap : 1) * sizeof *k.cells);
  k.map = malloc((size_t)(g->cells_used > 0 ? g->cells_used : 1) * sizeof *k.map);
  rootkey *rk = malloc((size_t)(g->nroots > 0 ? g->nroots : 1) * sizeof *rk);
  if (!k.pts || !k.cells || !k.map || !rk) {
    free(k.pts), free(k.cells), free(k.map), free(rk);
    g->disorder = 0; /* try again after as many updates */
    return;
  }
  /* Roots in lexicographic (k2, k1, k0) order: rows of roots stay together. */
  for (int32_t i = 0; i < g->nroots; ++i) {
    memcpy(rk[i].k, g->cells[g->roots[i]].k, sizeof rk[i].k);
    rk[i].c = g->roots[i];
  }
  qsort(rk, (size_t)g->nroots, sizeof *rk, cmp_rootkey);
  for (int32_t i = 0; i < g->nroots; ++i) g->roots[i] = rk[i].c;
  free(rk);
  for (int32_t i = 0; i < g->nroots; ++i) compact_cell(&k, g->roots[i]);
  for (int32_t c = 0; c < k.nc; ++c) {
    gcell *cc = &k.cells[c];
    if (cc->parent >= 0) cc->parent = k.map[cc->parent];
    for (int i = 0; i < 8; ++i)
      if (cc->child[i] >= 0) cc->child[i] = k.map[cc->child[i]];
  }
  for (int32_t i = 0; i < g->nroots; ++i) {
    g->roots[i] = k.map[g->roots[i]];
    k.cells[g->roots[i]].slot = i;
  }
  free(g->pts);
  free(g->cells);
  free(k.map);
  g->pts = k.pts;
  g->cells = k.cells;
  g->slot_used = k.np;
  g->free_slot = -1;
  g->cells_used = k.nc;
  g->free_head = -1;
  hash_clear(g);
  for (int32_t c = 0; c < k.nc; ++c) hash_put(g, k.cells[c].hash, c);
  g->disorder = 0;
}

static void maybe_compact(pm_grid *g) {
  if (g->disorder > COMPACT_MIN && g->disorder > COMPACT_FRACTION * g->n) compact(g);
}

/* ---- lifecycle ------------------------------------------------------------------------------ */

pm_status pm_grid_create(double hmin, pm_grid **out, pm_error *err) {
  *out = NULL;
  if (!(isfinite(hmin) && hmin > 0))
    return pm_error_setf(err, PM_ERR_ARG, "neighbour grid: hmin must be finite and > 0, got %g",
                         hmin);
  pm_grid *g = calloc(1, sizeof *g);
  if (!g) return pm_error_setf(err, PM_ERR_NOMEM, "neighbour grid: out of memory");
  if (hmin < 0x1p-1000) hmin = 0x1p-1000;
  if (hmin > COORD_MAX) hmin = COORD_MAX;
  g->hmin = hmin;
  g->lmin = ceil_log2(hmin) - SHIFT;
  g->free_head = -1;
  g->free_slot = -1;
  g->top = g->entry = LVL_NONE;
  g->maxl = LVL_NONE;
  g->tab_cap = 64;
  g->tab = malloc(g->tab_cap * sizeof *g->tab);
  if (!g->tab) {
    free(g);
    return pm_error_setf(err, PM_ERR_NOMEM, "neighbour grid: out of memory");
  }
  hash_clear(g);
  *out = g;
  return PM_OK;
}

void pm_grid_destroy(pm_grid *g) {
  if (!g) return;
  free(g->slot_of);
  free(g->pts);
  free(g->cells);
  free(g->tab);
  free(g->roots);
  free(g->roots2);
  free(g);
}

void pm_grid_clear(pm_grid *g) {
  for (int32_t i = 0; i < g->id_cap; ++i) g->slot_of[i] = -1;
  g->n = 0;
  g->slot_used = 0;
  g->free_slot = -1;
  g->disorder = 0;
  g->cells_used = 0;
  g->free_head = -1;
  hash_clear(g);
  g->nroots = 0;
  g->top = g->entry = LVL_NONE;
  g->maxl = LVL_NONE;
  memset(g->lvl_cnt, 0, sizeof g->lvl_cnt);
  memset(g->bin_cnt, 0, sizeof g->bin_cnt);
}

int32_t pm_grid_count(const pm_grid *g) { return g->n; }

pm_status pm_grid_reserve(pm_grid *g, int32_t max_id, pm_error *err) {
  if (max_id < 0) return PM_OK;
  if (max_id == INT32_MAX)
    return pm_error_setf(err, PM_ERR_ARG, "neighbour grid: id %d out of range", max_id);
  if (max_id < g->id_cap) return PM_OK;
  int64_t cap = g->id_cap ? 2 * (int64_t)g->id_cap : 64;
  if (cap < (int64_t)max_id + 1) cap = (int64_t)max_id + 1;
  if (cap > INT32_MAX) cap = INT32_MAX;
  int32_t *s = realloc(g->slot_of, (size_t)cap * sizeof *s);
  if (!s)
    return pm_error_setf(err, PM_ERR_NOMEM, "neighbour grid: out of memory for %lld ids",
                         (long long)cap);
  for (int64_t i = g->id_cap; i < cap; ++i) s[i] = -1;
  g->slot_of = s;
  g->id_cap = (int32_t)cap;
  return PM_OK;
}

pm_status pm_grid_renumber(pm_grid *g, int32_t nmap, const int32_t *new_id, pm_error *err) {
  /* check everything first, so that a bad map leaves the grid as it was */
  int32_t top = -1;
  for (int32_t id = 0; id < g->id_cap; ++id) {
    if (g->slot_of[id] < 0) continue;
    int32_t to = id < nmap ? new_id[id] : -1;
    if (to < 0)
      return pm_error_setf(err, PM_ERR_ARG, "neighbour grid renumbering: point %d has no new id",
                           id);
    if (to > top) top = to;
  }
  int32_t *s = malloc((size_t)(top >= g->id_cap ? top + 1 : g->id_cap) * sizeof *s);
  if (!s) return pm_error_setf(err, PM_ERR_NOMEM, "neighbour grid: out of memory for ids");
  const int32_t cap = top >= g->id_cap ? top + 1 : g->id_cap;
  for (int32_t i = 0; i < cap; ++i) s[i] = -1;
  for (int32_t id = 0; id < g->id_cap; ++id) {
    if (g->slot_of[id] < 0) continue;
    if (s[new_id[id]] >= 0) {
      free(s);
      return pm_error_setf(err, PM_ERR_ARG,
                           "neighbour grid renumbering: two points get the new id %d", new_id[id]);
    }
    s[new_id[id]] = g->slot_of[id];
  }
  for (int32_t id = 0; id < cap; ++id)
    if (s[id] >= 0) g->pts[s[id]].id = id;
  free(g->slot_of);
  g->slot_of = s;
  g->id_cap = cap;
  return PM_OK;
}

/* Room for one more point record. */
static pm_status reserve_slot(pm_grid *g, pm_error *err) {
  if (g->free_slot >= 0 || g->slot_used < g->slot_cap) return PM_OK;
  int64_t cap = g->slot_cap ? 2 * (int64_t)g->slot_cap : 64;
  if (cap > INT32_MAX) cap = INT32_MAX;
  if (cap <= g->slot_used)
    return pm_error_setf(err, PM_ERR_LIMIT, "neighbour grid: more than %d points", INT32_MAX);
  gpoint *p = realloc(g->pts, (size_t)cap * sizeof *p);
  if (!p)
    return pm_error_setf(err, PM_ERR_NOMEM, "neighbour grid: out of memory for %lld points",
                         (long long)cap);
  g->pts = p;
  g->slot_cap = (int32_t)cap;
  return PM_OK;
}

static int32_t slot_alloc(pm_grid *g) {
  if (g->free_slot >= 0) {
    int32_t s = g->free_slot;
    g->free_slot = g->pts[s].next;
    return s;
  }
  return g->slot_used++;
}

static pm_status check_point(const double xyz[3], double r, pm_error *err) {
  for (int a = 0; a < 3; ++a)
    if (!(fabs(xyz[a]) <= COORD_MAX))
      return pm_error_setf(err, PM_ERR_ARG,
                           "neighbour grid: coordinate %g is not finite or beyond 1e150", xyz[a]);
  if (!(r >= 0 && r <= COORD_MAX))
    return pm_error_setf(err, PM_ERR_ARG,
                         "neighbour grid: radius %g is negative, not finite or beyond 1e150", r);
  return PM_OK;
}

static void link_point(pm_grid *g, int32_t s, int32_t c) {
  gpoint *p = &g->pts[s];
  gcell *cc = &g->cells[c];
  p->cell = c;
  p->prev = -1;
  p->next = cc->head;
  if (cc->head >= 0) g->pts[cc->head].prev = s;
  cc->head = s;
  cc->nown++;
}

static void unlink_point(pm_grid *g, int32_t s) {
  gpoint *p = &g->pts[s];
  gcell *cc = &g->cells[p->cell];
  if (p->prev >= 0)
    g->pts[p->prev].next = p->next;
  else
    cc->head = p->next;
  if (p->next >= 0) g->pts[p->next].prev = p->prev;
  cc->nown--;
  p->cell = -1;
}

static int has_id(const pm_grid *g, int32_t id) {
  return id >= 0 && id < g->id_cap && g->slot_of[id] >= 0;
}

pm_status pm_grid_insert(pm_grid *g, int32_t id, const double xyz[3], double r, pm_error *err) {
  if (id < 0 || id == INT32_MAX)
    return pm_error_setf(err, PM_ERR_ARG, "neighbour grid: id %d out of range", id);
  pm_status st = check_point(xyz, r, err);
  if (st) return st;
  if ((st = pm_grid_reserve(g, id, err))) return st;
  if (g->slot_of[id] >= 0)
    return pm_error_setf(err, PM_ERR_ARG, "neighbour grid: id %d is already in the grid", id);
  if ((st = reserve_slot(g, err))) return st;
  int32_t l = level_for(g, xyz, r);
  if (g->n == 0)
    g->top = g->entry = l + TOP_GAP;
  else if ((st = lift_for(g, l, err)))
    return st;
  if ((st = reserve_cells(g, (int64_t)g->top - l + 1, err))) return st;
  int64_t k[3];
  key_of(xyz, l, k);
  int32_t c = cell_get(g, l, k);
  int32_t s = slot_alloc(g);
  gpoint *p = &g->pts[s];
  p->x[0] = xyz[0], p->x[1] = xyz[1], p->x[2] = xyz[2];
  p->r = r;
  p->id = id;
  p->level = (int16_t)l;
  p->bin = (uint8_t)bin_for(r, l);
  g->slot_of[id] = s;
  link_point(g, s, c);
  for (int32_t a = c; a >= 0; a = g->cells[a].parent) {
    g->cells[a].count++;
    if (g->cells[a].maxlev < l) g->cells[a].maxlev = l;
    if (g->cells[a].maxr < r) g->cells[a].maxr = r;
  }
  stats_add(g, l, p->bin);
  g->n++;
  g->disorder++;
  settle_levels(g);
  maybe_compact(g);
  return PM_OK;
}

pm_status pm_grid_remove(pm_grid *g, int32_t id, pm_error *err) {
  if (!has_id(g, id))
    return pm_error_setf(err, PM_ERR_ARG, "neighbour grid: id %d is not in the grid", id);
  int32_t s = g->slot_of[id];
  gpoint *p = &g->pts[s];
  int32_t c = p->cell;
  unlink_point(g, s);
  while (c >= 0) {
    int32_t up = g->cells[c].parent;
    if (--g->cells[c].count == 0)
      cell_delete(g, c);
    else
      g->cells[c].maxlev = maxlev_of(g, c);
    c = up;
  }
  stats_remove(g, p->level, p->bin);
  g->slot_of[id] = -1;
  p->next = g->free_slot;
  g->free_slot = s;
  g->n--;
  if (g->n == 0) g->top = g->entry = LVL_NONE;
  settle_levels(g);
  return PM_OK;
}

pm_status pm_grid_move(pm_grid *g, int32_t id, const double xyz[3], double r, pm_error *err) {
  if (!has_id(g, id))
    return pm_error_setf(err, PM_ERR_ARG, "neighbour grid: id %d is not in the grid", id);
  pm_status st = check_point(xyz, r, err);
  if (st) return st;
  int32_t s = g->slot_of[id];
  gpoint *p = &g->pts[s];
  int32_t l = level_for(g, xyz, r), oc = p->cell;
  int64_t k[3];
  key_of(xyz, l, k);
  int b = bin_for(r, l);
  const gcell *occ = &g->cells[oc];
  if (l == occ->level && k[0] == occ->k[0] && k[1] == occ->k[1] && k[2] == occ->k[2]) {
    /* Same cell: only the position and the radius bin change. */
    p->x[0] = xyz[0], p->x[1] = xyz[1], p->x[2] = xyz[2];
    p->r = r;
    raise_maxr(g, oc, r);
    if (b != p->bin) {
      stats_add(g, l, b); /* add first: the level never looks empty in between */
      stats_remove(g, l, p->bin);
      p->bin = (uint8_t)b;
    }
    return PM_OK;
  }
  if ((st = lift_for(g, l, err))) return st;
  if ((st = reserve_cells(g, (int64_t)g->top - l + 1, err))) return st;
  int32_t nc = cell_get(g, l, k); /* may create cells; never the old one */
  p = &g->pts[s];
  int32_t ol = p->level, ob = p->bin;
  unlink_point(g, s);
  p->x[0] = xyz[0], p->x[1] = xyz[1], p->x[2] = xyz[2];
  p->r = r;
  p->level = (int16_t)l;
  p->bin = (uint8_t)b;
  link_point(g, s, nc);
  raise_maxr(g, nc, r);
  /* Counts: +1 along the new chain, -1 along the old one, up to their lowest common ancestor
   * (above it nothing changes). The lower of the two walkers steps first, so they meet there. */
  int32_t a = nc, o = oc, survivor = -1;
  while (a != o) {
    int32_t la = a >= 0 ? g->cells[a].level : INT32_MAX;
    int32_t lo = o >= 0 ? g->cells[o].level : INT32_MAX;
    if (la <= lo) {
      g->cells[a].count++;
      a = g->cells[a].parent;
    }
    if (lo <= la) {
      int32_t up = g->cells[o].parent;
      if (--g->cells[o].count == 0)
        cell_delete(g, o);
      else if (survivor < 0)
        survivor = o;
      o = up;
    }
  }
  int32_t common = a;
  /* Highest levels: each side below the common ancestor only sees its own change; the common
   * ancestor and above see both. */
  if (survivor >= 0) fix_maxlev(g, survivor, common);
  for (int32_t c = nc; c >= 0 && c != common; c = g->cells[c].parent)
    g->cells[c].maxlev = maxlev_of(g, c);
  if (common >= 0) fix_maxlev(g, common, -1);
  stats_add(g, l, b);
  stats_remove(g, ol, ob);
  settle_levels(g);
  g->disorder++;
  maybe_compact(g);
  return PM_OK;
}

int pm_grid_get(const pm_grid *g, int32_t id, double xyz[3], double *r) {
  if (!has_id(g, id)) return 0;
  const gpoint *p = &g->pts[g->slot_of[id]];
  if (xyz) xyz[0] = p->x[0], xyz[1] = p->x[1], xyz[2] = p->x[2];
  if (r) *r = p->r;
  return 1;
}

/* ---- queries ------------------------------------------------------------------------------ */

static inline double key_dist2(int32_t level, const int64_t k[3], const double x[3]) {
  double s = pow2i(level), d2 = 0;
  for (int a = 0; a < 3; ++a) {
    double lo = (double)k[a] * s, hi = lo + s;
    double d = x[a] < lo ? lo - x[a] : (x[a] > hi ? x[a] - hi : 0);
    d2 += d * d;
  }
  return d2;
}

static inline double point_dist2(const gpoint *p, const double x[3]) {
  double dx = p->x[0] - x[0], dy = p->x[1] - x[1], dz = p->x[2] - x[2];
  return dx * dx + dy * dy + dz * dz;
}

/* Largest radius a point of c's subtree can have: the smaller of two valid bounds, the cell's
 * own (tight after compaction) and the level histogram's for its highest level. */
static inline double radius_bound(const pm_grid *g, const gcell *c) {
  double b = g->bound[c->maxlev - LVL_LO];
  return c->maxr < b ? c->maxr : b;
}

/* Reach of a query over a subtree whose radii are at most rb. */
static inline double reach(pm_grid_kind kind, double r, double rb) {
  switch (kind) {
    case PM_GRID_MUTUAL: return r > rb ? r : rb;
    case PM_GRID_OVERLAP: return r + rb;
    default: return r;
  }
}

typedef struct qctx {
  const pm_grid *g;
  double x[3];
  double r, r2;
  pm_grid_kind kind;
  pm_grid_visit_fn fn;
  void *user;
  int32_t calls;
} qctx;

/* Squared distances from x to the cubes of the 8 children of cell cc, from the parent's key
 * alone (no access to the children's records): per axis the distance to the lower and to the
 * upper half, then the 8 sums. Lets the descent skip a child before touching its memory. */
static inline void child_dist2(const gcell *cc, const double x[3], double d2[8]) {
  double h = pow2i(cc->level - 1), ax[3][2];
  for (int a = 0; a < 3; ++a) {
    double lo = (double)cc->k[a] * (2 * h), mid = lo + h, hi = mid + h;
    double d0 = x[a] < lo ? lo - x[a] : (x[a] > mid ? x[a] - mid : 0);
    double d1 = x[a] < mid ? mid - x[a] : (x[a] > hi ? x[a] - hi : 0);
    ax[a][0] = d0 * d0, ax[a][1] = d1 * d1;
  }
  for (int i = 0; i < 8; ++i) d2[i] = ax[0][i & 1] + ax[1][(i >> 1) & 1] + ax[2][(i >> 2) & 1];
}

/* The descent, one copy per query kind so that the per-point test has no branch on the kind.
 * Visit the subtree of c, whose cube is known to be within reach; returns non-zero when fn asked
 * to stop. A child is entered only if its cube is within the reach computed from the parent's
 * highest level (a bound for the child's), and then within its own. */
#define DEFINE_VISIT(NAME, KIND, ACCEPT)                                                   \
  static int NAME(qctx *q, int32_t c) {                                                    \
    const pm_grid *g = q->g;                                                               \
    const gcell *cc = &g->cells[c];                                                        \
    for (int32_t s = cc->head; s >= 0;) {                                                  \
      const gpoint *p = &g->pts[s];                                                        \
      double d2 = point_dist2(p, q->x);                                                    \
      if (ACCEPT) {                                                                        \
        q->calls++;                                                                        \
        if (q->fn(p->id, d2, q->user)) return 1;                                           \
      }                                                                                    \
      s = p->next;                                                                         \
    }                                                                                      \
    if (cc->count == cc->nown) return 0;                                                   \
    double b = reach(KIND, q->r, radius_bound(g, cc)), lim = b * b * PRUNE_MARGIN;         \
    double cd2[8];                                                                         \
    child_dist2(cc, q->x, cd2);                                                            \
    for (int i = 0; i < 8; ++i) {                                                          \
      int32_t ch = cc->child[i];                                                           \
      if (ch < 0 || cd2[i] > lim) continue;                                                \
      const gcell *hc = &g->cells[ch];                                                     \
      if (KIND != PM_GRID_BALL) {                                                          \
        double bc = reach(KIND, q->r, radius_bound(g, hc));                                \
        if (cd2[i] > bc * bc * PRUNE_MARGIN) continue;                                     \
      }                                                                                    \
      if (NAME(q, ch)) return 1;                                                           \
    }                                                                                      \
    return 0;                                                                              \
  }

DEFINE_VISIT(visit_ball, PM_GRID_BALL, d2 <= q->r2)
DEFINE_VISIT(visit_mutual, PM_GRID_MUTUAL, d2 < (q->r > p->r ? q->r : p->r) * (q->r > p->r ? q->r : p->r))
DEFINE_VISIT(visit_overlap, PM_GRID_OVERLAP, d2 < (q->r + p->r) * (q->r + p->r))

/* Enter cell c from the top: test its own cube, then descend. */
static int visit_cell(qctx *q, int32_t c) {
  const pm_grid *g = q->g;
  const gcell *cc = &g->cells[c];
  double b = reach(q->kind, q->r, radius_bound(g, cc));
  if (key_dist2(cc->level, cc->k, q->x) > b * b * PRUNE_MARGIN) return 0;
  switch (q->kind) {
    case PM_GRID_MUTUAL: return visit_mutual(q, c);
    case PM_GRID_OVERLAP: return visit_overlap(q, c);
    default: return visit_ball(q, c);
  }
}

/* The same descent for pm_grid_query, appending ids straight into the buffer: the id is written
 * unconditionally and the count advanced by the test's outcome, so the point loop has no
 * branch to mispredict (a third of the tested points are answers, in no pattern). */
typedef struct cctx {
  const pm_grid *g;
  double x[3];
  double r, r2;
  pm_grid_kind kind;
  pm_idbuf *out;
  pm_error *err;
  pm_status st;
} cctx;

#define DEFINE_COLLECT(NAME, KIND, ACCEPT)                                                 \
  static int NAME(cctx *q, int32_t c) {                                                    \
    const pm_grid *g = q->g;                                                               \
    const gcell *cc = &g->cells[c];                                                        \
    if (cc->nown > 0) {                                                                    \
      pm_idbuf *out = q->out;                                                              \
      if (out->cap - out->n < cc->nown &&                                                  \
          (q->st = pm_idbuf_reserve(out, out->n + cc->nown, q->err)))                      \
        return 1;                                                                          \
      int32_t *ids = out->ids, n = out->n;                                                 \
      for (int32_t s = cc->head; s >= 0;) {                                                \
        const gpoint *p = &g->pts[s];                                                      \
        double d2 = point_dist2(p, q->x);                                                  \
        ids[n] = p->id;                                                                    \
        n += (ACCEPT);                                                                     \
        s = p->next;                                                                       \
      }                                                                                    \
      out->n = n;                                                                          \
    }                                                                                      \
    if (cc->count == cc->nown) return 0;                                                   \
    double b = reach(KIND, q->r, radius_bound(g, cc)), lim = b * b * PRUNE_MARGIN;         \
    double cd2[8];                                                                         \
    child_dist2(cc, q->x, cd2);                                                            \
    for (int i = 0; i < 8; ++i) {                                                          \
      int32_t ch = cc->child[i];                                                           \
      if (ch < 0 || cd2[i] > lim) continue;                                                \
      const gcell *hc = &g->cells[ch];                                                     \
      if (KIND != PM_GRID_BALL) {                                                          \
        double bc = reach(KIND, q->r, radius_bound(g, hc));                                \
        if (cd2[i] > bc * bc * PRUNE_MARGIN) continue;                                     \
      }                                                                                    \
      if (NAME(q, ch)) return 1;                                                           \
    }                                                                                      \
    return 0;                                                                              \
  }

DEFINE_COLLECT(collect_ball, PM_GRID_BALL, d2 <= q->r2)
DEFINE_COLLECT(collect_mutual, PM_GRID_MUTUAL, d2 < (q->r > p->r ? q->r : p->r) * (q->r > p->r ? q->r : p->r))
DEFINE_COLLECT(collect_overlap, PM_GRID_OVERLAP, d2 < (q->r + p->r) * (q->r + p->r))

static int collect_root(void *ctx, int32_t c) {
  cctx *q = ctx;
  const pm_grid *g = q->g;
  const gcell *cc = &g->cells[c];
  double b = reach(q->kind, q->r, radius_bound(g, cc));
  if (key_dist2(cc->level, cc->k, q->x) > b * b * PRUNE_MARGIN) return 0;
  switch (q->kind) {
    case PM_GRID_MUTUAL: return collect_mutual(q, c);
    case PM_GRID_OVERLAP: return collect_overlap(q, c);
    default: return collect_ball(q, c);
  }
}

/* Call f(c) for every cell of the entry level T whose cube lies within `rch` of x: by hash
 * lookups over the covered keys (skipping keys whose cube is out of reach), or, when the box
 * covers too many keys, by a descent from the apex that prunes on the same distance. */
typedef int (*root_fn)(void *ctx, int32_t c);

static int descend_to_entry(const pm_grid *g, int32_t c, const double x[3], double lim,
                            root_fn f, void *ctx) {
  const gcell *cc = &g->cells[c];
  if (cc->level == g->entry) return f(ctx, c);
  double cd2[8];
  child_dist2(cc, x, cd2);
  for (int i = 0; i < 8; ++i)
    if (cc->child[i] >= 0 && cd2[i] <= lim && descend_to_entry(g, cc->child[i], x, lim, f, ctx))
      return 1;
  return 0;
}

static void for_roots(const pm_grid *g, const double x[3], double rch, root_fn f, void *ctx) {
  double lo[3], hi[3], ncell = 1, lim = rch * rch * PRUNE_MARGIN;
  for (int a = 0; a < 3; ++a) {
    lo[a] = floor(ldexp(x[a] - rch, -g->entry));
    hi[a] = floor(ldexp(x[a] + rch, -g->entry));
    if (!(lo[a] >= -KEY_CLAMP)) lo[a] = -KEY_CLAMP;
    if (!(hi[a] <= KEY_CLAMP)) hi[a] = KEY_CLAMP;
    if (hi[a] < lo[a]) hi[a] = lo[a];
    ncell *= hi[a] - lo[a] + 1;
  }
  if (ncell > LOOKUP_MAX) {
    for (int32_t i = 0; i < g->nroots; ++i) {
      int32_t r = g->roots[i];
      if (key_dist2(g->cells[r].level, g->cells[r].k, x) <= lim &&
          descend_to_entry(g, r, x, lim, f, ctx))
        return;
    }
    return;
  }
  int64_t k[3];
  for (k[2] = (int64_t)lo[2]; k[2] <= (int64_t)hi[2]; ++k[2])
    for (k[1] = (int64_t)lo[1]; k[1] <= (int64_t)hi[1]; ++k[1])
      for (k[0] = (int64_t)lo[0]; k[0] <= (int64_t)hi[0]; ++k[0]) {
        if (key_dist2(g->entry, k, x) > lim) continue;
        int32_t c = cell_find(g, g->entry, k, key_hash(g->entry, k));
        if (c >= 0 && f(ctx, c)) return;
      }
}

static int visit_root(void *ctx, int32_t c) { return visit_cell((qctx *)ctx, c); }

static int query_ok(const double xyz[3], double r) {
  return isfinite(xyz[0]) && isfinite(xyz[1]) && isfinite(xyz[2]) && r >= 0; /* r may be +inf */
}

int32_t pm_grid_visit(const pm_grid *g, const double xyz[3], double r, pm_grid_kind kind,
                      pm_grid_visit_fn fn, void *user) {
  if (g->n == 0 || !query_ok(xyz, r)) return 0;
  qctx q = {g, {xyz[0], xyz[1], xyz[2]}, r, r * r, kind, fn, user, 0};
  for_roots(g, q.x, reach(kind, r, g->bound[g->maxl - LVL_LO]), visit_root, &q);
  return q.calls;
}

pm_status pm_grid_query(const pm_grid *g, const double xyz[3], double r, pm_grid_kind kind,
                        pm_idbuf *out, pm_error *err) {
  out->n = 0;
  if (!query_ok(xyz, r))
    return pm_error_setf(err, PM_ERR_ARG,
                         "neighbour query: point (%g, %g, %g) or radius %g is not valid", xyz[0],
                         xyz[1], xyz[2], r);
  if (kind != PM_GRID_BALL && kind != PM_GRID_MUTUAL && kind != PM_GRID_OVERLAP)
    return pm_error_setf(err, PM_ERR_ARG, "neighbour query: unknown kind %d", (int)kind);
  if (g->n == 0) return PM_OK;
  cctx q = {g, {xyz[0], xyz[1], xyz[2]}, r, r * r, kind, out, err, PM_OK};
  for_roots(g, q.x, reach(kind, r, g->bound[g->maxl - LVL_LO]), collect_root, &q);
  if (q.st) {
    out->n = 0;
    return q.st;
  }
  pm_sort_ids(out->ids, out->n);
  return PM_OK;
}

pm_status pm_grid_query_ball(const pm_grid *g, const double xyz[3], double r, pm_idbuf *out,
                             pm_error *err) {
  return pm_grid_query(g, xyz, r, PM_GRID_BALL, out, err);
}

pm_status pm_grid_query_mutual(const pm_grid *g, const double xyz[3], double r, pm_idbuf *out,
                               pm_error *err) {
  return pm_grid_query(g, xyz, r, PM_GRID_MUTUAL, out, err);
}

pm_status pm_grid_query_overlap(const pm_grid *g, const double xyz[3], double r, pm_idbuf *out,
                                pm_error *err) {
  return pm_grid_query(g, xyz, r, PM_GRID_OVERLAP, out, err);
}

/* ---- k nearest --------------------------------------------------------------------------- */

/* A max-heap of the best k (d2, id) pairs found so far; "better" is the smaller d2, then the
 * smaller id, so the answer is one definite set even with ties. */
typedef struct knn {
  const pm_grid *g;
  double x[3];
  int32_t k, n;
  int32_t *ids;
  double *d2;
} knn;

static inline int worse(double da, int32_t ia, double db, int32_t ib) {
  return da > db || (da == db && ia > ib);
}

static void heap_sift_down(knn *h, int32_t i) {
  for (;;) {
    int32_t l = 2 * i + 1, r = l + 1, m = i;
    if (l < h->n && worse(h->d2[l], h->ids[l], h->d2[m], h->ids[m])) m = l;
    if (r < h->n && worse(h->d2[r], h->ids[r], h->d2[m], h->ids[m])) m = r;
    if (m == i) return;
    double td = h->d2[i];
    int32_t ti = h->ids[i];
    h->d2[i] = h->d2[m], h->ids[i] = h->ids[m];
    h->d2[m] = td, h->ids[m] = ti;
    i = m;
  }
}

static void heap_offer(knn *h, int32_t id, double d2) {
  if (h->n < h->k) {
    int32_t i = h->n++;
    while (i > 0) {
      int32_t p = (i - 1) / 2;
      if (!worse(d2, id, h->d2[p], h->ids[p])) break;
      h->d2[i] = h->d2[p], h->ids[i] = h->ids[p];
      i = p;
    }
    h->d2[i] = d2, h->ids[i] = id;
  } else if (worse(h->d2[0], h->ids[0], d2, id)) {
    h->d2[0] = d2, h->ids[0] = id;
    heap_sift_down(h, 0);
  }
}

/* Depth-first descent for k nearest, nearest child first, pruning on the current k-th distance
 * (the classic tree search): the first dive reaches the points next to x at once, and from then
 * on every subtree farther than the k-th point held is skipped. A best-first order over cube
 * distances does badly here: for a query off a flat point set, large cells look nearer than the
 * small ones that hold the answer, and the frontier fills with them. */
static void knn_descend(knn *h, int32_t c) {
  const pm_grid *g = h->g;
  const gcell *cc = &g->cells[c];
  for (int32_t s = cc->head; s >= 0; s = g->pts[s].next)
    heap_offer(h, g->pts[s].id, point_dist2(&g->pts[s], h->x));
  if (cc->count == cc->nown) return;
  double cd2[8];
  int order[8], n = 0;
  child_dist2(cc, h->x, cd2);
  for (int i = 0; i < 8; ++i) {
    if (cc->child[i] < 0) continue;
    int j = n++;
    while (j > 0 && cd2[order[j - 1]] > cd2[i]) order[j] = order[j - 1], --j;
    order[j] = i;
  }
  for (int j = 0; j < n; ++j) {
    if (h->n == h->k && cd2[order[j]] > h->d2[0] * PRUNE_MARGIN) break; /* sorted: all farther */
    knn_descend(h, cc->child[order[j]]);
  }
}

static void knn_search(knn *h) {
  const pm_grid *g = h->g;
  /* apex cells nearest first (there are at most APEX_MAX of them unless raising them failed) */
  enum { NSORT = 64 };
  int32_t order[NSORT];
  double rd2[NSORT];
  int32_t n = g->nroots < NSORT ? g->nroots : NSORT;
  for (int32_t i = 0; i < n; ++i) {
    int32_t r = g->roots[i], j = i;
    double d2 = key_dist2(g->cells[r].level, g->cells[r].k, h->x);
    while (j > 0 && rd2[j - 1] > d2) rd2[j] = rd2[j - 1], order[j] = order[j - 1], --j;
    rd2[j] = d2, order[j] = r;
  }
  for (int32_t i = 0; i < n; ++i) {
    if (h->n == h->k && rd2[i] > h->d2[0] * PRUNE_MARGIN) break;
    knn_descend(h, order[i]);
  }
  for (int32_t i = n; i < g->nroots; ++i) {
    int32_t r = g->roots[i];
    double d2 = key_dist2(g->cells[r].level, g->cells[r].k, h->x);
    if (h->n < h->k || d2 <= h->d2[0] * PRUNE_MARGIN) knn_descend(h, r);
  }
}

int32_t pm_grid_knearest_fixed(const pm_grid *g, const double xyz[3], int32_t k, int32_t *ids,
                               double *d2) {
  if (k < 1 || g->n == 0 || !query_ok(xyz, 0)) return 0;
  if (k > g->n) k = g->n;
  double dbuf[64];
  double *dd = d2 ? d2 : (k <= 64 ? dbuf : malloc((size_t)k * sizeof *dd));
  if (!dd) return 0;
  knn h = {g, {xyz[0], xyz[1], xyz[2]}, k, 0, ids, dd};
  knn_search(&h);
  /* Heap -> increasing (d2, id). */
  for (int32_t i = 1; i < k; ++i) {
    double dv = dd[i];
    int32_t iv = ids[i], j = i;
    while (j > 0 && worse(dd[j - 1], ids[j - 1], dv, iv)) dd[j] = dd[j - 1], ids[j] = ids[j - 1], --j;
    dd[j] = dv, ids[j] = iv;
  }
  if (dd != d2 && dd != dbuf) free(dd);
  return k;
}

int32_t pm_grid_nearest(const pm_grid *g, const double xyz[3], double *dist) {
  int32_t id;
  double d2;
  if (pm_grid_knearest_fixed(g, xyz, 1, &id, &d2) != 1) return -1;
  if (dist) *dist = sqrt(d2);
  return id;
}

pm_status pm_grid_knearest(const pm_grid *g, const double xyz[3], int32_t k, pm_idbuf *out,
                           pm_error *err) {
  out->n = 0;
  if (k < 1) return pm_error_setf(err, PM_ERR_ARG, "k nearest: k must be >= 1, got %d", k);
  if (!query_ok(xyz, 0))
    return pm_error_setf(err, PM_ERR_ARG, "k nearest: point (%g, %g, %g) is not finite", xyz[0],
                         xyz[1], xyz[2]);
  int32_t want = k < g->n ? k : g->n;
  if (want == 0) return PM_OK;
  pm_status st = pm_idbuf_reserve(out, want, err);
  if (st) return st;
  double *d2 = malloc((size_t)want * sizeof *d2);
  if (!d2)
    return pm_error_setf(err, PM_ERR_NOMEM, "k nearest: out of memory for %d distances", want);
  out->n = pm_grid_knearest_fixed(g, xyz, want, out->ids, d2);
  free(d2);
  pm_sort_ids(out->ids, out->n);
  return PM_OK;
}

/* ---- validation ---------------------------------------------------------------------------- */

#define BAD(...) return pm_error_setf(err, PM_ERR_INTERNAL, "neighbour grid invalid: " __VA_ARGS__)

static pm_status validate_with(const pm_grid *g, int32_t *lvl, int32_t (*bins)[NBIN],
                               pm_error *err) {
  int32_t npts = 0;
  for (int32_t id = 0; id < g->id_cap; ++id) {
    int32_t s = g->slot_of[id];
    if (s < 0) continue;
    ++npts;
    if (s >= g->slot_used) BAD("id %d maps to slot %d beyond %d", id, s, g->slot_used);
    const gpoint *p = &g->pts[s];
    if (p->id != id) BAD("slot %d holds id %d, expected %d", s, p->id, id);
    if (p->cell < 0 || p->cell >= g->cells_used || g->cells[p->cell].count <= 0)
      BAD("point %d refers to dead cell %d", id, p->cell);
    const gcell *c = &g->cells[p->cell];
    int32_t l = level_for(g, p->x, p->r);
    if (l != p->level || c->level != l)
      BAD("point %d filed at level %d, expected %d", id, c->level, l);
    int64_t k[3];
    key_of(p->x, l, k);
    if (k[0] != c->k[0] || k[1] != c->k[1] || k[2] != c->k[2]) BAD("point %d outside its cell", id);
    if (p->r > g->bound[l - LVL_LO])
      BAD("point %d radius %g above level bound %g", id, p->r, g->bound[l - LVL_LO]);
    if (bin_for(p->r, l) != p->bin) BAD("point %d has a stale radius bin", id);
    lvl[l - LVL_LO]++;
    bins[l - LVL_LO][p->bin]++;
  }
  if (npts != g->n) BAD("count %d but %d points stored", g->n, npts);
  int32_t m = LVL_NONE;
  for (int32_t i = 0; i < NLVL; ++i) {
    if (lvl[i] != g->lvl_cnt[i])
      BAD("level %d histogram %d, expected %d", i + LVL_LO, g->lvl_cnt[i], lvl[i]);
    for (int b = 0; b < NBIN; ++b)
      if (bins[i][b] != g->bin_cnt[i][b]) BAD("level %d bin %d histogram off", i + LVL_LO, b);
    if (lvl[i] > 0) {
      m = i + LVL_LO;
      int hb = NBIN - 1;
      while (bins[i][hb] == 0) --hb;
      if (g->bound[i] != bin_edge(i + LVL_LO, hb))
        BAD("level %d bound %g stale", i + LVL_LO, g->bound[i]);
    }
  }
  if (m != g->maxl) BAD("highest level %d, recorded %d", m, g->maxl);
  if (g->n > 0 && (g->entry < g->maxl + TOP_GAP || g->entry > g->maxl + TOP_GAP + 2))
    BAD("entry level %d not within [%d, %d]", g->entry, g->maxl + TOP_GAP, g->maxl + TOP_GAP + 2);
  if (g->n > 0 && g->top < g->entry) BAD("apex level %d below entry level %d", g->top, g->entry);
  int32_t live = 0, rootsum = 0, owned = 0;
  for (int32_t c = 0; c < g->cells_used; ++c) {
    const gcell *cc = &g->cells[c];
    if (cc->count < 0) continue;
    ++live;
    if (cc->count == 0) BAD("empty cell %d kept", c);
    int32_t sum = cc->nown, own = 0;
    for (int32_t s = cc->head; s >= 0; s = g->pts[s].next) {
      if (g->pts[s].cell != c) BAD("cell %d lists slot %d of cell %d", c, s, g->pts[s].cell);
      if (g->slot_of[g->pts[s].id] != s) BAD("cell %d lists a stale slot %d", c, s);
      if (g->pts[s].next >= 0 && g->pts[g->pts[s].next].prev != s) BAD("cell %d list broken", c);
      if (++own > g->n) BAD("cell %d list loops", c);
    }
    if (own != cc->nown) BAD("cell %d owns %d points, recorded %d", c, own, cc->nown);
    owned += own;
    for (int i = 0; i < 8; ++i) {
      int32_t ch = cc->child[i];
      if (ch < 0) continue;
      const gcell *h = &g->cells[ch];
      if (h->count <= 0 || h->parent != c || h->level != cc->level - 1 ||
          child_index(h->k) != i || fdiv2(h->k[0]) != cc->k[0] || fdiv2(h->k[1]) != cc->k[1] ||
          fdiv2(h->k[2]) != cc->k[2])
        BAD("cell %d child %d link broken", c, i);
      sum += h->count;
    }
    if (sum != cc->count) BAD("cell %d count %d, subtree holds %d", c, cc->count, sum);
    if (maxlev_of(g, c) != cc->maxlev) BAD("cell %d maxlev %d stale", c, cc->maxlev);
    for (int32_t s = cc->head; s >= 0; s = g->pts[s].next)
      if (g->pts[s].r > cc->maxr) BAD("cell %d radius bound %g below a radius %g", c, cc->maxr, g->pts[s].r);
    for (int i = 0; i < 8; ++i)
      if (cc->child[i] >= 0 && g->cells[cc->child[i]].maxr > cc->maxr)
        BAD("cell %d radius bound %g below its child's", c, cc->maxr);
    if (cell_find(g, cc->level, cc->k, key_hash(cc->level, cc->k)) != c)
      BAD("cell %d not hashed", c);
    if (cc->parent < 0) {
      if (cc->level != g->top || cc->slot < 0 || cc->slot >= g->nroots || g->roots[cc->slot] != c)
        BAD("root %d not at top level or not listed", c);
      rootsum += cc->count;
    } else if (g->cells[cc->parent].child[child_index(cc->k)] != c) {
      BAD("cell %d not linked from its parent", c);
    }
  }
  if (owned != g->n) BAD("cells own %d points, grid %d", owned, g->n);
  if ((uint32_t)live != g->tab_used) BAD("%d live cells but %u hashed", live, g->tab_used);
  if (rootsum != g->n) BAD("roots hold %d points, grid %d", rootsum, g->n);
  return PM_OK;
}

pm_status pm_grid_validate(const pm_grid *g, pm_error *err) {
  int32_t *lvl = calloc(NLVL, sizeof *lvl);
  int32_t(*bins)[NBIN] = calloc(NLVL, sizeof *bins);
  pm_status st = (!lvl || !bins)
                     ? pm_error_setf(err, PM_ERR_NOMEM, "neighbour grid validation: out of memory")
                     : validate_with(g, lvl, bins, err);
  free(lvl), free(bins);
  return st;
}
