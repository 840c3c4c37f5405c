/* The record of a run (packmesh_extended.h, "the record of a run"): the stats, trace and frames
 * of report/, and the measuring `packmesh mesh --stats` and `packmesh quality` run on a mesh. */
#include <packmesh/packmesh_extended.h>

#include <stdlib.h>
#include <string.h>

#include "api/api.h"
#include "common/base/clock.h"
#include "common/geom/geom.h"
#include "common/measure/distance.h"
#include "common/measure/needles.h"
#include "common/measure/quality.h"
#include "common/mesh/mesh_check.h"
#include "common/report/quality_table.h"
#include "common/report/run_report.h"

struct pm_report {
  char *method, *input;
  pm_stats stats;
  pm_trace *trace;   /* NULL unless pm_report_record_trace */
  pm_frames *frames; /* NULL unless pm_report_record_frames */
  pm_run_report run; /* the three above, for the observer */
  /* The last pm_report_measure, kept whole for the table and the per-element CSV. */
  unsigned measured;
  pm_check_report check;
  pm_quality quality;
  pm_needles needles;
  pm_distance distance;
  int has_distance;
};

static char *copy(const char *s) {
  size_t n = strlen(s) + 1;
  char *c = malloc(n);
  if (c) memcpy(c, s, n);
  return c;
}

