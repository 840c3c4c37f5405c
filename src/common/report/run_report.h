/* A run's reports, where `packmesh mesh`, the comparison harness, the tests and the benchmarks
 * keep them: the stats record, the iteration trace and the particle frames. The methods report
 * through an observer (method.h) and know nothing of these; this file connects the two. */
#ifndef PM_RUN_REPORT_H
#define PM_RUN_REPORT_H

#include "common/method/method.h"
#include "common/report/frames.h"
#include "common/report/stats.h"
#include "common/report/trace.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Where the reports of one run go; every field is borrowed and may be NULL. */
typedef struct pm_run_report {
  pm_stats *stats;   /* phase times and the method's numbers and texts */
  pm_trace *trace;   /* one row per iteration; the method sets the columns */
  pm_frames *frames; /* snapshots of the particles */
} pm_run_report;

/* An observer (method.h) that sends a method's reports to r, which must outlive the run. Only
 * the callbacks of the parts r has are set, so a method computes no trace row when there is no
 * trace, and takes no snapshot when there are no frames. */
void pm_run_report_observer(pm_run_report *r, pm_run_observer *out);

#ifdef __cplusplus
}
#endif

#endif /* PM_RUN_REPORT_H */
