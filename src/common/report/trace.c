/* Per-iteration records (see trace.h). */
#include "common/report/trace.h"

#include <stdlib.h>
#include <string.h>

#include "common/base/atomic_file.h"
#include "common/report/stats.h"

struct pm_trace {
  int ncol;
  char **name;      /* [ncol] owned */
  double *v;        /* [ncol * cap] */
  int64_t nrow, cap, dropped;
  pm_trace_observer observer; /* may be NULL */
  void *observer_user;
};

void pm_trace_observe(pm_trace *t, pm_trace_observer fn, void *user) {
  t->observer = fn;
  t->observer_user = user;
}

pm_status pm_trace_create(pm_trace **out, pm_error *err) {
  *out = calloc(1, sizeof **out);
  return *out ? PM_OK : pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
}

pm_status pm_trace_columns(pm_trace *t, int ncol, const char *const *names, pm_error *err) {
  if (t->ncol || t->nrow) return pm_error_setf(err, PM_ERR_INTERNAL, "trace columns set twice");
  if (ncol <= 0) return pm_error_setf(err, PM_ERR_ARG, "a trace needs at least one column");
  t->name = calloc((size_t)ncol, sizeof(char *));
  if (!t->name) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  t->ncol = ncol;
  for (int i = 0; i < ncol; ++i)
    if (!(t->name[i] = strdup(names[i]))) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  return PM_OK;
}

pm_status pm_trace_add(pm_trace *t, const double *row, pm_error *err) {
  if (!t->ncol) return pm_error_setf(err, PM_ERR_INTERNAL, "trace row before its columns");
  if (t->nrow >= PM_TRACE_MAX_ROWS) {
    t->dropped++;
    return PM_OK;
  }
  if (t->nrow == t->cap) {
    int64_t cap = t->cap ? 2 * t->cap : 256;
    double *v = realloc(t->v, sizeof(double) * (size_t)(cap * t->ncol));
    if (!v) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    t->v = v, t->cap = cap;
  }
  memcpy(&t->v[t->nrow * t->ncol], row, sizeof(double) * (size_t)t->ncol);
  t->nrow++;
  if (t->observer) t->observer(t->observer_user, t, row);
  return PM_OK;
}

int pm_trace_ncol(const pm_trace *t) { return t->ncol; }
const char *pm_trace_column(const pm_trace *t, int col) { return t->name[col]; }
int64_t pm_trace_nrow(const pm_trace *t) { return t->nrow; }
const double *pm_trace_row(const pm_trace *t, int64_t i) { return &t->v[i * t->ncol]; }
int64_t pm_trace_dropped(const pm_trace *t) { return t->dropped; }

pm_status pm_trace_write_csv(const pm_trace *t, const char *path, pm_error *err) {
  pm_atomic_file a;
  pm_status s = pm_atomic_begin(&a, path, 1, err);
  if (s) return s;
  for (int c = 0; c < t->ncol; ++c) {
    if (c) fputc(',', a.f);
    pm_csv_field(a.f, t->name[c]);
  }
  fputc('\n', a.f);
  for (int64_t r = 0; r < t->nrow; ++r) {
    for (int c = 0; c < t->ncol; ++c) {
      if (c) fputc(',', a.f);
      pm_csv_number(a.f, t->v[r * t->ncol + c]);
    }
    fputc('\n', a.f);
  }
  return pm_atomic_commit(&a, err);
}

void pm_trace_destroy(pm_trace *t) {
  if (!t) return;
  for (int i = 0; i < t->ncol; ++i) free(t->name[i]);
  free(t->name);
  free(t->v);
  free(t);
}
