/* Size fields sampled at the nodes of a mesh: how one method's field (psys's inferred sigma,
 * papers/001 eq. 11-15, converted to edge lengths) is handed to the other so both run on the
 * same field.
 *
 * Evaluation at x:
 *   1. Elements near x: every triangle and tet is filed by its box widened by `tol` (the box
 *      holds every point within tol of the element) in the bins of one level of a dyadic grid,
 *      the level whose cells are at least as wide as the box, so that it lies in at most 2 x 2 x 2
 *      bins (found by hash). x looks in its own bin at every level in use and keeps the elements
 *      whose box holds it: a superset of the elements within tol of x, whatever the grading of
 *      the sample mesh. (A pm_grid of balls, descended from its roots, answered the same in
 *      about twice the time and took a quarter of bubble's run on wrench.stp at 1e5 nodes.)
 *   2. For each, the closest point of the element to x and its barycentric coordinates
 *      (triangles: the Voronoi-region walk of Ericson, Real-Time Collision Detection, 5.1.5;
 *      tets: the barycentric coordinates when x is inside, else the closest point over the four
 *      faces). The element at the smallest distance wins (ties: triangles before tets, then the
 *      smaller index, so the choice does not depend on the grid's visiting order).
 *   3. If that distance is within tol = SAMPLE_TOL x the element's longest edge, the value is the
 *      linear interpolation at the closest point: exact for a linear field inside an element,
 *      and for x just off a curved boundary (the polygon of the sample mesh cuts inside the true
 *      boundary by the sagitta, h^2 / (8 R) <= h / 16 for a circle sampled with h <= R / 2) the
 *      value at the nearest point of the mesh.
 *   4. Otherwise inverse-distance weighting (weights 1 / d^2) of the SAMPLE_K nearest nodes
 *      (pm_grid_knearest_fixed, ranked by distance then id so the sum has a fixed order); a node
 *      at distance 0 gives its value directly.
 * Both branches are convex combinations of sample values, so the field stays within
 * [min value, max value] (the result is clamped to it against rounding). Neither the papers nor
 * DESIGN.md fix how a sampled field is interpolated; this is the natural choice for a field
 * given on a mesh and continuous inside it.
 *
 * Evaluation reads only immutable data and stack storage: safe from any number of threads.
 *
 * Cost (bench_sizing): about 1 us on the mesh, about 2 us beside it in its plane. The fallback is
 * meant for points near the mesh: far from a thin sample set (well above a planar mesh, deep
 * inside a closed surface mesh) many nodes are almost equally near, and an exact k-nearest
 * search must look at all of them (tens of microseconds on 10^4 nodes). A field for a volume
 * should be sampled on tets.
 */
#include "common/sizing/sizing_private.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/keyindex.h"
#include "common/sizing/grid.h"

/* Distance within which a point counts as on an element, relative to its longest edge. */
#define SAMPLE_TOL 0.1
/* Nodes averaged by the inverse-distance fallback. */
#define SAMPLE_K 8
/* Bin keys: 6 bits of level (relative to the finest level filed) and 19 bits per axis. */
#define BIN_LEVELS 64
#define BIN_AXIS_BITS 19
#define BIN_AXIS_MAX ((int64_t)1 << BIN_AXIS_BITS)
/* An element whose area (volume) is below this fraction of its longest edge squared (cubed)
 * is degenerate: it has no barycentric coordinates and is left out. */
#define DEGENERATE_REL 1e-12

struct sz_sampled {
  int32_t nnode, ntri, ntet;
  double *xyz;   /* [3 nnode] */
  double *val;   /* [nnode] */
  int32_t *tri;  /* [3 ntri] */
  int32_t *tet;  /* [4 ntet] */
  double *tol;   /* [ntri + ntet] distance tolerance per element */
  double vmin, vmax;
  pm_grid *nodes; /* ids: node indices */
  /* The element bins (step 1; element e < ntri is triangle e, else tet e - ntri). */
  double *box;         /* [6 nel] lo, hi of the box widened by tol; NaN: degenerate, never filed */
  double origin[3];    /* bin (l, i, j, k) is origin + 2^l [i, i + 1) x [j, j + 1) x [k, k + 1) */
  int32_t nlev;        /* levels in use, listed in lev[] (ascending, relative to the finest
                          level filed; lev_scale holds 2^-l of each) */
  int8_t lev[BIN_LEVELS];
  double lev_scale[BIN_LEVELS]; /* 2^-l of each listed level */
  pm_keyindex bins;    /* key -> bin */
  int32_t *bin_off;    /* [nbin + 1] into bin_ids */
  int32_t *bin_ids;
};

