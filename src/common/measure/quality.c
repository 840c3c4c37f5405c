/* Element and mesh quality measures (see quality.h for the definitions and conventions).
 *
 * Element measures are computed in parallel (each element writes its own slot, so the result
 * does not depend on the thread count); sums are then taken sequentially in index order. The
 * node degrees of eps_t and the unique edges of the size conformity come from the edge table of
 * mesh_topo.h (linear time). Percentiles sort with a radix sort, so 10^6 elements take
 * milliseconds per statistic.
 */
#include "common/measure/quality.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/mesh/mesh_topo.h"

#define RAD2DEG 57.295779513082320876798154814105

/* ---- vector helpers ----------------------------------------------------------------------- */

static inline void sub3(const double a[3], const double b[3], double o[3]) {
  o[0] = a[0] - b[0];
  o[1] = a[1] - b[1];
  o[2] = a[2] - b[2];
}
static inline double dot3(const double a[3], const double b[3]) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
static inline void cross3(const double a[3], const double b[3], double o[3]) {
  o[0] = a[1] * b[2] - a[2] * b[1];
  o[1] = a[2] * b[0] - a[0] * b[2];
  o[2] = a[0] * b[1] - a[1] * b[0];
}
static inline double norm3(const double a[3]) { return sqrt(dot3(a, a)); }

/* The angle between u and w in degrees, as atan2(|u x w|, u . w): accurate near 0 and 180
 * degrees, where acos of the normalized dot product loses half the digits. */
static double angle_deg(const double u[3], const double w[3]) {
  double c[3];
  cross3(u, w, c);
  return atan2(norm3(c), dot3(u, w)) * RAD2DEG;
}

/* ---- sorting and summaries ---------------------------------------------------------------- */

/* An unsigned key with the order of the doubles: flip every bit of a negative number, only the
 * sign bit of a positive one. */
static inline uint64_t dkey(double x) {
  uint64_t u;
  memcpy(&u, &x, sizeof u);
  return (u >> 63) ? ~u : (u | 0x8000000000000000ull);
}
static inline double dval(uint64_t k) {
  uint64_t u = (k >> 63) ? (k & 0x7fffffffffffffffull) : ~k;
  double x;
  memcpy(&x, &u, sizeof x);
  return x;
}

static int cmp_double(const void *pa, const void *pb) {
  double a = *(const double *)pa, b = *(const double *)pb;
  return (a > b) - (a < b);
}

pm_status pm_sort_doubles(double *v, size_t n, pm_error *err) {
  if (n < 2) return PM_OK;
  if (n < 256) {
    qsort(v, n, sizeof *v, cmp_double);
    return PM_OK;
  }
  /* LSD radix sort, six passes of 11 bits; a pass whose digit is the same for every key (the
   * high exponent bits of values of one magnitude, typically) is skipped. */
  uint64_t *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b);
  if (!a || !b) {
    free(a);
    free(b);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory sorting %zu values", n);
  }
  for (size_t i = 0; i < n; ++i) a[i] = dkey(v[i]);
  enum { BITS = 11, BUCKETS = 1 << BITS };
  size_t count[BUCKETS];
  for (int shift = 0; shift < 64; shift += BITS) {
    memset(count, 0, sizeof count);
    for (size_t i = 0; i < n; ++i) count[(a[i] >> shift) & (BUCKETS - 1)]++;
    if (count[(a[0] >> shift) & (BUCKETS - 1)] == n) continue;
    size_t sum = 0;
    for (int k = 0; k < BUCKETS; ++k) {
      size_t c = count[k];
      count[k] = sum;
      sum += c;
    }
    for (size_t i = 0; i < n; ++i) b[count[(a[i] >> shift) & (BUCKETS - 1)]++] = a[i];
    uint64_t *t = a;
    a = b;
    b = t;
  }
  for (size_t i = 0; i < n; ++i) v[i] = dval(a[i]);
  free(a);
  free(b);
  return PM_OK;
}

