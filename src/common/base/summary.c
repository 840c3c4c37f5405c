/* Summaries (summary.h). Percentiles sort with a radix sort, so 10^6 values take milliseconds
 * per statistic. */
#include "common/base/summary.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

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
