/* The mesh validity checker (see mesh_check.h for what is checked).
 *
 * Layout of the work: element-local checks first (indices, tags, degeneracy, orientation of
 * tets); then the triangle edge table of mesh_topo.h, walked once, edge by edge, for duplicate
 * triangles, orientation within faces, segment conformity, patch boundaries and the shell
 * counts of every volume; then per-shell sums (Euler characteristic, components, enclosed
 * volume); then the tet face table for tet-tet and tet-triangle matching; finally node
 * classification. Each problem kind keeps a count and the first offending case as text.
 */
#include "common/mesh/mesh_check.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/mesh/mesh_topo.h"
#include "common/backends/predicates.h"
#include "common/mesh/element_measure.h"

static const char *const kind_names[PM_CHECK_NKIND] = {
    "bad node indices",
    "element tags or node classifications naming no model cell",
    "duplicate nodes",
    "duplicate elements",
    "zero-area triangles",
    "zero-volume tetrahedra",
    "inverted tetrahedra",
    "inconsistently oriented triangles within a face",
    "nodes classified outside their element's cell",
    "model cells without elements",
    "segments that are not edges of the faces their curve bounds",
    "face patch boundary edges without a boundary-curve segment",
    "edges with more than two triangles of one face",
    "open or over-used shell edges",
    "inconsistently oriented shells",
    "shells oriented inwards",
    "tetrahedron faces shared badly",
    "tetrahedra boundary not matching the shell triangles",
    "triangles against their face's mesh orientation",
};

const char *pm_check_kind_name(pm_check_kind k) {
  return (k >= 0 && k < PM_CHECK_NKIND) ? kind_names[k] : "unknown problem";
}

void pm_check_report_clear(pm_check_report *r) {
  if (!r) return;
  free(r->shell);
  memset(r, 0, sizeof *r);
}

/* ---- small growable int64 list ------------------------------------------------------------ */

typedef struct ilist {
  int64_t *v;
  size_t n, cap;
} ilist;

static int ilist_push(ilist *l, int64_t x) {
  if (l->n == l->cap) {
    size_t c = l->cap ? 2 * l->cap : 16;
    int64_t *p = realloc(l->v, c * sizeof *p);
    if (!p) return 0;
    l->v = p;
    l->cap = c;
  }
  l->v[l->n++] = x;
  return 1;
}

static int cmp_i64(const void *a, const void *b) {
  int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
  return (x > y) - (x < y);
}

static void ilist_sort_unique(ilist *l) {
  if (l->n < 2) return;
  qsort(l->v, l->n, sizeof *l->v, cmp_i64);
  size_t k = 1;
  for (size_t i = 1; i < l->n; ++i)
    if (l->v[i] != l->v[k - 1]) l->v[k++] = l->v[i];
  l->n = k;
}

static int sorted_has(const int64_t *v, size_t n, int64_t x) {
  size_t lo = 0, hi = n;
  while (lo < hi) {
    size_t mid = lo + (hi - lo) / 2;
    if (v[mid] == x) return 1;
    if (v[mid] < x)
      lo = mid + 1;
    else
      hi = mid;
  }
  return 0;
}

static inline int64_t cref(int dim, int32_t index) { return ((int64_t)dim << 32) | (uint32_t)index; }

/* ---- the checker's state ------------------------------------------------------------------ */

typedef struct ctx {
  const pm_mesh *m;
  const pm_model *md;
  pm_check_report *r;
  char first[PM_CHECK_NKIND][240];
  int nomem;

  uint8_t *seg_ok, *tri_ok, *tet_ok; /* indices valid and distinct */
  int32_t *seg_c, *tri_c, *tet_c;    /* cell index when valid for the model, else -1 */

  /* Model tables (model given). */
  int32_t nc, nf, nv;
  int64_t *fc_off; int32_t *fc_curve;        /* face -> boundary curve uses, sorted */
  int64_t *cf_off; int32_t *cf_face;         /* curve -> faces it bounds or is embedded in */
  int64_t *fv_off; int32_t *fv_vol;         /* face -> volumes it bounds */
  int8_t *fv_sense;                          /* ... and the sign that turns the face's triangles
                                                outward of that volume (face_sign x sense) */
  int8_t *face_sign;                         /* [nf] pm_face_mesh_sign of each face */
  int64_t *cv_off; int32_t *cv_vol; int32_t *cv_uses; /* curve -> (volume, uses in shell) */
  int64_t *fh_off; int32_t *fh_vol;          /* face -> volumes it is embedded in */
  int64_t *ch_off; int32_t *ch_vol;          /* curve -> volumes it is embedded in */
  ilist *closure[4];                         /* [dim][i]: sorted cells in the closure */
  uint8_t *vol_has_tets;

  /* Shell accounting per volume (or one whole-mesh shell). */
  int64_t *shell_edges, *shell_open, *shell_nonmanifold;
} ctx;

