/* The particle arrays of the psys mesher, their neighbour grid, and the cell adjacency that the
 * gap size of papers/001 section 3.1 needs ("two k-cells are adjacent if one is on the boundary
 * of the other"). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "common/geom/geom_cad.h"
#include "common/base/morton.h"
#include "common/base/rng.h"
#include "common/base/vec3.h"
#include "psys/psys_private.h"

/* ---- cell closures ------------------------------------------------------------------------ */

typedef struct ibuf {
  int32_t n, cap;
  int32_t *v;
} ibuf;

static int ibuf_push(ibuf *b, int32_t x) {
  if (b->n == b->cap) {
    int32_t cap = b->cap ? 2 * b->cap : 16;
    int32_t *v = realloc(b->v, sizeof(int32_t) * (size_t)cap);
    if (!v) return -1;
    b->v = v, b->cap = cap;
  }
  b->v[b->n++] = x;
  return 0;
}

/* Append the closure of cell (dim, idx) to b: the cell, its boundary cells, the cells embedded in
 * it, recursively (duplicates removed later). Dimensions above 2 are not particle cells. */
static int closure_add(const psys_sys *s, int dim, int32_t idx, ibuf *b, int depth) {
  if (dim > 2 || depth > 8) return 0;
  const pm_cell *c = pm_model_cell(s->model, dim, idx);
  if (ibuf_push(b, psys_key(s, dim, idx))) return -1;
  for (int32_t k = 0; k < c->nbound; ++k)
    if (closure_add(s, dim - 1, c->bound[k].cell, b, depth + 1)) return -1;
  for (int32_t k = 0; k < c->nembed; ++k)
    if (c->embed[k].dim < dim &&
        closure_add(s, c->embed[k].dim, c->embed[k].index, b, depth + 1))
      return -1;
  return 0;
}

static pm_status build_closures(psys_sys *s, pm_error *err) {
  const pm_model *m = s->model;
  s->koff[0] = 0;
  s->koff[1] = m->count[0];
  s->koff[2] = m->count[0] + m->count[1];
  s->nkey = s->koff[2] + m->count[2];
  s->clo_off = malloc(sizeof(int32_t) * ((size_t)s->nkey + 1));
  s->vert_off = malloc(sizeof(int32_t) * ((size_t)s->nkey + 1));
  ibuf all = {0}, verts = {0}, one = {0};
  if (!s->clo_off || !s->vert_off) goto oom;
  s->clo_off[0] = s->vert_off[0] = 0;
  for (int d = 0; d <= 2; ++d)
    for (int32_t i = 0; i < m->count[d]; ++i) {
      one.n = 0;
      if (closure_add(s, d, i, &one, 0)) goto oom;
      pm_sort_ids(one.v, one.n);
      int32_t k = psys_key(s, d, i);
      for (int32_t q = 0; q < one.n; ++q) {
        if (q && one.v[q] == one.v[q - 1]) continue;
        if (ibuf_push(&all, one.v[q])) goto oom;
        /* keys below koff[1] are vertices, and keys are sorted, so are the vertex indices */
        if (one.v[q] < s->koff[1] && ibuf_push(&verts, one.v[q])) goto oom;
      }
      s->clo_off[k + 1] = all.n;
      s->vert_off[k + 1] = verts.n;
    }
  s->clo = all.v ? all.v : malloc(sizeof(int32_t));
  s->vert = verts.v ? verts.v : malloc(sizeof(int32_t));
  free(one.v);
  if (!s->clo || !s->vert) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  return PM_OK;
oom:
  free(all.v), free(verts.v), free(one.v);
  return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
}

