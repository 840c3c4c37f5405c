/* packmesh: the public C API.
 *
 * This header holds what every part of the library shares: the status codes and the error
 * record. The shared layer's headers (src/common/ headers) and the methods' headers build on it.
 *
 * Error convention (every fallible function):
 *   - it returns a pm_status, PM_OK (0) on success;
 *   - its last argument is a pm_error * that may be NULL; on failure it is filled with the
 *     code and a one-line message naming the problem;
 *   - the library never prints and never calls exit(): the caller decides what to show.
 */
#ifndef PACKMESH_PACKMESH_H
#define PACKMESH_PACKMESH_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum pm_status {
  PM_OK = 0,
  PM_ERR_ARG,      /* a bad argument or parameter value (out of range, unknown key) */
  PM_ERR_IO,       /* a file could not be read or written */
  PM_ERR_PARSE,    /* a file or expression is malformed */
  PM_ERR_GEOM,     /* the geometry cannot be handled (empty model, failed evaluation) */
  PM_ERR_BACKEND,  /* a third-party library (gmsh, CGAL, TetGen, Embree) failed */
  PM_ERR_LIMIT,    /* a cap (nodes, iterations, memory budget) would be exceeded */
  PM_ERR_NOMEM,    /* an allocation failed */
  PM_ERR_INTERNAL, /* a broken invariant detected at run time */
  PM_ERR_CANCELLED /* the caller's progress callback asked the run to stop */
} pm_status;

/* The error record. Plain data; lives on the caller's stack. */
typedef struct pm_error {
  pm_status code;   /* PM_OK when nothing went wrong */
  char msg[512];    /* one line, no trailing newline */
} pm_error;

/* Fill err (when not NULL) with code and a printf-style message; returns code so that call
 * sites read `return pm_error_setf(err, PM_ERR_ARG, "size must be > 0, got %g", d);`. */
pm_status pm_error_setf(pm_error *err, pm_status code, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Prefix an existing message with context ("reading x.step: <old message>"); keeps the code.
 * Returns err->code (PM_OK if err is NULL). */
pm_status pm_error_prefix(pm_error *err, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* Reset to PM_OK with an empty message. Accepts NULL. */
void pm_error_clear(pm_error *err);

/* A short name for a status code ("bad argument", "i/o error", ...). */
const char *pm_status_name(pm_status s);

/* The library version, "MAJOR.MINOR.PATCH". */
const char *pm_version(void);

#ifdef __cplusplus
}
#endif

#endif /* PACKMESH_PACKMESH_H */