static void note(ctx *c, pm_check_kind k, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

static void note(ctx *c, pm_check_kind k, const char *fmt, ...) {
  if (c->r->count[k]++ == 0) {
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(c->first[k], sizeof c->first[k], fmt, ap);
    va_end(ap);
  }
}

static const char *dim_name(int d) {
  static const char *const n[4] = {"vertex", "curve", "face", "volume"};
  return (d >= 0 && d < 4) ? n[d] : "cell";
}

/* ---- element-local checks ----------------------------------------------------------------- */

static void check_indices(ctx *c, const int32_t *conn, int32_t n, int per, uint8_t *ok,
                          const char *what) {
  int32_t nn = c->m->nnode;
  for (int32_t t = 0; t < n; ++t) {
    const int32_t *e = conn + (size_t)per * t;
    ok[t] = 1;
    for (int k = 0; k < per; ++k) {
      if (e[k] < 0 || e[k] >= nn) {
        note(c, PM_CHECK_INDEX, "%s %ld uses node %ld of %ld", what, (long)t, (long)e[k],
             (long)nn);
        ok[t] = 0;
        break;
      }
      for (int j = 0; j < k; ++j)
        if (e[j] == e[k] && ok[t]) {
          note(c, PM_CHECK_INDEX, "%s %ld repeats node %ld", what, (long)t, (long)e[k]);
          ok[t] = 0;
        }
      if (!ok[t]) break;
    }
  }
}

static void check_tags(ctx *c, const int32_t *tags, int32_t n, int dim, int32_t *cellof,
                       const char *what) {
  for (int32_t t = 0; t < n; ++t) {
    cellof[t] = -1;
    if (!c->md) continue;
    int32_t g = tags[t];
    if (g < 0 || g >= c->md->count[dim])
      note(c, PM_CHECK_CELL_TAG, "%s %ld is tagged %s %ld, the model has %ld", what, (long)t,
           dim_name(dim), (long)g, (long)c->md->count[dim]);
    else
      cellof[t] = g;
  }
}

static void check_node_tags(ctx *c) {
  const pm_mesh *m = c->m;
  if (!c->md) return;
  for (int32_t v = 0; v < m->nnode; ++v) {
    int d = m->node_dim[v];
    if (d < 0) continue;
    if (d > 3 || m->node_cell[v] < 0 || m->node_cell[v] >= c->md->count[d])
      note(c, PM_CHECK_CELL_TAG, "node %ld is classified on %s %ld, which the model lacks",
           (long)v, dim_name(d), (long)m->node_cell[v]);
  }
}

static void check_degenerate(ctx *c) {
  const pm_mesh *m = c->m;
  for (int32_t t = 0; t < m->ntri; ++t) {
    if (!c->tri_ok[t]) continue;
    const int32_t *e = m->tri + 3 * (size_t)t;
    pm_tri_measure q;
    pm_tri_measure_eval(m->xyz + 3 * (size_t)e[0], m->xyz + 3 * (size_t)e[1],
                        m->xyz + 3 * (size_t)e[2], &q);
    if (q.degenerate)
      note(c, PM_CHECK_ZERO_AREA, "triangle %ld (nodes %ld %ld %ld), area %g", (long)t,
           (long)e[0], (long)e[1], (long)e[2], q.area);
  }
  for (int32_t t = 0; t < m->ntet; ++t) {
    if (!c->tet_ok[t]) continue;
    const int32_t *e = m->tet + 4 * (size_t)t;
    const double *p0 = m->xyz + 3 * (size_t)e[0], *p1 = m->xyz + 3 * (size_t)e[1],
                 *p2 = m->xyz + 3 * (size_t)e[2], *p3 = m->xyz + 3 * (size_t)e[3];
    pm_tet_measure q;
    pm_tet_measure_eval(p0, p1, p2, p3, &q);
    if (q.degenerate)
      note(c, PM_CHECK_ZERO_VOLUME, "tetrahedron %ld (nodes %ld %ld %ld %ld), volume %g",
           (long)t, (long)e[0], (long)e[1], (long)e[2], (long)e[3], q.volume);
    else if (pm_orient3d(p0, p1, p2, p3) < 0) /* exact sign: topology, not a tolerance */
      note(c, PM_CHECK_INVERTED, "tetrahedron %ld (nodes %ld %ld %ld %ld), volume %g", (long)t,
           (long)e[0], (long)e[1], (long)e[2], (long)e[3], q.volume);
  }
}

/* Duplicate nodes through a hash grid. The cells are 1024 times the tolerance wide, so that a
 * node almost always has a cell to itself and only looks into a neighbouring cell when it lies
 * within the tolerance of that side (one probe instead of 27, typically). */
typedef struct grid_slot {
  int64_t key[3];
  int32_t head; /* first node in the cell, -1 for an empty slot */
} grid_slot;

static uint64_t hash3(const int64_t k[3]) {
  uint64_t h = (uint64_t)k[0] * 0x9E3779B97F4A7C15ull;
  h ^= (uint64_t)k[1] * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
  h ^= (uint64_t)k[2] * 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
  return h ^ (h >> 31);
}

static int check_dup_nodes(ctx *c) {
  const pm_mesh *m = c->m;
  int32_t n = m->nnode;
  if (n < 2) return 1;
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (int32_t v = 0; v < n; ++v)
    for (int k = 0; k < 3; ++k) {
      double x = m->xyz[3 * (size_t)v + k];
      if (!isfinite(x)) {
        note(c, PM_CHECK_DUP_NODE, "node %ld has a non-finite coordinate", (long)v);
        return 1;
      }
      lo[k] = fmin(lo[k], x);
      hi[k] = fmax(hi[k], x);
    }
  double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                     (hi[2] - lo[2]) * (hi[2] - lo[2]));
  double tol = PM_CHECK_DUP_NODE_REL * diag;
  if (!(tol > 0)) {
    note(c, PM_CHECK_DUP_NODE, "all %ld nodes coincide", (long)n);
    c->r->count[PM_CHECK_DUP_NODE] += n - 2;
    return 1;
  }
  size_t cap = 1;
  while (cap < 2 * (size_t)n) cap <<= 1;
  grid_slot *slot = malloc(cap * sizeof *slot);
  int32_t *next = malloc((size_t)n * sizeof *next);
  if (!slot || !next) {
    free(slot);
    free(next);
    return 0;
  }
  for (size_t i = 0; i < cap; ++i) slot[i].head = -1;
  double tol2 = tol * tol, h = 1024.0 * tol;
  for (int32_t v = 0; v < n; ++v) {
    const double *p = m->xyz + 3 * (size_t)v;
    int64_t key[3];
    int lo_off[3], hi_off[3];
    for (int k = 0; k < 3; ++k) {
      double f = (p[k] - lo[k]) / h;
      key[k] = (int64_t)floor(f);
      double in = (p[k] - lo[k]) - (double)key[k] * h; /* position inside the cell */
      lo_off[k] = in <= tol ? -1 : 0;
      hi_off[k] = h - in <= tol ? 1 : 0;
    }
    int found = -1;
    for (int dx = lo_off[0]; dx <= hi_off[0] && found < 0; ++dx)
      for (int dy = lo_off[1]; dy <= hi_off[1] && found < 0; ++dy)
        for (int dz = lo_off[2]; dz <= hi_off[2] && found < 0; ++dz) {
          int64_t k2[3] = {key[0] + dx, key[1] + dy, key[2] + dz};
          for (size_t hs = hash3(k2) & (cap - 1);; hs = (hs + 1) & (cap - 1)) {
            if (slot[hs].head < 0) break;
            if (slot[hs].key[0] != k2[0] || slot[hs].key[1] != k2[1] ||
                slot[hs].key[2] != k2[2])
              continue;
            for (int32_t w = slot[hs].head; w >= 0; w = next[w]) {
              const double *q = m->xyz + 3 * (size_t)w;
              double d2 = (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                          (p[2] - q[2]) * (p[2] - q[2]);
              if (d2 <= tol2) {
                found = w;
                break;
              }
            }
            break;
          }
        }
    if (found >= 0)
      note(c, PM_CHECK_DUP_NODE, "nodes %ld and %ld at (%g, %g, %g)", (long)found, (long)v,
           p[0], p[1], p[2]);
    size_t hs = hash3(key) & (cap - 1);
    while (slot[hs].head >= 0 &&
           (slot[hs].key[0] != key[0] || slot[hs].key[1] != key[1] || slot[hs].key[2] != key[2]))
      hs = (hs + 1) & (cap - 1);
    if (slot[hs].head < 0) memcpy(slot[hs].key, key, sizeof key);
    next[v] = slot[hs].head;
    slot[hs].head = v;
  }
  free(slot);
  free(next);
  return 1;
}

/* ---- model tables ------------------------------------------------------------------------- */

/* Build CSR "from -> (to, extra)" out of (from, to, extra) triples. */
typedef struct trip {
  int32_t from, to, extra;
} trip;

static int cmp_trip(const void *pa, const void *pb) {
  const trip *a = pa, *b = pb;
  if (a->from != b->from) return (a->from > b->from) - (a->from < b->from);
  if (a->to != b->to) return (a->to > b->to) - (a->to < b->to);
  return (a->extra > b->extra) - (a->extra < b->extra);
}

static int csr_from_trips(trip *t, size_t n, int32_t nfrom, int64_t **off, int32_t **to,
                          int32_t **extra) {
  if (n > 1) qsort(t, n, sizeof *t, cmp_trip);
  *off = calloc((size_t)nfrom + 1, sizeof **off);
  *to = malloc((n ? n : 1) * sizeof **to);
  if (extra) *extra = malloc((n ? n : 1) * sizeof **extra);
  if (!*off || !*to || (extra && !*extra)) return 0;
  for (size_t i = 0; i < n; ++i) {
    (*off)[t[i].from + 1]++;
    (*to)[i] = t[i].to;
    if (extra) (*extra)[i] = t[i].extra;
  }
  for (int32_t i = 0; i < nfrom; ++i) (*off)[i + 1] += (*off)[i];
  return 1;
}

typedef struct tripbuf {
  trip *t;
  size_t n, cap;
} tripbuf;

static int trip_push(tripbuf *b, int32_t from, int32_t to, int32_t extra) {
  if (b->n == b->cap) {
    size_t c = b->cap ? 2 * b->cap : 64;
    trip *p = realloc(b->t, c * sizeof *p);
    if (!p) return 0;
    b->t = p;
    b->cap = c;
  }
  b->t[b->n++] = (trip){from, to, extra};
  return 1;
}

static int valid_ref(const pm_model *md, int dim, int32_t i) {
  return dim >= 0 && dim <= 3 && i >= 0 && i < md->count[dim];
}

/* Add cell (dim, i) and everything on its boundary or embedded in it to l. */
static int add_closure(const pm_model *md, int dim, int32_t i, ilist *l, int depth) {
  if (!valid_ref(md, dim, i) || depth > 8) return 1;
  if (!ilist_push(l, cref(dim, i))) return 0;
  const pm_cell *cl = &md->cells[dim][i];
  if (dim > 0)
    for (int32_t k = 0; k < cl->nbound; ++k)
      if (!add_closure(md, dim - 1, cl->bound[k].cell, l, depth + 1)) return 0;
  for (int32_t k = 0; k < cl->nembed; ++k)
    if (cl->embed[k].dim < dim &&
        !add_closure(md, cl->embed[k].dim, cl->embed[k].index, l, depth + 1))
      return 0;
  return 1;
}

static int build_model_tables(ctx *c) {
  const pm_model *md = c->md;
  c->nc = md->count[1];
  c->nf = md->count[2];
  c->nv = md->count[3];
  tripbuf fc = {0}, cf = {0}, fv = {0}, cv = {0}, fh = {0}, ch = {0};
  int ok = 1;
  for (int32_t f = 0; f < c->nf && ok; ++f) {
    const pm_cell *cl = &md->cells[2][f];
    for (int32_t k = 0; k < cl->nbound && ok; ++k) {
      int32_t cu = cl->bound[k].cell;
      if (cu < 0 || cu >= c->nc) continue;
      ok = trip_push(&fc, f, cu, 0) && trip_push(&cf, cu, f, 0);
    }
    for (int32_t k = 0; k < cl->nembed && ok; ++k)
      if (cl->embed[k].dim == 1 && valid_ref(md, 1, cl->embed[k].index))
        ok = trip_push(&cf, cl->embed[k].index, f, 1);
  }
  for (int32_t v = 0; v < c->nv && ok; ++v) {
    const pm_cell *cl = &md->cells[3][v];
    for (int32_t k = 0; k < cl->nbound && ok; ++k) {
      int32_t f = cl->bound[k].cell;
      if (f < 0 || f >= c->nf) continue;
      ok = trip_push(&fv, f, v, cl->bound[k].sense);
      const pm_cell *fc2 = &md->cells[2][f];
      for (int32_t j = 0; j < fc2->nbound && ok; ++j)
        if (fc2->bound[j].cell >= 0 && fc2->bound[j].cell < c->nc)
          ok = trip_push(&cv, fc2->bound[j].cell, v, 1);
      /* A curve embedded in a shell face has that face's triangles on both sides. */
      for (int32_t j = 0; j < fc2->nembed && ok; ++j)
        if (fc2->embed[j].dim == 1 && valid_ref(md, 1, fc2->embed[j].index))
          ok = trip_push(&cv, fc2->embed[j].index, v, 1) &&
               trip_push(&cv, fc2->embed[j].index, v, 1);
    }
    for (int32_t k = 0; k < cl->nembed && ok; ++k) {
      const pm_cellref *er = &cl->embed[k];
      if (er->dim == 2 && valid_ref(md, 2, er->index)) ok = trip_push(&fh, er->index, v, 0);
      if (er->dim == 1 && valid_ref(md, 1, er->index)) ok = trip_push(&ch, er->index, v, 0);
    }
  }
  if (ok) ok = csr_from_trips(fh.t, fh.n, c->nf, &c->fh_off, &c->fh_vol, NULL);
  if (ok) ok = csr_from_trips(ch.t, ch.n, c->nc, &c->ch_off, &c->ch_vol, NULL);
  free(fh.t);
  free(ch.t);
  if (ok) ok = csr_from_trips(fc.t, fc.n, c->nf, &c->fc_off, &c->fc_curve, NULL);
  /* curve -> faces: a face appears once however many times it uses the curve */
  if (ok && cf.n > 1) {
    qsort(cf.t, cf.n, sizeof *cf.t, cmp_trip);
    size_t k = 1;
    for (size_t i = 1; i < cf.n; ++i)
      if (cf.t[i].from != cf.t[k - 1].from || cf.t[i].to != cf.t[k - 1].to) cf.t[k++] = cf.t[i];
    cf.n = k;
  }
  if (ok) ok = csr_from_trips(cf.t, cf.n, c->nc, &c->cf_off, &c->cf_face, NULL);
  int32_t *sense32 = NULL;
  if (ok) ok = csr_from_trips(fv.t, fv.n, c->nf, &c->fv_off, &c->fv_vol, &sense32);
  if (ok) {
    c->fv_sense = malloc((fv.n ? fv.n : 1) * sizeof *c->fv_sense);
    ok = c->fv_sense != NULL;
    for (size_t i = 0; ok && i < fv.n; ++i) c->fv_sense[i] = (int8_t)(sense32[i] < 0 ? -1 : 1);
  }
  free(sense32);
  /* The orientation of each face's triangles (geom.h, pm_face_mesh_sign): outward of the first
   * volume the face bounds, the natural normal for a face that bounds none. A model whose `up`
   * lists were not derived (pm_model_finish not run) gets the same rule from the bound lists:
   * the first volume is the one of lowest index. */
  if (ok) {
    c->face_sign = malloc((size_t)(c->nf ? c->nf : 1));
    ok = c->face_sign != NULL;
  }
  for (int32_t f = 0; ok && f < c->nf; ++f) {
    if (md->cells[2][f].nup > 0)
      c->face_sign[f] = (int8_t)pm_face_mesh_sign(md, f);
    else
      c->face_sign[f] = (int8_t)(c->fv_off[f + 1] > c->fv_off[f] ? c->fv_sense[c->fv_off[f]] : 1);
  }
  /* From here on fv_sense is the outward sign of the triangles themselves in each volume. */
  for (int32_t f = 0; ok && f < c->nf; ++f)
    for (int64_t k = c->fv_off[f]; k < c->fv_off[f + 1]; ++k)
      c->fv_sense[k] = (int8_t)(c->fv_sense[k] * c->face_sign[f]);
  /* curve -> (volume, number of uses of the curve by the volume's shell faces) */
  if (ok && cv.n > 0) {
    qsort(cv.t, cv.n, sizeof *cv.t, cmp_trip);
    size_t k = 0;
    for (size_t i = 0; i < cv.n; ++i) {
      if (k > 0 && cv.t[k - 1].from == cv.t[i].from && cv.t[k - 1].to == cv.t[i].to)
        cv.t[k - 1].extra++;
      else
        cv.t[k++] = cv.t[i];
    }
    cv.n = k;
  }
  if (ok) ok = csr_from_trips(cv.t, cv.n, c->nc, &c->cv_off, &c->cv_vol, &c->cv_uses);
  free(fc.t);
  free(cf.t);
  free(fv.t);
  free(cv.t);
  for (int d = 1; d <= 3 && ok; ++d) {
    c->closure[d] = calloc((size_t)(md->count[d] ? md->count[d] : 1), sizeof(ilist));
    if (!c->closure[d]) return 0;
    for (int32_t i = 0; i < md->count[d] && ok; ++i) {
      ok = add_closure(md, d, i, &c->closure[d][i], 0);
      ilist_sort_unique(&c->closure[d][i]);
    }
  }
  return ok;
}

static int uses_of(const ctx *c, int32_t f, int32_t curve) {
  int n = 0;
  for (int64_t k = c->fc_off[f]; k < c->fc_off[f + 1]; ++k) n += c->fc_curve[k] == curve;
  return n;
}

static int shell_uses(const ctx *c, int32_t curve, int32_t v) {
  for (int64_t k = c->cv_off[curve]; k < c->cv_off[curve + 1]; ++k)
    if (c->cv_vol[k] == v) return c->cv_uses[k];
  return 0;
}

/* ---- the triangle edge walk --------------------------------------------------------------- */

typedef struct erec {
  int32_t cell, tri;
  int8_t dir;
} erec;

typedef struct vacc {
  int32_t vol;
  int k;
  int sdir;
} vacc;

/* Elements at one edge or face up to which pairs are compared directly (a sound mesh has one or
 * two there); more, which only a broken mesh has, are sorted instead, so that no input makes the
 * checker quadratic in the number of elements. */
#define GROUP_DIRECT 8

/* (value, tiebreak) pairs of int32. */
static int cmp_pair(const void *pa, const void *pb) {
  const int32_t *a = pa, *b = pb;
  if (a[0] != b[0]) return (a[0] > b[0]) - (a[0] < b[0]);
  return (a[1] > b[1]) - (a[1] < b[1]);
}

static int cmp_erec(const void *pa, const void *pb) {
  const erec *a = pa, *b = pb;
  if (a->cell != b->cell) return (a->cell > b->cell) - (a->cell < b->cell);
  return (a->tri > b->tri) - (a->tri < b->tri);
}

static void sort_erecs(erec *r, int n) {
  if (n > GROUP_DIRECT) {
    qsort(r, (size_t)n, sizeof *r, cmp_erec);
    return;
  }
  for (int i = 1; i < n; ++i) {
    erec x = r[i];
    int j = i;
    while (j > 0 && (r[j - 1].cell > x.cell || (r[j - 1].cell == x.cell && r[j - 1].tri > x.tri))) {
      r[j] = r[j - 1];
      --j;
    }
    r[j] = x;
  }
}

static int walk_edges(ctx *c, const pm_edges *e, const int32_t *tri, const int32_t *tri_id,
                      const int64_t *es_off, const int32_t *es_seg) {
  const pm_mesh *m = c->m;
  int64_t maxn = 0;
  for (int64_t i = 0; i < e->nedge; ++i)
    if (e->off[i + 1] - e->off[i] > maxn) maxn = e->off[i + 1] - e->off[i];
  erec *rec = malloc((size_t)(maxn ? maxn : 1) * sizeof *rec);
  int32_t *third = malloc((size_t)(maxn ? maxn : 1) * 2 * sizeof *third);
  /* The volumes whose shells meet at one edge: a face may bound any number of volumes in a
   * model read from a file, so one slot per volume of the model, found through va_at (the edge
   * that last used a volume's slot, and which slot). */
  int32_t nvol = c->md ? c->nv : 0;
  vacc *va = malloc((size_t)(nvol ? nvol : 1) * sizeof *va);
  int64_t *va_edge = malloc((size_t)(nvol ? nvol : 1) * sizeof *va_edge);
  int32_t *va_at = malloc((size_t)(nvol ? nvol : 1) * sizeof *va_at);
  if (!rec || !third || !va || !va_edge || !va_at) {
    free(rec);
    free(third);
    free(va);
    free(va_edge);
    free(va_at);
    return 0;
  }
  for (int32_t v = 0; v < nvol; ++v) va_edge[v] = -1;
  for (int64_t i = 0; i < e->nedge; ++i) {
    int32_t a = e->ends[2 * i], b = e->ends[2 * i + 1];
    int n = (int)(e->off[i + 1] - e->off[i]);
    /* Duplicate triangles: among the triangles whose two smallest nodes are (a, b), a repeated
     * third node. */
    int nt = 0;
    for (int k = 0; k < n; ++k) {
      int32_t tl = e->elem[e->off[i] + k];
      const int32_t *v = tri + 3 * (size_t)tl;
      int32_t x = (int32_t)((int64_t)v[0] + v[1] + v[2] - a - b); /* nodes are distinct */
      if (x > b) {
        third[2 * nt] = x;
        third[2 * nt + 1] = tl;
        ++nt;
      }
    }
    if (nt > GROUP_DIRECT) {
      qsort(third, (size_t)nt, 2 * sizeof *third, cmp_pair);
      for (int p = 1; p < nt; ++p)
        if (third[2 * p] == third[2 * p - 2])
          note(c, PM_CHECK_DUP_ELEMENT, "triangles %ld and %ld (nodes %ld %ld %ld)",
               (long)tri_id[third[2 * p - 1]], (long)tri_id[third[2 * p + 1]], (long)a, (long)b,
               (long)third[2 * p]);
    } else {
      for (int p = 1; p < nt; ++p)
        for (int q = 0; q < p; ++q)
          if (third[2 * p] == third[2 * q]) {
            note(c, PM_CHECK_DUP_ELEMENT, "triangles %ld and %ld (nodes %ld %ld %ld)",
                 (long)tri_id[third[2 * q + 1]], (long)tri_id[third[2 * p + 1]], (long)a, (long)b,
                 (long)third[2 * p]);
            break;
          }
    }

    for (int k = 0; k < n; ++k) {
      int32_t tl = e->elem[e->off[i] + k];
      int32_t t = tri_id[tl];
      rec[k] = (erec){c->md ? c->tri_c[t] : m->tri_cell[t], t, e->dir[e->off[i] + k]};
    }
    sort_erecs(rec, n);
    int nva = 0;
    for (int g = 0; g < n;) {
      int h = g;
      while (h < n && rec[h].cell == rec[g].cell) ++h;
      int nf = h - g;
      int32_t f = rec[g].cell;
      if (nf == 2 && rec[g].dir == rec[g + 1].dir)
        note(c, PM_CHECK_ORIENTATION, "triangles %ld and %ld of face %ld along nodes %ld-%ld",
             (long)rec[g].tri, (long)rec[g + 1].tri, (long)f, (long)a, (long)b);
      if (c->md && f >= 0) {
        if (nf > 2)
          note(c, PM_CHECK_FACE_NONMANIFOLD, "%d triangles of face %ld along nodes %ld-%ld", nf,
               (long)f, (long)a, (long)b);
        if (nf == 1) {
          int found = 0;
          for (int64_t s = es_off[i]; s < es_off[i + 1] && !found; ++s) {
            int32_t cu = c->seg_c[es_seg[s]];
            if (cu >= 0 && uses_of(c, f, cu) > 0) found = 1;
          }
          if (!found)
            note(c, PM_CHECK_PATCH_BOUNDARY,
                 "triangle %ld of face %ld has edge %ld-%ld on no segment of the face's "
                 "boundary curves",
                 (long)rec[g].tri, (long)f, (long)a, (long)b);
        }
        /* Shell counts: every volume this face bounds. */
        for (int64_t s = c->fv_off[f]; s < c->fv_off[f + 1]; ++s) {
          int32_t vol = c->fv_vol[s];
          if (va_edge[vol] != i) {
            va_edge[vol] = i;
            va_at[vol] = nva;
            va[nva++] = (vacc){vol, 0, 0};
          }
          int j = va_at[vol];
          va[j].k += nf;
          for (int r2 = g; r2 < h; ++r2) va[j].sdir += rec[r2].dir * c->fv_sense[s];
        }
      }
      g = h;
    }
    if (!c->md) {
      /* The whole-mesh shell: every edge should have two triangles. */
      c->shell_edges[0]++;
      if (n != 2) c->shell_open[0]++;
      continue;
    }
    /* Segments here: conformity with every face their curve bounds or is embedded in. */
    int32_t seg_curve = -1;
    for (int64_t s = es_off[i]; s < es_off[i + 1]; ++s) {
      int32_t cu = c->seg_c[es_seg[s]];
      if (cu < 0) continue;
      seg_curve = cu;
      for (int64_t k = c->cf_off[cu]; k < c->cf_off[cu + 1]; ++k) {
        int32_t f = c->cf_face[k];
        int present = 0;
        for (int r2 = 0; r2 < n && !present; ++r2) present = rec[r2].cell == f;
        if (!present)
          note(c, PM_CHECK_SEG_CONFORM,
               "segment %ld of curve %ld (nodes %ld-%ld) is no edge of a triangle of face %ld",
               (long)es_seg[s], (long)cu, (long)a, (long)b, (long)f);
      }
    }
    for (int j = 0; j < nva; ++j) {
      int32_t vol = va[j].vol;
      int expect = seg_curve >= 0 ? shell_uses(c, seg_curve, vol) : 2;
      c->shell_edges[vol]++;
      if (va[j].k != 2) c->shell_nonmanifold[vol]++;
      if (va[j].k != expect) {
        c->shell_open[vol]++;
        note(c, PM_CHECK_SHELL_OPEN,
             "edge %ld-%ld is used by %d triangles of the shell of volume %ld, expected %d",
             (long)a, (long)b, va[j].k, (long)vol, expect);
      } else if (va[j].k == 2 && va[j].sdir != 0) {
        note(c, PM_CHECK_SHELL_ORIENTATION,
             "shell of volume %ld: the two triangles at edge %ld-%ld run the same way",
             (long)vol, (long)a, (long)b);
      }
    }
  }
  free(rec);
  free(third);
  free(va);
  free(va_edge);
  free(va_at);
  return 1;
}

/* Segments that are on no triangle edge (their curve must then bound or lie in no face). */
static void orphan_segments(ctx *c, const int64_t *seg_edge) {
  const pm_mesh *m = c->m;
  if (!c->md || m->ntri == 0) return;
  for (int32_t s = 0; s < m->nseg; ++s) {
    int32_t cu = c->seg_c[s];
    if (!c->seg_ok[s] || cu < 0 || seg_edge[s] >= 0) continue;
    if (c->cf_off[cu + 1] > c->cf_off[cu])
      note(c, PM_CHECK_SEG_CONFORM,
           "segment %ld of curve %ld (nodes %ld-%ld) is no edge of a triangle of face %ld",
           (long)s, (long)cu, (long)m->seg[2 * (size_t)s], (long)m->seg[2 * (size_t)s + 1],
           (long)c->cf_face[c->cf_off[cu]]);
  }
}

/* ---- shells ------------------------------------------------------------------------------- */

static int32_t uf_find(int32_t *parent, int32_t x) {
  while (parent[x] != x) {
    parent[x] = parent[parent[x]];
    x = parent[x];
  }
  return x;
}

static double det3(const double *a, const double *b, const double *cc, const double o[3]) {
  double x[3] = {a[0] - o[0], a[1] - o[1], a[2] - o[2]};
  double y[3] = {b[0] - o[0], b[1] - o[1], b[2] - o[2]};
  double z[3] = {cc[0] - o[0], cc[1] - o[1], cc[2] - o[2]};
  return x[0] * (y[1] * z[2] - y[2] * z[1]) - x[1] * (y[0] * z[2] - y[2] * z[0]) +
         x[2] * (y[0] * z[1] - y[1] * z[0]);
}

/* Fill one shell record from the triangles `list` (indices into m->tri) with senses. */
static void shell_sums(ctx *c, pm_check_shell *sh, const int32_t *list, const int8_t *sense,
                       int64_t nlist, int32_t *stamp, int32_t *parent, int32_t mark,
                       const double origin[3]) {
  const pm_mesh *m = c->m;
  int64_t nodes = 0;
  double vol6 = 0.0;
  for (int64_t k = 0; k < nlist; ++k) {
    const int32_t *v = m->tri + 3 * (size_t)list[k];
    for (int j = 0; j < 3; ++j)
      if (stamp[v[j]] != mark) {
        stamp[v[j]] = mark;
        parent[v[j]] = v[j];
        ++nodes;
      }
    int32_t r0 = uf_find(parent, v[0]);
    for (int j = 1; j < 3; ++j) {
      int32_t rj = uf_find(parent, v[j]);
      if (rj != r0) parent[rj] = r0;
    }
    vol6 += sense[k] * det3(m->xyz + 3 * (size_t)v[0], m->xyz + 3 * (size_t)v[1],
                            m->xyz + 3 * (size_t)v[2], origin);
  }
  int32_t comps = 0;
  for (int64_t k = 0; k < nlist; ++k) {
    const int32_t *v = m->tri + 3 * (size_t)list[k];
    for (int j = 0; j < 3; ++j)
      if (stamp[v[j]] == mark && uf_find(parent, v[j]) == v[j]) {
        ++comps;
        stamp[v[j]] = mark - 1; /* counted; a different mark so it is not counted again */
        parent[v[j]] = v[j];
      }
  }
  sh->nodes = nodes;
  sh->triangles = nlist;
  sh->euler = sh->nodes - sh->edges + sh->triangles;
  sh->components = comps;
  sh->closed = sh->open_edges == 0 && nlist > 0;
  sh->enclosed = vol6 / 6.0;
  sh->genus = -1;
}

static int build_shells(ctx *c) {
  const pm_mesh *m = c->m;
  pm_check_report *r = c->r;
  int32_t nn = m->nnode;
  int32_t *stamp = malloc((size_t)(nn ? nn : 1) * sizeof *stamp);
  int32_t *parent = malloc((size_t)(nn ? nn : 1) * sizeof *parent);
  if (!stamp || !parent) {
    free(stamp);
    free(parent);
    return 0;
  }
  for (int32_t v = 0; v < nn; ++v) stamp[v] = 0;
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  for (int32_t v = 0; v < nn; ++v)
    for (int k = 0; k < 3; ++k) {
      double x = m->xyz[3 * (size_t)v + k];
      if (v == 0 || x < lo[k]) lo[k] = x;
      if (v == 0 || x > hi[k]) hi[k] = x;
    }
  double origin[3] = {0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])};
  int ok = 1;
  if (!c->md) {
    r->nshell = 1;
    r->shell = calloc(1, sizeof *r->shell);
    int32_t *list = malloc((size_t)(m->ntri ? m->ntri : 1) * sizeof *list);
    int8_t *sense = malloc((size_t)(m->ntri ? m->ntri : 1));
    ok = r->shell && list && sense;
    if (ok) {
      int64_t nl = 0;
      for (int32_t t = 0; t < m->ntri; ++t)
        if (c->tri_ok[t]) {
          list[nl] = t;
          sense[nl++] = 1;
        }
      pm_check_shell *sh = &r->shell[0];
      sh->volume = -1;
      sh->edges = c->shell_edges[0];
      sh->open_edges = c->shell_open[0];
      shell_sums(c, sh, list, sense, nl, stamp, parent, 2, origin);
      if (sh->closed && (2 * (int64_t)sh->components - sh->euler) % 2 == 0 &&
          2 * (int64_t)sh->components - sh->euler >= 0)
        sh->genus = (int32_t)((2 * (int64_t)sh->components - sh->euler) / 2);
    }
    free(list);
    free(sense);
  } else {
    /* Triangles per face. */
    int32_t nf = c->nf;
    int64_t *foff = calloc((size_t)nf + 1, sizeof *foff);
    int32_t *ftri = malloc((size_t)(m->ntri ? m->ntri : 1) * sizeof *ftri);
    ok = foff && ftri;
    if (ok) {
      for (int32_t t = 0; t < m->ntri; ++t)
        if (c->tri_ok[t] && c->tri_c[t] >= 0) foff[c->tri_c[t] + 1]++;
      for (int32_t f = 0; f < nf; ++f) foff[f + 1] += foff[f];
      int64_t *fill = malloc(((size_t)nf + 1) * sizeof *fill);
      ok = fill != NULL;
      if (ok) {
        memcpy(fill, foff, ((size_t)nf + 1) * sizeof *fill);
        for (int32_t t = 0; t < m->ntri; ++t)
          if (c->tri_ok[t] && c->tri_c[t] >= 0) ftri[fill[c->tri_c[t]]++] = t;
      }
      free(fill);
    }
    r->nshell = c->nv;
    r->shell = calloc((size_t)(c->nv ? c->nv : 1), sizeof *r->shell);
    ok = ok && r->shell;
    int32_t *list = NULL;
    int8_t *sense = NULL;
    for (int32_t v = 0; ok && v < c->nv; ++v) {
      const pm_cell *cl = &c->md->cells[3][v];
      int64_t nl = 0;
      for (int32_t k = 0; k < cl->nbound; ++k) {
        int32_t f = cl->bound[k].cell;
        if (f >= 0 && f < nf) nl += foff[f + 1] - foff[f];
      }
      free(list);
      free(sense);
      list = malloc((size_t)(nl ? nl : 1) * sizeof *list);
      sense = malloc((size_t)(nl ? nl : 1));
      if (!list || !sense) {
        ok = 0;
        break;
      }
      nl = 0;
      for (int32_t k = 0; k < cl->nbound; ++k) {
        int32_t f = cl->bound[k].cell;
        if (f < 0 || f >= nf) continue;
        for (int64_t j = foff[f]; j < foff[f + 1]; ++j) {
          list[nl] = ftri[j];
          sense[nl++] = (int8_t)((cl->bound[k].sense < 0 ? -1 : 1) * c->face_sign[f]);
        }
      }
      pm_check_shell *sh = &r->shell[v];
      sh->volume = v;
      sh->edges = c->shell_edges[v];
      sh->open_edges = c->shell_open[v];
      shell_sums(c, sh, list, sense, nl, stamp, parent, 2 * (v + 1), origin);
      if (sh->closed && c->shell_nonmanifold[v] == 0 &&
          (2 * (int64_t)sh->components - sh->euler) % 2 == 0 &&
          2 * (int64_t)sh->components - sh->euler >= 0)
        sh->genus = (int32_t)((2 * (int64_t)sh->components - sh->euler) / 2);
      if (sh->closed && !(sh->enclosed > 0))
        note(c, PM_CHECK_SHELL_INWARD,
             "the shell of volume %ld encloses volume %g: its triangles point inwards", (long)v,
             sh->enclosed);
    }
    free(list);
    free(sense);
    free(foff);
    free(ftri);
  }
  free(stamp);
  free(parent);
  return ok;
}