double pm_percentile_sorted(const double *x, size_t n, double p) {
  if (n == 0) return 0.0;
  if (!(p > 0.0)) return x[0];
  if (p >= 1.0) return x[n - 1];
  double h = (double)(n - 1) * p;
  size_t i = (size_t)floor(h);
  if (i >= n - 1) return x[n - 1];
  double f = h - (double)i;
  return x[i] + f * (x[i + 1] - x[i]);
}

static inline void swapd(double *a, double *b) {
  double t = *a;
  *a = *b;
  *b = t;
}

/* Partial sort: afterwards x[k] holds the value of rank k in x[lo, hi), everything before it is
 * <= x[k] and everything after it >= x[k] (Hoare's selection with a median-of-three pivot).
 * Expected linear time; should the partitions keep coming out lopsided (more rounds than twice
 * the bits of the range size), the range is sorted instead, which bounds the worst case. */
static pm_status select_kth(double *x, size_t lo, size_t hi, size_t k, pm_error *err) {
  int rounds = 0, limit = 64;
  for (size_t m = hi - lo; m > 1; m >>= 1) limit += 2;
  while (hi - lo > 16) {
    if (++rounds > limit) return pm_sort_doubles(x + lo, hi - lo, err);
    size_t mid = lo + (hi - lo) / 2;
    if (x[mid] < x[lo]) swapd(&x[mid], &x[lo]);
    if (x[hi - 1] < x[lo]) swapd(&x[hi - 1], &x[lo]);
    if (x[hi - 1] < x[mid]) swapd(&x[hi - 1], &x[mid]);
    double pivot = x[mid];
    size_t i = lo, j = hi - 1;
    for (;;) {
      while (x[i] < pivot) ++i;
      while (x[j] > pivot) --j;
      if (i >= j) break;
      swapd(&x[i], &x[j]);
      ++i;
      --j;
    }
    /* now x[lo, j] <= pivot <= x[j + 1, hi) (and x[i - 1] == pivot when i == j) */
    if (k <= j)
      hi = j + 1;
    else
      lo = j + 1;
  }
  for (size_t a = lo + 1; a < hi; ++a)
    for (size_t b = a; b > lo && x[b] < x[b - 1]; --b) swapd(&x[b], &x[b - 1]);
  return PM_OK;
}

/* Smallest of x[lo, hi). */
static double min_of(const double *x, size_t lo, size_t hi) {
  double m = x[lo];
  for (size_t a = lo + 1; a < hi; ++a)
    if (x[a] < m) m = x[a];
  return m;
}

/* The quartiles (type 7) of the n values of x, which are reordered. The median's rank is
 * selected first; the lower quartile's is then searched left of it and the upper quartile's
 * right of it. Rank i + 1, needed when h = (n - 1) p is not whole, is the smallest value right of
 * rank i (up to the next rank already in place). */
static pm_status quartiles(double *x, size_t n, double q[3], pm_error *err) {
  double h[3];
  size_t k[3];
  for (int j = 0; j < 3; ++j) {
    h[j] = (double)(n - 1) * 0.25 * (j + 1);
    k[j] = (size_t)floor(h[j]);
    if (k[j] > n - 1) k[j] = n - 1;
  }
  pm_status s = select_kth(x, 0, n, k[1], err);
  if (!s && k[0] < k[1]) s = select_kth(x, 0, k[1], k[0], err);
  if (!s && k[2] > k[1]) s = select_kth(x, k[1] + 1, n, k[2], err);
  if (s) return s;
  /* x[k[j]] is in place for every j; the value of rank k[j] + 1 lies in (k[j], end). */
  size_t end[3] = {k[1] > k[0] ? k[1] + 1 : n, k[2] > k[1] ? k[2] + 1 : n, n};
  for (int j = 0; j < 3; ++j) {
    double f = h[j] - (double)k[j];
    if (f == 0.0 || k[j] + 1 >= n) {
      q[j] = x[k[j]];
      continue;
    }
    size_t hi = end[j] < n ? end[j] : n;
    double next = k[j] + 1 < hi ? min_of(x, k[j] + 1, hi) : x[k[j] + 1];
    q[j] = x[k[j]] + f * (next - x[k[j]]);
  }
  return PM_OK;
}

