/* pm_generate (packmesh.h): one method on one model, the node-target search around it, and the
 * progress callback between the method's iterations. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "api/api.h"
#include "common/base/clock.h"
#include "common/geom/geom.h"
#include "common/mesh/mesh.h"
#include "common/sizing/sizing.h"

void pm_generate_options_init(pm_generate_options *o) {
  memset(o, 0, sizeof *o);
  o->seed = 1;
  o->threads = 1;
  o->max_nodes = PM_DEFAULT_MAX_NODES;
  o->target_tolerance = 0.03;
  o->target_runs = 8;
}

static int is_planar(const pm_model *m) {
  return m->dim == 2 && m->box[2] == 0 && m->box[5] == 0;
}

pm_status pm_generate_check(const pm_model *model, const pm_sizing *size, const pm_method *method,
                            const pm_generate_options *opts, pm_generate_misfit *misfit,
                            pm_error *err) {
  pm_generate_misfit dummy;
  if (!misfit) misfit = &dummy;
  *misfit = PM_MISFIT_NONE;
  if (!model || !method)
    return pm_error_setf(err, PM_ERR_ARG, "pm_generate: no %s", model ? "method" : "model");
  const int planar = is_planar(model);
  if (method->planar_only && !planar) {
    *misfit = PM_MISFIT_PLANAR_ONLY;
    return pm_error_setf(err, PM_ERR_ARG, "method %s meshes planar domains only; '%s' is not one",
                         method->name, model->name);
  }
  if (opts && opts->volume && pm_model_count(model, PM_VOLUME) == 0) {
    *misfit = PM_MISFIT_VOLUME;
    return pm_error_setf(err, PM_ERR_ARG, "'%s' has no volumes to mesh (%s)", model->name,
                         planar ? "a planar domain" : "a model of faces, curves and vertices only");
  }
  if (!size && method->needs_size)
    return pm_error_setf(err, PM_ERR_ARG, "method %s needs a size field (it has no default)",
                         method->name);
  if (opts && opts->target_nodes > 0 && !size && !method->default_size) {
    *misfit = PM_MISFIT_TARGET;
    return pm_error_setf(err, PM_ERR_ARG,
                         "a node target needs a size field for method %s (it has no default field "
                         "to scale)",
                         method->name);
  }
  return PM_OK;
}

static pm_status check_options(const pm_generate_options *o, pm_error *err) {
  if (o->threads < 1 || o->threads > 1024)
    return pm_error_setf(err, PM_ERR_ARG, "threads must be 1 to 1024, got %d", o->threads);
  if (o->max_nodes < 3)
    return pm_error_setf(err, PM_ERR_ARG, "max_nodes must be >= 3, got %lld",
                         (long long)o->max_nodes);
  if (o->target_nodes < 0 || (o->target_nodes > 0 && o->target_nodes < 3))
    return pm_error_setf(err, PM_ERR_ARG, "target_nodes must be 0 (none) or >= 3, got %lld",
                         (long long)o->target_nodes);
  if (o->target_nodes > 0 && !(o->target_tolerance > 0 && o->target_tolerance < 1))
    return pm_error_setf(err, PM_ERR_ARG, "target_tolerance must be in (0, 1), got %g",
                         o->target_tolerance);
  if (o->target_nodes > 0 && (o->target_runs < 1 || o->target_runs > 100))
    return pm_error_setf(err, PM_ERR_ARG, "target_runs must be 1 to 100, got %d", o->target_runs);
  return PM_OK;
}

/* ---- the observer between the method and the caller --------------------------------------- */

typedef struct watch {
  const pm_run_observer *report; /* may be NULL */
  const pm_generate_options *o;
  const pm_method *method;
  int run;
  int ncol;
  const char *const *columns;
  int event; /* the trace's `event` column (0: an iteration; else a row between them), or -1 */
} watch;

static pm_status cancelled(const watch *w, const char *where, pm_error *err) {
  return pm_error_setf(err, PM_ERR_CANCELLED, "%s: cancelled by the progress callback %s",
                       w->method->name, where);
}