static inline void sub3(const double *a, const double *b, double *o) {
  o[0] = a[0] - b[0], o[1] = a[1] - b[1], o[2] = a[2] - b[2];
}
static inline double dot3(const double *a, const double *b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
static inline double dist2(const double *a, const double *b) {
  double d[3];
  sub3(a, b, d);
  return dot3(d, d);
}

/* Closest point of triangle (a, b, c) to p: barycentric coordinates into w, squared distance
 * returned. Ericson 5.1.5: find the Voronoi region of p (vertex, edge or face) from the signs of
 * a few dot products, so no case divides by a vanishing quantity. */
static double tri_closest(const double *a, const double *b, const double *c, const double *p,
                          double w[3]) {
  double ab[3], ac[3], ap[3], bp[3], cp[3];
  sub3(b, a, ab), sub3(c, a, ac), sub3(p, a, ap);
  double d1 = dot3(ab, ap), d2 = dot3(ac, ap);
  if (d1 <= 0 && d2 <= 0) {
    w[0] = 1, w[1] = 0, w[2] = 0;
    return dist2(p, a);
  }
  sub3(p, b, bp);
  double d3 = dot3(ab, bp), d4 = dot3(ac, bp);
  if (d3 >= 0 && d4 <= d3) {
    w[0] = 0, w[1] = 1, w[2] = 0;
    return dist2(p, b);
  }
  double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    double v = d1 / (d1 - d3);
    w[0] = 1 - v, w[1] = v, w[2] = 0;
  } else {
    sub3(p, c, cp);
    double d5 = dot3(ab, cp), d6 = dot3(ac, cp);
    if (d6 >= 0 && d5 <= d6) {
      w[0] = 0, w[1] = 0, w[2] = 1;
      return dist2(p, c);
    }
    double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) {
      double t = d2 / (d2 - d6);
      w[0] = 1 - t, w[1] = 0, w[2] = t;
    } else {
      double va = d3 * d6 - d5 * d4;
      if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
        double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        w[0] = 0, w[1] = 1 - t, w[2] = t;
      } else {
        double den = 1 / (va + vb + vc);
        w[1] = vb * den, w[2] = vc * den, w[0] = 1 - w[1] - w[2];
      }
    }
  }
  double q[3];
  for (int k = 0; k < 3; ++k) q[k] = w[0] * a[k] + w[1] * b[k] + w[2] * c[k];
  return dist2(p, q);
}

/* Closest point of tet (a, b, c, d) to p: barycentric coordinates into w[4], squared distance
 * returned (0 inside). */