pm_status pm_summary_compute(const double *v, size_t n, pm_summary *out, pm_error *err) {
  memset(out, 0, sizeof *out);
  if (n == 0) return PM_OK;
  double *x = malloc(n * sizeof *x);
  if (!x) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory summarizing %zu values", n);
  size_t m = 0;
  /* Neumaier's compensated sum: the mean does not drift with 10^6 terms. */
  double sum = 0.0, comp = 0.0, lo = INFINITY, hi = -INFINITY;
  for (size_t i = 0; i < n; ++i) {
    double a = v[i];
    if (isnan(a)) continue;
    x[m++] = a;
    double t = sum + a;
    comp += fabs(sum) >= fabs(a) ? (sum - t) + a : (a - t) + sum;
    sum = t;
    if (a < lo) lo = a;
    if (a > hi) hi = a;
  }
  if (m == 0) {
    free(x);
    return PM_OK;
  }
  out->n = (int64_t)m;
  out->min = lo;
  out->max = hi;
  out->mean = (sum + comp) / (double)m;
  double q[3];
  pm_status s = quartiles(x, m, q, err);
  out->p25 = q[0];
  out->median = q[1];
  out->p75 = q[2];
  free(x);
  return s;
}

/* ---- single elements ---------------------------------------------------------------------- */

void pm_tri_measure_eval(const double a[3], const double b[3], const double c[3],
                         pm_tri_measure *out) {
  double ab[3], bc[3], ca[3];
  sub3(b, a, ab);
  sub3(c, b, bc);
  sub3(a, c, ca);
  double la = norm3(bc), lb = norm3(ca), lc = norm3(ab); /* opposite a, b, c */
  double lmin = fmin(la, fmin(lb, lc)), lmax = fmax(la, fmax(lb, lc));
  /* Twice the area from the cross product at the vertex opposite the longest edge: its two
   * edges are the shortest, which keeps cancellation smallest for thin triangles. */
  double u[3], w[3], x[3];
  if (la >= lb && la >= lc) {
    sub3(b, a, u);
    sub3(c, a, w);
  } else if (lb >= lc) {
    sub3(c, b, u);
    sub3(a, b, w);
  } else {
    sub3(a, c, u);
    sub3(b, c, w);
  }
  cross3(u, w, x);
  double a2 = norm3(x);
  out->area = isfinite(a2) ? 0.5 * a2 : 0.0;
  /* Written as !(a > b) so that NaN coordinates also land in the degenerate branch. */
  if (!(a2 > PM_DEGENERATE_REL * lmax * lmax) || !isfinite(a2)) {
    out->degenerate = 1;
    out->radius_ratio = 0.0;
    out->rr = 0.0;
    out->aspect_ratio = PM_QUALITY_HUGE;
    out->min_angle = 0.0;
    out->max_angle = 180.0;
    return;
  }
  out->degenerate = 0;
  double abc = la * lb * lc;
  /* q = 2 r / R with r = A / s (s the half perimeter) and R = abc / (4 A):
   * q = 8 A^2 / (s abc) = 4 (2A)^2 / ((a + b + c) abc), papers/004 section 2.5. */
  out->radius_ratio = 4.0 * a2 * a2 / ((la + lb + lc) * abc);
  out->rr = 0.5 * out->radius_ratio;
  double R = abc / (2.0 * a2);
  out->aspect_ratio = fmin(R / lmin, PM_QUALITY_HUGE);
  /* The smallest angle faces the shortest edge and the largest the longest one; both are
   * atan2(2A, dot) at their vertex (|cross| = 2A at every vertex), so two atan2 calls suffice. */
  double e1[3], e2[3];
  const double *pv[3] = {a, b, c};
  const double lv[3] = {la, lb, lc};
  int imin = 0, imax = 0;
  for (int k = 1; k < 3; ++k) {
    if (lv[k] < lv[imin]) imin = k;
    if (lv[k] > lv[imax]) imax = k;
  }
  if (imin == imax) imax = (imin + 1) % 3; /* equilateral: any two vertices */
  sub3(pv[(imin + 1) % 3], pv[imin], e1);
  sub3(pv[(imin + 2) % 3], pv[imin], e2);
  out->min_angle = atan2(a2, dot3(e1, e2)) * RAD2DEG;
  sub3(pv[(imax + 1) % 3], pv[imax], e1);
  sub3(pv[(imax + 2) % 3], pv[imax], e2);
  out->max_angle = atan2(a2, dot3(e1, e2)) * RAD2DEG;
  if (out->min_angle > out->max_angle) { /* ties broken the other way round */
    double t = out->min_angle;
    out->min_angle = out->max_angle;
    out->max_angle = t;
  }
}

