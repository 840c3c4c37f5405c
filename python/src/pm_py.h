/* The C extension packmesh._packmesh: what its files share among themselves.
 *
 * The extension is built on libpackmesh.so's public API and nothing else: <packmesh/packmesh.h>
 * and <packmesh/packmesh_extended.h>, as the packmesh command is (test_layers checks the
 * includes of python/src). Its files, one concern each:
 *   _packmesh.c   the module: its functions, and the tables (version, methods, cases)
 *   py_errors.c   a pm_error as a Python exception; a Python exception kept across a run
 *   py_sizing.c   the size argument (None, a number, text, a callable) as a pm_sizing
 *   py_mesh.c     a pm_mesh as a capsule and as NumPy arrays; reading and writing files
 *   py_generate.c mesh(): the run with the GIL released, its record (the --stats JSON)
 *   py_quality.c  quality(): per-element measures, summaries and the checker's verdict
 * The pure-Python layer (python/packmesh/__init__.py) wraps these in Mesh, Quality and Study.
 */
#ifndef PM_PY_H
#define PM_PY_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>

/* One NumPy C-API table for the whole extension: _packmesh.c imports it, the others use it. */
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#define PY_ARRAY_UNIQUE_SYMBOL pm_py_numpy_api
#ifndef PM_PY_IMPORTS_NUMPY
#define NO_IMPORT_ARRAY
#endif
#include <numpy/arrayobject.h>

#include <packmesh/packmesh.h>
#include <packmesh/packmesh_extended.h>

#include <stdatomic.h>

/* ---- errors (py_errors.c) ---- */

/* Raise err as ValueError (PM_ERR_ARG), OSError (PM_ERR_IO) or RuntimeError (any other code),
 * with the library's message; the exception's `status` attribute is pm_status_name(code).
 * Returns NULL, for `return pm_py_raise(&err);`. */
PyObject *pm_py_raise(const pm_error *err);

/* The first Python exception raised where the library calls back into Python (a size callable,
 * a KeyboardInterrupt seen by the progress callback) while a run holds no GIL: kept here, and
 * raised by the caller once the run is over. `set` is read without the GIL to stop early. */
typedef struct pm_py_pending {
  atomic_int set;
  PyObject *exc; /* the exception instance (a new reference) once set */
} pm_py_pending;

/* With the GIL and an exception set: keep it (the first one only; a later one is dropped) and
 * clear the error indicator. */
void pm_py_pending_keep(pm_py_pending *p);
/* 1 when an exception is kept (any thread, no GIL needed). */
int pm_py_pending_is_set(const pm_py_pending *p);
/* With the GIL, after a run that held no GIL: raise the kept exception (it says more than the
 * library's "cancelled" or its complaint about the values that followed it), else err when the
 * run's status s failed. Returns 1 when an exception is set. */
int pm_py_run_failed(pm_py_pending *p, pm_status s, const pm_error *err);
/* With the GIL: drop the kept exception, if any. */
void pm_py_pending_clear(pm_py_pending *p);

/* ---- the size argument (py_sizing.c) ---- */

typedef enum pm_py_size_kind {
  PM_PY_SIZE_DEFAULT,  /* None: the input's own field, else the method's default */
  PM_PY_SIZE_CONSTANT, /* a number */
  PM_PY_SIZE_TEXT,     /* a number or an expression as text, as --size takes it */
  PM_PY_SIZE_INFERRED, /* "inferred": psys's field (what --size inferred means) */
  PM_PY_SIZE_CALLABLE  /* f(x, y, z) -> float */
} pm_py_size_kind;

typedef struct pm_py_size {
  pm_py_size_kind kind;
  double constant;
  const char *text;     /* borrowed from the argument, which outlives the call */
  PyObject *fn;         /* borrowed, likewise */
  char description[96]; /* a callable's name in the stats' "size" */
  double fallback;      /* what the callable's trampoline returns once it has failed */
  pm_py_pending *pending; /* where the callable's exception goes (borrowed) */
} pm_py_size;

/* With the GIL: read the size argument `arg` into s (pending: where a callable's exception will
 * be kept). -1 with TypeError for anything else than None, a real number, str or a callable. */
int pm_py_size_read(PyObject *arg, pm_py_pending *pending, pm_py_size *s);

/* Without the GIL (a callable takes it itself, from whichever thread calls it): make the field
 * into *out. model (may be NULL) gives "inferred" its model and the callable its fallback;
 * method (may be NULL) is the method that will use the field: psys makes its own inferred
 * field, so "inferred" with psys gives NULL (as the command does). PM_PY_SIZE_DEFAULT gives
 * NULL. Text that does not parse is PM_ERR_ARG (a bad argument, as for --size). */
pm_status pm_py_size_make(pm_py_size *s, const pm_model *model, const pm_method *method,
                          uint64_t seed, int threads, pm_sizing **out, pm_error *err);

/* ---- meshes (py_mesh.c) ---- */

/* A capsule owning m (pm_mesh_destroy when it goes); NULL with an exception (m is then
 * destroyed). */
PyObject *pm_py_mesh_capsule(pm_mesh *m);
/* The mesh in a capsule made by pm_py_mesh_capsule; NULL with TypeError otherwise. */
const pm_mesh *pm_py_mesh_of(PyObject *capsule);
/* A dict of NumPy copies of m's arrays: nodes (n x 3 float64), node_dims (int8), node_cells,
 * segments (k x 2), triangles (k x 3), tets (k x 4) and segment_cells, triangle_cells,
 * tet_cells (int32, the model cell of each element, -1 unknown). NULL with an exception. */
PyObject *pm_py_mesh_arrays(const pm_mesh *m);

/* An n-element (rows x cols when cols > 0) NumPy array of type `type` holding a copy of data
 * (may be NULL when n is 0). NULL with an exception. */
PyObject *pm_py_array_copy(int type, const void *data, npy_intp rows, npy_intp cols,
                           size_t item_size);

PyObject *pm_py_read(PyObject *self, PyObject *args);
PyObject *pm_py_write(PyObject *self, PyObject *args, PyObject *kwargs);

/* ---- mesh() and quality() (py_generate.c, py_quality.c) ---- */

PyObject *pm_py_generate(PyObject *self, PyObject *args, PyObject *kwargs);
PyObject *pm_py_quality(PyObject *self, PyObject *args, PyObject *kwargs);

#endif /* PM_PY_H */
