/* Statistics over the repeats of a study, as honest as the runs allow:
 *   - runs whose mesh.msh files are byte-identical (a method that ignores the seed, or two seeds
 *     that happen to give one mesh) are one result: each such row is marked with the first row
 *     that made its mesh (same_mesh_as), counted once in the means and in the element pools of
 *     the box plots, and the tables give the number of distinct results;
 *   - the tables give the mean and the sample standard deviation over the distinct results (the
 *     time of a run is a measurement of its own, so time keys use every successful run);
 *   - box plots have Tukey's whiskers (the furthest values within 1.5 IQR of the box) with the
 *     values beyond as points, or the minimum and maximum when the suite asks for them
 *     ("whiskers": "minmax", papers/001 Fig. 11).
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "common/base/summary.h"
#include "compare/src/study.h"

/* FNV-1a, 64 bits: equal files hash equal; the bytes are compared when the hashes are. */
static uint64_t fnv1a(const char *b, size_t n) {
  uint64_t h = 1469598103934665603ULL;
  for (size_t i = 0; i < n; ++i) h = (h ^ (unsigned char)b[i]) * 1099511628211ULL;
  return h;
}

static char *row_mesh_bytes(const pm_cmp_study *st, const pm_cmp_row *r, size_t *n) {
  char path[4400];
  snprintf(path, sizeof path, "%s/runs/%s/mesh.msh", st->dir, r->id);
  return pm_cmp_read_file(path, n);
}

pm_status pm_cmp_duplicates_mark(pm_cmp_study *st, pm_error *err) {
  uint64_t *hash = calloc((size_t)st->nrow + 1, sizeof *hash);
  if (!hash) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  for (int i = 0; i < st->nrow; ++i) {
    pm_cmp_row *r = &st->rows[i];
    r->same_mesh_as = -1;
    if (r->status != PM_CMP_OK) continue;
    size_t n = 0;
    char *b = row_mesh_bytes(st, r, &n);
    if (!b) continue; /* no mesh to compare: a result of its own */
    hash[i] = fnv1a(b, n);
    for (int j = 0; j < i && r->same_mesh_as < 0; ++j) {
      const pm_cmp_row *q = &st->rows[j];
      if (q->status != PM_CMP_OK || q->same_mesh_as >= 0 || hash[j] != hash[i] ||
          q->icase != r->icase || q->imethod != r->imethod || q->isweep != r->isweep)
        continue;
      size_t m = 0;
      char *c = row_mesh_bytes(st, q, &m);
      if (c && m == n && memcmp(b, c, n) == 0) r->same_mesh_as = j;
      free(c);
    }
    free(b);
  }
  free(hash);
  return PM_OK;
}

static int in_group(const pm_cmp_row *r, int c, int m, int w) {
  return r->icase == c && r->imethod == m && (w < 0 || r->isweep == w) && r->status == PM_CMP_OK;
}

int pm_cmp_distinct_count(const pm_cmp_study *st, int c, int m, int w) {
  int n = 0;
  for (int i = 0; i < st->nrow; ++i)
    n += in_group(&st->rows[i], c, m, w) && st->rows[i].same_mesh_as < 0;
  return n;
}

void pm_cmp_mean_sd(const pm_cmp_study *st, int c, int m, int w, const char *key, double *mean,
                    double *sd, int *n) {
  const int every_run = strncmp(key, "time_s", 6) == 0 || strcmp(key, "wall_s") == 0;
  double sum = 0, sum2 = 0;
  int k = 0;
  /* Two passes (mean, then squares about it): no cancellation for values far from 0. */
  for (int pass = 0; pass < 2; ++pass)
    for (int i = 0; i < st->nrow; ++i) {
      const pm_cmp_row *r = &st->rows[i];
      if (!in_group(r, c, m, w) || (!every_run && r->same_mesh_as >= 0)) continue;
      double v = pm_cmp_row_value(r, key);
      if (!isfinite(v)) continue;
      if (pass == 0)
        sum += v, ++k;
      else
        sum2 += (v - sum / k) * (v - sum / k);
    }
  *n = k;
  *mean = k ? sum / k : NAN;
  *sd = k > 1 ? sqrt(sum2 / (k - 1)) : NAN;
}

void pm_cmp_box_of_sorted(const double *v, size_t n, int minmax, pm_cmp_box *b) {
  memset(b, 0, sizeof *b);
  if (!n) return;
  b->n = (int64_t)n;
  b->min = v[0];
  b->max = v[n - 1];
  b->p25 = pm_percentile_sorted(v, n, 0.25);
  b->median = pm_percentile_sorted(v, n, 0.5);
  b->p75 = pm_percentile_sorted(v, n, 0.75);
  b->lo_end = 0;
  b->hi_begin = n;
  if (!minmax) {
    /* Tukey (Exploratory Data Analysis, 1977): the fences 1.5 IQR beyond the box; a whisker
     * ends at the furthest value inside its fence. */
    double iqr = b->p75 - b->p25, lo = b->p25 - 1.5 * iqr, hi = b->p75 + 1.5 * iqr;
    while (b->lo_end < n && v[b->lo_end] < lo) b->lo_end++;
    while (b->hi_begin > b->lo_end && v[b->hi_begin - 1] > hi) b->hi_begin--;
  }
  b->whisker_lo = v[b->lo_end < n ? b->lo_end : n - 1];
  b->whisker_hi = v[b->hi_begin > 0 ? b->hi_begin - 1 : 0];
}