void pm_tet_measure_eval(const double a[3], const double b[3], const double c[3],
                         const double d[3], pm_tet_measure *out) {
  const double *p[4] = {a, b, c, d};
  static const int edge[6][4] = {/* i, j, then the other two */
                                 {0, 1, 2, 3}, {0, 2, 1, 3}, {0, 3, 1, 2},
                                 {1, 2, 0, 3}, {1, 3, 0, 2}, {2, 3, 0, 1}};
  double lmin = INFINITY, lmax = 0.0;
  for (int k = 0; k < 6; ++k) {
    double e[3];
    sub3(p[edge[k][1]], p[edge[k][0]], e);
    double l = norm3(e);
    lmin = fmin(lmin, l);
    lmax = fmax(lmax, l);
  }
  double u[3], v[3], w[3], vw[3], wu[3], uv[3];
  sub3(b, a, u);
  sub3(c, a, v);
  sub3(d, a, w);
  cross3(v, w, vw);
  cross3(w, u, wu);
  cross3(u, v, uv);
  double vol6 = dot3(u, vw);
  out->volume = isfinite(vol6) ? vol6 / 6.0 : 0.0;
  if (!(fabs(vol6) > PM_DEGENERATE_REL * lmax * lmax * lmax) || !isfinite(vol6)) {
    out->degenerate = 1;
    out->radius_ratio = 0.0;
    out->rr = 0.0;
    out->aspect_ratio = PM_QUALITY_HUGE;
    out->min_dihedral = 0.0;
    out->max_dihedral = 180.0;
    return;
  }
  out->degenerate = 0;
  /* Sum of the face areas: faces (a,b,c), (a,b,d), (a,c,d) from the cross products above,
   * (b,c,d) from its own. */
  double bc[3], bd[3], x[3];
  sub3(c, b, bc);
  sub3(d, b, bd);
  cross3(bc, bd, x);
  double area = 0.5 * (norm3(uv) + norm3(wu) + norm3(vw) + norm3(x));
  /* r_in = 3 V / area; circumcentre - a = (|u|^2 (v x w) + |v|^2 (w x u) + |w|^2 (u x v)) / (2 u.(v x w)). */
  double r = 0.5 * fabs(vol6) / area;
  double uu = dot3(u, u), vv = dot3(v, v), ww = dot3(w, w), o[3];
  for (int k = 0; k < 3; ++k) o[k] = (uu * vw[k] + vv * wu[k] + ww * uv[k]) / (2.0 * vol6);
  double R = norm3(o);
  out->rr = r / R;
  out->radius_ratio = 3.0 * r / R;
  out->aspect_ratio = fmin(R / lmin, PM_QUALITY_HUGE);
  /* The dihedral angle along edge (i, j) is the angle between the normals e x (p_k - p_i) and
   * e x (p_l - p_i) of its two faces: both are the components of p_k - p_i and p_l - p_i across
   * e, turned by the same quarter turn about e. */
  double dmin = 180.0, dmax = 0.0;
  for (int k = 0; k < 6; ++k) {
    const double *pi = p[edge[k][0]];
    double e[3], vk[3], vl[3], n1[3], n2[3];
    sub3(p[edge[k][1]], pi, e);
    sub3(p[edge[k][2]], pi, vk);
    sub3(p[edge[k][3]], pi, vl);
    cross3(e, vk, n1);
    cross3(e, vl, n2);
    double ang = angle_deg(n1, n2);
    dmin = fmin(dmin, ang);
    dmax = fmax(dmax, ang);
  }
  out->min_dihedral = dmin;
  out->max_dihedral = dmax;
}

