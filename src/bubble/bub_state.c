/* The bubble arrays, the cell relations between bubbles (papers/000 section 4.2.2) and the
 * neighbour grid.
 *
 * Relations. 000 section 4.2.2 gives each bubble active neighbours (felt in the dynamics and in
 * the overlap ratio), overlap-only neighbours (the outside layer) and passive ones (neither):
 * vertex bubbles feel nothing (they are fixed), edge bubbles feel vertex and edge bubbles, face
 * bubbles feel all of them. The thesis deals with one face; on a model with many cells we read
 * "vertex and edge bubbles" as those of the bubble's own closure: a curve bubble feels the
 * bubbles of its curve and of its two end vertices, a face bubble those of its face, of the
 * curves and vertices on the face's boundary and of the cells embedded in it. Bubbles of a
 * neighbouring face across a shared curve are never felt: the connection step triangulates each
 * face from its own nodes and its boundary chains only, and a bubble of another face pulling at
 * a sharp edge would only open gaps along it.
 * Carried up one dimension (000 deals with faces only): a volume bubble feels the bubbles of its
 * volume and of the cells in its closure -- bounding faces, their curves and vertices, and the
 * faces, curves and points embedded in the volume -- and no bubble of a lower dimension feels a
 * volume bubble. Two volumes sharing a face do not feel each other's bubbles, for the same reason
 * as two faces sharing a curve.
 */
#include "bubble/bub_private.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/morton.h"
#include "common/base/vec3.h"

/* ---- closure tables ----------------------------------------------------------------------- */

typedef struct keyvec {
  uint32_t *k;
  int32_t n, cap;
} keyvec;

static int keyvec_push(keyvec *v, uint32_t key) {
  if (v->n == v->cap) {
    int32_t nc = v->cap ? 2 * v->cap : 16;
    uint32_t *nk = realloc(v->k, sizeof(uint32_t) * (size_t)nc);
    if (!nk) return 0;
    v->k = nk, v->cap = nc;
  }
  v->k[v->n++] = key;
  return 1;
}

static int cmp_u32(const void *a, const void *b) {
  uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
  return (x > y) - (x < y);
}

/* Add the closure of cell (dim, idx) (the cell itself excluded) to v. */
static int closure_add(const pm_model *m, int dim, int32_t idx, keyvec *v, int depth) {
  if (depth > 8) return 1; /* models are at most 3 levels deep; guards a malformed one */
  const pm_cell *c = pm_model_cell(m, dim, idx);
  if (dim == PM_CURVE) {
    for (int32_t k = 0; k < c->nbound; ++k)
      if (!keyvec_push(v, bub_key(PM_VERTEX, c->bound[k].cell))) return 0;
  } else if (dim == PM_FACE || dim == PM_VOLUME) {
    for (int32_t k = 0; k < c->nbound; ++k) {
      if (!keyvec_push(v, bub_key(dim - 1, c->bound[k].cell))) return 0;
      if (!closure_add(m, dim - 1, c->bound[k].cell, v, depth + 1)) return 0;
    }
  }
  for (int32_t k = 0; k < c->nembed; ++k) {
    const pm_cellref *e = &c->embed[k];
    if (e->dim >= dim) continue;
    if (!keyvec_push(v, bub_key(e->dim, e->index))) return 0;
    if (!closure_add(m, e->dim, e->index, v, depth + 1)) return 0;
  }
  return 1;
}