/* ---- tets --------------------------------------------------------------------------------- */

/* Tets at a face by volume, then by position at the face (so that a group keeps its order). */
static int cmp_group(const void *pa, const void *pb) {
  const int32_t *a = pa, *b = pb;
  if (a[0] != b[0]) return (a[0] > b[0]) - (a[0] < b[0]);
  return (a[3] > b[3]) - (a[3] < b[3]);
}

static int check_tets(ctx *c, const int32_t *tet, const int32_t *tet_id, int32_t ntet) {
  const pm_mesh *m = c->m;
  pm_faces F;
  pm_error e2 = {0};
  if (pm_faces_build(m->nnode, tet, ntet, &F, &e2)) return 0;
  /* Per face: tets grouped by volume (generic: one group). */
  int64_t maxn = 0;
  for (int64_t j = 0; j < F.nface; ++j)
    if (F.off[j + 1] - F.off[j] > maxn) maxn = F.off[j + 1] - F.off[j];
  int32_t *grp = malloc((size_t)(maxn ? maxn : 1) * 4 * sizeof *grp);
  int32_t *fourth = malloc((size_t)(maxn ? maxn : 1) * 2 * sizeof *fourth);
  if (!grp || !fourth) {
    free(grp);
    free(fourth);
    pm_faces_free(&F);
    return 0;
  }
  /* Triangles at each tet face (model checks). */
  int64_t *tf_off = NULL;
  int32_t *tf_tri = NULL;
  int8_t *tf_par = NULL;
  int64_t *tri_face = NULL;
  int ok = 1;
  if (c->md && m->ntri > 0) {
    tf_off = calloc((size_t)F.nface + 1, sizeof *tf_off);
    tri_face = malloc((size_t)m->ntri * sizeof *tri_face);
    int8_t *par = malloc((size_t)m->ntri);
    ok = tf_off && tri_face && par;
    for (int32_t t = 0; ok && t < m->ntri; ++t) {
      tri_face[t] = -1;
      if (!c->tri_ok[t]) continue;
      const int32_t *v = m->tri + 3 * (size_t)t;
      int p;
      tri_face[t] = pm_faces_find(&F, v[0], v[1], v[2], &p);
      par[t] = (int8_t)p;
      if (tri_face[t] >= 0) tf_off[tri_face[t] + 1]++;
    }
    if (ok) {
      for (int64_t j = 0; j < F.nface; ++j) tf_off[j + 1] += tf_off[j];
      int64_t n = tf_off[F.nface];
      tf_tri = malloc((size_t)(n ? n : 1) * sizeof *tf_tri);
      tf_par = malloc((size_t)(n ? n : 1));
      int64_t *fill = malloc(((size_t)F.nface + 1) * sizeof *fill);
      ok = tf_tri && tf_par && fill;
      if (ok) {
        memcpy(fill, tf_off, ((size_t)F.nface + 1) * sizeof *fill);
        for (int32_t t = 0; t < m->ntri; ++t)
          if (tri_face[t] >= 0) {
            int64_t at = fill[tri_face[t]]++;
            tf_tri[at] = t;
            tf_par[at] = par[t];
          }
      }
      free(fill);
    }
    free(par);
  }

  for (int64_t j = 0; ok && j < F.nface; ++j) {
    int32_t a = F.abc[3 * j], b = F.abc[3 * j + 1], cc = F.abc[3 * j + 2];
    int n = (int)(F.off[j + 1] - F.off[j]);
    /* Duplicate tets: the face's three nodes are the tet's smallest three and its fourth node
     * repeats. A sound mesh has one or two tets at a face; a broken one may have any number,
     * which are then sorted rather than compared pairwise (quadratic in the count). */
    if (n > GROUP_DIRECT) {
      int64_t nx = 0;
      for (int p = 0; p < n; ++p) {
        const int32_t *vp = tet + 4 * (size_t)F.tet[F.off[j] + p];
        int32_t xp = (int32_t)((int64_t)vp[0] + vp[1] + vp[2] + vp[3] - a - b - cc);
        if (xp >= cc) fourth[2 * nx] = xp, fourth[2 * nx + 1] = tet_id[F.tet[F.off[j] + p]], ++nx;
      }
      qsort(fourth, (size_t)nx, 2 * sizeof *fourth, cmp_pair);
      for (int64_t k = 1; k < nx; ++k)
        if (fourth[2 * k] == fourth[2 * k - 2])
          note(c, PM_CHECK_DUP_ELEMENT, "tetrahedra %ld and %ld", (long)fourth[2 * k - 1],
               (long)fourth[2 * k + 1]);
    } else {
      for (int p = 0; p < n; ++p) {
        const int32_t *vp = tet + 4 * (size_t)F.tet[F.off[j] + p];
        int32_t xp = (int32_t)((int64_t)vp[0] + vp[1] + vp[2] + vp[3] - a - b - cc);
        if (xp < cc) continue;
        for (int q = 0; q < p; ++q) {
          const int32_t *vq = tet + 4 * (size_t)F.tet[F.off[j] + q];
          int32_t xq = (int32_t)((int64_t)vq[0] + vq[1] + vq[2] + vq[3] - a - b - cc);
          if (xq == xp) {
            note(c, PM_CHECK_DUP_ELEMENT, "tetrahedra %ld and %ld",
                 (long)tet_id[F.tet[F.off[j] + q]], (long)tet_id[F.tet[F.off[j] + p]]);
            break;
          }
        }
      }
    }
    /* Group by volume tag (no model: everything in one group); many tets at a face are sorted
     * by volume (and position) so that each group is one run. */
    for (int k = 0; k < n; ++k) {
      int32_t tl = F.tet[F.off[j] + k];
      grp[4 * k] = c->md ? c->tet_c[tet_id[tl]] : 0;
      grp[4 * k + 1] = tet_id[tl];
      grp[4 * k + 2] = F.side[F.off[j] + k];
      grp[4 * k + 3] = k;
    }
    if (n > GROUP_DIRECT) qsort(grp, (size_t)n, 4 * sizeof *grp, cmp_group);
    for (int g = 0; g < n; ++g) {
      int32_t vol = grp[4 * g];
      int first = 1;
      if (n > GROUP_DIRECT)
        first = g == 0 || grp[4 * (g - 1)] != vol;
      else
        for (int q = 0; q < g; ++q) first &= grp[4 * q] != vol;
      if (!first) continue;
      int nvol = 0, sum = 0, t1 = -1, t2 = -1, side = 0;
      for (int q = g; q < n && (n <= GROUP_DIRECT || grp[4 * q] == vol); ++q)
        if (grp[4 * q] == vol) {
          ++nvol;
          sum += grp[4 * q + 2];
          if (t1 < 0) {
            t1 = grp[4 * q + 1];
            side = grp[4 * q + 2];
          } else if (t2 < 0) {
            t2 = grp[4 * q + 1];
          }
        }
      if (nvol > 2)
        note(c, PM_CHECK_TET_FACE, "face %ld %ld %ld is shared by %d tetrahedra", (long)a,
             (long)b, (long)cc, nvol);
      else if (nvol == 2 && sum != 0)
        note(c, PM_CHECK_TET_FACE,
             "tetrahedra %ld and %ld lie on the same side of their common face %ld %ld %ld",
             (long)t1, (long)t2, (long)a, (long)b, (long)cc);
      if (!c->md || vol < 0) continue;
      if (nvol == 1) {
        /* A boundary face of the volume's tets: a shell triangle, oriented outward. */
        int found = 0, oriented = 0;
        for (int64_t k = tf_off ? tf_off[j] : 0; tf_off && k < tf_off[j + 1]; ++k) {
          int32_t t = tf_tri[k], f = c->tri_c[t];
          if (f < 0) continue;
          for (int64_t s = c->fv_off[f]; s < c->fv_off[f + 1]; ++s)
            if (c->fv_vol[s] == vol) {
              found = 1;
              if (tf_par[k] * c->fv_sense[s] == side) oriented = 1;
            }
        }
        if (!found)
          note(c, PM_CHECK_TET_BOUNDARY,
               "boundary face %ld %ld %ld of tetrahedron %ld (volume %ld) is no triangle of the "
               "volume's shell",
               (long)a, (long)b, (long)cc, (long)t1, (long)vol);
        else if (!oriented)
          note(c, PM_CHECK_TET_BOUNDARY,
               "the shell triangle on face %ld %ld %ld of tetrahedron %ld (volume %ld) points "
               "into the volume",
               (long)a, (long)b, (long)cc, (long)t1, (long)vol);
      }
    }
  }

  /* Every shell triangle of a volume with tets is a boundary face of that volume's tets; every
   * triangle of a face embedded in it lies between two of them. */
  if (ok && c->md && tri_face) {
    for (int32_t t = 0; t < m->ntri; ++t) {
      int32_t f = c->tri_c[t];
      if (!c->tri_ok[t] || f < 0) continue;
      int64_t j = tri_face[t];
      for (int64_t s = c->fv_off[f]; s < c->fv_off[f + 1]; ++s) {
        int32_t vol = c->fv_vol[s];
        if (!c->vol_has_tets[vol]) continue;
        int nvol = 0;
        /* At most a few tets per face in a sound mesh; stop counting at 2 in a broken one. */
        for (int64_t k = j >= 0 ? F.off[j] : 0; j >= 0 && k < F.off[j + 1] && nvol < 2; ++k)
          nvol += c->tet_c[tet_id[F.tet[k]]] == vol;
        if (nvol != 1)
          note(c, PM_CHECK_TET_BOUNDARY,
               "triangle %ld of face %ld is a face of %s tetrahedra of volume %ld, expected 1",
               (long)t, (long)f, nvol ? "2 or more" : "0", (long)vol);
      }
      for (int64_t h = c->fh_off[f]; h < c->fh_off[f + 1]; ++h) {
        int32_t vol = c->fh_vol[h];
        if (!c->vol_has_tets[vol]) continue;
        int nvol = 0;
        /* Two tets of the volume in a sound mesh; stop counting at 3 in a broken one. */
        for (int64_t k = j >= 0 ? F.off[j] : 0; j >= 0 && k < F.off[j + 1] && nvol < 3; ++k)
          nvol += c->tet_c[tet_id[F.tet[k]]] == vol;
        if (nvol != 2)
          note(c, PM_CHECK_TET_BOUNDARY,
               "triangle %ld of face %ld embedded in volume %ld is a face of %s of its "
               "tetrahedra, expected 2",
               (long)t, (long)f, (long)vol, nvol == 3 ? "3 or more" : nvol ? "1" : "0");
      }
    }
  }
  free(grp);
  free(fourth);
  free(tf_off);
  free(tf_tri);
  free(tf_par);
  free(tri_face);
  pm_faces_free(&F);
  return ok;
}

