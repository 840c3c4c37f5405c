/* quality(): the measures of every triangle and tet of a mesh, their summaries and the checker's
 * verdict, through the public quality functions of packmesh.h (pm_py.h). The same measures as
 * `packmesh quality` (one implementation in the library); the model, when given, is what
 * --geometry gives the command: the checker's model checks, and its own size field for the size
 * conformity when no size is given, and the classification of a file's untagged nodes. */
#include "pm_py.h"

#include <string.h>

/* The names of the measures in per-element arrays and summaries: the columns of
 * `packmesh quality --csv` (a tet's angles are its dihedral angles). */
static const char *const measure_names[PM_MEASURE_COUNT] = {"radius_ratio", "aspect_ratio",
                                                            "min_angle_deg", "max_angle_deg"};

typedef struct qjob {
  /* in */
  const char *path; /* a file to read, or NULL: `mesh` is given */
  const pm_mesh *mesh;
  const char *geometry; /* may be NULL */
  pm_py_size size;
  pm_py_pending pending;
  /* out */
  pm_mesh *read;
  pm_quality *q;
  pm_check_result check;
  pm_error err;
} qjob;

static pm_status run(qjob *j) {
  pm_error *e = &j->err;
  pm_model *model = NULL;
  pm_sizing *input_size = NULL, *size = NULL;
  pm_status s = PM_OK;
  if (j->path) {
    s = pm_mesh_read(j->path, &j->read, e);
    j->mesh = j->read;
  }
  if (!s && j->geometry) {
    s = pm_model_open(j->geometry, &model, &input_size, e);
    if (s) pm_error_prefix(e, "geometry");
  }
  /* A file without entity tags is put on the model's cells first, as `packmesh quality
   * --geometry` does (pm_mesh_classify); a Mesh object given is left as it is. */
  if (!s && model && j->read) s = pm_mesh_classify(j->read, model, NULL, NULL, e);
  if (!s) s = pm_py_size_make(&j->size, model, NULL, 1, 1, &size, e);
  const pm_sizing *field = size ? size : input_size;
  if (!s) s = pm_quality_measure(j->mesh, field, &j->q, e);
  if (!s) s = pm_mesh_validate(j->mesh, model, &j->check, e);
  pm_sizing_destroy(size);
  pm_sizing_destroy(input_size);
  pm_model_destroy(model);
  return s;
}

static PyObject *summary_dict(const pm_summary *s) {
  return Py_BuildValue("{s:L,s:d,s:d,s:d,s:d,s:d,s:d}", "n", (long long)s->n, "min", s->min, "p25",
                       s->p25, "median", s->median, "p75", s->p75, "max", s->max, "mean", s->mean);
}

/* d[key] = value, value's reference stolen; -1 on failure. */
static int put(PyObject *d, const char *key, PyObject *value) {
  if (!value) return -1;
  int r = PyDict_SetItemString(d, key, value);
  Py_DECREF(value);
  return r;
}

/* {"values": {measure: array}, "summary": {measure: {...}, "eps_t", "eps_g", "size_ratio"}} of
 * the elements of dimension dim. */
static PyObject *kind_dict(const pm_quality *q, int dim) {
  PyObject *values = PyDict_New(), *summary = PyDict_New();
  if (!values || !summary) goto fail;
  for (int w = 0; w < PM_MEASURE_COUNT; ++w) {
    int32_t n = 0;
    const double *v = pm_quality_values(q, dim, (pm_measure)w, &n);
    pm_summary sm;
    pm_error err = {0};
    if (pm_quality_summary(q, dim, (pm_measure)w, &sm, &err)) {
      pm_py_raise(&err);
      goto fail;
    }
    if (put(values, measure_names[w], pm_py_array_copy(NPY_FLOAT64, v, n, 0, sizeof(double))) ||
        put(summary, measure_names[w], summary_dict(&sm)))
      goto fail;
  }
  pm_summary ratio = pm_quality_size_ratio(q, dim);
  if (put(summary, "eps_t", PyFloat_FromDouble(pm_quality_eps_t(q, dim))) ||
      put(summary, "eps_g", PyFloat_FromDouble(pm_quality_eps_g(q, dim))) ||
      put(summary, "size_ratio", ratio.n ? summary_dict(&ratio) : (Py_INCREF(Py_None), Py_None)))
    goto fail;
  return Py_BuildValue("{s:N,s:N}", "values", values, "summary", summary);
fail:
  Py_XDECREF(values);
  Py_XDECREF(summary);
  return NULL;
}

static PyObject *problems_list(const pm_check_result *c) {
  PyObject *l = PyList_New(0);
  for (int i = 0; l && i < c->nproblem; ++i) {
    PyObject *line = PyUnicode_DecodeUTF8(c->problem[i], (Py_ssize_t)strlen(c->problem[i]),
                                          "replace");
    if (!line || PyList_Append(l, line) < 0) Py_CLEAR(l);
    Py_XDECREF(line);
  }
  return l;
}

/* _quality(mesh, size=None, geometry=None) with mesh a handle or a path
 *   -> {"triangles": kind_dict, "tets": kind_dict, "valid": bool, "problems": [str]} */
PyObject *pm_py_quality(PyObject *self, PyObject *args, PyObject *kwargs) {
  (void)self;
  static char *kwlist[] = {"mesh", "size", "geometry", NULL};
  PyObject *mesh_arg, *size_arg = Py_None, *geometry_arg = Py_None;
  if (!PyArg_ParseTupleAndKeywords(args, kwargs, "O|OO:quality", kwlist, &mesh_arg, &size_arg,
                                   &geometry_arg))
    return NULL;
  qjob j;
  memset(&j, 0, sizeof j);
  PyObject *path_obj = NULL, *geometry_obj = NULL, *out = NULL;
  if (PyUnicode_Check(mesh_arg) || PyBytes_Check(mesh_arg) ||
      PyObject_HasAttrString(mesh_arg, "__fspath__")) {
    if (!PyUnicode_FSConverter(mesh_arg, &path_obj)) return NULL;
    j.path = PyBytes_AS_STRING(path_obj);
  } else if (!(j.mesh = pm_py_mesh_of(mesh_arg))) {
    return NULL;
  }
  if (geometry_arg != Py_None) {
    if (!PyUnicode_FSConverter(geometry_arg, &geometry_obj)) goto done;
    j.geometry = PyBytes_AS_STRING(geometry_obj);
  }
  if (pm_py_size_read(size_arg, &j.pending, &j.size)) goto done;
  pm_status s;
  Py_BEGIN_ALLOW_THREADS
  s = run(&j);
  Py_END_ALLOW_THREADS
  if (pm_py_run_failed(&j.pending, s, &j.err)) goto done;
  PyObject *tri = kind_dict(j.q, 2), *tet = tri ? kind_dict(j.q, 3) : NULL;
  if (!tri || !tet) {
    Py_XDECREF(tri);
    goto done;
  }
  out = Py_BuildValue("{s:N,s:N,s:O,s:N}", "triangles", tri, "tets", tet, "valid",
                      j.check.valid ? Py_True : Py_False, "problems", problems_list(&j.check));
done:
  pm_py_pending_clear(&j.pending);
  pm_quality_destroy(j.q);
  pm_mesh_destroy(j.read);
  Py_XDECREF(path_obj);
  Py_XDECREF(geometry_obj);
  return out;
}
