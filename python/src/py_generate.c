/* mesh(): one run of a method on an input, as `packmesh mesh --stats` makes it, through the
 * public API (pm_py.h).
 *
 * The arguments are read into a job with the GIL held; the run itself (open the model, make the
 * size field, pm_generate_report, pm_report_measure, the stats JSON) holds no GIL, so that other
 * Python threads go on and a size callable can be called from pm_generate's OpenMP threads.
 * The record is made as examples/run_stats.c and the command make it (pm_report,
 * packmesh_extended.h): the stats JSON is the one `packmesh mesh --stats` writes for the same
 * run. The progress callback cancels the run at the next iteration or stage once a Python
 * exception is kept (from the size callable, or a KeyboardInterrupt).
 */
#include "pm_py.h"

#include <stdlib.h>
#include <string.h>
#include <time.h>

/* Seconds on a monotonic clock: the run's "total", timed as the command times it. */
static double now(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

typedef struct job {
  /* in: borrowed from the arguments, which outlive the run */
  const char *input;
  const pm_method *method;
  Py_ssize_t nparam;
  const char **keys, **values;
  pm_py_size size;
  pm_generate_options opts;
  pm_py_pending pending;
  /* out */
  pm_mesh *mesh;
  char *stats_json;
  pm_generate_result result;
  pm_error err;
} job;

/* Called by pm_generate on the thread that called it, between iterations and stages: a kept
 * exception, or a signal Python wants handled (Ctrl-C), ends the run. */
static int on_progress(void *user, const pm_progress *p) {
  (void)p;
  job *j = user;
  if (pm_py_pending_is_set(&j->pending)) return 1;
  PyGILState_STATE gil = PyGILState_Ensure();
  if (PyErr_CheckSignals() < 0) pm_py_pending_keep(&j->pending);
  PyGILState_Release(gil);
  return pm_py_pending_is_set(&j->pending);
}

/* The run, without the GIL: what `packmesh mesh INPUT --stats` does, in its order. */
static pm_status run(job *j) {
  pm_error *e = &j->err;
  double t_start = now();
  pm_method_params *params = NULL;
  pm_model *model = NULL;
  pm_sizing *input_size = NULL, *size = NULL, *scaled = NULL;
  pm_report *report = NULL;
  pm_status s = pm_method_params_create(j->method, &params, e);
  for (Py_ssize_t i = 0; !s && i < j->nparam; ++i)
    s = pm_method_params_set(params, j->keys[i], j->values[i], e);
  if (!s) s = pm_method_params_check(params, e);
  if (!s) s = pm_model_open(j->input, &model, &input_size, e);
  /* The size field: the argument, else the input's own, else the method's default (NULL). */
  if (!s && j->size.kind != PM_PY_SIZE_DEFAULT)
    s = pm_py_size_make(&j->size, model, j->method, j->opts.seed, j->opts.threads, &size, e);
  else if (!s)
    size = input_size, input_size = NULL;
  pm_generate_misfit misfit = PM_MISFIT_NONE;
  if (!s) s = pm_generate_check(model, size, j->method, &j->opts, &misfit, e);
  /* A misfit named by the argument that caused it, as the command names its option. */
  if (s && misfit == PM_MISFIT_VOLUME) pm_error_prefix(e, "volume=True");
  if (s && misfit == PM_MISFIT_TARGET)
    pm_error_setf(e, PM_ERR_ARG,
                  "target_nodes needs a size for method %s (it has no default field to scale)",
                  pm_method_name(j->method));
  if (!s) s = pm_report_create(pm_method_name(j->method), j->input, &report, e);
  if (!s)
    s = pm_generate_report(model, size, j->method, params, &j->opts, report, &scaled, &j->mesh,
                           &j->result, e);
  double t_run = now() - t_start;
  const pm_sizing *final_size = scaled ? scaled : size;
  if (!s) s = pm_report_measure(report, j->mesh, model, final_size, PM_REPORT_ALL, e);
  if (!s) s = pm_report_set_time(report, "total", t_run, e);
  if (!s)
    s = pm_report_record_run(report, model, j->method, params, &j->opts, &j->result, final_size,
                             e);
  if (!s) s = pm_report_stats_json(report, &j->stats_json, e);
  if (s) {
    pm_mesh_destroy(j->mesh);
    j->mesh = NULL;
  }
  pm_report_destroy(report);
  pm_sizing_destroy(scaled);
  pm_sizing_destroy(size);
  pm_sizing_destroy(input_size);
  pm_model_destroy(model);
  pm_method_params_destroy(params);
  return s;
}

/* params: a sequence of (key, value) pairs of str, read into j (the strings borrowed from
 * `pairs`, which the caller keeps). -1 with an exception. */
static int read_params(PyObject *pairs, job *j) {
  PyObject *seq = PySequence_Fast(pairs, "params must be a sequence of (key, value) pairs");
  if (!seq) return -1;
  Py_ssize_t n = PySequence_Fast_GET_SIZE(seq);
  j->keys = calloc((size_t)n + 1, sizeof *j->keys);
  j->values = calloc((size_t)n + 1, sizeof *j->values);
  if (!j->keys || !j->values) {
    Py_DECREF(seq);
    PyErr_NoMemory();
    return -1;
  }
  for (Py_ssize_t i = 0; i < n; ++i) {
    PyObject *pair = PySequence_Fast_GET_ITEM(seq, i);
    PyObject *k, *v;
    if (!PyTuple_Check(pair) || PyTuple_GET_SIZE(pair) != 2 ||
        !PyUnicode_Check(k = PyTuple_GET_ITEM(pair, 0)) ||
        !PyUnicode_Check(v = PyTuple_GET_ITEM(pair, 1))) {
      Py_DECREF(seq);
      PyErr_SetString(PyExc_TypeError, "params must be (str, str) pairs");
      return -1;
    }
    if (!(j->keys[i] = PyUnicode_AsUTF8(k)) || !(j->values[i] = PyUnicode_AsUTF8(v))) {
      Py_DECREF(seq);
      return -1;
    }
  }
  j->nparam = n;
  /* The strings live in the tuples, which `pairs` holds: the fast sequence may go. */
  Py_DECREF(seq);
  return 0;
}

/* What the run did, beside its stats. */
static PyObject *result_dict(const pm_generate_result *r) {
  return Py_BuildValue("{s:L,s:s,s:i,s:d,s:O,s:d}", "iterations", (long long)r->iterations,
                       "stop_reason", r->stop_reason, "runs", r->runs, "size_scale",
                       r->size_scale, "target_met", r->target_met ? Py_True : Py_False,
                       "seconds", r->seconds);
}

/* _generate(input, method, size, params, seed, volume, threads, target_nodes, max_nodes)
 *   -> (handle, arrays, stats_json, result) */
PyObject *pm_py_generate(PyObject *self, PyObject *args, PyObject *kwargs) {
  (void)self;
  static char *kwlist[] = {"input",   "method",  "size",         "params",    "seed",
                           "volume",  "threads", "target_nodes", "max_nodes", NULL};
  PyObject *input_obj = NULL, *size_arg = Py_None, *pairs = NULL;
  const char *method_name;
  unsigned long long seed = 1;
  int volume = 0, threads = 1;
  long long target_nodes = 0, max_nodes = 0;
  if (!PyArg_ParseTupleAndKeywords(args, kwargs, "O&sOOKpiLL:mesh", kwlist,
                                   PyUnicode_FSConverter, &input_obj, &method_name, &size_arg,
                                   &pairs, &seed, &volume, &threads, &target_nodes, &max_nodes))
    return NULL;
  job j;
  memset(&j, 0, sizeof j);
  PyObject *out = NULL;
  j.input = PyBytes_AS_STRING(input_obj);
  j.method = pm_method_find(method_name);
  if (!j.method) {
    char names[512];
    pm_method_names(names, sizeof names);
    PyErr_Format(PyExc_ValueError, "unknown method '%s' (known: %s)", method_name, names);
    goto done;
  }
  if (read_params(pairs, &j) || pm_py_size_read(size_arg, &j.pending, &j.size)) goto done;
  pm_generate_options_init(&j.opts);
  j.opts.seed = seed;
  j.opts.threads = threads;
  j.opts.volume = volume;
  j.opts.target_nodes = target_nodes;
  if (max_nodes > 0) j.opts.max_nodes = max_nodes;
  j.opts.progress = on_progress;
  j.opts.progress_user = &j;

  pm_status s;
  Py_BEGIN_ALLOW_THREADS
  s = run(&j);
  Py_END_ALLOW_THREADS
  if (pm_py_run_failed(&j.pending, s, &j.err)) goto done;
  PyObject *arrays = pm_py_mesh_arrays(j.mesh);
  if (!arrays) goto done;
  PyObject *handle = pm_py_mesh_capsule(j.mesh);
  j.mesh = NULL; /* the capsule owns it, or destroyed it */
  if (!handle) {
    Py_DECREF(arrays);
    goto done;
  }
  out = Py_BuildValue("(NNsN)", handle, arrays, j.stats_json, result_dict(&j.result));
done:
  pm_py_pending_clear(&j.pending);
  pm_mesh_destroy(j.mesh);
  free(j.stats_json);
  free(j.keys);
  free(j.values);
  Py_DECREF(input_obj);
  return out;
}