/* Segments of curves embedded in a volume with tets must be tet edges. */
static int embedded_curves_in_tets(ctx *c, const int32_t *tet, int32_t ntet) {
  const pm_mesh *m = c->m;
  int any = 0;
  for (int32_t v = 0; v < c->nv && !any; ++v) {
    const pm_cell *cl = &c->md->cells[3][v];
    for (int32_t k = 0; k < cl->nembed; ++k)
      if (cl->embed[k].dim == 1 && c->vol_has_tets[v]) any = 1;
  }
  if (!any) return 1;
  pm_edges E;
  pm_error e2 = {0};
  if (pm_edges_build(m->nnode, tet, ntet, 4, &E, &e2)) return 0;
  for (int32_t s = 0; s < m->nseg; ++s) {
    int32_t cu = c->seg_c[s];
    if (!c->seg_ok[s] || cu < 0) continue;
    for (int64_t h = c->ch_off[cu]; h < c->ch_off[cu + 1]; ++h) {
      int32_t vol = c->ch_vol[h];
      if (!c->vol_has_tets[vol]) continue;
      if (pm_edges_find(&E, m->seg[2 * (size_t)s], m->seg[2 * (size_t)s + 1]) < 0)
        note(c, PM_CHECK_SEG_CONFORM,
             "segment %ld of curve %ld embedded in volume %ld is no tetrahedron edge", (long)s,
             (long)cu, (long)vol);
    }
  }
  pm_edges_free(&E);
  return 1;
}