static int sorted_has(const int32_t *v, int32_t n, int32_t x) {
  int32_t lo = 0, hi = n;
  while (lo < hi) {
    int32_t mid = lo + (hi - lo) / 2;
    if (v[mid] < x)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo < n && v[lo] == x;
}

int psys_adjacent(const psys_sys *s, int32_t ka, int32_t kb) {
  return sorted_has(s->clo + s->clo_off[ka], s->clo_off[ka + 1] - s->clo_off[ka], kb) ||
         sorted_has(s->clo + s->clo_off[kb], s->clo_off[kb + 1] - s->clo_off[kb], ka);
}

int psys_touch(const psys_sys *s, int32_t ka, int32_t kb) {
  const int32_t *a = s->vert + s->vert_off[ka], *b = s->vert + s->vert_off[kb];
  int32_t na = s->vert_off[ka + 1] - s->vert_off[ka], nb = s->vert_off[kb + 1] - s->vert_off[kb];
  int32_t i = 0, j = 0;
  while (i < na && j < nb) {
    if (a[i] == b[j]) return 1;
    if (a[i] < b[j])
      ++i;
    else
      ++j;
  }
  return 0;
}

/* ---- time per step ---------------------------------------------------------------------- */

const char *const psys_step_names[PSYS_T_COUNT] = {
    "neighbours", "colouring", "energy", "step", "surface", "sizing.curvature", "sizing.gap",
    "sizing.lipschitz", "sizing.field", "population", "seeding"};

void psys_clock_split(psys_sys *s, double wall, int m, const psys_step *ks, const double *cpu) {
  double sum = 0;
  for (int k = 0; k < m; ++k) sum += cpu[k];
  for (int k = 0; k < m; ++k) psys_clock_add(s, ks[k], sum > 0 ? wall * cpu[k] / sum : wall / m);
}

/* ---- random streams ----------------------------------------------------------------------- */

static uint64_t mix64(uint64_t x) {
  x ^= x >> 30, x *= 0xbf58476d1ce4e5b9ULL;
  x ^= x >> 27, x *= 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

double psys_random(const psys_sys *s, int32_t i, int purpose) {
  /* One stream per (particle serial, iteration, purpose): independent of indices, of the order
   * in which particles are visited and of the thread count. */
  uint64_t stream = mix64(s->serial[i] * 0x9e3779b97f4a7c15ULL ^ mix64((uint64_t)s->iter) ^
                          ((uint64_t)purpose << 56));
  pm_rng r;
  pm_rng_init(&r, s->seed, stream);
  return pm_rng_uniform(&r);
}

/* ---- creation ----------------------------------------------------------------------------- */

pm_status psys_sys_create(const pm_model *m, const psys_params *p, const pm_sizing *size,
                          uint64_t seed, int threads, int64_t max_particles, psys_sys **out,
                          pm_error *err) {
  *out = NULL;
  if (!m || !p) return pm_error_setf(err, PM_ERR_ARG, "psys: no model or parameters");
  if (!(m->diagonal > 0) || !isfinite(m->diagonal))
    return pm_error_setf(err, PM_ERR_GEOM, "psys: the model has no extent");
  pm_status st = psys_params_check(p, err);
  if (st) return st;
  psys_sys *s = calloc(1, sizeof *s);
  if (!s) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  s->model = m;
  s->p = *p;
  s->size = size;
  s->seed = seed;
  s->threads = threads > 0 ? threads : 1;
  s->max_particles = max_particles > 0 ? max_particles : INT32_MAX;
  if (p->max_memory_gb > 0) {
    s->max_bytes = p->max_memory_gb * 1e9;
  } else {
    long pages = sysconf(_SC_PHYS_PAGES), size = sysconf(_SC_PAGESIZE);
    s->max_bytes = pages > 0 && size > 0 ? (double)pages * (double)size : INFINITY;
  }
  /* kappa_min / kappa_max default to 5 and 500 over the model diagonal (ours: the paper leaves
   * them to the user): sigma_max = diagonal / (5 s_kappa) = diagonal / 10 gives edges of about
   * 1/17 of the diagonal on flat parts, like the built-in cases' default sizes, and sigma_min =
   * diagonal / 1000 stops the refinement at features a thousand times smaller than the part. */
  s->kappa_min = p->kappa_min > 0 ? p->kappa_min : 5.0 / m->diagonal;
  s->kappa_max = p->kappa_max > 0 ? p->kappa_max : 500.0 / m->diagonal;
  if (!(s->kappa_min < s->kappa_max)) {
    psys_sys_destroy(s);
    return pm_error_setf(err, PM_ERR_ARG, "psys: need kappa_min < kappa_max, got %g and %g",
                         s->kappa_min, s->kappa_max);
  }
  s->sigma_min = 1.0 / (p->s_kappa * s->kappa_max); /* eq. 12 */
  s->sigma_max = 1.0 / (p->s_kappa * s->kappa_min); /* eq. 13 */
  /* The narrow places (feature_width): the shared field of their width f (an edge length, the
   * one bubble's default size uses) gives sigma <= f / edge_per_sigma, where the paper's gap
   * does not look (between cells that meet: wedges, cusps). Its grade L edge_per_sigma makes
   * that bound L-Lipschitz, as eq. 14 asks of sigma. */
  if (!size && p->feature_width &&
      (st = pm_feature_size_create(m, INFINITY, fmin(10, p->lipschitz * p->edge_per_sigma),
                                   PM_FEATURE_WIDTH, &s->width, err))) {
    psys_sys_destroy(s);
    return st;
  }
  if ((st = build_closures(s, err))) {
    psys_sys_destroy(s);
    return st;
  }
  s->corner = calloc((size_t)m->count[0] + 1, sizeof(double));
  s->slow_face = calloc((size_t)m->count[2] + 1, 1);
  if (!s->corner || !s->slow_face) {
    psys_sys_destroy(s);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  for (int32_t f = 0; f < m->count[2]; ++f)
    s->slow_face[f] = pm_cad_cell_is_fast(pm_model_cell(m, PM_FACE, f)) == 0;
  /* Cell extents (psys_population.c): a curve's length from 64 chords, a face's box diagonal. */
  s->extent = calloc((size_t)m->count[1] + (size_t)m->count[2] + 1, sizeof(double));
  if (!s->extent) {
    psys_sys_destroy(s);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  for (int32_t c = 0; c < m->count[1]; ++c) {
    const pm_cell *cv = pm_model_cell(m, PM_CURVE, c);
    if (cv->degenerate) continue;
    double prev[3], len = 0;
    for (int k = 0; k <= 64; ++k) {
      double t = cv->lo[0] + (cv->hi[0] - cv->lo[0]) * k / 64.0, x[3];
      pm_cell_point(cv, &t, x);
      if (k) len += pm_v3_dist(prev, x);
      pm_v3_copy(prev, x);
    }
    s->extent[c] = len;
  }
  for (int32_t f = 0; f < m->count[2]; ++f) {
    const double *b = pm_model_cell(m, PM_FACE, f)->box;
    double d[3] = {b[3] - b[0], b[4] - b[1], b[5] - b[2]};
    s->extent[m->count[1] + f] = pm_v3_norm(d);
  }
  if ((st = psys_nbr_init(s, err))) {
    psys_sys_destroy(s);
    return st;
  }
  s->phase = 1;
  *out = s;
  return PM_OK;
}

void psys_sys_destroy(psys_sys *s) {
  if (!s) return;
  psys_nbr_free(s);
  pm_feature_size_destroy(s->width);
  free(s->dim), free(s->cell), free(s->par), free(s->xyz), free(s->xs), free(s->deriv);
  free(s->fxyz), free(s->sigma), free(s->lambda), free(s->energy), free(s->force);
  free(s->sig_curv), free(s->kxyz), free(s->bdist), free(s->serial), free(s->grace);
  free(s->fixed), free(s->frozen);
  free(s->clo_off), free(s->clo), free(s->vert_off), free(s->vert);
  free(s->corner), free(s->slow_face), free(s->extent);
  free(s->chain_off), free(s->chain), free(s->chain_pos), free(s->vpart), free(s->face_on);
  free(s->target), free(s->key);
  free(s->colour), free(s->colour_order), free(s->colour_start), free(s->colour_x0);
  free(s->colour_mark), free(s->colour_mended);
  free(s);
}

#define GROW(ptr, type, mult)                                                 \
  do {                                                                        \
    type *q_ = realloc(s->ptr, sizeof(type) * (size_t)(mult) * (size_t)cap);  \
    if (!q_) return -1;                                                       \
    s->ptr = q_;                                                              \
  } while (0)

static int reserve(psys_sys *s, int32_t need) {
  if (need <= s->cap) return 0;
  int32_t cap = s->cap ? s->cap : 256;
  while (cap < need) cap = cap > INT32_MAX / 2 ? INT32_MAX : 2 * cap;
  if (cap > s->max_particles && need <= s->max_particles) cap = (int32_t)s->max_particles;
  GROW(dim, int8_t, 1);
  GROW(cell, int32_t, 1);
  GROW(par, double, 2);
  GROW(xyz, double, 3);
  GROW(xs, double, 4);
  GROW(deriv, double, 6);
  GROW(fxyz, double, 3);
  GROW(sigma, double, 1);
  GROW(lambda, double, 1);
  GROW(energy, double, 1);
  GROW(force, double, 3);
  GROW(sig_curv, double, 1);
  GROW(kxyz, double, 3);
  GROW(bdist, double, 1);
  GROW(serial, uint64_t, 1);
  GROW(grace, int64_t, 1);
  GROW(fixed, uint8_t, 1);
  GROW(frozen, uint8_t, 1);
  GROW(target, double, 1);
  GROW(key, double, 1);
  if (psys_nbr_reserve(s, cap, NULL)) return -1;
  s->cap = cap;
  return 0;
}

/* Evaluate the point and first derivatives of particle i at its par. */
static void eval_point(psys_sys *s, int32_t i) {
  const pm_cell *c = pm_model_cell(s->model, s->dim[i], s->cell[i]);
  double *x = &s->xyz[3 * i], *d = &s->deriv[6 * i];
  memset(d, 0, 6 * sizeof(double));
  /* the frame (deriv) is evaluated where the point is */
  double *fx = &s->fxyz[3 * i];
  if (c->dim == PM_VERTEX) {
    pm_v3_copy(x, c->xyz);
  } else if (c->dim == PM_CURVE) {
    pm_curve_point cp;
    pm_curve_eval(c, s->par[2 * i], 1, &cp);
    pm_v3_copy(x, cp.p), pm_v3_copy(d, cp.d1);
  } else {
    pm_face_point fp;
    pm_face_eval(c, &s->par[2 * i], 1, &fp);
    pm_v3_copy(x, fp.p), pm_v3_copy(d, fp.su), pm_v3_copy(d + 3, fp.sv);
  }
  pm_v3_copy(fx, x);
  for (int k = 0; k < 3; ++k) s->xs[4 * i + k] = x[k];
}

/* The given field's sigma at x, or an error naming the point. */
static pm_status field_sigma(const psys_sys *s, const double x[3], double *sigma, pm_error *err) {
  double d = pm_sizing_eval(s->size, x);
  if (!(d > 0) || !isfinite(d))
    return pm_error_setf(err, PM_ERR_ARG,
                         "size field is %g at (%g, %g, %g): it must be finite and > 0", d, x[0],
                         x[1], x[2]);
  *sigma = d / s->p.edge_per_sigma;
  return PM_OK;
}

static pm_status add_core(psys_sys *s, int dim, int32_t cell, const double *par, double sigma,
                          int32_t parent, int32_t *index, pm_error *err) {
  if ((int64_t)s->n + 1 > s->max_particles)
    return pm_error_setf(err, PM_ERR_LIMIT,
                         "psys: the particle count would exceed the node cap of %lld",
                         (long long)s->max_particles);
  if (s->n + 1 > s->cap) {
    /* the memory the arrays are about to take, checked before they grow */
    const double bytes = PSYS_BYTES_PER_PARTICLE * 2.0 * (s->cap ? s->cap : 128);
    if (bytes > s->max_bytes)
      return pm_error_setf(err, PM_ERR_LIMIT,
                           "psys: %d particles would take about %.2g GB, above the memory cap of "
                           "%.2g GB (max_memory_gb)",
                           (int)(2 * s->cap), bytes / 1e9, s->max_bytes / 1e9);
  }
  if (reserve(s, s->n + 1)) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  int32_t i = s->n;
  s->dim[i] = (int8_t)dim;
  s->cell[i] = cell;
  s->par[2 * i] = dim >= 1 && par ? par[0] : 0;
  s->par[2 * i + 1] = dim == 2 && par ? par[1] : 0;
  eval_point(s, i);
  const double *x = &s->xyz[3 * i];
  if (parent >= 0) {
    /* A split child starts with its parent's curvature bound and gap, evaluated at the parent:
     * the child is within a sigma, and both are refreshed as it moves away (psys_sizing.c). */
    s->sig_curv[i] = s->sig_curv[parent];
    pm_v3_copy(&s->kxyz[3 * i], &s->kxyz[3 * parent]);
  } else {
    s->sig_curv[i] = s->size ? 0 : psys_geometry_sigma(s, dim, cell, &s->par[2 * i], x);
    pm_v3_copy(&s->kxyz[3 * i], x);
  }
  if (!(sigma > 0)) {
    if (s->size) {
      pm_status st = field_sigma(s, x, &sigma, err);
      if (st) return st;
    } else {
      sigma = s->sig_curv[i];
      s->unsized = 1;
    }
  }
  psys_set_sigma(s, i, sigma);
  s->lambda[i] = s->p.lambda_init;
  s->energy[i] = 0;
  pm_v3_zero(&s->force[3 * i]);
  s->serial[i] = s->next_serial++;
  s->grace[i] = 0;
  s->bdist[i] = INFINITY;
  s->fixed[i] = dim == PM_VERTEX;
  s->frozen[i] = 0;
  s->target[i] = sigma;
  s->n++;
  if (index) *index = i;
  return PM_OK;
}

pm_status psys_add(psys_sys *s, int dim, int32_t cell, const double *par, double sigma,
                   int32_t *index, pm_error *err) {
  if (dim < 0 || dim > 2 || cell < 0 || cell >= s->model->count[dim])
    return pm_error_setf(err, PM_ERR_ARG, "psys: no cell (%d, %d) in the model", dim, (int)cell);
  return add_core(s, dim, cell, par, sigma, -1, index, err);
}

pm_status psys_add_child(psys_sys *s, int32_t parent, const double *par, int32_t *index,
                         pm_error *err) {
  return add_core(s, s->dim[parent], s->cell[parent], par, s->sigma[parent], parent, index, err);
}

pm_status psys_compact(psys_sys *s, const uint8_t *dead, pm_error *err) {
  const int32_t n_old = s->n;
  int32_t *map = malloc(sizeof(int32_t) * ((size_t)n_old + 1));
  if (!map) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  int32_t n = 0;
  for (int32_t i = 0; i < n_old; ++i) {
    if (dead[i]) {
      map[i] = -1;
      continue;
    }
    map[i] = n;
    if (n != i) {
      s->dim[n] = s->dim[i], s->cell[n] = s->cell[i];
      memcpy(&s->par[2 * n], &s->par[2 * i], 2 * sizeof(double));
      memcpy(&s->xyz[3 * n], &s->xyz[3 * i], 3 * sizeof(double));
      memcpy(&s->xs[4 * n], &s->xs[4 * i], 4 * sizeof(double));
      memcpy(&s->deriv[6 * n], &s->deriv[6 * i], 6 * sizeof(double));
      memcpy(&s->fxyz[3 * n], &s->fxyz[3 * i], 3 * sizeof(double));
      s->sigma[n] = s->sigma[i], s->lambda[n] = s->lambda[i], s->energy[n] = s->energy[i];
      memcpy(&s->force[3 * n], &s->force[3 * i], 3 * sizeof(double));
      s->sig_curv[n] = s->sig_curv[i];
      memcpy(&s->kxyz[3 * n], &s->kxyz[3 * i], 3 * sizeof(double));
      s->serial[n] = s->serial[i], s->fixed[n] = s->fixed[i], s->frozen[n] = s->frozen[i];
      s->grace[n] = s->grace[i];
      s->bdist[n] = s->bdist[i];
      s->target[n] = s->target[i];
    }
    ++n;
  }
  s->n = n;
  pm_status st = psys_nbr_compact(s, map, n_old, err);
  free(map);
  return st;
}

/* ---- spatial order --------------------------------------------------------------------------- */

typedef struct mkey {
  uint64_t key;
  int32_t i;
} mkey;

static int cmp_mkey(const void *a, const void *b) {
  const mkey *x = a, *y = b;
  if (x->key != y->key) return x->key < y->key ? -1 : 1;
  return (x->i > y->i) - (x->i < y->i);
}

/* a[lo + k] := a[perm[k]] for k < m, elements of `size` bytes, through `tmp`. */
static void permute(void *a, size_t size, int32_t lo, int32_t m, const int32_t *perm, void *tmp) {
  char *c = a, *t = tmp;
  for (int32_t k = 0; k < m; ++k) memcpy(t + size * (size_t)k, c + size * (size_t)perm[k], size);
  memcpy(c + size * (size_t)lo, t, size * (size_t)m);
}

pm_status psys_reorder(psys_sys *s, pm_error *err) {
  const int32_t lo = s->phase == 3 ? s->nfrozen : 0, m = s->n - lo;
  s->ordered_serial = s->next_serial;
  if (m < 2) return PM_OK;
  mkey *k = malloc(sizeof(mkey) * (size_t)m);
  int32_t *perm = malloc(sizeof(int32_t) * (size_t)m);
  void *tmp = malloc(sizeof(double) * 6 * (size_t)m);
  if (!k || !perm || !tmp) {
    free(k), free(perm), free(tmp);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  const double *b = s->model->box;
  double ext = fmax(fmax(b[3] - b[0], b[4] - b[1]), b[5] - b[2]);
  const double scale = ext > 0 ? 2097151.0 / ext : 0;
  for (int32_t q = 0; q < m; ++q) {
    const double *x = &s->xyz[3 * (lo + q)];
    uint64_t c[3];
    for (int a = 0; a < 3; ++a) {
      double t = (x[a] - b[a]) * scale;
      c[a] = t <= 0 ? 0 : (t >= 2097151.0 ? 2097151 : (uint64_t)t);
    }
    k[q].key =
        pm_morton_spread3(c[0]) | pm_morton_spread3(c[1]) << 1 | pm_morton_spread3(c[2]) << 2;
    k[q].i = lo + q;
  }
  qsort(k, (size_t)m, sizeof(mkey), cmp_mkey);
  for (int32_t q = 0; q < m; ++q) perm[q] = k[q].i;
  free(k);
#define PERMUTE(arr, n_per) permute(s->arr, sizeof(*s->arr) * (n_per), lo, m, perm, tmp)
  /* arrays of several values per particle are permuted as blocks of that many */
  permute(s->dim, 1, lo, m, perm, tmp);
  PERMUTE(cell, 1);
  PERMUTE(par, 2);
  PERMUTE(xyz, 3);
  PERMUTE(xs, 4);
  PERMUTE(deriv, 6);
  PERMUTE(fxyz, 3);
  PERMUTE(sigma, 1);
  PERMUTE(lambda, 1);
  PERMUTE(energy, 1);
  PERMUTE(force, 3);
  PERMUTE(sig_curv, 1);
  PERMUTE(kxyz, 3);
  PERMUTE(bdist, 1);
  PERMUTE(serial, 1);
  PERMUTE(grace, 1);
  PERMUTE(fixed, 1);
  PERMUTE(frozen, 1);
  PERMUTE(target, 1);
#undef PERMUTE
  pm_status st = psys_nbr_permute(s, lo, m, perm, err);
  free(perm), free(tmp);
  return st;
}

/* ---- caps ------------------------------------------------------------------------------------ */

/* Edge length of the field at x: the given field, or the largest the inferred one allows. */
static double edge_at(const psys_sys *s, const double x[3]) {
  return s->size ? pm_sizing_eval(s->size, x) : s->sigma_max * s->p.edge_per_sigma;
}

void psys_estimate_count(const psys_sys *s, double *curves, double *faces) {
  const pm_model *m = s->model;
  double nc = 0, nf = 0;
  /* curves: the integral of 1 / d over the arc length, by 64 chords */
  for (int32_t c = 0; c < m->count[PM_CURVE]; ++c) {
    const pm_cell *cv = pm_model_cell(m, PM_CURVE, c);
    if (cv->degenerate) continue;
    double prev[3];
    for (int k = 0; k <= 64; ++k) {
      double t = cv->lo[0] + (cv->hi[0] - cv->lo[0]) * k / 64.0, x[3], mid[3];
      pm_cell_point(cv, &t, x);
      if (k) {
        for (int a = 0; a < 3; ++a) mid[a] = 0.5 * (x[a] + prev[a]);
        nc += pm_v3_dist(prev, x) / edge_at(s, mid);
      }
      pm_v3_copy(prev, x);
    }
  }
  /* faces: the integral of 1 / (sqrt(3)/2 d^2), the area of a node of the hexagonal lattice, by
   * the midpoint rule on a 24 x 24 grid of the parameter box (points inside the trim) */
  enum { G = 24 };
  double uv[2 * G * G];
  pm_face_point fp[G * G];
  for (int32_t f = 0; f < m->count[PM_FACE]; ++f) {
    const pm_cell *c = pm_model_cell(m, PM_FACE, f);
    const double du = (c->hi[0] - c->lo[0]) / G, dv = (c->hi[1] - c->lo[1]) / G;
    for (int a = 0; a < G; ++a)
      for (int b = 0; b < G; ++b)
        uv[2 * (a * G + b)] = c->lo[0] + (a + 0.5) * du, uv[2 * (a * G + b) + 1] = c->lo[1] + (b + 0.5) * dv;
    pm_face_eval_many(c, G * G, uv, 1, fp);
    for (int k = 0; k < G * G; ++k) {
      if (!pm_face_inside(c, &uv[2 * k])) continue;
      double n[3];
      pm_v3_cross(n, fp[k].su, fp[k].sv);
      const double d = edge_at(s, fp[k].p);
      nf += pm_v3_norm(n) * du * dv / (0.8660254037844386 * d * d);
    }
  }
  *curves = nc, *faces = nf;
}

pm_status psys_check_caps(const psys_sys *s, pm_error *err) {
  double nc, nf;
  psys_estimate_count(s, &nc, &nf);
  const double n = nc + nf + s->model->count[PM_VERTEX];
  const double cap_n = (double)s->max_particles;
  const double cap_m = s->max_bytes / PSYS_BYTES_PER_PARTICLE;
  const double cap = cap_n < cap_m ? cap_n : cap_m;
  if (!(n > cap)) return PM_OK;
  /* the factor c on the field that fits: nf / c^2 + nc / c = cap */
  const double c = (nc + sqrt(nc * nc + 4 * cap * nf)) / (2 * cap);
  char what[128];
  if (cap_n <= cap_m)
    snprintf(what, sizeof what, "the particle cap of %.0f (--max-nodes)", cap_n);
  else
    snprintf(what, sizeof what, "the %.0f particles that fit the memory cap of %.2g GB "
             "(max_memory_gb)", cap_m, s->max_bytes / 1e9);
  if (!s->size)
    return pm_error_setf(err, PM_ERR_LIMIT,
                         "psys: even at its largest sigma the inferred field needs about %.3g "
                         "particles, above %s; a kappa_min %.3g times smaller fits",
                         n, what, c);
  /* a constant field reads back as a number: name the size that fits */
  const char *text = pm_sizing_describe(s->size);
  char *end = NULL;
  const double d = text ? strtod(text, &end) : 0;
  if (end && end != text && *end == '\0' && d > 0)
    return pm_error_setf(err, PM_ERR_LIMIT,
                         "psys: size %g needs about %.3g particles (curves %.3g, faces %.3g), "
                         "above %s; a size of at least %.3g fits",
                         d, n, nc, nf, what, c * d * (1 + 1e-3));
  return pm_error_setf(err, PM_ERR_LIMIT,
                       "psys: the size field needs about %.3g particles (curves %.3g, faces %.3g), "
                       "above %s; the field multiplied by at least %.3g fits",
                       n, nc, nf, what, c * (1 + 1e-3));
}

