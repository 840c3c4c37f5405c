/* The sizing field of the particle system (papers/001 section 3.1, eq. 11-15, Algorithm 2):
 * every free particle's sigma, inferred from curvature, gap size and a Lipschitz bound, or taken
 * from a given edge-length field.
 *
 * Eq. 11 against Algorithm 2. Eq. 11 reads sigma_i = max{sigma_min, min{sigma_max, sigma_kappa,
 * sigma_tau, sigma_L}} with sigma_kappa = 1 / kappa, while Algorithm 2 (line 10) writes
 * s_kappa sigma_kappa and s_tau sigma_tau. The bounds of eq. 12-13, sigma_min = 1 / (s_kappa
 * kappa_max) and sigma_max = 1 / (s_kappa kappa_min), are the curvature term evaluated at the
 * curvature limits only if the curvature term is 1 / (s_kappa kappa): s_kappa scales the
 * curvature ("in unit proportion to surface curvature", section 5.2.2; a larger s_kappa fits the
 * geometry closer, Fig. 2). We therefore use
 *     sigma_kappa' = 1 / (s_kappa clamp(kappa, kappa_min, kappa_max)),
 *     sigma_tau'   = s_tau x gap                (s_tau < 1 leaves room for more rows, Fig. 4),
 *     sigma_i      = max{sigma_min, min{sigma_max, sigma_kappa', sigma_tau', sigma_L}},
 * so a sphere of radius R settles at sigma = R / s_kappa.
 *
 * Lipschitz bound. Eq. 15, sigma_L = min_j (|r_ij| L + sigma_j) over the neighbours, is applied as
 * the fixpoint of eq. 11 and 15 together (section 3.1: "the sigma_i that respects all
 * constraints"), solved each update by a Dijkstra sweep from every particle's own bound
 * (curvature, gap, limits). The neighbours of i are the j with |r_ij| < max(sigma_i, sigma_j), a
 * set that depends on sigma_i itself: a j far smaller than its distance (sigma_j < (1 - L)|r_ij|)
 * constrains sigma_i only while i's ball reaches it, and sigma_j + L |r_ij| < |r_ij| does not.
 * Applied pair by pair the bound then flips from one update to the next (on: sigma_i drops below
 * |r_ij| and j stops being a neighbour; off: sigma_i grows back). The largest sigma_i for which
 * every neighbour pair, neighbours taken with the final sigma, satisfies eq. 14 is
 *     sigma_i = min{ bound_i, min_j max(|r_ij|, sigma_j + L |r_ij|) }
 * (i may stay larger than sigma_j + L |r_ij| as long as its ball stops short of j). Each pair
 * term is non-decreasing in sigma_j and at least sigma_j, so Dijkstra's label setting solves the
 * system exactly, and its result is the unique largest solution whatever the order of the
 * pairs. One application of eq. 15 per iteration would instead let a change travel one
 * neighbour per iteration; the paper notes that boundary values "pull down local sigma values
 * very quickly", and the fixpoint is what that tends to. Particles whose sigma is frozen
 * (vertices and curves in phase 3) act as fixed sources only: the bound holds from them to the
 * free particles, the paper's relaxation of the constraint where it cannot be satisfied
 * (section 3.1, end).
 *
 * Growth. A particle's sigma may rise by at most sigma_grow (1.5) per update (ours; the paper is
 * silent). Falls are immediate. This bounds the radius within which the gap and the Lipschitz
 * pairs have to be searched. The gap search, the widest, runs every third update where the last
 * gap found (less what the particle moved since) cannot constrain sigma, and every update where
 * the gap is, or may become, active.
 *
 * Gap size (section 3.1 "Gap Size", section 4.2, Algorithm 2). Phase 2, vertex and curve
 * particles: the gap of particle i is the distance to the nearest particle j on another cell
 * that is not adjacent to i's cell (neither lies in the other's closure), unless the two cells
 * meet at a vertex v and i or j lies inside v's corner ball (radius: v's sigma at the end of
 * phase 1). Cells that do not meet keep their gap inside corner balls too: the corner
 * degeneracy of section 4.2 only arises between cells that meet at the corner, and the two
 * parallel edges of a thin plate meet at no vertex, so their gap must hold up to the ends.
 * Phase 3, face particles ("this notion can be extended to 2-cells as well"; the extension is
 * ours): (a) the other cells that share no vertex with the face (another face, curve or vertex
 * across a thin wall): the nearest particle's distance, as above; (b) the face's own boundary:
 * the local width of the face through the particle, the least d_A + d_B over pairs of its
 * boundary cells A, B that share no vertex (two sides of a strip, a hole and the outline; a
 * narrow strip between two boundary curves gets sigma <= s_tau x its width across its whole
 * width, near its ends too, and a wide face is not constrained near its own edges, whose
 * neighbouring sides touch). d_A is the distance to a vertex, or to the polyline of a curve's
 * frozen particles between its end vertices, near the nearest of them: the boundary is sampled
 * at the spacing of its own sigma, and a short curve may hold no particle at all, so the distance
 * to its particles alone can exceed the width by half a spacing or more. Faces that share a vertex or a curve with the
 * particle's face are not a gap (their particles meet along the shared curve at every scale).
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "common/clock.h"
#include "common/vec3.h"
#include "psys/psys_private.h"

/* ---- curvature ---------------------------------------------------------------------------- */