/* ---- triangles against their face's normal ------------------------------------------------ */

static int check_face_normals(ctx *c) {
  const pm_mesh *m = c->m;
  const pm_model *md = c->md;
  int any = 0;
  for (int32_t f = 0; f < c->nf && !any; ++f)
    any = md->cells[2][f].cls && md->cells[2][f].cls->face_eval;
  if (!any || m->ntri == 0) return 1;
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (int32_t v = 0; v < m->nnode; ++v)
    for (int k = 0; k < 3; ++k) {
      lo[k] = fmin(lo[k], m->xyz[3 * (size_t)v + k]);
      hi[k] = fmax(hi[k], m->xyz[3 * (size_t)v + k]);
    }
  double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                     (hi[2] - lo[2]) * (hi[2] - lo[2]));
  if (md->diagonal > diag) diag = md->diagonal;
  /* A node's parameters are trusted when they evaluate back to the node. */
  double ptol = 1e-6 * diag;
  /* Per triangle: +1 when the majority of its judged nodes agree, -1 when they disagree, 0 when
   * none could be judged; 2 marks a triangle every judged node of which (two at least)
   * disagrees. */
  int8_t *vote = calloc((size_t)m->ntri, 1);
  double *area = calloc((size_t)m->ntri, sizeof *area);
  if (!vote || !area) {
    free(vote);
    free(area);
    return 0;
  }