static pm_status build_closures(bub_state *s, pm_error *err) {
  const pm_model *m = s->model;
  for (int dim = 1; dim <= 3; ++dim) {
    int32_t nc = m->count[dim];
    s->clo_off[dim] = calloc((size_t)nc + 1, sizeof(int32_t));
    if (!s->clo_off[dim]) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    keyvec all = {0}, one = {0};
    for (int32_t c = 0; c < nc; ++c) {
      one.n = 0;
      if (!closure_add(m, dim, c, &one, 0)) goto nomem;
      qsort(one.k, (size_t)one.n, sizeof(uint32_t), cmp_u32);
      int32_t w = 0;
      for (int32_t k = 0; k < one.n; ++k)
        if (w == 0 || one.k[k] != one.k[w - 1]) one.k[w++] = one.k[k];
      for (int32_t k = 0; k < w; ++k)
        if (!keyvec_push(&all, one.k[k])) goto nomem;
      s->clo_off[dim][c + 1] = all.n;
    }
    free(one.k);
    s->clo[dim] = all.k ? all.k : malloc(sizeof(uint32_t));
    if (!s->clo[dim]) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    continue;
  nomem:
    free(one.k), free(all.k);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  /* Seams: a curve used twice by one face. */
  int32_t ncur = m->count[PM_CURVE];
  s->seam = calloc((size_t)ncur + 1, 1);
  if (!s->seam) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  for (int32_t f = 0; f < m->count[PM_FACE]; ++f) {
    const pm_cell *fc = pm_model_cell(m, PM_FACE, f);
    for (int32_t a = 0; a < fc->nbound; ++a)
      for (int32_t b = a + 1; b < fc->nbound; ++b)
        if (fc->bound[a].cell == fc->bound[b].cell) s->seam[fc->bound[a].cell] = 1;
  }
  return PM_OK;
}

static int in_closure(const bub_state *s, int dim, int32_t cell, uint32_t key) {
  if (dim < 1 || dim > 3) return 0;
  const uint32_t *k = s->clo[dim];
  int32_t lo = s->clo_off[dim][cell], hi = s->clo_off[dim][cell + 1];
  while (lo < hi) {
    int32_t mid = (lo + hi) >> 1;
    if (k[mid] < key)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo < s->clo_off[dim][cell + 1] && k[lo] == key;
}

int bub_related_cell(const bub_state *s, int kind, int32_t cell, int32_t j) {
  int kj = s->kind[j];
  if (kj == BUB_KOUT || kind == BUB_KVERTEX || kind == BUB_KOUT) return 0;
  if (kj == kind) return s->cell[j] == cell;
  if (kj > kind) return 0;
  return in_closure(s, kind, cell, bub_key(kj, s->cell[j]));
}

int bub_related(const bub_state *s, int32_t i, int32_t j) {
  return i != j && bub_related_cell(s, s->kind[i], s->cell[i], j);
}

/* ---- arrays ------------------------------------------------------------------------------- */

static pm_status grow(bub_state *s, int32_t need, pm_error *err) {
  if (need <= s->cap) return PM_OK;
  int32_t nc = s->cap ? s->cap : 256;
  while (nc < need) nc = nc > (INT32_MAX / 2) ? INT32_MAX : 2 * nc;
#define GROW(ptr, per)                                                                  \
  do {                                                                                  \
    void *np = realloc(s->ptr, sizeof(*s->ptr) * (size_t)(per) * (size_t)nc);         \
    if (!np) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory (%d bubbles)", nc); \
    s->ptr = np;                                                                        \
  } while (0)
  GROW(x, 3);
  GROW(v, 3);
  GROW(par, 2);
  GROW(der, 6);
  GROW(d, 1);
  GROW(dmoved, 1);
  GROW(alpha, 1);
  GROW(kind, 1);
  GROW(cell, 1);
  GROW(flags, 1);
  GROW(wall, 1);
  GROW(frame, BUB_FRAME_LEN);
  GROW(frame_r, 1);
  GROW(clear, 3);
#undef GROW
  s->cap = nc;
  return PM_OK;
}

/* ---- affine cells ---------------------------------------------------------------------------- */

/* 1 when the Taylor model at one point reproduces the cell at the corners, centre and edge
 * midpoints of its parameter box to 1e-12 of the model's size: a plane or a line, whose frames
 * never need an exact evaluation (bub_dynamics.c). Only cells their backend calls "plane",
 * "segment" or "line" are tried. */
static int cell_affine(const pm_cell *c, double scale) {
  const char *nm = c->cls && c->cls->name ? c->cls->name : "";
  const int face = c->dim == PM_FACE;
  if (face ? strcmp(nm, "plane") != 0 : (strcmp(nm, "segment") != 0 && strcmp(nm, "line") != 0))
    return 0;
  if (!(c->hi[0] > c->lo[0]) || (face && !(c->hi[1] > c->lo[1]))) return 0;
  double p0[3], d0[6];
  double par0[2] = {c->lo[0], face ? c->lo[1] : 0};
  if (face) {
    pm_face_point fp;
    pm_face_eval(c, par0, 1, &fp);
    pm_v3_copy(p0, fp.p), pm_v3_copy(d0, fp.su), pm_v3_copy(d0 + 3, fp.sv);
  } else {
    pm_curve_point cp;
    pm_curve_eval(c, par0[0], 1, &cp);
    pm_v3_copy(p0, cp.p), pm_v3_copy(d0, cp.d1), pm_v3_zero(d0 + 3);
  }
  const double tol = 1e-12 * scale;
  for (int a = 0; a <= 2; ++a)
    for (int b = 0; b <= (face ? 2 : 0); ++b) {
      double du = 0.5 * a * (c->hi[0] - c->lo[0]), dv = face ? 0.5 * b * (c->hi[1] - c->lo[1]) : 0;
      double par[2] = {par0[0] + du, par0[1] + dv}, x[3], d1[6];
      if (face) {
        pm_face_point fp;
        pm_face_eval(c, par, 1, &fp);
        pm_v3_copy(x, fp.p), pm_v3_copy(d1, fp.su), pm_v3_copy(d1 + 3, fp.sv);
      } else {
        pm_curve_point cp;
        pm_curve_eval(c, par[0], 1, &cp);
        pm_v3_copy(x, cp.p), pm_v3_copy(d1, cp.d1), pm_v3_zero(d1 + 3);
      }
      for (int k = 0; k < 3; ++k) {
        double model = p0[k] + d0[k] * du + d0[3 + k] * dv;
        if (!(fabs(model - x[k]) <= tol)) return 0;
        if (!(fabs(d1[k] - d0[k]) <= 1e-12 * (fabs(d0[k]) + 1e-300) + tol) ||
            !(fabs(d1[3 + k] - d0[3 + k]) <= 1e-12 * (fabs(d0[3 + k]) + 1e-300) + tol))
          return 0;
      }
    }
  return 1;
}

static pm_status find_affine(bub_state *s, pm_error *err) {
  const pm_model *m = s->model;
  int32_t nf = m->count[PM_FACE], nc = m->count[PM_CURVE];
  s->affine = calloc((size_t)(nf + nc) + 1, 1);
  if (!s->affine) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  double scale = m->diagonal > 0 ? m->diagonal : 1;
  s->normal = calloc(3 * (size_t)nf + 1, sizeof(double));
  s->pinv = calloc(6 * (size_t)nf + 1, sizeof(double));
  s->pgain = calloc((size_t)nf + 1, sizeof(double));
  if (!s->normal || !s->pinv || !s->pgain) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  for (int32_t f = 0; f < nf; ++f) {
    const pm_cell *c = pm_model_cell(m, PM_FACE, f);
    s->affine[f] = (uint8_t)cell_affine(c, scale);
    if (!s->affine[f]) continue;
    pm_face_point fp;
    double uv[2] = {c->lo[0], c->lo[1]};
    pm_face_eval(c, uv, 1, &fp);
    pm_v3_cross(&s->normal[3 * f], fp.su, fp.sv);
    if (!(pm_v3_normalize(&s->normal[3 * f]) > 0)) s->affine[f] = 0;
    /* The rows of M^-1 J: the parameter steps of the unit steps along x, y, z (the shared rule
     * applied to each, so that the fast path steps exactly as pm_cell_param_delta would). */
    for (int k = 0; k < 3; ++k) {
      double e[3] = {k == 0, k == 1, k == 2}, dp[3] = {0, 0, 0};
      double der[6] = {fp.su[0], fp.su[1], fp.su[2], fp.sv[0], fp.sv[1], fp.sv[2]};
      pm_cell_param_delta(c, uv, der, e, dp);
      s->pinv[6 * f + k] = dp[0], s->pinv[6 * f + 3 + k] = dp[1];
    }
    /* |M^-1 J dx|^2 = dx^T J^T M^-2 J dx <= |dx|^2 / lambda_min(M) (J J^T = M), with a margin for
     * rounding. */
    const double a = pm_v3_dot(fp.su, fp.su), b = pm_v3_dot(fp.su, fp.sv), cc = pm_v3_dot(fp.sv, fp.sv);
    const double lmin = 0.5 * (a + cc) - sqrt(0.25 * (a - cc) * (a - cc) + b * b);
    s->pgain[f] = lmin > 0 ? (1 + 1e-9) / sqrt(lmin) : 0;
    if (!(s->pgain[f] > 0) || !isfinite(s->pgain[f])) s->affine[f] = 0;
  }
  for (int32_t c = 0; c < nc; ++c)
    s->affine[nf + c] = (uint8_t)cell_affine(pm_model_cell(m, PM_CURVE, c), scale);
  return PM_OK;
}

pm_status bub_state_create(const pm_model *m, const pm_sizing *size, const bub_params *p,
                           int threads, uint64_t seed, bub_state **out, pm_error *err) {
  *out = NULL;
  bub_state *s = calloc(1, sizeof *s);
  if (!s) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  s->model = m, s->size = size, s->p = *p;
  s->threads = threads >= 1 ? threads : 1;
  s->seed = seed;
  s->grid_factor = fmax(1.0, bub_outer_reach(p));
  pm_status st = build_closures(s, err);
  if (!st) st = find_affine(s, err);
  /* hmin of the grid: far below any bubble (it only affects speed). */
  if (!st) st = pm_grid_create(1e-6 * (m->diagonal > 0 ? m->diagonal : 1), &s->grid, err);
  if (!st) st = grow(s, 256, err);
  if (st) {
    bub_state_destroy(s);
    return st;
  }
  *out = s;
  return PM_OK;
}

void bub_state_destroy(bub_state *s) {
  if (!s) return;
  free(s->x), free(s->v), free(s->par), free(s->der), free(s->d), free(s->dmoved), free(s->alpha);
  free(s->kind), free(s->cell), free(s->flags), free(s->wall), free(s->frame), free(s->frame_r);
  free(s->clear), free(s->normal), free(s->pinv), free(s->pgain);
  free(s->affine);
  if (s->shell)
    for (int32_t v = 0; v < s->model->count[PM_VOLUME]; ++v) pm_volume_shell_destroy(s->shell[v]);
  free(s->shell);
  pm_grid_destroy(s->grid);
  free(s->nb_off), free(s->nb), free(s->nbo), free(s->nb_cnt), free(s->nbo_cnt), free(s->nb_mark), free(s->nb_moved), free(s->x_build), free(s->d_build);
  free(s->xo_build), free(s->do_build);
  for (int k = 0; k < 4; ++k) free(s->clo_off[k]), free(s->clo[k]);
  free(s->seam);
  for (int k = 0; k < 3; ++k) free(s->pos[k]);
  free(s->vs), free(s->sumv), free(s->suma), free(s->ders), free(s->pot), free(s->disp), free(s->deg);
  free(s->skin0), free(s->room), free(s->hist), free(s->timers);
  free(s->chunks);
  bub_neighbors_free(s);
  free(s);
}

void bub_state_eval(const bub_state *s, int32_t i) {
  const pm_cell *c = pm_model_cell(s->model, s->kind[i], s->cell[i]);
  if (s->kind[i] == BUB_KCURVE) {
    pm_curve_point cp;
    pm_curve_eval(c, s->par[2 * i], 1, &cp);
    pm_v3_copy(&s->x[3 * i], cp.p);
    pm_v3_copy(&s->der[6 * i], cp.d1);
    pm_v3_zero(&s->der[6 * i + 3]);
  } else if (s->kind[i] == BUB_KFACE) {
    pm_face_point fp;
    pm_face_eval(c, &s->par[2 * i], 1, &fp);
    pm_v3_copy(&s->x[3 * i], fp.p);
    pm_v3_copy(&s->der[6 * i], fp.su);
    pm_v3_copy(&s->der[6 * i + 3], fp.sv);
  }
}

pm_status bub_size_at(const bub_state *s, const double x[3], double *d, pm_error *err) {
  double v = pm_sizing_eval(s->size, x);
  if (!(v > 0) || !isfinite(v)) {
    *d = 0;
    return pm_error_setf(err, PM_ERR_ARG,
                         "the size field is %g at (%g, %g, %g) on the model: it must be finite "
                         "and > 0",
                         v, x[0], x[1], x[2]);
  }
  *d = v;
  return PM_OK;
}

pm_status bub_state_add(bub_state *s, int kind, int32_t cell, const double *par,
                        const double *xyz, double d, int32_t *id, pm_error *err) {
  pm_status st = grow(s, s->n + 1, err);
  if (st) return st;
  int32_t i = s->n;
  s->kind[i] = (int8_t)kind, s->cell[i] = cell, s->flags[i] = 0, s->alpha[i] = 0;
  s->dmoved[i] = 0;
  s->wall[i] = 0;
  s->frame_r[i] = 0; /* no frame yet: the first step evaluates the cell (bub_dynamics.c) */
  s->clear[3 * i + 2] = 0;
  s->par[2 * i] = par && kind >= BUB_KCURVE && kind <= BUB_KFACE ? par[0] : 0;
  s->par[2 * i + 1] = par && kind == BUB_KFACE ? par[1] : 0;
  pm_v3_zero(&s->v[3 * i]);
  for (int k = 0; k < 6; ++k) s->der[6 * i + k] = 0;
  s->n++;
  if (kind == BUB_KVERTEX) {
    pm_v3_copy(&s->x[3 * i], pm_model_cell(s->model, PM_VERTEX, cell)->xyz);
  } else if (kind == BUB_KOUT) {
    pm_v3_copy(&s->x[3 * i], xyz);
    s->d[i] = d;
  } else if (kind == BUB_KVOLUME) {
    pm_v3_copy(&s->x[3 * i], xyz);
  } else {
    bub_state_eval(s, i);
  }
  if (kind != BUB_KOUT) {
    st = bub_size_at(s, &s->x[3 * i], &s->d[i], err);
    if (st) {
      s->n--;
      return st;
    }
  }
  if (id) *id = i;
  s->grid_valid = 0;
  s->lists_valid = 0;
  return PM_OK;
}

/* ---- compaction ----------------------------------------------------------------------------- */

/* bub_state_order sorts the bubbles of a cell along a Morton (Z-order) curve of their positions,
 * ties by their previous index: bubbles near in space are near in memory, so the force sums'
 * gathers hit the cache (at 10^6 bubbles a list in random order runs several times slower), and
 * bubbles inserted by population control join their neighbourhood instead of the array's end.
 * bub_state_compact keeps the previous order within a cell (tests rely on the indices). */
typedef struct sort_key {
  int8_t kind;
  int32_t cell;
  uint64_t z;
  int32_t idx;
} sort_key;

static int cmp_key(const void *a, const void *b) {
  const sort_key *x = a, *y = b;
  if (x->kind != y->kind) return x->kind - y->kind;
  if (x->cell != y->cell) return (x->cell > y->cell) - (x->cell < y->cell);
  if (x->z != y->z) return (x->z > y->z) - (x->z < y->z);
  return (x->idx > y->idx) - (x->idx < y->idx);
}

static uint64_t morton(const pm_model *m, const double x[3]) {
  uint64_t z = 0;
  for (int k = 0; k < 3; ++k) {
    double ext = m->box[k + 3] - m->box[k], t = ext > 0 ? (x[k] - m->box[k]) / ext : 0;
    if (!(t > 0)) t = 0; /* also NaN */
    if (t > 1) t = 1;
    z |= pm_morton_spread3((uint64_t)(t * 2097151.0)) << k;
  }
  return z;
}

static pm_status compact(bub_state *s, int spatial, pm_error *err) {
  int32_t n = 0;
  sort_key *keys = malloc(sizeof(sort_key) * ((size_t)s->n + 1));
  if (!keys) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  for (int32_t i = 0; i < s->n; ++i)
    if (!(s->flags[i] & BUB_FDEAD) && s->kind[i] != BUB_KOUT)
      keys[n++] = (sort_key){s->kind[i], s->cell[i], spatial ? morton(s->model, &s->x[3 * i]) : 0, i};
  qsort(keys, (size_t)n, sizeof(sort_key), cmp_key);
  /* Permute through a copy of each array. */
  size_t need = (size_t)(n ? n : 1);
  double *buf = malloc(sizeof(double) * 6 * need);
  if (!buf) {
    free(keys);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
#define PERMUTE(ptr, per, type)                                                  \
  do {                                                                           \
    type *tmp = (type *)buf;                                                     \
    for (int32_t k = 0; k < n; ++k)                                              \
      memcpy(&tmp[(size_t)(per) * k], &s->ptr[(size_t)(per) * keys[k].idx],     \
             sizeof(type) * (size_t)(per));                                      \
    memcpy(s->ptr, tmp, sizeof(type) * (size_t)(per) * (size_t)n);               \
  } while (0)
  PERMUTE(x, 3, double);
  PERMUTE(v, 3, double);
  PERMUTE(par, 2, double);
  PERMUTE(der, 6, double);
  PERMUTE(d, 1, double);
  PERMUTE(dmoved, 1, double);
  PERMUTE(alpha, 1, double);
  PERMUTE(kind, 1, int8_t);
  PERMUTE(cell, 1, int32_t);
  PERMUTE(flags, 1, uint8_t);
  PERMUTE(wall, 1, double);
  PERMUTE(frame_r, 1, double);
  PERMUTE(clear, 3, double);
#undef PERMUTE
  /* The frames, 20 doubles a bubble, through a buffer of their own. */
  double *fb = malloc(sizeof(double) * BUB_FRAME_LEN * need);
  if (!fb) {
    free(buf), free(keys);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  for (int32_t k = 0; k < n; ++k)
    memcpy(&fb[(size_t)BUB_FRAME_LEN * k], &s->frame[(size_t)BUB_FRAME_LEN * keys[k].idx], sizeof(double) * BUB_FRAME_LEN);
  memcpy(s->frame, fb, sizeof(double) * BUB_FRAME_LEN * (size_t)n);
  free(fb);
  free(buf);
  free(keys);
  s->n = n;
  s->nv = s->nc = s->nf = s->nw = 0;
  for (int32_t i = 0; i < n; ++i) {
    s->flags[i] &= (uint8_t)~(BUB_FNEW | BUB_FDONE);
    if (s->kind[i] <= BUB_KVERTEX) s->nv = i + 1;
    if (s->kind[i] <= BUB_KCURVE) s->nc = i + 1;
    if (s->kind[i] <= BUB_KFACE) s->nf = i + 1;
    if (s->kind[i] <= BUB_KVOLUME) s->nw = i + 1;
  }
  if (s->nc < s->nv) s->nc = s->nv;
  if (s->nf < s->nc) s->nf = s->nc;
  if (s->nw < s->nf) s->nw = s->nf;
  s->grid_valid = 0;
  s->lists_valid = 0;
  return PM_OK;
}

pm_status bub_state_compact(bub_state *s, pm_error *err) { return compact(s, 0, err); }

pm_status bub_state_order(bub_state *s, pm_error *err) { return compact(s, 1, err); }

pm_status bub_state_grid_rebuild(bub_state *s, pm_error *err) {
  pm_grid_clear(s->grid);
  pm_status st = pm_grid_reserve(s->grid, s->n, err);
  for (int32_t i = 0; i < s->n && !st; ++i)
    if (!(s->flags[i] & BUB_FDEAD)) st = pm_grid_insert(s->grid, i, &s->x[3 * i], s->grid_factor * s->d[i], err);
  s->grid_valid = !st;
  return st;
}
