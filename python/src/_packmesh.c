/* packmesh._packmesh: the C extension behind the Python module packmesh (pm_py.h lists its
 * files). This file defines the module and answers from the library's own tables: its version,
 * the methods and their parameters, the built-in cases. The pure-Python layer
 * (python/packmesh/__init__.py) is the interface users see; these functions are its private
 * back end. */
#define PM_PY_IMPORTS_NUMPY
#include "pm_py.h"

/* _version() -> "MAJOR.MINOR.PATCH" */
static PyObject *py_version(PyObject *self, PyObject *unused) {
  (void)self, (void)unused;
  return PyUnicode_FromString(pm_version());
}

/* _methods() -> [{"name", "description", "traces", "planar_only"}] in pm_method_at order */
static PyObject *py_methods(PyObject *self, PyObject *unused) {
  (void)self, (void)unused;
  PyObject *l = PyList_New(0);
  for (int i = 0; l && i < pm_method_count(); ++i) {
    const pm_method *m = pm_method_at(i);
    PyObject *d = Py_BuildValue("{s:s,s:s,s:O,s:O}", "name", pm_method_name(m), "description",
                                pm_method_description(m), "traces",
                                pm_method_traces(m) ? Py_True : Py_False, "planar_only",
                                pm_method_planar_only(m) ? Py_True : Py_False);
    if (!d || PyList_Append(l, d) < 0) Py_CLEAR(l);
    Py_XDECREF(d);
  }
  return l;
}

/* _method_params(name) -> [{"key", "default", "range", "unit", "source", "doc"}], the table of
 * `packmesh mesh --method NAME --help`; ValueError for an unknown method. */
static PyObject *py_method_params(PyObject *self, PyObject *args) {
  (void)self;
  const char *name;
  if (!PyArg_ParseTuple(args, "s:method_params", &name)) return NULL;
  const pm_method *m = pm_method_find(name);
  if (!m) {
    char names[512];
    pm_method_names(names, sizeof names);
    return PyErr_Format(PyExc_ValueError, "unknown method '%s' (known: %s)", name, names);
  }
  PyObject *l = PyList_New(0);
  for (int i = 0; l && i < pm_method_param_count(m); ++i) {
    pm_param_info info;
    pm_error err = {0};
    if (pm_method_param_info(m, i, &info, &err)) {
      Py_DECREF(l);
      return pm_py_raise(&err);
    }
    PyObject *d = Py_BuildValue("{s:s,s:s,s:s,s:s,s:s,s:s}", "key", info.key, "default",
                                info.default_value, "range", info.range, "unit", info.unit,
                                "source", info.source, "doc", info.doc);
    if (!d || PyList_Append(l, d) < 0) Py_CLEAR(l);
    Py_XDECREF(d);
  }
  return l;
}

/* _cases() -> [{"name", "dimension", "description", "default_size", "source"}] */
static PyObject *py_cases(PyObject *self, PyObject *unused) {
  (void)self, (void)unused;
  PyObject *l = PyList_New(0);
  for (int i = 0; l && i < pm_case_count(); ++i) {
    PyObject *d = Py_BuildValue("{s:s,s:i,s:s,s:s,s:s}", "name", pm_case_name(i), "dimension",
                                pm_case_dimension(i), "description", pm_case_description(i),
                                "default_size", pm_case_default_size(i), "source",
                                pm_case_source(i));
    if (!d || PyList_Append(l, d) < 0) Py_CLEAR(l);
    Py_XDECREF(d);
  }
  return l;
}

static PyMethodDef functions[] = {
    {"_version", py_version, METH_NOARGS, "The library's version, pm_version()."},
    {"_methods", py_methods, METH_NOARGS, "The methods, in the library's order."},
    {"_method_params", py_method_params, METH_VARARGS, "A method's parameter table."},
    {"_cases", py_cases, METH_NOARGS, "The built-in cases."},
    {"_generate", (PyCFunction)(void (*)(void))pm_py_generate, METH_VARARGS | METH_KEYWORDS,
     "One run: (handle, arrays, stats_json, result)."},
    {"_quality", (PyCFunction)(void (*)(void))pm_py_quality, METH_VARARGS | METH_KEYWORDS,
     "Per-element measures, summaries and the checker's verdict of a mesh (handle or path)."},
    {"_read", pm_py_read, METH_VARARGS, "Read a mesh file: (handle, arrays)."},
    {"_write", (PyCFunction)(void (*)(void))pm_py_write, METH_VARARGS | METH_KEYWORDS,
     "Write a mesh (handle) to a file; the format follows the extension."},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_packmesh",
                                    "The C extension behind packmesh (private).", -1, functions,
                                    NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__packmesh(void) {
  import_array();
  return PyModule_Create(&module);
}
