/* Per-iteration records of a run (--trace TRACE.csv): the method names the columns once, then
 * adds one row of numbers per iteration; the CSV feeds the convergence plots of comparison
 * studies (papers/003 Table 1, papers/004 Fig. 7) and teaching. */
#ifndef PM_TRACE_H
#define PM_TRACE_H

#include <packmesh/packmesh.h>

#include <stdint.h>

typedef struct pm_trace pm_trace;

/* An empty trace (no columns yet). */
pm_status pm_trace_create(pm_trace **out, pm_error *err);

/* Name the columns (copied). Allowed once, before the first row. */
pm_status pm_trace_columns(pm_trace *t, int ncol, const char *const *names, pm_error *err);

/* Append a row of ncol values (copied). Rows beyond PM_TRACE_MAX_ROWS are dropped and counted:
 * a trace never grows without bound. */
pm_status pm_trace_add(pm_trace *t, const double *row, pm_error *err);
#define PM_TRACE_MAX_ROWS 10000000

/* Called with every row pm_trace_add records (the trace's columns and the row, both borrowed),
 * on the thread that adds it: a caller's progress display. NULL removes it. */
typedef void (*pm_trace_observer)(void *user, const pm_trace *t, const double *row);
void pm_trace_observe(pm_trace *t, pm_trace_observer fn, void *user);

int pm_trace_ncol(const pm_trace *t);
const char *pm_trace_column(const pm_trace *t, int col);
int64_t pm_trace_nrow(const pm_trace *t);
/* Row i ([ncol] values), borrowed. */
const double *pm_trace_row(const pm_trace *t, int64_t i);
int64_t pm_trace_dropped(const pm_trace *t);

/* Write the CSV (header line, then rows), atomically. */
pm_status pm_trace_write_csv(const pm_trace *t, const char *path, pm_error *err);

void pm_trace_destroy(pm_trace *t);

#endif /* PM_TRACE_H */
