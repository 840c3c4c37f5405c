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
 * pairs have to be searched: the gap of particle i among the particles within R_i = sigma_grow
 * sigma_i / s_tau (a farther one cannot bring s_tau x gap below sigma_grow sigma_i), the
 * Lipschitz pairs among those within sigma_grow max(sigma_i, sigma_j).
 *
 * Incremental update. Both searches read the lists of the neighbour structure (psys_nbr.c),
 * which are kept valid as particles move and sigma changes, instead of searching a grid: the gap
 * from the particle's gap list (the particles of cells that can make a gap for it), the
 * Lipschitz pairs from its neighbour list; each filters its list with the current points and
 * sigma, so the field is exactly the one a search from scratch gives at every update. The closure
 * starts from a parallel pass in which each particle takes the lowest pair term of its
 * neighbours' bounds; only the particles that pass lowered enter Dijkstra's heap (see
 * lipschitz_lists). psys_sigma_reference computes the same field from scratch (a fresh grid,
 * Dijkstra over every particle); the tests hold the two to 1e-12.
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

#include "common/base/clock.h"
#include "common/base/vec3.h"
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

double psys_geometry_sigma(const psys_sys *s, int dim, int32_t cell, const double *par,
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
  double sg = 1.0 / (s->p.s_kappa * k);
  if (s->width) sg = fmin(sg, pm_feature_size_eval(s->width, xyz) / s->p.edge_per_sigma);
  return sg;
}

/* ---- candidates around a particle ---------------------------------------------------------- */

/* Candidates of a gap: ids and squared distances. */
typedef struct cand {
  int32_t n, cap;
  int32_t *id;
  double *d2;
} cand;

static int cand_reserve(cand *c, int32_t cap) {
  if (cap <= c->cap) return 0;
  int32_t nc = c->cap ? 2 * c->cap : 64;
  if (nc < cap) nc = cap;
  int32_t *id = realloc(c->id, sizeof(int32_t) * (size_t)nc);
  if (id) c->id = id;
  double *d2 = realloc(c->d2, sizeof(double) * (size_t)nc);
  if (d2) c->d2 = d2;
  if (!id || !d2) return -1;
  c->cap = nc;
  return 0;
}

static void cand_free(cand *c) {
  free(c->id), free(c->d2);
  memset(c, 0, sizeof *c);
}

/* ---- gap size ------------------------------------------------------------------------------ */

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