static pm_status stage(const watch *w, const char *name, pm_error *err) {
  if (!w->o->progress) return PM_OK;
  pm_progress p = {w->method->name, name, w->run, -1, 0, NULL, NULL};
  if (w->o->progress(w->o->progress_user, &p)) return cancelled(w, name, err);
  return PM_OK;
}

static pm_status w_columns(void *ctx, int ncol, const char *const *names, pm_error *err) {
  watch *w = ctx;
  w->ncol = ncol, w->columns = names, w->event = -1;
  for (int c = 0; c < ncol; ++c)
    if (strcmp(names[c], "event") == 0) w->event = c;
  return pm_observe_trace_columns(w->report, ncol, names, err);
}

static pm_status w_row(void *ctx, const double *row, pm_error *err) {
  watch *w = ctx;
  pm_status s = pm_observe_trace_row(w->report, row, err);
  /* Progress is per iteration: the population changes between them and the mesh's row are not
   * (DESIGN.md, "Traces"). */
  if (s || !w->o->progress || (w->event >= 0 && row[w->event] != 0)) return s;
  pm_progress p = {w->method->name, "iteration", w->run, w->ncol ? (int64_t)row[0] : -1, w->ncol,
                   w->columns, row};
  if (w->o->progress(w->o->progress_user, &p)) {
    char where[64];
    snprintf(where, sizeof where, "at iteration %lld", (long long)p.iteration);
    return cancelled(w, where, err);
  }
  return PM_OK;
}

static pm_status w_frame(void *ctx, const pm_run_frame *frame, pm_error *err) {
  return pm_observe_frame(((watch *)ctx)->report, frame, err);
}

static pm_status w_time(void *ctx, const char *phase, double seconds, pm_error *err) {
  return pm_observe_time(((watch *)ctx)->report, phase, seconds, err);
}

static pm_status w_number(void *ctx, const char *key, double value, pm_error *err) {
  return pm_observe_number(((watch *)ctx)->report, key, value, err);
}

static pm_status w_text(void *ctx, const char *key, const char *text, pm_error *err) {
  return pm_observe_text(((watch *)ctx)->report, key, text, err);
}

/* Only what someone reads is asked of the method: no trace rows without a trace or a progress
 * callback, no snapshots without frames. */
static void watch_observer(watch *w, pm_run_observer *obs) {
  memset(obs, 0, sizeof *obs);
  obs->ctx = w;
  if (pm_observe_wants_trace(w->report) || w->o->progress)
    obs->trace_columns = w_columns, obs->trace_row = w_row;
  if (pm_observe_wants_frames(w->report)) obs->frame = w_frame;
  obs->time = w_time, obs->number = w_number, obs->text = w_text;
}

/* ---- the runs ------------------------------------------------------------------------------ */