static double face_kappa(const pm_cell *f, const double uv[2]) {
  double k1 = 0, k2 = 0;
  pm_face_curvatures(f, uv, &k1, &k2, NULL);
  return fabs(k1);
}

/* Largest principal curvature of face f at the point xyz (a point of a cell embedded in f). */
static double face_kappa_at(const pm_cell *f, const double xyz[3]) {
  double uv[2];
  if (pm_cell_project(f, xyz, NULL, uv, NULL, NULL, NULL) != PM_OK) return 0;
  return face_kappa(f, uv);
}

/* Curves: the larger of the curve's own curvature and the largest principal curvatures of the
 * faces it bounds or lies in, at parameter t (section 3.1: "for 1-cells, using the curvature of
 * the edge itself is insufficient"). */
static double curve_kappa(const psys_sys *s, const pm_cell *c, double t, const double xyz[3]) {
  double k = pm_curve_curvature(c, t);
  for (int32_t q = 0; q < c->nup; ++q) {
    const pm_cell *f = pm_model_cell(s->model, PM_FACE, c->up[q]);
    for (int32_t u = 0; u < f->nbound; ++u)
      if (f->bound[u].cell == c->index) {
        double uv[2];
        pm_face_curve_uv(f, &f->bound[u], t, uv);
        k = fmax(k, face_kappa(f, uv));
        break; /* a seam's two uses are the same points */
      }
  }
  for (int32_t q = 0; q < c->nhost; ++q)
    if (c->host[q].dim == PM_FACE)
      k = fmax(k, face_kappa_at(pm_model_cell(s->model, PM_FACE, c->host[q].index), xyz));
  return k;
}

double psys_curvature_sigma(const psys_sys *s, int dim, int32_t cell, const double *par,
                            const double xyz[3]) {
  const pm_cell *c = pm_model_cell(s->model, dim, cell);
  double k = 0;
  if (dim == PM_FACE) {
    k = face_kappa(c, par);
  } else if (dim == PM_CURVE) {
    k = curve_kappa(s, c, par[0], xyz);
  } else {
    /* 0-cells: the largest curvature of the 1-cells ending there. */
    int found = 0;
    for (int32_t q = 0; q < c->nup; ++q) {
      const pm_cell *cv = pm_model_cell(s->model, PM_CURVE, c->up[q]);
      if (cv->degenerate) continue;
      if (cv->nbound >= 1 && cv->bound[0].cell == cell)
        k = fmax(k, curve_kappa(s, cv, cv->lo[0], xyz)), found = 1;
      if (cv->nbound >= 2 && cv->bound[1].cell == cell)
        k = fmax(k, curve_kappa(s, cv, cv->hi[0], xyz)), found = 1;
    }
    if (!found)
      for (int32_t q = 0; q < c->nhost; ++q)
        if (c->host[q].dim == PM_FACE)
          k = fmax(k, face_kappa_at(pm_model_cell(s->model, PM_FACE, c->host[q].index), xyz));
  }
  if (!isfinite(k)) k = 0;
  /* eq. 12-13: the curvature is bounded to [kappa_min, kappa_max], so sigma_kappa' is bounded
   * to [sigma_min, sigma_max]. */
  k = fmin(fmax(k, s->kappa_min), s->kappa_max);
  return 1.0 / (s->p.s_kappa * k);
}

/* ---- candidates around a particle ---------------------------------------------------------- */

typedef struct cand {
  int32_t n, cap;
  int32_t *id;
  double *d2;
  int oom;
} cand;

static int cand_collect(int32_t id, double d2, void *user) {
  cand *c = user;
  if (c->n == c->cap) {
    int32_t cap = c->cap ? 2 * c->cap : 64;
    int32_t *id2 = realloc(c->id, sizeof(int32_t) * (size_t)cap);
    if (id2) c->id = id2;
    double *dd = realloc(c->d2, sizeof(double) * (size_t)cap);
    if (dd) c->d2 = dd;
    if (!id2 || !dd) {
      c->oom = 1;
      return 1;
    }
    c->cap = cap;
  }
  c->id[c->n] = id, c->d2[c->n] = d2, c->n++;
  return 0;
}

static void cand_free(cand *c) {
  free(c->id), free(c->d2);
  memset(c, 0, sizeof *c);
}

/* ---- gap size ------------------------------------------------------------------------------ */

/* Whether the gap applies to particle i now. */
static int gap_active(const psys_sys *s, int32_t i) {
  if (s->size || s->frozen[i]) return 0;
  return s->dim[i] <= PM_CURVE ? s->gap_curves : s->gap_faces;
}