static double tet_closest(const double *const v[4], const double *p, double w[4]) {
  double e1[3], e2[3], e3[3], q[3];
  sub3(v[1], v[0], e1), sub3(v[2], v[0], e2), sub3(v[3], v[0], e3), sub3(p, v[0], q);
  /* Cramer's rule on [e1 e2 e3] l = q. */
  double c23[3] = {e2[1] * e3[2] - e2[2] * e3[1], e2[2] * e3[0] - e2[0] * e3[2],
                   e2[0] * e3[1] - e2[1] * e3[0]};
  double det = dot3(e1, c23);
  double c31[3] = {e3[1] * e1[2] - e3[2] * e1[1], e3[2] * e1[0] - e3[0] * e1[2],
                   e3[0] * e1[1] - e3[1] * e1[0]};
  double c12[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                   e1[0] * e2[1] - e1[1] * e2[0]};
  double l1 = dot3(q, c23) / det, l2 = dot3(q, c31) / det, l3 = dot3(q, c12) / det;
  double l0 = 1 - l1 - l2 - l3;
  /* Inside up to rounding: the coordinates are the interpolation weights. */
  const double eps = -1e-12;
  if (l0 >= eps && l1 >= eps && l2 >= eps && l3 >= eps) {
    w[0] = l0, w[1] = l1, w[2] = l2, w[3] = l3;
    return 0;
  }
  static const int face[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  double best = INFINITY;
  for (int f = 0; f < 4; ++f) {
    double fw[3];
    double d2 = tri_closest(v[face[f][0]], v[face[f][1]], v[face[f][2]], p, fw);
    if (d2 < best) {
      best = d2;
      w[0] = w[1] = w[2] = w[3] = 0;
      for (int k = 0; k < 3; ++k) w[face[f][k]] = fw[k];
    }
  }
  return best;
}

/* ---- evaluation ---------------------------------------------------------------------------- */

typedef struct hit {
  const sz_sampled *s;
  const double *x;
  double best_d2; /* squared distance of the best element so far */
  int32_t best;   /* its element id, -1 */
  double w[4];    /* its barycentric coordinates */
} hit;

/* The bin key of level lev (relative) and axis keys k3. */
static inline uint64_t bin_key(int lev, const int64_t k3[3]) {
  return ((uint64_t)lev << (3 * BIN_AXIS_BITS)) | ((uint64_t)k3[0] << (2 * BIN_AXIS_BITS)) |
         ((uint64_t)k3[1] << BIN_AXIS_BITS) | (uint64_t)k3[2];
}

/* The axis keys of point x at listed level q; 0 when x lies outside the keyed range (no bin
 * there). The same arithmetic files the boxes, so a box holding x has a bin holding x's. */
static inline int bin_key_of(const sz_sampled *s, int32_t q, const double x[3], int64_t k3[3]) {
  for (int a = 0; a < 3; ++a) {
    const double f = floor((x[a] - s->origin[a]) * s->lev_scale[q]);
    if (!(f >= 0 && f < (double)BIN_AXIS_MAX)) return 0;
    k3[a] = (int64_t)f;
  }
  return 1;
}

static int on_element(int32_t e, double d2c, void *user) {
  (void)d2c;
  hit *h = user;
  const sz_sampled *s = h->s;
  double w[4] = {0, 0, 0, 0}, d2;
  if (e < s->ntri) {
    const int32_t *t = s->tri + 3 * e;
    d2 = tri_closest(s->xyz + 3 * t[0], s->xyz + 3 * t[1], s->xyz + 3 * t[2], h->x, w);
  } else {
    const int32_t *t = s->tet + 4 * (e - s->ntri);
    const double *v[4] = {s->xyz + 3 * t[0], s->xyz + 3 * t[1], s->xyz + 3 * t[2],
                          s->xyz + 3 * t[3]};
    d2 = tet_closest(v, h->x, w);
  }
  if (d2 > s->tol[e] * s->tol[e]) return 0;
  if (d2 < h->best_d2 || (d2 == h->best_d2 && e < h->best)) {
    h->best_d2 = d2;
    h->best = e;
    memcpy(h->w, w, sizeof w);
  }
  return 0;
}

double sz_sampled_eval(const sz_sampled *s, const double xyz[3]) {
  double v;
  hit h = {s, xyz, INFINITY, -1, {0, 0, 0, 0}};
  for (int32_t q = 0; q < s->nlev; ++q) {
    int64_t k3[3];
    if (!bin_key_of(s, q, xyz, k3)) continue;
    const int32_t b = pm_keyindex_get(&s->bins, bin_key(s->lev[q], k3));
    if (b < 0) continue;
    for (int32_t a = s->bin_off[b]; a < s->bin_off[b + 1]; ++a) {
      const int32_t e = s->bin_ids[a];
      const double *bx = s->box + 6 * e;
      if (xyz[0] >= bx[0] && xyz[0] <= bx[3] && xyz[1] >= bx[1] && xyz[1] <= bx[4] &&
          xyz[2] >= bx[2] && xyz[2] <= bx[5])
        on_element(e, 0, &h);
    }
  }
  if (h.best >= 0) {
    if (h.best < s->ntri) {
      const int32_t *t = s->tri + 3 * h.best;
      v = h.w[0] * s->val[t[0]] + h.w[1] * s->val[t[1]] + h.w[2] * s->val[t[2]];
    } else {
      const int32_t *t = s->tet + 4 * (h.best - s->ntri);
      v = h.w[0] * s->val[t[0]] + h.w[1] * s->val[t[1]] + h.w[2] * s->val[t[2]] +
          h.w[3] * s->val[t[3]];
    }
  } else {
    int32_t ids[SAMPLE_K];
    double d2[SAMPLE_K];
    int32_t k = pm_grid_knearest_fixed(s->nodes, xyz, SAMPLE_K, ids, d2);
    if (k == 0) return NAN; /* x not finite */
    if (d2[0] == 0) {
      /* on a node (or several coincident ones): their mean */
      double sum = 0;
      int32_t m = 0;
      while (m < k && d2[m] == 0) sum += s->val[ids[m++]];
      v = sum / m;
    } else {
      double sw = 0, sv = 0;
      for (int32_t i = 0; i < k; ++i) {
        double wi = 1 / d2[i];
        sw += wi;
        sv += wi * s->val[ids[i]];
      }
      v = sv / sw;
    }
  }
  return v < s->vmin ? s->vmin : (v > s->vmax ? s->vmax : v);
}

/* ---- construction -------------------------------------------------------------------------- */

void sz_sampled_destroy(sz_sampled *s) {
  if (!s) return;
  pm_grid_destroy(s->nodes);
  pm_keyindex_free(&s->bins);
  free(s->box), free(s->bin_off), free(s->bin_ids);
  free(s->xyz), free(s->val), free(s->tri), free(s->tet), free(s->tol);
  free(s);
}

static double longest_edge(const double *const v[], int nv) {
  double m = 0;
  for (int i = 0; i < nv; ++i)
    for (int j = i + 1; j < nv; ++j) {
      double d = dist2(v[i], v[j]);
      if (d > m) m = d;
    }
  return sqrt(m);
}

/* The tolerance and widened box of element e (vertices v[nv]); a degenerate element gets a NaN
 * box and is never filed. */
static void element_box(sz_sampled *s, int32_t e, const double *const v[], int nv) {
  double h = longest_edge(v, nv);
  double u[3], w[3], z[3], n[3];
  sub3(v[1], v[0], u), sub3(v[2], v[0], w);
  n[0] = u[1] * w[2] - u[2] * w[1], n[1] = u[2] * w[0] - u[0] * w[2], n[2] = u[0] * w[1] - u[1] * w[0];
  double size = nv == 3 ? sqrt(dot3(n, n)) / (h * h) : 0;
  if (nv == 4) {
    sub3(v[3], v[0], z);
    size = fabs(dot3(n, z)) / (h * h * h);
  }
  s->tol[e] = SAMPLE_TOL * h;
  double *bx = s->box + 6 * e;
  if (!(h > 0) || !(size > DEGENERATE_REL)) {
    for (int k = 0; k < 6; ++k) bx[k] = NAN;
    return;
  }
  /* Every point within tol of the element lies in the box of its vertices widened by tol; the
   * extra 1e-9 of the element's size covers the rounding of the bounds and of the distance. */
  const double pad = s->tol[e] + 1e-9 * h;
  for (int k = 0; k < 3; ++k) {
    double lo = v[0][k], hi = v[0][k];
    for (int i = 1; i < nv; ++i) lo = fmin(lo, v[i][k]), hi = fmax(hi, v[i][k]);
    bx[k] = lo - pad, bx[3 + k] = hi + pad;
  }
}

/* The level of a box of largest side w: the smallest l with 2^l >= w. */
static int32_t level_of(double w) {
  int ex;
  const double m = frexp(w, &ex); /* w = m 2^ex, m in [0.5, 1) */
  return m == 0.5 ? ex - 1 : ex;
}

/* The keys of the bins of listed level q that box bx meets (at most 8, since the level's cells
 * are as wide as the box); -1 outside the keyed range, which holds every box by construction. */
static int32_t box_keys(const sz_sampled *s, int32_t q, const double *bx, uint64_t keys[8]) {
  int64_t lo[3], hi[3];
  if (!bin_key_of(s, q, bx, lo) || !bin_key_of(s, q, bx + 3, hi)) return -1;
  int32_t n = 0;
  for (int64_t i = lo[0]; i <= hi[0]; ++i)
    for (int64_t j = lo[1]; j <= hi[1]; ++j)
      for (int64_t k = lo[2]; k <= hi[2]; ++k) keys[n++] = bin_key(s->lev[q], (int64_t[3]){i, j, k});
  return n;
}

/* File the elements' boxes in the bins (see step 1). */
static pm_status file_elements(sz_sampled *s, int32_t nel, pm_error *err) {
  double glo[3] = {INFINITY, INFINITY, INFINITY}, ghi[3] = {-INFINITY, -INFINITY, -INFINITY};
  int32_t lmin = INT32_MAX, lmax = INT32_MIN, nfiled = 0;
  int32_t *level = malloc(sizeof(int32_t) * (size_t)nel);
  if (!level) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory for the element bins");
  for (int32_t e = 0; e < nel; ++e) {
    const double *bx = s->box + 6 * e;
    level[e] = INT32_MIN;
    if (isnan(bx[0])) continue;
    double w = 0;
    for (int k = 0; k < 3; ++k) {
      glo[k] = fmin(glo[k], bx[k]), ghi[k] = fmax(ghi[k], bx[3 + k]);
      w = fmax(w, bx[3 + k] - bx[k]);
    }
    level[e] = level_of(w);
    lmin = level[e] < lmin ? level[e] : lmin, lmax = level[e] > lmax ? level[e] : lmax;
    ++nfiled;
  }
  if (!nfiled) {
    free(level);
    return PM_OK;
  }
  /* The finest level keeps the whole span within BIN_AXIS_MAX keys per axis (finer boxes are
   * filed there: they still meet at most two bins per axis), and at most BIN_LEVELS levels are
   * used (boxes finer than the coarsest level's 2^-63 are filed 63 levels below it). */
  double span = 0;
  for (int k = 0; k < 3; ++k) s->origin[k] = glo[k], span = fmax(span, ghi[k] - glo[k]);
  int32_t floor_lev = level_of(span) - (BIN_AXIS_BITS - 2);
  if (lmin < floor_lev) lmin = floor_lev;
  if (lmax < lmin) lmax = lmin;
  if (lmin < lmax - (BIN_LEVELS - 1)) lmin = lmax - (BIN_LEVELS - 1);
  uint8_t used[BIN_LEVELS] = {0};
  for (int32_t e = 0; e < nel; ++e)
    if (level[e] != INT32_MIN) {
      if (level[e] < lmin) level[e] = lmin;
      used[level[e] - lmin] = 1;
    }
  int8_t slot[BIN_LEVELS];
  s->nlev = 0;
  for (int q = 0; q < BIN_LEVELS; ++q)
    if (used[q]) {
      slot[q] = (int8_t)s->nlev;
      s->lev[s->nlev] = (int8_t)q;
      s->lev_scale[s->nlev] = ldexp(1.0, -(lmin + q));
      s->nlev++;
    }
  /* Two passes: number the bins and count their elements, then fill. The table and the counts
   * grow with the bins found (neighbouring elements share most of theirs), not with 8 per
   * element. */
  pm_status st = PM_OK;
  int32_t nbin = 0, cap = 0;
  int32_t *count = NULL;
  for (int pass = 0; pass < 2 && !st; ++pass) {
    for (int32_t e = 0; e < nel && !st; ++e) {
      if (level[e] == INT32_MIN) continue;
      if (pass == 0 && nbin + 8 > cap) {
        const int32_t nc = cap ? 2 * cap : 1024;
        int32_t *ncount = realloc(count, sizeof(int32_t) * (size_t)nc);
        if (!ncount || !pm_keyindex_reserve(&s->bins, nc)) {
          if (ncount) count = ncount;
          st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory for the element bins");
          break;
        }
        memset(ncount + cap, 0, sizeof(int32_t) * (size_t)(nc - cap));
        count = ncount, cap = nc;
      }
      uint64_t keys[8];
      const int32_t nk = box_keys(s, slot[level[e] - lmin], s->box + 6 * e, keys);
      for (int32_t a = 0; a < nk; ++a) {
        int32_t b = pm_keyindex_get(&s->bins, keys[a]);
        if (pass == 0) {
          if (b < 0) pm_keyindex_put(&s->bins, keys[a], b = nbin++);
          count[b]++;
        } else {
          s->bin_ids[s->bin_off[b] + count[b]++] = e;
        }
      }
    }
    if (st) break;
    if (pass == 0) {
      s->bin_off = malloc(sizeof(int32_t) * ((size_t)nbin + 1));
      int64_t total = 0;
      for (int32_t b = 0; b < nbin; ++b) total += count[b];
      s->bin_ids = malloc(sizeof(int32_t) * (size_t)(total + 1));
      if (!s->bin_off || !s->bin_ids) {
        st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory for the element bins");
        break;
      }
      s->bin_off[0] = 0;
      for (int32_t b = 0; b < nbin; ++b) s->bin_off[b + 1] = s->bin_off[b] + count[b], count[b] = 0;
    }
  }
  free(count), free(level);
  return st;
}

pm_status sz_sampled_create(const pm_mesh *m, const double *values, sz_sampled **out,
                            pm_error *err) {
  *out = NULL;
  if (!m || !values) return pm_error_setf(err, PM_ERR_ARG, "sampled size: no mesh or no values");
  if (m->nnode < 1) return pm_error_setf(err, PM_ERR_ARG, "sampled size: the mesh has no nodes");
  for (int32_t i = 0; i < m->nnode; ++i) {
    if (!(isfinite(values[i]) && values[i] > 0))
      return pm_error_setf(err, PM_ERR_ARG,
                           "sampled size: value %g at node %d is not a finite number > 0",
                           values[i], (int)i);
    for (int k = 0; k < 3; ++k)
      if (!isfinite(m->xyz[3 * i + k]))
        return pm_error_setf(err, PM_ERR_ARG, "sampled size: node %d has a non-finite coordinate",
                             (int)i);
  }
  for (int32_t e = 0; e < 3 * m->ntri; ++e)
    if (m->tri[e] < 0 || m->tri[e] >= m->nnode)
      return pm_error_setf(err, PM_ERR_ARG, "sampled size: triangle %d refers to node %d of %d",
                           (int)(e / 3), (int)m->tri[e], (int)m->nnode);
  for (int32_t e = 0; e < 4 * m->ntet; ++e)
    if (m->tet[e] < 0 || m->tet[e] >= m->nnode)
      return pm_error_setf(err, PM_ERR_ARG, "sampled size: tet %d refers to node %d of %d",
                           (int)(e / 4), (int)m->tet[e], (int)m->nnode);
  if ((int64_t)m->ntri + m->ntet >= INT32_MAX)
    return pm_error_setf(err, PM_ERR_LIMIT, "sampled size: too many elements");

  sz_sampled *s = calloc(1, sizeof *s);
  if (!s) return pm_error_setf(err, PM_ERR_NOMEM, "sampled size: out of memory");
  s->nnode = m->nnode, s->ntri = m->ntri, s->ntet = m->ntet;
  int32_t nel = s->ntri + s->ntet;
  s->xyz = malloc(sizeof(double) * 3 * (size_t)s->nnode);
  s->val = malloc(sizeof(double) * (size_t)s->nnode);
  s->tri = malloc(sizeof(int32_t) * 3 * (size_t)(s->ntri > 0 ? s->ntri : 1));
  s->tet = malloc(sizeof(int32_t) * 4 * (size_t)(s->ntet > 0 ? s->ntet : 1));
  s->tol = malloc(sizeof(double) * (size_t)(nel > 0 ? nel : 1));
  double *spacing = malloc(sizeof(double) * (size_t)s->nnode);
  if (!s->xyz || !s->val || !s->tri || !s->tet || !s->tol || !spacing) {
    free(spacing);
    sz_sampled_destroy(s);
    return pm_error_setf(err, PM_ERR_NOMEM, "sampled size: out of memory for %d nodes",
                         (int)m->nnode);
  }
  memcpy(s->xyz, m->xyz, sizeof(double) * 3 * (size_t)s->nnode);
  memcpy(s->val, values, sizeof(double) * (size_t)s->nnode);
  if (s->ntri) memcpy(s->tri, m->tri, sizeof(int32_t) * 3 * (size_t)s->ntri);
  if (s->ntet) memcpy(s->tet, m->tet, sizeof(int32_t) * 4 * (size_t)s->ntet);
  s->vmin = s->vmax = values[0];
  for (int32_t i = 1; i < s->nnode; ++i) s->vmin = fmin(s->vmin, values[i]), s->vmax = fmax(s->vmax, values[i]);

  /* Each node's spacing (its shortest element edge) is its radius in the node grid: the grid
   * files points by radius, and the spacing is the scale nearest-node queries work at. Nodes on
   * no element take the typical spacing of the bounding box. */
  double lo[3], hi[3];
  for (int k = 0; k < 3; ++k) lo[k] = hi[k] = s->xyz[k];
  for (int32_t i = 0; i < s->nnode; ++i) {
    spacing[i] = INFINITY;
    for (int k = 0; k < 3; ++k) lo[k] = fmin(lo[k], s->xyz[3 * i + k]), hi[k] = fmax(hi[k], s->xyz[3 * i + k]);
  }
  for (int32_t e = 0; e < nel; ++e) {
    int nv = e < s->ntri ? 3 : 4;
    const int32_t *t = e < s->ntri ? s->tri + 3 * e : s->tet + 4 * (e - s->ntri);
    for (int a = 0; a < nv; ++a)
      for (int b = a + 1; b < nv; ++b) {
        double d = sqrt(dist2(s->xyz + 3 * t[a], s->xyz + 3 * t[b]));
        if (d > 0) spacing[t[a]] = fmin(spacing[t[a]], d), spacing[t[b]] = fmin(spacing[t[b]], d);
      }
  }
  double diag = sqrt(dist2(lo, hi));
  double typical = diag > 0 ? diag / cbrt((double)s->nnode) : 1;
  double smallest = typical;
  for (int32_t i = 0; i < s->nnode; ++i) {
    if (!isfinite(spacing[i])) spacing[i] = typical;
    smallest = fmin(smallest, spacing[i]);
  }
  pm_status st = pm_grid_create(0.5 * smallest, &s->nodes, err);
  if (!st) st = pm_grid_reserve(s->nodes, s->nnode - 1, err);
  for (int32_t i = 0; i < s->nnode && !st; ++i)
    st = pm_grid_insert(s->nodes, i, s->xyz + 3 * i, spacing[i], err);
  free(spacing);
  if (!st && nel > 0) {
    if (!(s->box = malloc(sizeof(double) * 6 * (size_t)nel)))
      st = pm_error_setf(err, PM_ERR_NOMEM, "out of memory for %d elements", (int)nel);
    for (int32_t e = 0; e < nel && !st; ++e) {
      int nv = e < s->ntri ? 3 : 4;
      const int32_t *t = e < s->ntri ? s->tri + 3 * e : s->tet + 4 * (e - s->ntri);
      const double *v[4] = {s->xyz + 3 * t[0], s->xyz + 3 * t[1], s->xyz + 3 * t[2],
                            nv == 4 ? s->xyz + 3 * t[3] : NULL};
      element_box(s, e, v, nv);
    }
    if (!st) st = file_elements(s, nel, err);
  }
  if (st) {
    sz_sampled_destroy(s);
    return pm_error_prefix(err, "sampled size");
  }
  *out = s;
  return PM_OK;
}