#pragma omp parallel for schedule(dynamic, 1024)
  for (int32_t t = 0; t < m->ntri; ++t) {
    int32_t f = c->tri_c[t];
    if (!c->tri_ok[t] || f < 0) continue;
    const pm_cell *fc = &md->cells[2][f];
    if (!fc->cls || !fc->cls->face_eval) continue;
    const int32_t *v = m->tri + 3 * (size_t)t;
    const double *a = m->xyz + 3 * (size_t)v[0], *b = m->xyz + 3 * (size_t)v[1],
                 *cc = m->xyz + 3 * (size_t)v[2];
    double u1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double u2[3] = {cc[0] - a[0], cc[1] - a[1], cc[2] - a[2]};
    double tn[3] = {u1[1] * u2[2] - u1[2] * u2[1], u1[2] * u2[0] - u1[0] * u2[2],
                    u1[0] * u2[1] - u1[1] * u2[0]};
    int judged = 0, against = 0;
    for (int j = 0; j < 3; ++j) {
      if (!(m->node_dim[v[j]] == PM_FACE && m->node_cell[v[j]] == f)) continue;
      const double *x = m->xyz + 3 * (size_t)v[j];
      pm_face_point fp;
      pm_face_eval(fc, m->node_par + 2 * (size_t)v[j], 1, &fp);
      double dx = fp.p[0] - x[0], dy = fp.p[1] - x[1], dz = fp.p[2] - x[2];
      if (!(dx * dx + dy * dy + dz * dz <= ptol * ptol)) continue;
      double n[3] = {fp.su[1] * fp.sv[2] - fp.su[2] * fp.sv[1],
                     fp.su[2] * fp.sv[0] - fp.su[0] * fp.sv[2],
                     fp.su[0] * fp.sv[1] - fp.su[1] * fp.sv[0]};
      double nn = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
      double su = sqrt(fp.su[0] * fp.su[0] + fp.su[1] * fp.su[1] + fp.su[2] * fp.su[2]);
      double sv = sqrt(fp.sv[0] * fp.sv[0] + fp.sv[1] * fp.sv[1] + fp.sv[2] * fp.sv[2]);
      if (!(nn > 1e-12 * su * sv)) continue; /* a pole: no normal to compare with */
      ++judged;
      if (c->face_sign[f] * (tn[0] * n[0] + tn[1] * n[1] + tn[2] * n[2]) < 0) ++against;
    }
    if (!judged) continue;
    area[t] = 0.5 * sqrt(tn[0] * tn[0] + tn[1] * tn[1] + tn[2] * tn[2]);
    vote[t] = (int8_t)(2 * against > judged ? -1 : 1);
    if (judged >= 2 && against == judged) vote[t] = 2;
  }
  /* A face whose judged triangle area mostly runs against its orientation is reversed. */
  double *agree = calloc((size_t)(c->nf ? c->nf : 1), sizeof *agree);
  double *oppose = calloc((size_t)(c->nf ? c->nf : 1), sizeof *oppose);
  if (!agree || !oppose) {
    free(vote);
    free(area);
    free(agree);
    free(oppose);
    return 0;
  }
  for (int32_t t = 0; t < m->ntri; ++t) {
    if (!vote[t]) continue;
    if (vote[t] > 0 && vote[t] != 2)
      agree[c->tri_c[t]] += area[t];
    else
      oppose[c->tri_c[t]] += area[t];
  }
  for (int32_t f = 0; f < c->nf; ++f)
    if (oppose[f] > agree[f])
      note(c, PM_CHECK_FACE_NORMAL,
           "face %ld: %.0f%% of its triangles' area runs against the face's %s", (long)f,
           100.0 * oppose[f] / (oppose[f] + agree[f]),
           c->face_sign[f] > 0 ? "natural normal Su x Sv" : "reversed normal -Su x Sv");
  for (int32_t t = 0; t < m->ntri; ++t)
    if (vote[t] == 2 && !(oppose[c->tri_c[t]] > agree[c->tri_c[t]]))
      note(c, PM_CHECK_FACE_NORMAL,
           "triangle %ld of face %ld is folded over: it runs against the face's %s at each of "
           "its face nodes",
           (long)t, (long)c->tri_c[t],
           c->face_sign[c->tri_c[t]] > 0 ? "natural normal Su x Sv" : "reversed normal -Su x Sv");
  free(vote);
  free(area);
  free(agree);
  free(oppose);
  return 1;
}