/* The radius of the Lipschitz pairs searched around particle i: sigma_grow sigma_i, the largest
 * radius sigma_i can reach in this update. */
static double update_radius(const psys_sys *s, int32_t i) {
  return s->p.sigma_grow * s->sigma[i];
}

/* A tiny memo of relations between the particle's cell and the few other cells around it. */
typedef struct memo {
  int32_t n;
  int32_t key[16];
  int8_t val[16];
} memo;

static int memo_touch(const psys_sys *s, memo *m, int32_t ka, int32_t kb) {
  for (int32_t q = 0; q < m->n; ++q)
    if (m->key[q] == kb) return m->val[q];
  int v = psys_touch(s, ka, kb);
  if (m->n < 16) m->key[m->n] = kb, m->val[m->n] = (int8_t)v, m->n++;
  return v;
}

static int in_closure(const psys_sys *s, int32_t ka, int32_t kb) {
  /* kb in the closure of ka */
  const int32_t *v = s->clo + s->clo_off[ka];
  int32_t lo = 0, hi = s->clo_off[ka + 1] - s->clo_off[ka];
  while (lo < hi) {
    int32_t mid = lo + (hi - lo) / 2;
    if (v[mid] < kb)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo < s->clo_off[ka + 1] - s->clo_off[ka] && v[lo] == kb;
}

/* Section 4.2: the pair (i, j) on cells ka, kb lies "in a corner" when the cells meet at a
 * vertex v whose corner ball holds i or j. */
static int in_corner(const psys_sys *s, int32_t ka, int32_t kb, int32_t i, int32_t j) {
  const int32_t *a = s->vert + s->vert_off[ka], *b = s->vert + s->vert_off[kb];
  int32_t na = s->vert_off[ka + 1] - s->vert_off[ka], nb = s->vert_off[kb + 1] - s->vert_off[kb];
  int32_t p = 0, q = 0;
  while (p < na && q < nb) {
    if (a[p] < b[q]) {
      ++p;
    } else if (a[p] > b[q]) {
      ++q;
    } else {
      int32_t v = a[p];
      double rho = s->corner[v];
      const double *xv = pm_model_cell(s->model, PM_VERTEX, v)->xyz;
      if (rho > 0 && (pm_v3_dist2(&s->xyz[3 * i], xv) < rho * rho ||
                      pm_v3_dist2(&s->xyz[3 * j], xv) < rho * rho))
        return 1;
      ++p, ++q;
    }
  }
  return 0;
}

/* Record cell key k, reached through particle j at squared distance d2, in a small table of
 * cells (keeping the nearest particle per cell; when full, the farthest cell gives way). */
static void add_cell(int32_t *key, int32_t *near, double *d2s, int *n, int cap, int32_t k,
                     int32_t j, double d2) {
  for (int q = 0; q < *n; ++q)
    if (key[q] == k) {
      if (d2 < d2s[q]) d2s[q] = d2, near[q] = j;
      return;
    }
  if (*n < cap) {
    key[*n] = k, near[*n] = j, d2s[*n] = d2, ++*n;
    return;
  }
  int far = 0;
  for (int q = 1; q < cap; ++q)
    if (d2s[q] > d2s[far]) far = q;
  if (d2 < d2s[far]) key[far] = k, near[far] = j, d2s[far] = d2;
}

static double segment_distance(const double x[3], const double a[3], const double b[3]) {
  double ab[3], ax[3];
  pm_v3_sub(ab, b, a), pm_v3_sub(ax, x, a);
  double l2 = pm_v3_dot(ab, ab), t = l2 > 0 ? pm_v3_dot(ax, ab) / l2 : 0;
  t = t < 0 ? 0 : (t > 1 ? 1 : t);
  double p[3];
  pm_v3_axpy(p, a, t, ab);
  return pm_v3_dist(x, p);
}

/* Distance from x to the polyline of curve c's chain, on the segments at particle j (a particle
 * of the chain: a curve particle, or an end vertex). INFINITY when j is not on the chain. */
static double chain_distance(const psys_sys *s, int32_t c, int32_t j, const double x[3]) {
  const int32_t a = s->chain_off[c], b = s->chain_off[c + 1];
  int32_t p = -1;
  if (s->dim[j] == PM_CURVE && j < s->nfrozen) {
    p = s->chain_pos[j];
  } else if (s->dim[j] == PM_VERTEX) {
    if (b > a && s->chain[a] == j) p = a;
    else if (b > a && s->chain[b - 1] == j) p = b - 1;
  }
  if (p < a || p >= b) return INFINITY;
  double d = pm_v3_dist(x, &s->xyz[3 * s->chain[p]]);
  if (p > a) d = fmin(d, segment_distance(x, &s->xyz[3 * s->chain[p - 1]], &s->xyz[3 * s->chain[p]]));
  if (p + 1 < b) d = fmin(d, segment_distance(x, &s->xyz[3 * s->chain[p]], &s->xyz[3 * s->chain[p + 1]]));
  return d;
}

double psys_boundary_distance(const psys_sys *s, int32_t i, const double x[3], const int32_t *ids,
                              int32_t m) {
  double best = INFINITY;
  if (s->dim[i] != PM_FACE || !s->chain_off) return best;
  const int32_t ki = psys_key(s, PM_FACE, s->cell[i]);
  for (int32_t q = 0; q < m; ++q) {
    int32_t j = ids[q];
    if (j >= s->nfrozen || s->dim[j] == PM_FACE) continue;
    if (s->dim[j] == PM_CURVE) {
      if (in_closure(s, ki, psys_key(s, PM_CURVE, s->cell[j])))
        best = fmin(best, chain_distance(s, s->cell[j], j, x));
    } else {
      const pm_cell *v = pm_model_cell(s->model, PM_VERTEX, s->cell[j]);
      if (!in_closure(s, ki, psys_key(s, PM_VERTEX, s->cell[j]))) continue;
      best = fmin(best, pm_v3_dist(x, &s->xyz[3 * j]));
      for (int32_t u = 0; u < v->nup; ++u)
        if (in_closure(s, ki, psys_key(s, PM_CURVE, v->up[u])))
          best = fmin(best, chain_distance(s, v->up[u], j, x));
    }
  }
  return best;
}

typedef struct tkey {
  double t;
  int32_t id;
} tkey;

static int cmp_tkey(const void *a, const void *b) {
  const tkey *x = a, *y = b;
  if (x->t != y->t) return x->t < y->t ? -1 : 1;
  return (x->id > y->id) - (x->id < y->id);
}

pm_status psys_curve_chains(const psys_sys *s, int32_t **off_out, int32_t **chain_out,
                            int32_t **vpart_out, pm_error *err) {
  const pm_model *m = s->model;
  const int32_t nc = m->count[PM_CURVE], nv = m->count[PM_VERTEX];
  int32_t *off = calloc((size_t)nc + 1, sizeof(int32_t));
  int32_t *chain = malloc(sizeof(int32_t) * ((size_t)s->n + 2 * (size_t)nc + 1));
  int32_t *vpart = malloc(sizeof(int32_t) * ((size_t)nv + 1));
  int32_t *cnt = calloc((size_t)nc + 1, sizeof(int32_t));
  int32_t *start = malloc(sizeof(int32_t) * ((size_t)nc + 1));
  tkey *tk = malloc(sizeof(tkey) * ((size_t)s->n + 1));
  if (!off || !chain || !vpart || !cnt || !start || !tk) {
    free(off), free(chain), free(vpart), free(cnt), free(start), free(tk);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  for (int32_t v = 0; v < nv; ++v) vpart[v] = -1;
  for (int32_t i = 0; i < s->n; ++i) {
    if (s->dim[i] == PM_VERTEX) vpart[s->cell[i]] = i;
    if (s->dim[i] == PM_CURVE) cnt[s->cell[i]]++;
  }
  /* the particles of each curve, gathered by a counting sort, then ordered by t */
  for (int32_t c = 0, acc = 0; c < nc; ++c) start[c] = acc, acc += cnt[c], cnt[c] = 0;
  for (int32_t i = 0; i < s->n; ++i)
    if (s->dim[i] == PM_CURVE) {
      int32_t c = s->cell[i];
      tk[start[c] + cnt[c]++] = (tkey){s->par[2 * i], i};
    }
  int32_t pos = 0;
  for (int32_t c = 0; c < nc; ++c) {
    const pm_cell *cv = pm_model_cell(m, PM_CURVE, c);
    off[c] = pos;
    qsort(tk + start[c], (size_t)cnt[c], sizeof(tkey), cmp_tkey);
    int32_t va = cv->nbound >= 1 ? vpart[cv->bound[0].cell] : -1;
    int32_t vb = cv->nbound >= 2 ? vpart[cv->bound[1].cell] : -1;
    if (va >= 0) chain[pos++] = va;
    for (int32_t k = 0; k < cnt[c]; ++k) chain[pos++] = tk[start[c] + k].id;
    if (vb >= 0) chain[pos++] = vb;
  }
  off[nc] = pos;
  free(cnt), free(start), free(tk);
  *off_out = off, *chain_out = chain, *vpart_out = vpart;
  return PM_OK;
}

pm_status psys_build_chains(psys_sys *s, pm_error *err) {
  const pm_model *m = s->model;
  const int32_t nc = m->count[PM_CURVE];
  free(s->chain_off), free(s->chain), free(s->chain_pos), free(s->vpart);
  s->chain_off = s->chain = s->chain_pos = s->vpart = NULL;
  pm_status st = psys_curve_chains(s, &s->chain_off, &s->chain, &s->vpart, err);
  if (st) return st;
  if (!(s->chain_pos = malloc(sizeof(int32_t) * ((size_t)s->n + 1))))
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  s->nfrozen = s->n;
  for (int32_t i = 0; i < s->n; ++i) s->chain_pos[i] = -1;
  for (int32_t k = 0; k < s->chain_off[nc]; ++k)
    if (s->dim[s->chain[k]] == PM_CURVE) s->chain_pos[s->chain[k]] = k;
  /* the frozen particles alone, for the faces' gap searches */
  pm_grid_destroy(s->bgrid);
  s->bgrid = NULL;
  st = pm_grid_create(s->size ? 1e-6 * m->diagonal : 1e-2 * s->sigma_min, &s->bgrid, err);
  for (int32_t i = 0; i < s->n && !st; ++i)
    st = pm_grid_insert(s->bgrid, i, &s->xyz[3 * i], s->sigma[i], err);
  return st;
}

enum { GAP_BOUNDARY = 1, GAP_OTHER = 2 };

/* The gap of particle i from the candidates c: for a face particle, `parts` selects the width
 * through the face (GAP_BOUNDARY) and the nearest particle on a cell that shares no vertex with
 * the face (GAP_OTHER). */
static double gap_from(const psys_sys *s, int32_t i, const cand *c, int parts) {
  const int32_t ki = psys_key(s, s->dim[i], s->cell[i]);
  memo mt = {0};
  if (s->dim[i] <= PM_CURVE) {
    double best = INFINITY;
    for (int32_t q = 0; q < c->n; ++q) {
      int32_t j = c->id[q];
      if (j == i || !(c->d2[q] < best)) continue;
      int32_t kj = psys_key(s, s->dim[j], s->cell[j]);
      if (kj == ki || psys_adjacent(s, ki, kj)) continue;
      if (memo_touch(s, &mt, ki, kj) && in_corner(s, ki, kj, i, j)) continue;
      best = c->d2[q];
    }
    return sqrt(best);
  }
  /* A face particle: the distance to each boundary cell of the face that has a particle nearby,
   * and to the nearest particle of the cells that share no vertex with the face. */
  enum { MAXC = 32 };
  int32_t bk[MAXC], bnear[MAXC];
  double bd2[MAXC];
  int nb = 0;
  double other2 = INFINITY;
  for (int32_t q = 0; q < c->n; ++q) {
    int32_t j = c->id[q];
    if (j == i) continue;
    int32_t kj = psys_key(s, s->dim[j], s->cell[j]);
    if (kj == ki) continue;
    const double d2 = c->d2[q];
    if (s->dim[j] < PM_FACE && in_closure(s, ki, kj)) {
      add_cell(bk, bnear, bd2, &nb, MAXC, kj, j, d2);
      /* a vertex particle also stands for the curves of the face that end there: a curve
       * without particles of its own is known by its end vertices only */
      if (s->dim[j] == PM_VERTEX && s->chain_off) {
        const pm_cell *v = pm_model_cell(s->model, PM_VERTEX, s->cell[j]);
        for (int32_t u = 0; u < v->nup; ++u) {
          int32_t kc = psys_key(s, PM_CURVE, v->up[u]);
          if (in_closure(s, ki, kc)) add_cell(bk, bnear, bd2, &nb, MAXC, kc, j, INFINITY);
        }
      }
    } else if ((parts & GAP_OTHER) && d2 < other2 && !memo_touch(s, &mt, ki, kj)) {
      other2 = d2;
    }
  }
  if (!(parts & GAP_BOUNDARY)) return sqrt(other2);
  /* Distances to the curves: to their polylines of frozen particles near the nearest one found
   * (phase 3), not to that particle alone, so a sparse boundary does not look farther away than
   * it is. */
  double bd[MAXC];
  for (int a = 0; a < nb; ++a) {
    bd[a] = sqrt(bd2[a]);
    if (bk[a] >= s->koff[1] && s->chain_off) {
      double dc = chain_distance(s, bk[a] - s->koff[1], bnear[a], &s->xyz[3 * i]);
      if (dc < bd[a]) bd[a] = dc;
    }
  }
  /* The face's local width through the particle: the least sum of the distances to two of its
   * boundary cells that share no vertex (two sides of a strip, a hole and the outline). */
  double width = INFINITY;
  for (int a = 0; a < nb; ++a)
    for (int b = a + 1; b < nb; ++b) {
      double w = bd[a] + bd[b];
      if (w < width && !psys_touch(s, bk[a], bk[b])) width = w;
    }
  return fmin(width, sqrt(other2));
}

double psys_gap_distance(const psys_sys *s, int32_t i, double rq) {
  cand c = {0};
  pm_grid_visit(s->grid, &s->xyz[3 * i], rq, PM_GRID_BALL, cand_collect, &c);
  double g = c.oom ? INFINITY : gap_from(s, i, &c, GAP_BOUNDARY | GAP_OTHER);
  cand_free(&c);
  return g;
}

/* ---- the update ------------------------------------------------------------------------------ */

typedef struct ebuf {
  int64_t n, cap;
  int32_t *a, *b;
  double *r;
  int oom;
} ebuf;

static void ebuf_push(ebuf *e, int32_t a, int32_t b, double r) {
  if (e->oom) return;
  if (e->n == e->cap) {
    int64_t cap = e->cap ? 2 * e->cap : 1024;
    int32_t *na = realloc(e->a, sizeof(int32_t) * (size_t)cap);
    if (na) e->a = na;
    int32_t *nb = realloc(e->b, sizeof(int32_t) * (size_t)cap);
    if (nb) e->b = nb;
    double *nr = realloc(e->r, sizeof(double) * (size_t)cap);
    if (nr) e->r = nr;
    if (!na || !nb || !nr) {
      e->oom = 1;
      return;
    }
    e->cap = cap;
  }
  e->a[e->n] = a, e->b[e->n] = b, e->r[e->n] = r, e->n++;
}

/* Binary min-heap of particle indices keyed by key[], with positions for decrease-key. */
typedef struct heap {
  int32_t n;
  int32_t *h, *pos;
  const double *key;
} heap;

static int heap_less(const heap *H, int32_t a, int32_t b) {
  double ka = H->key[a], kb = H->key[b];
  return ka < kb || (ka == kb && a < b);
}

static void heap_up(heap *H, int32_t k) {
  int32_t x = H->h[k];
  while (k > 0) {
    int32_t p = (k - 1) / 2;
    if (!heap_less(H, x, H->h[p])) break;
    H->h[k] = H->h[p], H->pos[H->h[k]] = k, k = p;
  }
  H->h[k] = x, H->pos[x] = k;
}

static void heap_down(heap *H, int32_t k) {
  int32_t x = H->h[k];
  for (;;) {
    int32_t c = 2 * k + 1;
    if (c >= H->n) break;
    if (c + 1 < H->n && heap_less(H, H->h[c + 1], H->h[c])) ++c;
    if (!heap_less(H, H->h[c], x)) break;
    H->h[k] = H->h[c], H->pos[H->h[k]] = k, k = c;
  }
  H->h[k] = x, H->pos[x] = k;
}

/* The Lipschitz closure: key[] holds the bounds on entry and the closed field on return. */
static pm_status lipschitz_closure(psys_sys *s, double *key, const int32_t *ea, const int32_t *eb,
                                   const double *er, int64_t ne, pm_error *err) {
  const int32_t n = s->n;
  const double L = s->p.lipschitz;
  int64_t *off = calloc((size_t)n + 1, sizeof(int64_t));
  int32_t *adj = malloc(sizeof(int32_t) * (size_t)(2 * ne + 1));
  double *adr = malloc(sizeof(double) * (size_t)(2 * ne + 1));
  int32_t *h = malloc(sizeof(int32_t) * ((size_t)n + 1));
  int32_t *pos = malloc(sizeof(int32_t) * ((size_t)n + 1));
  uint8_t *done = calloc((size_t)n + 1, 1);
  pm_status st = PM_OK;
  if (!off || !adj || !adr || !h || !pos || !done) {
    st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto out;
  }
  for (int64_t e = 0; e < ne; ++e) off[ea[e] + 1]++, off[eb[e] + 1]++;
  for (int32_t i = 0; i < n; ++i) off[i + 1] += off[i];
  {
    int64_t *fill = malloc(sizeof(int64_t) * ((size_t)n + 1));
    if (!fill) {
      st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
      goto out;
    }
    memcpy(fill, off, sizeof(int64_t) * ((size_t)n + 1));
    for (int64_t e = 0; e < ne; ++e) {
      adj[fill[ea[e]]] = eb[e], adr[fill[ea[e]]++] = er[e];
      adj[fill[eb[e]]] = ea[e], adr[fill[eb[e]]++] = er[e];
    }
    free(fill);
  }
  heap H = {n, h, pos, key};
  for (int32_t i = 0; i < n; ++i) h[i] = i, pos[i] = i;
  for (int32_t k = n / 2 - 1; k >= 0; --k) heap_down(&H, k);
  while (H.n > 0) {
    int32_t u = H.h[0];
    H.h[0] = H.h[--H.n];
    if (H.n) H.pos[H.h[0]] = 0, heap_down(&H, 0);
    done[u] = 1;
    for (int64_t q = off[u]; q < off[u + 1]; ++q) {
      int32_t v = adj[q];
      if (done[v] || s->frozen[v]) continue;
      /* eq. 15 for the pair, unless v's ball stops short of u (see the file comment) */
      double r = adr[q], c = key[u] + L * r;
      if (c < r) c = r;
      if (c < key[v]) {
        key[v] = c;
        heap_up(&H, pos[v]);
      }
    }
  }
out:
  free(off), free(adj), free(adr), free(h), free(pos), free(done);
  return st;
}

static pm_status commit(psys_sys *s, const double *sig, pm_error *err) {
  for (int32_t i = 0; i < s->n; ++i) {
    if (s->frozen[i] || sig[i] == s->sigma[i]) continue;
    pm_status st = psys_set_sigma(s, i, sig[i], err);
    if (st) return st;
  }
  return PM_OK;
}

/* The given field: sigma = d(x) / edge_per_sigma. */
static pm_status update_given(psys_sys *s, pm_error *err) {
  const int32_t n = s->n;
  int32_t bad = -1;
#pragma omp parallel for num_threads(s->threads) schedule(dynamic, 256)
  for (int32_t i = 0; i < n; ++i) {
    if (s->frozen[i]) {
      s->target[i] = s->sigma[i];
      continue;
    }
    double d = pm_sizing_eval(s->size, &s->xyz[3 * i]);
    if (!(d > 0) || !isfinite(d)) {
#pragma omp critical(psys_bad)
      if (bad < 0 || i < bad) bad = i;
      s->target[i] = s->sigma[i];
      continue;
    }
    s->target[i] = d / s->p.edge_per_sigma;
  }
  if (bad >= 0) {
    const double *x = &s->xyz[3 * bad];
    return pm_error_setf(err, PM_ERR_ARG,
                         "size field is %g at (%g, %g, %g): it must be finite and > 0",
                         pm_sizing_eval(s->size, x), x[0], x[1], x[2]);
  }
  return commit(s, s->target, err);
}

pm_status psys_sigma_update(psys_sys *s, pm_error *err) {
  if (s->size) {
    double t0 = pm_seconds();
    pm_status st = update_given(s, err);
    psys_clock_add(s, PSYS_T_FIELD, pm_seconds() - t0);
    return st;
  }
  const int32_t n = s->n;
  const double g = s->p.sigma_grow;
  int oom = 0;
  int nthr = s->threads;
  ebuf *eb = calloc((size_t)nthr, sizeof(ebuf));
  double *key = malloc(sizeof(double) * ((size_t)n + 1));
  double(*cpu)[3] = calloc((size_t)nthr, sizeof *cpu); /* curvature, gap, Lipschitz pairs */
  if (!eb || !key || !cpu) {
    free(eb), free(key), free(cpu);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  double t_loop = pm_seconds();
#pragma omp parallel num_threads(nthr)
  {
#ifdef _OPENMP
    const int tid = omp_get_thread_num();
#else
    const int tid = 0;
#endif
    ebuf *e = &eb[tid];
    cand c = {0};
#pragma omp for schedule(dynamic, 64)
    for (int32_t i = 0; i < n; ++i) {
      const double *xi = &s->xyz[3 * i];
      if (s->frozen[i]) {
        s->target[i] = s->sigma[i];
        continue;
      }
      double ta = pm_seconds();
      /* the curvature bound, re-evaluated once the particle has moved kappa_refresh sigma */
      double moved2 = pm_v3_dist2(xi, &s->kxyz[3 * i]);
      double lim = s->p.kappa_refresh * s->sigma[i];
      if (s->dim[i] != PM_VERTEX && (moved2 > lim * lim || s->p.kappa_refresh == 0)) {
        s->sig_curv[i] = psys_curvature_sigma(s, s->dim[i], s->cell[i], &s->par[2 * i], xi);
        pm_v3_copy(&s->kxyz[3 * i], xi);
      }
      double T = fmin(s->sigma_max, s->sig_curv[i]);
      const double tmax = g * s->sigma[i];
      double tb = pm_seconds();
      cpu[tid][0] += tb - ta;
      if (gap_active(s, i)) {
        const double R = tmax / s->p.s_tau;
        double moved = pm_v3_dist(xi, &s->gxyz[3 * i]);
        double G = INFINITY;
        int fail = 0;
        if (s->dim[i] == PM_FACE && s->bgrid) {
          /* Phase 3, faces. The frozen particles (curves and vertices) never move: the width
           * through the face and the frozen cells that share no vertex with it are searched in
           * their own, sparse grid at every update. The particles of other faces (across a thin
           * wall) are searched in the main grid, with radius tmax / s_tau, every third update
           * (staggered by serial number) or once the particle moved a quarter sigma; in between,
           * the last distance found less the distance moved since bounds that gap from below
           * (the distance to a set is 1-Lipschitz), and new particles across the wall are seen
           * with a delay of at most two updates. */
          c.n = 0;
          pm_grid_visit(s->bgrid, xi, R, PM_GRID_BALL, cand_collect, &c);
          fail |= c.oom;
          if (!fail) G = gap_from(s, i, &c, GAP_BOUNDARY | GAP_OTHER);
          if (s->gap[i] < 0 || moved > 0.25 * s->sigma[i] ||
              (s->serial[i] + (uint64_t)s->iter) % 3 == 0) {
            c.n = 0;
            pm_grid_visit(s->grid, xi, R, PM_GRID_BALL, cand_collect, &c);
            fail |= c.oom;
            double Go = fail ? INFINITY : gap_from(s, i, &c, GAP_OTHER);
            s->gap[i] = Go < R ? Go : R;
            pm_v3_copy(&s->gxyz[3 * i], xi);
            G = fmin(G, Go);
          } else {
            G = fmin(G, s->gap[i] - moved);
          }
        } else if (s->gap[i] < 0 || s->p.s_tau * (s->gap[i] - 2 * moved) < tmax ||
                   (s->serial[i] + (uint64_t)s->iter) % 3 == 0) {
          /* Curves and vertices (phase 2): the gap search (radius tmax / s_tau: a farther
           * particle cannot bring s_tau x gap below tmax) is redone every third update
           * (staggered by serial number), and at once where the last gap found, less twice the
           * distance the particle moved since, could constrain sigma. Between searches new
           * particles on other cells, or their moves, may shorten the gap unseen for at most
           * two updates; a phase ends only after quiet iterations, when the searches have
           * caught up. */
          c.n = 0;
          pm_grid_visit(s->grid, xi, R, PM_GRID_BALL, cand_collect, &c);
          fail |= c.oom;
          G = fail ? INFINITY : gap_from(s, i, &c, GAP_BOUNDARY | GAP_OTHER);
          s->gap[i] = G < R ? G : R;
          pm_v3_copy(&s->gxyz[3 * i], xi);
        }
        if (fail) {
#pragma omp atomic write
          oom = 1;
          continue;
        }
        T = fmin(T, s->p.s_tau * G);
      }
      ta = pm_seconds();
      cpu[tid][1] += ta - tb;
      c.n = 0;
      pm_grid_visit(s->grid, xi, update_radius(s, i), PM_GRID_MUTUAL, cand_collect, &c);
      if (c.oom) {
#pragma omp atomic write
        oom = 1;
        continue;
      }
      T = fmin(T, tmax);
      T = fmax(T, s->sigma_min);
      s->target[i] = T;
      /* Lipschitz pairs: each unordered pair once (from the lower index, or from the one whose
       * search found the other alone); frozen particles do not search. */
      for (int32_t q = 0; q < c.n; ++q) {
        int32_t j = c.id[q];
        if (j == i) continue;
        double sj = s->sigma[j], si = s->sigma[i];
        double r = sqrt(c.d2[q]);
        if (!(r < g * (si > sj ? si : sj))) continue;
        int keep = s->frozen[j] || j > i;
        if (!keep) {
          double R = update_radius(s, j);
          if (si > R) R = si;
          keep = !(c.d2[q] < R * R * (1 - 1e-12)); /* j's search does not reach i */
        }
        if (keep) ebuf_push(e, i, j, r);
      }
      cpu[tid][2] += pm_seconds() - ta;
    }
    cand_free(&c);
  }
  {
    const psys_step ks[3] = {PSYS_T_CURVATURE, PSYS_T_GAP, PSYS_T_LIPSCHITZ};
    double sum[3] = {0, 0, 0};
    for (int t = 0; t < nthr; ++t)
      for (int k = 0; k < 3; ++k) sum[k] += cpu[t][k];
    psys_clock_split(s, pm_seconds() - t_loop, 3, ks, sum);
  }
  t_loop = pm_seconds();
  pm_status st = PM_OK;
  int64_t ne = 0;
  for (int t = 0; t < nthr; ++t) {
    if (eb[t].oom) oom = 1;
    ne += eb[t].n;
  }
  if (oom) {
    st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto out;
  }
  {
    int32_t *ea = malloc(sizeof(int32_t) * (size_t)(ne + 1));
    int32_t *ebb = malloc(sizeof(int32_t) * (size_t)(ne + 1));
    double *er = malloc(sizeof(double) * (size_t)(ne + 1));
    if (!ea || !ebb || !er) {
      free(ea), free(ebb), free(er);
      st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
      goto out;
    }
    int64_t k = 0;
    for (int t = 0; t < nthr; ++t) {
      if (!eb[t].n) continue;
      memcpy(ea + k, eb[t].a, sizeof(int32_t) * (size_t)eb[t].n);
      memcpy(ebb + k, eb[t].b, sizeof(int32_t) * (size_t)eb[t].n);
      memcpy(er + k, eb[t].r, sizeof(double) * (size_t)eb[t].n);
      k += eb[t].n;
    }
    for (int32_t i = 0; i < n; ++i) key[i] = s->target[i];
    /* Dijkstra's result is the unique largest fixpoint below the bounds (rounding is monotone),
     * so the order of the pairs, which depends on the threads, does not change it. */
    st = lipschitz_closure(s, key, ea, ebb, er, ne, err);
    free(ea), free(ebb), free(er);
    if (!st) st = commit(s, key, err);
    if (!st) s->unsized = 0;
  }
out:
  psys_clock_add(s, PSYS_T_LIPSCHITZ, pm_seconds() - t_loop);
  for (int t = 0; t < nthr; ++t) free(eb[t].a), free(eb[t].b), free(eb[t].r);
  free(eb);
  free(key);
  free(cpu);
  return st;
}
