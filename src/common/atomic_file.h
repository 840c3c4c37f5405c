/* Output files that appear whole or not at all.
 *
 * A file is written under a temporary name in the destination's folder (so that the final
 * rename stays on one file system and is atomic), with the destination's extension kept at the
 * end ("out.pmtmp-Ab12Cd.msh": gmsh chooses its writer by extension), and renamed onto the
 * destination when complete. On any failure the temporary file is removed, so no half-written
 * file is ever left, neither at the destination nor beside it.
 */
#ifndef PM_ATOMIC_FILE_H
#define PM_ATOMIC_FILE_H

#include <packmesh/packmesh.h>

#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct pm_atomic_file {
  char *path;   /* destination, owned */
  char *tmp;    /* temporary file name, owned */
  FILE *f;      /* open stream on tmp when requested, else NULL */
} pm_atomic_file;

/* Create the (empty) temporary file for path; when `stream` is set, open it for writing in f.
 * PM_ERR_IO naming path when the folder is not writable. */
pm_status pm_atomic_begin(pm_atomic_file *a, const char *path, int stream, pm_error *err);

/* Close the stream (a write error is PM_ERR_IO), then rename tmp onto path. On failure the
 * temporary file is removed. Releases a in every case. */
pm_status pm_atomic_commit(pm_atomic_file *a, pm_error *err);

/* Close and remove the temporary file; release a. Accepts a zeroed a. */
void pm_atomic_abort(pm_atomic_file *a);

/* Write `len` bytes of data to path atomically. */
pm_status pm_atomic_write(const char *path, const void *data, size_t len, pm_error *err);

#ifdef __cplusplus
}
#endif

#endif /* PM_ATOMIC_FILE_H */