int psys_in_closure(const psys_sys *s, int32_t ka, int32_t kb) {
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
  /* the frozen particles j with |x_i - x_j| < max((1 + step_max) sigma_i, sigma_j), wherever x
   * is: the ones a step of i can come near (whatever else the list holds) */
  const double ri = (1 + s->p.step_max) * s->sigma[i];
  for (int32_t q = 0; q < m; ++q) {
    int32_t j = ids[q];
    if (j >= s->nfrozen) break; /* the frozen particles come first: 0 .. nfrozen-1, ids sorted */
    if (s->dim[j] == PM_FACE) continue;
    const double rj = ri > s->sigma[j] ? ri : s->sigma[j];
    if (!(psys_d2(&s->xyz[3 * i], &s->xyz[3 * j]) < rj * rj)) continue;
    if (s->dim[j] == PM_CURVE) {
      if (psys_in_closure(s, ki, psys_key(s, PM_CURVE, s->cell[j])))
        best = fmin(best, chain_distance(s, s->cell[j], j, x));
    } else {
      const pm_cell *v = pm_model_cell(s->model, PM_VERTEX, s->cell[j]);
      if (!psys_in_closure(s, ki, psys_key(s, PM_VERTEX, s->cell[j]))) continue;
      best = fmin(best, pm_v3_dist(x, &s->xyz[3 * j]));
      for (int32_t u = 0; u < v->nup; ++u)
        if (psys_in_closure(s, ki, psys_key(s, PM_CURVE, v->up[u])))
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
  return PM_OK;
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
    if (s->dim[j] < PM_FACE && psys_in_closure(s, ki, kj)) {
      add_cell(bk, bnear, bd2, &nb, MAXC, kj, j, d2);
      /* a vertex particle also stands for the curves of the face that end there: a curve
       * without particles of its own is known by its end vertices only */
      if (s->dim[j] == PM_VERTEX && s->chain_off) {
        const pm_cell *v = pm_model_cell(s->model, PM_VERTEX, s->cell[j]);
        for (int32_t u = 0; u < v->nup; ++u) {
          int32_t kc = psys_key(s, PM_CURVE, v->up[u]);
          if (psys_in_closure(s, ki, kc)) add_cell(bk, bnear, bd2, &nb, MAXC, kc, j, INFINITY);
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

/* The radius R_i within which the gap of particle i is looked for: sigma_grow sigma_i / s_tau (a
 * farther particle cannot bring s_tau x gap below the largest sigma_i may reach in this update,
 * sigma_grow sigma_i). */
static double gap_radius(const psys_sys *s, int32_t i) {
  return s->p.sigma_grow * s->sigma[i] / s->p.s_tau;
}

/* The gap of particle i from the candidates ids[m] (sorted): those within R_i, in id order. */
static double gap_of(const psys_sys *s, int32_t i, const int32_t *ids, int32_t m, cand *c) {
  const double R = gap_radius(s, i), R2 = R * R;
  if (cand_reserve(c, m)) return -1;
  c->n = 0;
  const double *xi = &s->xyz[3 * i];
  for (int32_t q = 0; q < m; ++q) {
    const double d2 = psys_d2(&s->xyz[3 * ids[q]], xi);
    if (d2 <= R2 && ids[q] != i) c->id[c->n] = ids[q], c->d2[c->n++] = d2;
  }
  return gap_from(s, i, c, GAP_BOUNDARY | GAP_OTHER);
}

double psys_gap_distance(const psys_sys *s, int32_t i) {
  cand c = {0};
  const psys_list *l = psys_gp(s, i);
  double g = gap_of(s, i, l->ids, l->n, &c);
  cand_free(&c);
  return g < 0 ? INFINITY : g;
}

/* ---- the Lipschitz closure ----------------------------------------------------------------- */

/* Binary min-heap of particle indices keyed by key[] (ties: the lower index), with positions for
 * decrease-key; pos[v] = -1 when v is not in the heap. */
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

static void heap_push_or_lower(heap *H, int32_t v) {
  if (H->pos[v] < 0) H->h[H->n] = v, H->pos[v] = H->n, H->n++;
  heap_up(H, H->pos[v]);
}

static int32_t heap_pop(heap *H) {
  int32_t u = H->h[0];
  H->pos[u] = -1;
  H->h[0] = H->h[--H->n];
  if (H->n) H->pos[H->h[0]] = 0, heap_down(H, 0);
  return u;
}

/* The pair term of eq. 15 for pair distance r from the neighbour's value k: k + L r, but at least
 * r (the ball of the particle may stop short of the neighbour; see the file comment). */
static inline double lip_term(double k, double L, double r) {
  double c = k + L * r;
  return c < r ? r : c;
}

/* Whether the pair (i, j) takes part in the Lipschitz closure: |x_i - x_j| < sigma_grow
 * max(sigma_i, sigma_j), with the sigma of before the update; *r receives the distance. */
static inline int lip_pair(const psys_sys *s, int32_t i, int32_t j, double *r) {
  const double *xi = &s->xs[4 * i], *xj = &s->xs[4 * j];
  const double m = s->p.sigma_grow * (xi[3] > xj[3] ? xi[3] : xj[3]);
  const double d2 = psys_d2(xi, xj);
  /* r < m, decided on d2 first where it is clear (the square root only near the edge and
   * inside: sqrt is correctly rounded, so r < m and d2 < m^2 differ only within an ulp) */
  if (d2 > m * m * (1 + 1e-12)) return 0;
  *r = sqrt(d2);
  return *r < m;
}

/* The closure from the bounds b[] (target) into key[], over the neighbour lists. A particle
 * whose bound no neighbour's bound lowers (the first, parallel pass) keeps it unless a lowered
 * neighbour lowers it later; the lowered ones are settled by Dijkstra's label setting in order of
 * their value. Every pair term is non-decreasing in the neighbour's value and at least that
 * value, so a particle popped from the heap is final, and the result is the unique largest
 * solution -- the same, to the bit, as Dijkstra over every particle (psys_sigma_reference). */
static pm_status lipschitz_lists(psys_sys *s, const double *b, double *key, pm_error *err) {
  const int32_t n = s->n;
  const double L = s->p.lipschitz;
#pragma omp parallel for num_threads(s->threads) schedule(dynamic, 256) if (n > 2048)
  for (int32_t i = 0; i < n; ++i) {
    double k = b[i];
    if (!s->frozen[i]) {
      const psys_list *l = psys_nb(s, i);
      for (int32_t q = 0; q < l->n; ++q) {
        const int32_t j = l->ids[q];
        double r;
        if (!lip_pair(s, i, j, &r)) continue;
        const double c = lip_term(b[j], L, r);
        if (c < k) k = c;
      }
    }
    key[i] = k;
  }
  int32_t *h = malloc(sizeof(int32_t) * ((size_t)n + 1));
  int32_t *pos = malloc(sizeof(int32_t) * ((size_t)n + 1));
  if (!h || !pos) {
    free(h), free(pos);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  heap H = {0, h, pos, key};
  for (int32_t i = 0; i < n; ++i) pos[i] = -1;
  for (int32_t i = 0; i < n; ++i)
    if (key[i] < b[i]) h[H.n] = i, pos[i] = H.n, H.n++;
  for (int32_t k = H.n / 2 - 1; k >= 0; --k) heap_down(&H, k);
  while (H.n > 0) {
    const int32_t u = heap_pop(&H);
    const psys_list *l = psys_nb(s, u);
    for (int32_t q = 0; q < l->n; ++q) {
      const int32_t v = l->ids[q];
      double r;
      if (s->frozen[v] || !lip_pair(s, u, v, &r)) continue;
      const double c = lip_term(key[u], L, r);
      if (c < key[v]) {
        key[v] = c;
        heap_push_or_lower(&H, v);
      }
    }
  }
  free(h), free(pos);
  return PM_OK;
}

/* ---- the update ------------------------------------------------------------------------------ */

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
  for (int32_t i = 0; i < n; ++i)
    if (!s->frozen[i]) psys_set_sigma(s, i, s->target[i]);
  return PM_OK;
}

/* Whether particle i's curvature bound is due again: it moved kappa_refresh sigma since. */
static int curvature_due(const psys_sys *s, int32_t i) {
  if (s->dim[i] == PM_VERTEX) return 0;
  const double lim = s->p.kappa_refresh * s->sigma[i];
  return psys_d2(&s->xyz[3 * i], &s->kxyz[3 * i]) > lim * lim || s->p.kappa_refresh == 0;
}

/* The bound of eq. 11 before the Lipschitz term (curvature, limits, growth, gap G), then the
 * width of narrow places below sigma_min: sig_curv is the geometry's bound, at least sigma_min
 * unless a narrow place made it less, and so min(max(T, sigma_min), sig_curv) is eq. 11's bound
 * capped by that width. */
static double bound_of(const psys_sys *s, int32_t i, double sig_curv, double G) {
  const double tmax = s->p.sigma_grow * s->sigma[i];
  double T = fmin(s->sigma_max, sig_curv);
  if (G < INFINITY) T = fmin(T, s->p.s_tau * G);
  T = fmin(T, tmax);
  return fmin(fmax(T, s->sigma_min), sig_curv);
}

pm_status psys_sigma_update(psys_sys *s, pm_error *err) {
  double t0 = pm_seconds();
  if (s->size) {
    pm_status st = update_given(s, err);
    psys_clock_add(s, PSYS_T_FIELD, pm_seconds() - t0);
    return st;
  }
  const int32_t n = s->n;
  if (s->nbr.held) psys_nbr_reset(s); /* the gap lists again, and the growth budget */
  pm_status st = psys_nbr_update(s, err); /* timed as the neighbour structure's */
  if (st) return st;
  double t1 = pm_seconds();
  /* the curvature bounds, re-evaluated once a particle has moved kappa_refresh sigma */
#pragma omp parallel for num_threads(s->threads) schedule(dynamic, 64) if (n > 512)
  for (int32_t i = 0; i < n; ++i) {
    if (s->frozen[i] || !curvature_due(s, i)) continue;
    const double *xi = &s->xyz[3 * i];
    s->sig_curv[i] = psys_geometry_sigma(s, s->dim[i], s->cell[i], &s->par[2 * i], xi);
    pm_v3_copy(&s->kxyz[3 * i], xi);
  }
  t0 = pm_seconds();
  psys_clock_add(s, PSYS_T_CURVATURE, t0 - t1);
  /* the bounds with the gap (eq. 11 but sigma_L) */
  int oom = 0;
#pragma omp parallel num_threads(s->threads) if (n > 512)
  {
    cand c = {0};
#pragma omp for schedule(dynamic, 64)
    for (int32_t i = 0; i < n; ++i) {
      if (s->frozen[i]) {
        s->target[i] = s->sigma[i];
        continue;
      }
      double G = INFINITY;
      if (psys_gap_active(s, i)) {
        const psys_list *l = psys_gp(s, i);
        G = gap_of(s, i, l->ids, l->n, &c);
        if (G < 0) {
#pragma omp atomic write
          oom = 1;
          G = INFINITY;
        }
      }
      s->target[i] = bound_of(s, i, s->sig_curv[i], G);
    }
    cand_free(&c);
  }
  if (oom) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  t1 = pm_seconds();
  psys_clock_add(s, PSYS_T_GAP, t1 - t0);
  /* the Lipschitz closure (eq. 14-15), then the new sigma */
  if ((st = lipschitz_lists(s, s->target, s->key, err))) return st;
  for (int32_t i = 0; i < n; ++i)
    if (!s->frozen[i]) psys_set_sigma(s, i, s->key[i]);
  s->unsized = 0;
  psys_clock_add(s, PSYS_T_LIPSCHITZ, pm_seconds() - t1);
  return PM_OK;
}

/* ---- the reference: everything from scratch --------------------------------------------------- */

/* Dijkstra over every particle, pairs given as an edge list (the closure as first written). */
static pm_status lipschitz_all(const psys_sys *s, double *key, const int32_t *ea, const int32_t *eb,
                               const double *er, int64_t ne, pm_error *err) {
  const int32_t n = s->n;
  const double L = s->p.lipschitz;
  int64_t *off = calloc((size_t)n + 1, sizeof(int64_t));
  int32_t *adj = malloc(sizeof(int32_t) * (size_t)(2 * ne + 1));
  double *adr = malloc(sizeof(double) * (size_t)(2 * ne + 1));
  int32_t *h = malloc(sizeof(int32_t) * ((size_t)n + 1));
  int32_t *pos = malloc(sizeof(int32_t) * ((size_t)n + 1));
  uint8_t *done = calloc((size_t)n + 1, 1);
  int64_t *fill = malloc(sizeof(int64_t) * ((size_t)n + 1));
  pm_status st = PM_OK;
  if (!off || !adj || !adr || !h || !pos || !done || !fill) {
    st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    goto out;
  }
  for (int64_t e = 0; e < ne; ++e) off[ea[e] + 1]++, off[eb[e] + 1]++;
  for (int32_t i = 0; i < n; ++i) off[i + 1] += off[i];
  memcpy(fill, off, sizeof(int64_t) * ((size_t)n + 1));
  for (int64_t e = 0; e < ne; ++e) {
    adj[fill[ea[e]]] = eb[e], adr[fill[ea[e]]++] = er[e];
    adj[fill[eb[e]]] = ea[e], adr[fill[eb[e]]++] = er[e];
  }
  heap H = {n, h, pos, key};
  for (int32_t i = 0; i < n; ++i) h[i] = i, pos[i] = i;
  for (int32_t k = n / 2 - 1; k >= 0; --k) heap_down(&H, k);
  while (H.n > 0) {
    int32_t u = heap_pop(&H);
    done[u] = 1;
    for (int64_t q = off[u]; q < off[u + 1]; ++q) {
      int32_t v = adj[q];
      if (done[v] || s->frozen[v]) continue;
      double c = lip_term(key[u], L, adr[q]);
      if (c < key[v]) key[v] = c, heap_up(&H, pos[v]);
    }
  }
out:
  free(off), free(adj), free(adr), free(h), free(pos), free(done), free(fill);
  return st;
}

pm_status psys_sigma_reference(const psys_sys *s, double *out, pm_error *err) {
  const int32_t n = s->n;
  if (s->size) {
    for (int32_t i = 0; i < n; ++i) {
      double d = pm_sizing_eval(s->size, &s->xyz[3 * i]);
      out[i] = s->frozen[i] ? s->sigma[i] : d / s->p.edge_per_sigma;
    }
    return PM_OK;
  }
  pm_grid *g = NULL;
  pm_idbuf q = PM_IDBUF_INIT;
  cand c = {0};
  int32_t *ea = NULL, *eb = NULL;
  double *er = NULL;
  int64_t ne = 0, cap = 0;
  /* the particles with radius sigma_grow sigma: a MUTUAL query then finds exactly the pairs of
   * the closure, a BALL query the gap's candidates */
  pm_status st = pm_grid_create(1e-2 * s->sigma_min, &g, err);
  for (int32_t i = 0; i < n && !st; ++i)
    st = pm_grid_insert(g, i, &s->xyz[3 * i], s->p.sigma_grow * s->sigma[i], err);
  for (int32_t i = 0; i < n && !st; ++i) {
    if (s->frozen[i]) {
      out[i] = s->sigma[i];
      continue;
    }
    double kc = s->sig_curv[i];
    if (curvature_due(s, i))
      kc = psys_geometry_sigma(s, s->dim[i], s->cell[i], &s->par[2 * i], &s->xyz[3 * i]);
    double G = INFINITY;
    if (psys_gap_active(s, i)) {
      if ((st = pm_grid_query(g, &s->xyz[3 * i], gap_radius(s, i), PM_GRID_BALL, &q, err))) break;
      G = gap_of(s, i, q.ids, q.n, &c);
      if (G < 0) st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    }
    out[i] = bound_of(s, i, kc, G);
  }
  /* every pair with |x_i - x_j| < sigma_grow max(sigma_i, sigma_j), once */
  for (int32_t i = 0; i < n && !st; ++i) {
    if ((st = pm_grid_query(g, &s->xyz[3 * i], s->p.sigma_grow * s->sigma[i], PM_GRID_MUTUAL, &q,
                            err)))
      break;
    for (int32_t k = 0; k < q.n; ++k) {
      const int32_t j = q.ids[k];
      double r;
      if (j <= i || !lip_pair(s, i, j, &r)) continue;
      if (ne == cap) {
        cap = cap ? 2 * cap : 1024;
        int32_t *na = realloc(ea, sizeof(int32_t) * (size_t)cap);
        if (na) ea = na;
        int32_t *nb = realloc(eb, sizeof(int32_t) * (size_t)cap);
        if (nb) eb = nb;
        double *nr = realloc(er, sizeof(double) * (size_t)cap);
        if (nr) er = nr;
        if (!na || !nb || !nr) {
          st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
          break;
        }
      }
      ea[ne] = i, eb[ne] = j, er[ne++] = r;
    }
  }
  if (!st) st = lipschitz_all(s, out, ea, eb, er, ne, err);
  free(ea), free(eb), free(er);
  cand_free(&c);
  pm_idbuf_free(&q);
  pm_grid_destroy(g);
  return st;
}