/* ---- a whole mesh ------------------------------------------------------------------------- */

static pm_status check_indices(const int32_t *conn, int32_t n, int per, int32_t nnode,
                               const char *what, pm_error *err) {
  for (int32_t t = 0; t < n; ++t)
    for (int k = 0; k < per; ++k) {
      int32_t v = conn[(size_t)per * t + k];
      if (v < 0 || v >= nnode)
        return pm_error_setf(err, PM_ERR_ARG, "%s %ld uses node %ld, the mesh has %ld nodes",
                             what, (long)t, (long)v, (long)nnode);
    }
  return PM_OK;
}

static pm_status kind_alloc(pm_kind_quality *k, int32_t n, pm_error *err) {
  memset(k, 0, sizeof *k);
  k->n = n;
  size_t sz = (size_t)(n ? n : 1) * sizeof(double);
  k->radius_ratio = malloc(sz);
  k->aspect_ratio = malloc(sz);
  k->min_angle = malloc(sz);
  k->max_angle = malloc(sz);
  if (!k->radius_ratio || !k->aspect_ratio || !k->min_angle || !k->max_angle)
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory measuring %ld elements", (long)n);
  return PM_OK;
}

static void kind_free(pm_kind_quality *k) {
  free(k->radius_ratio);
  free(k->aspect_ratio);
  free(k->min_angle);
  free(k->max_angle);
  memset(k, 0, sizeof *k);
}

void pm_quality_clear(pm_quality *q) {
  if (!q) return;
  kind_free(&q->tri);
  kind_free(&q->tet);
  memset(q, 0, sizeof *q);
}

/* The four summaries are independent: one per thread. */
static pm_status kind_summaries(pm_kind_quality *k, pm_error *err) {
  const double *in[4] = {k->radius_ratio, k->aspect_ratio, k->min_angle, k->max_angle};
  pm_summary *out[4] = {&k->s_radius_ratio, &k->s_aspect_ratio, &k->s_min_angle,
                        &k->s_max_angle};
  pm_status st[4] = {PM_OK, PM_OK, PM_OK, PM_OK};
  pm_error e[4];
#pragma omp parallel for schedule(static, 1)
  for (int i = 0; i < 4; ++i) st[i] = pm_summary_compute(in[i], (size_t)k->n, out[i], &e[i]);
  for (int i = 0; i < 4; ++i)
    if (st[i]) {
      if (err) *err = e[i];
      return st[i];
    }
  return PM_OK;
}

/* eps_t of papers/003 eq. 8 from the edge table: degree = number of distinct neighbours.
 * `interior[v]` says whether node v counts. */
static void eps_t_from_edges(const pm_edges *e, const uint8_t *interior, int D,
                             pm_kind_quality *k, int32_t *deg) {
  memset(deg, 0, (size_t)e->nnode * sizeof *deg);
  for (int64_t i = 0; i < e->nedge; ++i) {
    deg[e->ends[2 * i]]++;
    deg[e->ends[2 * i + 1]]++;
  }
  double sum = 0.0;
  int32_t n = 0;
  for (int32_t v = 0; v < e->nnode; ++v) {
    if (!interior[v] || deg[v] == 0) continue;
    sum += fabs((double)deg[v] - D);
    ++n;
  }
  k->eps_t_nodes = n;
  k->eps_t = n ? sum / n : 0.0;
}