pm_status pm_generate_report(const pm_model *model, const pm_sizing *size,
                             const pm_method *method, const pm_method_params *params,
                             const pm_generate_options *opts, pm_report *r,
                             pm_sizing **final_size, pm_mesh **out, pm_generate_result *result,
                             pm_error *err) {
  if (final_size) *final_size = NULL;
  if (!out) return pm_error_setf(err, PM_ERR_ARG, "pm_generate: no place for the mesh");
  *out = NULL;
  pm_generate_options defaults;
  pm_generate_options_init(&defaults);
  const pm_generate_options *o = opts ? opts : &defaults;
  pm_status s = check_options(o, err);
  if (!s) s = pm_generate_check(model, size, method, o, NULL, err);
  if (s) return s;
  if (params && pm_method_params_method(params) != method)
    return pm_error_setf(err, PM_ERR_ARG, "parameters of method %s given to method %s",
                         pm_method_name(pm_method_params_method(params)), method->name);
  /* The method's parameters: the caller's, or the defaults; checked as a whole (the rules that
   * tie parameters to each other). */
  pm_method_params *own = NULL;
  if (!params) {
    if ((s = pm_method_params_create(method, &own, err))) return s;
    params = own;
  }
  const void *values = pm_method_params_values(params);
  if ((s = pm_method_params_check(params, err))) {
    pm_method_params_destroy(own);
    return s;
  }
  if (size && (s = pm_sizing_check(size, model, err))) {
    pm_method_params_destroy(own);
    return s;
  }

  const double t0 = pm_seconds();
  /* A node target scales the size field; without one given, the method's default field. */
  pm_sizing *base_own = NULL, *scaled = NULL;
  const pm_sizing *base = size;
  if (o->target_nodes > 0 && !base) {
    s = method->default_size(model, values, o->seed, o->threads, &base_own, err);
    base = base_own;
  }
  pm_run_observer report;
  if (r) pm_report_observer(r, &report);
  watch w = {r ? &report : NULL, o, method, 0, 0, NULL, -1};
  pm_run_observer obs;
  watch_observer(&w, &obs);
  pm_run_output ro;
  memset(&ro, 0, sizeof ro);
  double scale = 1;
  int target_met = 1;
  int64_t target_count = 0;
  while (!s) {
    ++w.run;
    const pm_sizing *use = base;
    if (scale != 1) {
      pm_sizing_destroy(scaled);
      scaled = NULL;
      if ((s = pm_sizing_scaled(base, scale, &scaled, err))) break;
      use = scaled;
    }
    if (r && w.run > 1 && (s = pm_report_new_run(r, err))) break;
    if ((s = stage(&w, "meshing", err))) break;
    pm_mesh_destroy(ro.mesh);
    memset(&ro, 0, sizeof ro);
    pm_run_input in;
    memset(&in, 0, sizeof in);
    in.model = model, in.size = use, in.seed = o->seed, in.threads = o->threads;
    in.volume = o->volume, in.max_nodes = o->max_nodes, in.observer = &obs;
    if ((s = method->run(&in, values, &ro, err))) break;
    if (o->target_nodes <= 0) break;
    int32_t counted = ro.mesh->nnode;
    if (o->target_surface && (s = pm_mesh_surface_nodes(ro.mesh, &counted, err))) break;
    /* Nodes of a surface go as 1/d^2, of a volume as 1/d^3. */
    target_count = counted;
    double ratio = (double)counted / (double)o->target_nodes;
    target_met = fabs(ratio - 1) <= o->target_tolerance;
    if (target_met || w.run >= o->target_runs) break;
    scale *= pow(ratio, 1.0 / (o->volume && ro.mesh->ntet && !o->target_surface ? 3.0 : 2.0));
  }
  if (!s) s = stage(&w, "done", err);
  if (!s) {
    *out = ro.mesh;
    ro.mesh = NULL;
    if (result) {
      memset(result, 0, sizeof *result);
      result->iterations = ro.iterations;
      snprintf(result->stop_reason, sizeof result->stop_reason, "%s", ro.stop_reason);
      result->runs = w.run;
      result->size_scale = scale;
      result->target_met = target_met;
      result->target_count = target_count;
      result->seconds = pm_seconds() - t0;
    }
    if (final_size) {
      if (scale != 1)
        *final_size = scaled, scaled = NULL;
      else if (base_own)
        *final_size = base_own, base_own = NULL;
    }
  }
  pm_mesh_destroy(ro.mesh);
  if (s && *out) {
    pm_mesh_destroy(*out);
    *out = NULL;
  }
  pm_sizing_destroy(scaled);
  pm_sizing_destroy(base_own);
  pm_method_params_destroy(own);
  return s;
}

pm_status pm_generate(const pm_model *model, const pm_sizing *size, const pm_method *method,
                      const pm_method_params *params, const pm_generate_options *opts,
                      pm_mesh **out, pm_generate_result *result, pm_error *err) {
  return pm_generate_report(model, size, method, params, opts, NULL, NULL, out, result, err);
}
