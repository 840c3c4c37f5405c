/* What the library offers beyond the public API (include/packmesh/packmesh.h) to the packmesh
 * command, the comparison engine and the tests: the same runs, with the run's reports (stats,
 * trace, frames) observed, and the checks of a run made before any file is opened. Nothing here is
 * exported from libpackmesh.so. */
#ifndef PM_API_H
#define PM_API_H

#include <packmesh/packmesh.h>

#include "common/method/method.h"

#ifdef __cplusplus
extern "C" {
#endif

/* "bubble, psys, gmsh-frontal, ..." for messages. */
void pm_method_names(char *buf, size_t len);

/* Set a parameter from "KEY=VALUE", as --set takes it (pm_method_params_set otherwise). */
pm_status pm_method_params_set_pair(pm_method_params *p, const char *pair, pm_error *err);

/* The method and the parameter struct of a parameter set (views). */
const pm_method *pm_method_params_method(const pm_method_params *p);
const void *pm_method_params_values(const pm_method_params *p);

/* Which choice of a run does not fit the model and method (pm_generate_check). */
typedef enum pm_generate_misfit {
  PM_MISFIT_NONE = 0,
  PM_MISFIT_PLANAR_ONLY, /* a planar-only method on a model that is not planar */
  PM_MISFIT_VOLUME,      /* volume meshing asked for, on a model without volumes */
  PM_MISFIT_TARGET       /* a node target without a size field, for a method with no default */
} pm_generate_misfit;

/* PM_ERR_ARG when the choices of a run do not fit the model and method, *misfit (may be NULL)
 * saying which; pm_generate makes the same check. */
pm_status pm_generate_check(const pm_model *model, const pm_sizing *size, const pm_method *method,
                            const pm_generate_options *opts, pm_generate_misfit *misfit,
                            pm_error *err);

/* What pm_generate_with adds to pm_generate. Every field may be NULL. */
typedef struct pm_generate_hooks {
  const pm_run_observer *report; /* the method's reports are forwarded here (run_report.h) */
  /* Called before every run of a node-target search (run = 1, 2, ...), so that the caller starts
   * its per-run reports afresh: they describe the last run only. */
  pm_status (*before_run)(void *ctx, int run, pm_error *err);
  void *ctx;
  pm_sizing **final_size; /* out: the field of the last run when it is not the one given (a
                             scaled field, the method's default made for a node target), else
                             NULL; the caller releases it */
} pm_generate_hooks;

/* pm_generate with hooks (may be NULL: pm_generate). */
pm_status pm_generate_with(const pm_model *model, const pm_sizing *size, const pm_method *method,
                           const pm_method_params *params, const pm_generate_options *opts,
                           const pm_generate_hooks *hooks, pm_mesh **out,
                           pm_generate_result *result, pm_error *err);

#ifdef __cplusplus
}
#endif

#endif /* PM_API_H */