/* ---- classification and missing cells ---------------------------------------------------- */

static void check_classification(ctx *c) {
  const pm_mesh *m = c->m;
  struct {
    const int32_t *conn, *cellof;
    const uint8_t *ok;
    int32_t n;
    int per, dim;
    const char *what;
  } kinds[3] = {{m->seg, c->seg_c, c->seg_ok, m->nseg, 2, 1, "segment"},
                {m->tri, c->tri_c, c->tri_ok, m->ntri, 3, 2, "triangle"},
                {m->tet, c->tet_c, c->tet_ok, m->ntet, 4, 3, "tetrahedron"}};
  for (int k = 0; k < 3; ++k)
    for (int32_t t = 0; t < kinds[k].n; ++t) {
      int32_t cell = kinds[k].cellof[t];
      if (!kinds[k].ok[t] || cell < 0) continue;
      const ilist *cl = &c->closure[kinds[k].dim][cell];
      for (int j = 0; j < kinds[k].per; ++j) {
        int32_t v = kinds[k].conn[(size_t)kinds[k].per * t + j];
        int d = m->node_dim[v];
        int32_t i = m->node_cell[v];
        if (d < 0 || d > 3 || i < 0 || i >= c->md->count[d]) continue;
        if (!sorted_has(cl->v, cl->n, cref(d, i)))
          note(c, PM_CHECK_CLASSIFICATION, "node %ld on %s %ld belongs to %s %ld of %s %ld",
               (long)v, dim_name(d), (long)i, kinds[k].what, (long)t, dim_name(kinds[k].dim),
               (long)cell);
      }
    }
}

static void check_missing(ctx *c) {
  const pm_mesh *m = c->m;
  const pm_model *md = c->md;
  struct {
    const int32_t *cellof;
    const uint8_t *ok;
    int32_t n;
    int dim;
    const char *what;
  } kinds[3] = {{c->seg_c, c->seg_ok, m->nseg, 1, "segments"},
                {c->tri_c, c->tri_ok, m->ntri, 2, "triangles"},
                {c->tet_c, c->tet_ok, m->ntet, 3, "tetrahedra"}};
  for (int k = 0; k < 3; ++k) {
    if (kinds[k].n == 0) continue;
    int d = kinds[k].dim;
    uint8_t *has = calloc((size_t)(md->count[d] ? md->count[d] : 1), 1);
    if (!has) {
      c->nomem = 1;
      return;
    }
    for (int32_t t = 0; t < kinds[k].n; ++t)
      if (kinds[k].ok[t] && kinds[k].cellof[t] >= 0) has[kinds[k].cellof[t]] = 1;
    for (int32_t i = 0; i < md->count[d]; ++i) {
      if (has[i]) continue;
      if (d == 1 && md->cells[1][i].degenerate) continue; /* a pole: nothing to mesh */
      note(c, PM_CHECK_MISSING, "%s %ld has no %s", dim_name(d), (long)i, kinds[k].what);
    }
    if (d == 3)
      memcpy(c->vol_has_tets, has, (size_t)md->count[3]);
    free(has);
  }
}

