/* The observer of a run's reports (run_report.h). */
#include "common/report/run_report.h"

#include <string.h>

static pm_status columns(void *ctx, int ncol, const char *const *names, pm_error *err) {
  return pm_trace_columns(((pm_run_report *)ctx)->trace, ncol, names, err);
}

static pm_status row(void *ctx, const double *values, pm_error *err) {
  return pm_trace_add(((pm_run_report *)ctx)->trace, values, err);
}

static pm_status frame(void *ctx, const pm_run_frame *f, pm_error *err) {
  return pm_frames_add(((pm_run_report *)ctx)->frames, f, err);
}

static pm_status phase_time(void *ctx, const char *phase, double seconds, pm_error *err) {
  return pm_stats_set_time(((pm_run_report *)ctx)->stats, phase, seconds, err);
}

static pm_status number(void *ctx, const char *key, double value, pm_error *err) {
  return pm_stats_add_number(((pm_run_report *)ctx)->stats, key, value, err);
}

static pm_status text(void *ctx, const char *key, const char *value, pm_error *err) {
  return pm_stats_add_text(((pm_run_report *)ctx)->stats, key, value, err);
}

void pm_run_report_observer(pm_run_report *r, pm_run_observer *out) {
  memset(out, 0, sizeof *out);
  out->ctx = r;
  if (r->trace) out->trace_columns = columns, out->trace_row = row;
  if (r->frames) out->frame = frame;
  if (r->stats) out->time = phase_time, out->number = number, out->text = text;
}
