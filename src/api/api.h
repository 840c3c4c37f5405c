/* What the files of src/api share among themselves: the internals behind the handles of the
 * public API (packmesh.h, packmesh_extended.h). Nothing outside src/api includes this, and
 * nothing here is exported from libpackmesh.so. */
#ifndef PM_API_H
#define PM_API_H

#include <packmesh/packmesh.h>
#include <packmesh/packmesh_extended.h>

#include "common/method/method.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The method and the parameter struct of a parameter set (views). */
const pm_method *pm_method_params_method(const pm_method_params *p);
const void *pm_method_params_values(const pm_method_params *p);

/* The observer (method.h) that keeps a method's reports in r. */
void pm_report_observer(pm_report *r, pm_run_observer *out);

/* Start r's per-run parts afresh before another run of a node-target search: the stats and the
 * trace describe the last run only. */
pm_status pm_report_new_run(pm_report *r, pm_error *err);

#ifdef __cplusplus
}
#endif

#endif /* PM_API_H */