/* ---- driver ------------------------------------------------------------------------------- */

/* The connectivity of the elements flagged ok, and the map back to element indices. */
static int compact(const int32_t *conn, int32_t n, int per, const uint8_t *ok, int32_t **out,
                   int32_t **id, int32_t *nout) {
  *out = malloc((size_t)(n ? n : 1) * (size_t)per * sizeof **out);
  *id = malloc((size_t)(n ? n : 1) * sizeof **id);
  if (!*out || !*id) return 0;
  int32_t k = 0;
  for (int32_t t = 0; t < n; ++t)
    if (ok[t]) {
      memcpy(*out + (size_t)per * k, conn + (size_t)per * t, (size_t)per * sizeof **out);
      (*id)[k++] = t;
    }
  *nout = k;
  return 1;
}

static void ctx_free(ctx *c) {
  free(c->seg_ok);
  free(c->tri_ok);
  free(c->tet_ok);
  free(c->seg_c);
  free(c->tri_c);
  free(c->tet_c);
  free(c->fc_off);
  free(c->fc_curve);
  free(c->cf_off);
  free(c->cf_face);
  free(c->fv_off);
  free(c->fv_vol);
  free(c->fv_sense);
  free(c->face_sign);
  free(c->cv_off);
  free(c->cv_vol);
  free(c->cv_uses);
  free(c->fh_off);
  free(c->fh_vol);
  free(c->ch_off);
  free(c->ch_vol);
  for (int d = 1; d <= 3; ++d) {
    if (!c->closure[d]) continue;
    for (int32_t i = 0; i < c->md->count[d]; ++i) free(c->closure[d][i].v);
    free(c->closure[d]);
  }
  free(c->vol_has_tets);
  free(c->shell_edges);
  free(c->shell_open);
  free(c->shell_nonmanifold);
}

static int run(ctx *c) {
  const pm_mesh *m = c->m;
  size_t ns = (size_t)(m->nseg ? m->nseg : 1), nt = (size_t)(m->ntri ? m->ntri : 1),
         nk = (size_t)(m->ntet ? m->ntet : 1);
  c->seg_ok = malloc(ns);
  c->tri_ok = malloc(nt);
  c->tet_ok = malloc(nk);
  c->seg_c = malloc(ns * sizeof(int32_t));
  c->tri_c = malloc(nt * sizeof(int32_t));
  c->tet_c = malloc(nk * sizeof(int32_t));
  size_t nshell = c->md ? (size_t)(c->md->count[3] ? c->md->count[3] : 1) : 1;
  c->shell_edges = calloc(nshell, sizeof(int64_t));
  c->shell_open = calloc(nshell, sizeof(int64_t));
  c->shell_nonmanifold = calloc(nshell, sizeof(int64_t));
  c->vol_has_tets = calloc(nshell, 1);
  if (!c->seg_ok || !c->tri_ok || !c->tet_ok || !c->seg_c || !c->tri_c || !c->tet_c ||
      !c->shell_edges || !c->shell_open || !c->shell_nonmanifold || !c->vol_has_tets)
    return 0;

  check_indices(c, m->seg, m->nseg, 2, c->seg_ok, "segment");
  check_indices(c, m->tri, m->ntri, 3, c->tri_ok, "triangle");
  check_indices(c, m->tet, m->ntet, 4, c->tet_ok, "tetrahedron");
  check_tags(c, m->seg_cell, m->nseg, 1, c->seg_c, "segment");
  check_tags(c, m->tri_cell, m->ntri, 2, c->tri_c, "triangle");
  check_tags(c, m->tet_cell, m->ntet, 3, c->tet_c, "tetrahedron");
  check_node_tags(c);
  if (!check_dup_nodes(c)) return 0;
  check_degenerate(c);
  if (c->md) {
    if (!build_model_tables(c)) return 0;
    check_missing(c);
    if (c->nomem) return 0;
  }

  /* Segments: duplicates, and the triangle edge each lies on. */
  int32_t *seg, *seg_id, nseg;
  if (!compact(m->seg, m->nseg, 2, c->seg_ok, &seg, &seg_id, &nseg)) {
    free(seg);
    free(seg_id);
    return 0;
  }
  pm_error e2 = {0};
  pm_edges SE;
  int ok = pm_edges_build(m->nnode, seg, nseg, 2, &SE, &e2) == PM_OK;
  if (ok) {
    for (int64_t i = 0; i < SE.nedge; ++i)
      if (SE.off[i + 1] - SE.off[i] > 1)
        note(c, PM_CHECK_DUP_ELEMENT, "segments %ld and %ld (nodes %ld-%ld)",
             (long)seg_id[SE.elem[SE.off[i]]], (long)seg_id[SE.elem[SE.off[i] + 1]],
             (long)SE.ends[2 * i], (long)SE.ends[2 * i + 1]);
    pm_edges_free(&SE);
  }

  int32_t *tri = NULL, *tri_id = NULL, ntri = 0;
  pm_edges TE;
  memset(&TE, 0, sizeof TE);
  int64_t *seg_edge = NULL, *es_off = NULL;
  int32_t *es_seg = NULL;
  ok = ok && compact(m->tri, m->ntri, 3, c->tri_ok, &tri, &tri_id, &ntri);
  ok = ok && pm_edges_build(m->nnode, tri, ntri, 3, &TE, &e2) == PM_OK;
  if (ok) {
    /* edge -> segments on it */
    seg_edge = malloc(ns * sizeof *seg_edge);
    es_off = calloc((size_t)TE.nedge + 1, sizeof *es_off);
    es_seg = malloc(ns * sizeof *es_seg);
    ok = seg_edge && es_off && es_seg;
  }
  if (ok) {
    for (int32_t s = 0; s < m->nseg; ++s) {
      seg_edge[s] = c->seg_ok[s] ? pm_edges_find(&TE, m->seg[2 * (size_t)s],
                                                 m->seg[2 * (size_t)s + 1])
                                 : -1;
      if (seg_edge[s] >= 0) es_off[seg_edge[s] + 1]++;
    }
    for (int64_t i = 0; i < TE.nedge; ++i) es_off[i + 1] += es_off[i];
    int64_t *fill = malloc(((size_t)TE.nedge + 1) * sizeof *fill);
    ok = fill != NULL;
    if (ok) {
      memcpy(fill, es_off, ((size_t)TE.nedge + 1) * sizeof *fill);
      for (int32_t s = 0; s < m->nseg; ++s)
        if (seg_edge[s] >= 0) es_seg[fill[seg_edge[s]]++] = s;
    }
    free(fill);
  }
  ok = ok && walk_edges(c, &TE, tri, tri_id, es_off, es_seg);
  if (ok) orphan_segments(c, seg_edge);
  ok = ok && build_shells(c);
  free(seg);
  free(seg_id);
  free(tri);
  free(tri_id);
  free(seg_edge);
  free(es_off);
  free(es_seg);
  pm_edges_free(&TE);

  int32_t *tet = NULL, *tet_id = NULL, ntet = 0;
  ok = ok && compact(m->tet, m->ntet, 4, c->tet_ok, &tet, &tet_id, &ntet);
  if (ok && ntet > 0) ok = check_tets(c, tet, tet_id, ntet);
  if (ok && ntet > 0 && c->md) ok = embedded_curves_in_tets(c, tet, ntet);
  free(tet);
  free(tet_id);
  if (ok && c->md) check_classification(c);
  if (ok && c->md) ok = check_face_normals(c);
  return ok;
}

pm_status pm_mesh_check(const pm_mesh *m, const pm_model *model, pm_check_report *out,
                        pm_error *err) {
  if (!out) return pm_error_setf(err, PM_ERR_ARG, "pm_mesh_check: no report");
  memset(out, 0, sizeof *out);
  if (!m) return pm_error_setf(err, PM_ERR_ARG, "pm_mesh_check: no mesh");
  ctx c;
  memset(&c, 0, sizeof c);
  c.m = m;
  c.md = model;
  c.r = out;
  int ok = run(&c);
  ctx_free(&c);
  if (!ok) {
    pm_check_report_clear(out);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory checking a mesh of %ld nodes",
                         (long)m->nnode);
  }
  out->valid = 1;
  for (int k = 0; k < PM_CHECK_NKIND; ++k) {
    if (out->count[k] == 0) continue;
    out->valid = 0;
    if (out->nproblem < PM_CHECK_MAX_PROBLEMS)
      snprintf(out->problem[out->nproblem++], sizeof out->problem[0], "%s: %lld (first: %s)",
               kind_names[k], (long long)out->count[k], c.first[k]);
  }
  return PM_OK;
}