/* Size conformity over the unique edges: |b - a| / d((a + b) / 2). */
static pm_status size_ratios(const pm_mesh *m, const pm_edges *e, pm_sizing_fn fn, void *user,
                             pm_kind_quality *k, pm_error *err) {
  int64_t ne = e->nedge;
  k->nedge = ne;
  if (ne == 0) {
    k->has_size = 1;
    return PM_OK;
  }
  double *ratio = malloc((size_t)ne * sizeof *ratio);
  if (!ratio) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory (size conformity)");
  int64_t bad = ne; /* the first edge whose d is not usable: reported deterministically */
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < ne; ++i) {
    const double *a = m->xyz + 3 * (size_t)e->ends[2 * i];
    const double *b = m->xyz + 3 * (size_t)e->ends[2 * i + 1];
    double mid[3] = {0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])}, ab[3];
    double d = fn(mid, user);
    sub3(b, a, ab);
    if (!(d > 0.0) || !isfinite(d)) {
#pragma omp critical(pm_quality_bad_size)
      if (i < bad) bad = i;
      ratio[i] = 0.0;
    } else {
      ratio[i] = norm3(ab) / d;
    }
  }
  if (bad < ne) {
    const double *a = m->xyz + 3 * (size_t)e->ends[2 * bad];
    const double *b = m->xyz + 3 * (size_t)e->ends[2 * bad + 1];
    double mid[3] = {0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])};
    double d = fn(mid, user);
    free(ratio);
    return pm_error_setf(err, PM_ERR_ARG,
                         "the size field is %g at (%g, %g, %g); it must be finite and > 0", d,
                         mid[0], mid[1], mid[2]);
  }
  pm_status s = pm_summary_compute(ratio, (size_t)ne, &k->size_ratio, err);
  if (!s) {
    double mean = k->size_ratio.mean, ss = 0.0;
    for (int64_t i = 0; i < ne; ++i) ss += (ratio[i] - mean) * (ratio[i] - mean);
    k->size_ratio_std = sqrt(ss / (double)ne);
    k->has_size = 1;
  }
  free(ratio);
  return s;
}

const char *pm_tri_site_name(pm_tri_site site) {
  static const char *const name[PM_TRI_SITES] = {"boundary", "irregular", "regular"};
  return site >= 0 && site < PM_TRI_SITES ? name[site] : "?";
}

/* The site of triangle c (quality.h), from the degrees and interior flags of eps_t. */
static pm_tri_site tri_site(const int32_t c[3], const int32_t *deg, const uint8_t *interior) {
  pm_tri_site w = PM_TRI_REGULAR;
  for (int j = 0; j < 3; ++j) {
    if (!interior[c[j]]) return PM_TRI_BOUNDARY;
    if (deg[c[j]] != 6) w = PM_TRI_IRREGULAR;
  }
  return w;
}

/* R / l_min of the triangles of each site: grouped by site (a counting sort), then summarized. */
static pm_status site_summaries(const pm_mesh *m, const pm_kind_quality *k, const int32_t *deg,
                                const uint8_t *interior, pm_summary out[PM_TRI_SITES],
                                pm_error *err) {
  const int32_t n = m->ntri;
  double *v = malloc((size_t)(n ? n : 1) * sizeof *v);
  if (!v) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory (triangle sites)");
  int32_t count[PM_TRI_SITES] = {0}, at[PM_TRI_SITES];
  for (int32_t t = 0; t < n; ++t) count[tri_site(m->tri + 3 * (size_t)t, deg, interior)]++;
  at[0] = 0;
  for (int w = 1; w < PM_TRI_SITES; ++w) at[w] = at[w - 1] + count[w - 1];
  for (int32_t t = 0; t < n; ++t)
    v[at[tri_site(m->tri + 3 * (size_t)t, deg, interior)]++] = k->aspect_ratio[t];
  pm_status s = PM_OK;
  for (int w = 0; w < PM_TRI_SITES && !s; ++w)
    s = pm_summary_compute(v + (at[w] - count[w]), (size_t)count[w], &out[w], err);
  free(v);
  return s;
}

