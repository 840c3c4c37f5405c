/* The size argument of mesh() and quality() as a pm_sizing (pm_py.h): None, a number, text as
 * --size takes it ("0.1", "0.2*abs(r-2)+0.15", "inferred"), or a Python callable f(x, y, z).
 *
 * A callable goes through the public API's C callback field. packmesh.h asks such a callback to
 * be thread-safe, and pm_generate evaluates the field from its OpenMP threads while the calling
 * thread has released the GIL: the trampoline therefore takes the GIL itself
 * (PyGILState_Ensure), from whichever thread calls it. An exception in the callable cannot cross
 * the library: it is kept (pm_py_pending), the trampoline answers with a harmless fallback size
 * from then on, the progress callback of the run cancels it at the next iteration or stage, and
 * the caller raises the kept exception once the run is over.
 */
#include "pm_py.h"

#include <stdio.h>
#include <string.h>

int pm_py_size_read(PyObject *arg, pm_py_pending *pending, pm_py_size *s) {
  memset(s, 0, sizeof *s);
  s->pending = pending;
  s->fallback = 1.0;
  if (arg == NULL || arg == Py_None) {
    s->kind = PM_PY_SIZE_DEFAULT;
    return 0;
  }
  if (PyUnicode_Check(arg)) {
    s->text = PyUnicode_AsUTF8(arg);
    if (!s->text) return -1;
    s->kind = strcmp(s->text, "inferred") == 0 ? PM_PY_SIZE_INFERRED : PM_PY_SIZE_TEXT;
    return 0;
  }
  /* True is a number to Python, never a size. */
  if (!PyBool_Check(arg) && (PyFloat_Check(arg) || PyLong_Check(arg) || PyIndex_Check(arg) ||
                             PyObject_HasAttrString(arg, "__float__"))) {
    s->constant = PyFloat_AsDouble(arg);
    if (s->constant == -1.0 && PyErr_Occurred()) return -1;
    s->kind = PM_PY_SIZE_CONSTANT;
    return 0;
  }
  if (PyCallable_Check(arg)) {
    s->fn = arg;
    s->kind = PM_PY_SIZE_CALLABLE;
    /* The stats' "size" names the function, as a --size names its expression. */
    PyObject *name = PyObject_GetAttrString(arg, "__name__");
    if (!name) PyErr_Clear();
    const char *n = name && PyUnicode_Check(name) ? PyUnicode_AsUTF8(name) : NULL;
    if (!n) PyErr_Clear();
    snprintf(s->description, sizeof s->description, "python callable %s",
             n ? n : Py_TYPE(arg)->tp_name);
    Py_XDECREF(name);
    return 0;
  }
  PyErr_Format(PyExc_TypeError,
               "size must be None, a number, a string (a number, an expression in x, y, z, r, "
               "or 'inferred') or a callable f(x, y, z), not %.80s",
               Py_TYPE(arg)->tp_name);
  return -1;
}

/* Say where the callable failed, on the exception itself (notes: Python 3.11 and later). */
static void add_note(const double xyz[3]) {
#if PY_VERSION_HEX >= 0x030B0000
  char note[160];
  snprintf(note, sizeof note, "raised by the size function at (%.6g, %.6g, %.6g)", xyz[0], xyz[1],
           xyz[2]);
#if PY_VERSION_HEX >= 0x030C0000
  PyObject *exc = PyErr_GetRaisedException();
#else
  PyObject *type, *exc, *tb;
  PyErr_Fetch(&type, &exc, &tb);
  PyErr_NormalizeException(&type, &exc, &tb);
#endif
  if (exc) {
    PyObject *r = PyObject_CallMethod(exc, "add_note", "s", note);
    if (!r) PyErr_Clear(); /* an exception without notes is raised as it is */
    Py_XDECREF(r);
  }
#if PY_VERSION_HEX >= 0x030C0000
  PyErr_SetRaisedException(exc);
#else
  PyErr_Restore(type, exc, tb);
#endif
#else
  (void)xyz;
#endif
}

static double trampoline(const double xyz[3], void *user) {
  pm_py_size *s = user;
  /* Once failed, no more calls into Python: the run is being cancelled. */
  if (pm_py_pending_is_set(s->pending)) return s->fallback;
  PyGILState_STATE gil = PyGILState_Ensure();
  double d = s->fallback;
  if (!pm_py_pending_is_set(s->pending)) {
    PyObject *r = PyObject_CallFunction(s->fn, "ddd", xyz[0], xyz[1], xyz[2]);
    double v = r ? PyFloat_AsDouble(r) : -1.0;
    Py_XDECREF(r);
    if (PyErr_Occurred()) {
      add_note(xyz);
      pm_py_pending_keep(s->pending);
    } else {
      /* A value that is not finite and > 0 goes to the library as it is, as an expression's
       * would: pm_generate judges the field against the model. */
      d = v;
    }
  }
  PyGILState_Release(gil);
  return d;
}

pm_status pm_py_size_make(pm_py_size *s, const pm_model *model, const pm_method *method,
                          uint64_t seed, int threads, pm_sizing **out, pm_error *err) {
  *out = NULL;
  pm_status st = PM_OK;
  switch (s->kind) {
    case PM_PY_SIZE_DEFAULT:
      return PM_OK;
    case PM_PY_SIZE_CONSTANT:
      return pm_sizing_constant(s->constant, out, err);
    case PM_PY_SIZE_TEXT:
      st = pm_sizing_parse(s->text, out, err);
      /* Text that is neither a number nor an expression is a bad argument, as --size's is. */
      if (st == PM_ERR_PARSE) err->code = st = PM_ERR_ARG;
      return st;
    case PM_PY_SIZE_INFERRED:
      if (method && strcmp(pm_method_name(method), "psys") == 0) return PM_OK; /* its own */
      if (!model)
        return pm_error_setf(err, PM_ERR_ARG, "size 'inferred' needs the model (geometry=...)");
      st = pm_sizing_inferred(model, seed, threads, out, err);
      if (st) pm_error_prefix(err, "size inferred");
      return st;
    case PM_PY_SIZE_CALLABLE:
      /* The coarsest spacing that makes sense on the model: a cancelled run ends quickly. */
      if (model && pm_model_diagonal(model) > 0) s->fallback = pm_model_diagonal(model);
      return pm_sizing_callback(trampoline, s, s->description, out, err);
  }
  return pm_error_setf(err, PM_ERR_INTERNAL, "size: unknown kind %d", (int)s->kind);
}
