/* The library's errors as Python exceptions, and Python exceptions kept across a run that holds
 * no GIL (pm_py.h). */
#include "pm_py.h"

PyObject *pm_py_raise(const pm_error *err) {
  PyObject *type = err->code == PM_ERR_ARG  ? PyExc_ValueError
                   : err->code == PM_ERR_IO ? PyExc_OSError
                                            : PyExc_RuntimeError;
  const char *msg = err->msg[0] ? err->msg : pm_status_name(err->code);
  PyObject *exc = PyObject_CallFunction(type, "s", msg);
  if (!exc) return NULL;
  /* Which of the library's codes it was, for a caller that tells PM_ERR_LIMIT from
   * PM_ERR_BACKEND (both RuntimeError). */
  PyObject *status = PyUnicode_FromString(pm_status_name(err->code));
  if (!status || PyObject_SetAttrString(exc, "status", status) < 0) {
    Py_XDECREF(status);
    Py_DECREF(exc);
    return NULL;
  }
  Py_DECREF(status);
  PyErr_SetObject(type, exc);
  Py_DECREF(exc);
  return NULL;
}

/* The exception set now, as one object (its traceback attached), the indicator cleared. */
static PyObject *take_exception(void) {
#if PY_VERSION_HEX >= 0x030C0000
  return PyErr_GetRaisedException();
#else
  PyObject *type, *value, *tb;
  PyErr_Fetch(&type, &value, &tb);
  PyErr_NormalizeException(&type, &value, &tb);
  if (tb && value) PyException_SetTraceback(value, tb);
  Py_XDECREF(type);
  Py_XDECREF(tb);
  return value;
#endif
}

void pm_py_pending_keep(pm_py_pending *p) {
  PyObject *exc = take_exception();
  /* Under the GIL: no other thread stores at the same time. */
  if (atomic_load(&p->set) || !exc) {
    Py_XDECREF(exc);
    return;
  }
  p->exc = exc;
  atomic_store(&p->set, 1);
}

int pm_py_pending_is_set(const pm_py_pending *p) {
  return atomic_load(&((pm_py_pending *)p)->set);
}

/* With the GIL: raise the kept exception (returns 1), or return 0 when none is kept. */
static int pm_py_pending_raise(pm_py_pending *p) {
  if (!atomic_load(&p->set)) return 0;
  PyObject *exc = p->exc;
  p->exc = NULL;
  atomic_store(&p->set, 0);
  PyErr_SetObject((PyObject *)Py_TYPE(exc), exc);
  Py_DECREF(exc);
  return 1;
}

int pm_py_run_failed(pm_py_pending *p, pm_status s, const pm_error *err) {
  if (pm_py_pending_raise(p)) return 1;
  if (s == PM_OK) return 0;
  pm_py_raise(err);
  return 1;
}

void pm_py_pending_clear(pm_py_pending *p) {
  Py_CLEAR(p->exc);
  atomic_store(&p->set, 0);
}
