/* A pm_mesh on the Python side (pm_py.h): a capsule that owns it, NumPy copies of its arrays,
 * and reading and writing mesh files. */
#include "pm_py.h"

#include <string.h>

#define CAPSULE_NAME "packmesh.pm_mesh"

static void capsule_release(PyObject *capsule) {
  pm_mesh_destroy(PyCapsule_GetPointer(capsule, CAPSULE_NAME));
}

PyObject *pm_py_mesh_capsule(pm_mesh *m) {
  PyObject *c = PyCapsule_New(m, CAPSULE_NAME, capsule_release);
  if (!c) pm_mesh_destroy(m);
  return c;
}

const pm_mesh *pm_py_mesh_of(PyObject *capsule) {
  if (!PyCapsule_IsValid(capsule, CAPSULE_NAME)) {
    PyErr_SetString(PyExc_TypeError, "expected a packmesh mesh handle");
    return NULL;
  }
  return PyCapsule_GetPointer(capsule, CAPSULE_NAME);
}

PyObject *pm_py_array_copy(int type, const void *data, npy_intp rows, npy_intp cols,
                           size_t item_size) {
  npy_intp dims[2] = {rows, cols};
  PyObject *a = PyArray_SimpleNew(cols > 0 ? 2 : 1, dims, type);
  if (!a) return NULL;
  size_t bytes = (size_t)rows * (size_t)(cols > 0 ? cols : 1) * item_size;
  if (bytes && data) memcpy(PyArray_DATA((PyArrayObject *)a), data, bytes);
  return a;
}

/* d[key] = value, value's reference stolen; -1 on failure. */
static int put(PyObject *d, const char *key, PyObject *value) {
  if (!value) return -1;
  int r = PyDict_SetItemString(d, key, value);
  Py_DECREF(value);
  return r;
}

PyObject *pm_py_mesh_arrays(const pm_mesh *m) {
  PyObject *d = PyDict_New();
  if (!d) return NULL;
  npy_intp n = pm_mesh_node_count(m);
  static const char *const kinds[4] = {NULL, "segments", "triangles", "tets"};
  static const char *const cells[4] = {NULL, "segment_cells", "triangle_cells", "tet_cells"};
  if (put(d, "nodes", pm_py_array_copy(NPY_FLOAT64, pm_mesh_nodes(m), n, 3, sizeof(double))) ||
      put(d, "node_dims", pm_py_array_copy(NPY_INT8, pm_mesh_node_dims(m), n, 0, sizeof(int8_t))) ||
      put(d, "node_cells",
          pm_py_array_copy(NPY_INT32, pm_mesh_node_cells(m), n, 0, sizeof(int32_t))))
    goto fail;
  for (int dim = 1; dim <= 3; ++dim) {
    npy_intp k = pm_mesh_element_count(m, dim);
    if (put(d, kinds[dim],
            pm_py_array_copy(NPY_INT32, pm_mesh_elements(m, dim), k, dim + 1, sizeof(int32_t))) ||
        put(d, cells[dim],
            pm_py_array_copy(NPY_INT32, pm_mesh_element_cells(m, dim), k, 0, sizeof(int32_t))))
      goto fail;
  }
  return d;
fail:
  Py_DECREF(d);
  return NULL;
}

/* _read(path) -> (handle, arrays) */
PyObject *pm_py_read(PyObject *self, PyObject *args) {
  (void)self;
  PyObject *path_obj = NULL;
  if (!PyArg_ParseTuple(args, "O&:read", PyUnicode_FSConverter, &path_obj)) return NULL;
  const char *path = PyBytes_AS_STRING(path_obj);
  pm_mesh *m = NULL;
  pm_error err = {0};
  pm_status s;
  Py_BEGIN_ALLOW_THREADS
  s = pm_mesh_read(path, &m, &err);
  Py_END_ALLOW_THREADS
  Py_DECREF(path_obj);
  if (s) return pm_py_raise(&err);
  PyObject *handle = pm_py_mesh_capsule(m);
  if (!handle) return NULL;
  PyObject *arrays = pm_py_mesh_arrays(m);
  if (!arrays) {
    Py_DECREF(handle);
    return NULL;
  }
  return Py_BuildValue("(NN)", handle, arrays);
}

/* _write(handle, path, msh_parametric=False) */
PyObject *pm_py_write(PyObject *self, PyObject *args, PyObject *kwargs) {
  (void)self;
  static char *kwlist[] = {"handle", "path", "msh_parametric", NULL};
  PyObject *handle, *path_obj = NULL;
  int parametric = 0;
  if (!PyArg_ParseTupleAndKeywords(args, kwargs, "OO&|p:write", kwlist, &handle,
                                   PyUnicode_FSConverter, &path_obj, &parametric))
    return NULL;
  const pm_mesh *m = pm_py_mesh_of(handle);
  if (!m) {
    Py_DECREF(path_obj);
    return NULL;
  }
  const char *path = PyBytes_AS_STRING(path_obj);
  pm_error err = {0};
  pm_mesh_write_opts opts = {0};
  opts.msh_parametric = parametric;
  pm_status s;
  /* The mesh is read only here, and the capsule (held by the arguments) keeps it alive. */
  Py_BEGIN_ALLOW_THREADS
  pm_mesh_format fmt;
  s = pm_mesh_format_of(path, &fmt, &err);
  if (!s && parametric && fmt != PM_MESH_MSH)
    s = pm_error_setf(&err, PM_ERR_ARG, "msh_parametric applies to .msh files only, not '%s'",
                      path);
  if (!s) s = pm_mesh_write_with(m, path, &opts, &err);
  Py_END_ALLOW_THREADS
  Py_DECREF(path_obj);
  if (s) return pm_py_raise(&err);
  Py_RETURN_NONE;
}