static pm_status triangles(const pm_mesh *m, pm_sizing_fn fn, void *user, pm_quality *q,
                           int32_t *deg, uint8_t *interior, pm_error *err) {
  pm_kind_quality *k = &q->tri;
  pm_status s = kind_alloc(k, m->ntri, err);
  if (s) return s;
  int32_t n = m->ntri;
  double *rr = malloc((size_t)(n ? n : 1) * sizeof *rr);
  uint8_t *dg = malloc((size_t)(n ? n : 1));
  if (!rr || !dg) {
    free(rr);
    free(dg);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory measuring triangles");
  }
#pragma omp parallel for schedule(static)
  for (int32_t t = 0; t < n; ++t) {
    const int32_t *v = m->tri + 3 * (size_t)t;
    pm_tri_measure me;
    pm_tri_measure_eval(m->xyz + 3 * (size_t)v[0], m->xyz + 3 * (size_t)v[1],
                        m->xyz + 3 * (size_t)v[2], &me);
    k->radius_ratio[t] = me.radius_ratio;
    k->aspect_ratio[t] = me.aspect_ratio;
    k->min_angle[t] = me.min_angle;
    k->max_angle[t] = me.max_angle;
    rr[t] = me.rr;
    dg[t] = (uint8_t)me.degenerate;
  }
  double sum_g = 0.0;
  for (int32_t t = 0; t < n; ++t) {
    k->degenerate += dg[t];
    sum_g += PM_EPS_G_A_TRI - rr[t]; /* papers/003 eq. 9 */
    int bin = (int)floor(k->min_angle[t] / 10.0);
    if (bin < 0) bin = 0;
    if (bin > 5) bin = 5; /* [50, 60]: 60 itself (equilateral) and rounding above it */
    q->tri_min_angle_bins[bin]++;
    if (k->max_angle[t] > 90.0) q->tri_max_angle_over[0]++;
    if (k->max_angle[t] > 120.0) q->tri_max_angle_over[1]++;
    if (k->max_angle[t] > 150.0) q->tri_max_angle_over[2]++;
  }
  k->eps_g = n ? sum_g / n : 0.0;
  free(rr);
  free(dg);
  s = kind_summaries(k, err);
  if (s || n == 0) return s;

  pm_edges e;
  s = pm_edges_build(m->nnode, m->tri, n, 3, &e, err);
  if (s) return s;
  /* Interior nodes (quality.h): classified on a face, or, unclassified, touching no edge that
   * has other than two triangles. */
  memset(interior, 1, (size_t)m->nnode);
  for (int64_t i = 0; i < e.nedge; ++i)
    if (e.off[i + 1] - e.off[i] != 2) {
      interior[e.ends[2 * i]] = 0;
      interior[e.ends[2 * i + 1]] = 0;
    }
  for (int32_t v = 0; v < m->nnode; ++v)
    if (m->node_dim[v] >= 0) interior[v] = m->node_dim[v] == PM_FACE;
  eps_t_from_edges(&e, interior, 6, k, deg);
  s = site_summaries(m, k, deg, interior, q->tri_site_aspect, err);
  if (!s && fn) s = size_ratios(m, &e, fn, user, k, err);
  pm_edges_free(&e);
  return s;
}