pm_status pm_report_create(const char *method, const char *input, pm_report **out,
                           pm_error *err) {
  if (!out) return pm_error_setf(err, PM_ERR_ARG, "pm_report_create: no place for the report");
  *out = NULL;
  if (!method || !input)
    return pm_error_setf(err, PM_ERR_ARG, "pm_report_create: no %s", method ? "input" : "method");
  pm_report *r = calloc(1, sizeof *r);
  if (r) r->method = copy(method), r->input = copy(input);
  if (!r || !r->method || !r->input) {
    pm_report_destroy(r);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  pm_stats_init(&r->stats);
  pm_stats_set_run(&r->stats, method, input);
  r->run.stats = &r->stats;
  *out = r;
  return PM_OK;
}

void pm_report_destroy(pm_report *r) {
  if (!r) return;
  pm_check_report_clear(&r->check);
  pm_quality_clear(&r->quality);
  pm_stats_clear(&r->stats);
  pm_trace_destroy(r->trace);
  pm_frames_destroy(r->frames);
  free(r->method);
  free(r->input);
  free(r);
}

pm_status pm_report_record_trace(pm_report *r, pm_error *err) {
  if (!r) return pm_error_setf(err, PM_ERR_ARG, "pm_report_record_trace: no report");
  if (r->trace) return PM_OK;
  pm_status s = pm_trace_create(&r->trace, err);
  r->run.trace = r->trace;
  return s;
}

pm_status pm_report_record_frames(pm_report *r, const char *dir, const pm_model *model,
                                  pm_error *err) {
  if (!r || !dir || !model)
    return pm_error_setf(err, PM_ERR_ARG, "pm_report_record_frames: no %s",
                         !r ? "report" : !dir ? "folder" : "model");
  if (r->frames) return pm_error_setf(err, PM_ERR_ARG, "pm_report_record_frames: recorded already");
  pm_status s = pm_frames_create(dir, model, &r->frames, err);
  r->run.frames = r->frames;
  return s;
}

void pm_report_observer(pm_report *r, pm_run_observer *out) {
  pm_run_report_observer(&r->run, out);
}

/* A node-target search's runs: the stats and the trace describe the last run only; the frames
 * show every run, one after the other. */
pm_status pm_report_new_run(pm_report *r, pm_error *err) {
  pm_stats_clear(&r->stats);
  pm_stats_init(&r->stats);
  pm_stats_set_run(&r->stats, r->method, r->input);
  if (!r->trace) return PM_OK;
  pm_trace_destroy(r->trace);
  r->trace = NULL;
  pm_status s = pm_trace_create(&r->trace, err);
  r->run.trace = r->trace;
  return s;
}

/* ---- measuring --------------------------------------------------------------------------- */

pm_status pm_report_measure(pm_report *r, const pm_mesh *m, const pm_model *model,
                            const pm_sizing *size, unsigned what, pm_error *err) {
  if (!r || !m)
    return pm_error_setf(err, PM_ERR_ARG, "pm_report_measure: no %s", r ? "mesh" : "report");
  /* The stats take each key once: a measure asked for again is refused before anything of the
   * report changes, so that the measures kept for the table stay the ones the stats show. */
  const unsigned again = what & r->measured & (PM_REPORT_CHECK | PM_REPORT_QUALITY | PM_REPORT_DISTANCE);
  if (again)
    return pm_error_setf(err, PM_ERR_ARG, "pm_report_measure: the %s was measured already",
                         again & PM_REPORT_CHECK ? "check" : again & PM_REPORT_QUALITY ? "quality" : "distance");
  const int timed = (what & PM_REPORT_TIMES) != 0;
  pm_stats *st = &r->stats;
  pm_status s = PM_OK;
  /* The model's loading is timed beside the measuring stages, so that a run shows whether
   * reading the part or measuring the mesh costs more than meshing it. */
  if (timed && model &&
      ((s = pm_stats_set_time(st, "load", model->time_open - model->time_build, err)) ||
       (s = pm_stats_set_time(st, "setup", model->time_build, err))))
    return s;
  double t0 = pm_seconds();
  if (what & PM_REPORT_CHECK) {
    if ((s = pm_mesh_check(m, model, &r->check, err)) || (s = pm_stats_set_check(st, &r->check, err)) ||
        (timed && (s = pm_stats_set_time(st, "check", pm_seconds() - t0, err))))
      return s;
    r->measured |= PM_REPORT_CHECK;
  }
  t0 = pm_seconds();
  if (what & PM_REPORT_QUALITY) {
    if ((s = pm_quality_compute(m, size, &r->quality, err))) return s;
    pm_stats_set_quality(st, &r->quality);
    pm_stats_set_mesh(st, m);
    /* The nodes a surface-node target counts (--target-surface-nodes), for every run, so that a
     * volume study can compare surfaces like for like. */
    int32_t surface = 0;
    if ((s = pm_mesh_surface_nodes(m, &surface, err)) ||
        (s = pm_stats_add_number(st, "surface_nodes", (double)surface, err)))
      return s;
    if ((s = pm_needles_classify(m, model, PM_NEEDLE_DEG, &r->needles, NULL, err)) ||
        (m->ntri > 0 && (s = pm_stats_set_needles(st, &r->needles, PM_NEEDLE_DEG, err))) ||
        (timed && (s = pm_stats_set_time(st, "quality", pm_seconds() - t0, err))))
      return s;
    r->measured |= PM_REPORT_QUALITY;
  }
  if ((what & PM_REPORT_DISTANCE) && model && (m->ntri > 0 || m->nseg > 0)) {
    pm_distance_params dp;
    pm_distance_params_init(&dp);
    t0 = pm_seconds();
    if ((s = pm_mesh_distance(m, model, size, &dp, &r->distance, err))) return s;
    const pm_distance *d = &r->distance;
    pm_stats_set_distance(st, d->mean, d->max, d->bbox_diagonal);
    if (d->has_size && ((s = pm_stats_add_number(st, "distance.rel_mean", d->rel_mean, err)) ||
                        (s = pm_stats_add_number(st, "distance.rel_max", d->rel_max, err))))
      return s;
    if (timed && (s = pm_stats_set_time(st, "distance", pm_seconds() - t0, err))) return s;
    r->has_distance = 1;
    r->measured |= PM_REPORT_DISTANCE;
  }
  return PM_OK;
}

pm_status pm_report_record_run(pm_report *r, const pm_model *model, const pm_method *method,
                               const pm_method_params *params, const pm_generate_options *opts,
                               const pm_generate_result *result, const pm_sizing *final_size,
                               pm_error *err) {
  if (!r || !model || !method || !opts || !result)
    return pm_error_setf(err, PM_ERR_ARG, "pm_report_record_run: no %s",
                         !r ? "report" : !model ? "model" : !method ? "method" : !opts ? "options" : "result");
  if (params && pm_method_params_method(params) != method)
    return pm_error_setf(err, PM_ERR_ARG, "parameters of method %s given to method %s",
                         pm_method_name(pm_method_params_method(params)), method->name);
  pm_stats *st = &r->stats;
  st->iterations = result->iterations;
  pm_status s;
  if ((s = pm_stats_add_text(st, "stop_reason", result->stop_reason, err)) ||
      (s = pm_stats_add_number(st, "seed", (double)opts->seed, err)) ||
      (model->heal[0] && (s = pm_stats_add_text(st, "heal", model->heal, err))) ||
      (s = pm_stats_add_number(st, "threads", (double)opts->threads, err)) ||
      (s = pm_stats_add_text(st, "size", final_size ? pm_sizing_describe(final_size) : "method default",
                             err)))
    return s;
  if (opts->target_nodes > 0 &&
      ((s = pm_stats_add_number(st, opts->target_surface ? "target_surface_nodes" : "target_nodes",
                                (double)opts->target_nodes, err)) ||
       (s = pm_stats_add_number(st, "size_scale", result->size_scale, err)) ||
       (s = pm_stats_add_number(st, "target_runs", result->runs, err)) ||
       (s = pm_stats_add_bool(st, "target_nodes_met", result->target_met, err))))
    return s;
  if (!method->params) return PM_OK;
  /* The parameters as they were used: the caller's set, or the defaults. */
  pm_method_params *own = NULL;
  if (!params) {
    if ((s = pm_method_params_create(method, &own, err))) return s;
    params = own;
  }
  for (int k = 0; !s && k < method->params->n; ++k) {
    char key[160], val[64];
    snprintf(key, sizeof key, "params.%s", method->params->desc[k].name);
    pm_params_format(&method->params->desc[k], pm_method_params_values(params), val, sizeof val);
    s = pm_stats_add_text(st, key, val, err);
  }
  pm_method_params_destroy(own);
  return s;
}

/* ---- keys and writing ---------------------------------------------------------------------- */

pm_status pm_report_set_time(pm_report *r, const char *phase, double seconds, pm_error *err) {
  if (!r || !phase) return pm_error_setf(err, PM_ERR_ARG, "pm_report_set_time: no %s", r ? "phase" : "report");
  return pm_stats_set_time(&r->stats, phase, seconds, err);
}

pm_status pm_report_add_number(pm_report *r, const char *key, double value, pm_error *err) {
  if (!r || !key) return pm_error_setf(err, PM_ERR_ARG, "pm_report_add_number: no %s", r ? "key" : "report");
  return pm_stats_add_number(&r->stats, key, value, err);
}

pm_status pm_report_add_text(pm_report *r, const char *key, const char *text, pm_error *err) {
  if (!r || !key || !text)
    return pm_error_setf(err, PM_ERR_ARG, "pm_report_add_text: no %s", !r ? "report" : !key ? "key" : "text");
  return pm_stats_add_text(&r->stats, key, text, err);
}

pm_status pm_report_stats_json(const pm_report *r, char **json, pm_error *err) {
  if (!r || !json) return pm_error_setf(err, PM_ERR_ARG, "pm_report_stats_json: no %s", r ? "place for the text" : "report");
  return pm_stats_to_json(&r->stats, json, err);
}

pm_status pm_report_write_stats(const pm_report *r, const char *path, pm_error *err) {
  if (!r || !path) return pm_error_setf(err, PM_ERR_ARG, "pm_report_write_stats: no %s", r ? "path" : "report");
  return pm_stats_write_json(&r->stats, path, err);
}

pm_status pm_report_write_trace(const pm_report *r, const char *path, pm_error *err) {
  if (!r || !path) return pm_error_setf(err, PM_ERR_ARG, "pm_report_write_trace: no %s", r ? "path" : "report");
  if (!r->trace) return pm_error_setf(err, PM_ERR_ARG, "%s: no trace was recorded", path);
  return pm_trace_write_csv(r->trace, path, err);
}

pm_status pm_report_finish_frames(pm_report *r, pm_error *err) {
  if (!r) return pm_error_setf(err, PM_ERR_ARG, "pm_report_finish_frames: no report");
  return r->frames ? pm_frames_finish(r->frames, err) : PM_OK;
}

static pm_status need_measures(const pm_report *r, unsigned what, const char *fn, pm_error *err) {
  if (!r) return pm_error_setf(err, PM_ERR_ARG, "%s: no report", fn);
  if ((r->measured & what) != what)
    return pm_error_setf(err, PM_ERR_ARG, "%s: the mesh was not measured (pm_report_measure)", fn);
  return PM_OK;
}

pm_status pm_report_write_table(const pm_report *r, const char *geometry, FILE *f,
                                pm_error *err) {
  pm_status s = need_measures(r, PM_REPORT_CHECK | PM_REPORT_QUALITY, "pm_report_write_table", err);
  if (s) return s;
  pm_quality_table_write(f, geometry, &r->stats, &r->quality, &r->check, &r->needles,
                         r->has_distance ? &r->distance : NULL);
  return ferror(f) ? pm_error_setf(err, PM_ERR_IO, "the table could not be written") : PM_OK;
}

pm_status pm_report_write_elements_csv(const pm_report *r, const pm_mesh *m, FILE *f,
                                       pm_error *err) {
  pm_status s = need_measures(r, PM_REPORT_QUALITY, "pm_report_write_elements_csv", err);
  if (s) return s;
  if (!m || m->ntri != r->quality.tri.n || m->ntet != r->quality.tet.n)
    return pm_error_setf(err, PM_ERR_ARG, "pm_report_write_elements_csv: not the measured mesh");
  return pm_stats_write_elements_csv(f, m, &r->quality, err);
}