static pm_status tets(const pm_mesh *m, pm_sizing_fn fn, void *user, pm_quality *q,
                      int32_t *deg, uint8_t *interior, pm_error *err) {
  pm_kind_quality *k = &q->tet;
  pm_status s = kind_alloc(k, m->ntet, err);
  if (s) return s;
  int32_t n = m->ntet;
  double *rr = malloc((size_t)(n ? n : 1) * sizeof *rr);
  uint8_t *dg = malloc((size_t)(n ? n : 1));
  if (!rr || !dg) {
    free(rr);
    free(dg);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory measuring tetrahedra");
  }
#pragma omp parallel for schedule(static)
  for (int32_t t = 0; t < n; ++t) {
    const int32_t *v = m->tet + 4 * (size_t)t;
    pm_tet_measure me;
    pm_tet_measure_eval(m->xyz + 3 * (size_t)v[0], m->xyz + 3 * (size_t)v[1],
                        m->xyz + 3 * (size_t)v[2], m->xyz + 3 * (size_t)v[3], &me);
    k->radius_ratio[t] = me.radius_ratio;
    k->aspect_ratio[t] = me.aspect_ratio;
    k->min_angle[t] = me.min_dihedral;
    k->max_angle[t] = me.max_dihedral;
    rr[t] = me.rr;
    dg[t] = (uint8_t)me.degenerate;
  }
  double sum_g = 0.0;
  for (int32_t t = 0; t < n; ++t) {
    k->degenerate += dg[t];
    sum_g += PM_EPS_G_A_TET - rr[t]; /* papers/003 eq. 9 */
  }
  k->eps_g = n ? sum_g / n : 0.0;
  free(rr);
  free(dg);
  s = kind_summaries(k, err);
  if (s || n == 0) return s;

  /* Interior nodes: classified in a volume, or, unclassified, on no boundary face (a face of a
   * single tet). The face table is only built when some node needs it. */
  int need_faces = 0;
  for (int32_t t = 0; t < n && !need_faces; ++t)
    for (int j = 0; j < 4; ++j)
      if (m->node_dim[m->tet[4 * (size_t)t + j]] < 0) need_faces = 1;
  memset(interior, 1, (size_t)m->nnode);
  if (need_faces) {
    pm_faces f;
    s = pm_faces_build(m->nnode, m->tet, n, &f, err);
    if (s) return s;
    for (int64_t i = 0; i < f.nface; ++i)
      if (f.off[i + 1] - f.off[i] == 1)
        for (int j = 0; j < 3; ++j) interior[f.abc[3 * i + j]] = 0;
    pm_faces_free(&f);
  }
  for (int32_t v = 0; v < m->nnode; ++v)
    if (m->node_dim[v] >= 0) interior[v] = m->node_dim[v] == PM_VOLUME;
  pm_edges e;
  s = pm_edges_build(m->nnode, m->tet, n, 4, &e, err);
  if (s) return s;
  eps_t_from_edges(&e, interior, 12, k, deg);
  if (fn) s = size_ratios(m, &e, fn, user, k, err);
  pm_edges_free(&e);
  return s;
}

pm_status pm_quality_compute_fn(const pm_mesh *m, pm_sizing_fn fn, void *user, pm_quality *q,
                                pm_error *err) {
  memset(q, 0, sizeof *q);
  if (!m) return pm_error_setf(err, PM_ERR_ARG, "pm_quality_compute: no mesh");
  pm_status s = check_indices(m->tri, m->ntri, 3, m->nnode, "triangle", err);
  if (!s) s = check_indices(m->tet, m->ntet, 4, m->nnode, "tetrahedron", err);
  if (s) return s;
  size_t nn = (size_t)(m->nnode ? m->nnode : 1);
  int32_t *deg = malloc(nn * sizeof *deg);
  uint8_t *interior = malloc(nn);
  if (!deg || !interior) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory (node degrees)");
  } else {
    s = triangles(m, fn, user, q, deg, interior, err);
    if (!s) s = tets(m, fn, user, q, deg, interior, err);
  }
  free(deg);
  free(interior);
  if (s) pm_quality_clear(q);
  return s;
}

static double eval_sizing(const double xyz[3], void *user) {
  return pm_sizing_eval((const pm_sizing *)user, xyz);
}

pm_status pm_quality_compute(const pm_mesh *m, const pm_sizing *size, pm_quality *q,
                             pm_error *err) {
  return pm_quality_compute_fn(m, size ? eval_sizing : NULL, (void *)size, q, err);
}
