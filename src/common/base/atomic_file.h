/* Output files that appear whole or not at all, alone or as a set.
 *
 * One file (pm_atomic_*): written under a temporary name in the destination's folder (so that the
 * final rename stays on one file system and is atomic), with the destination's extension kept at
 * the end ("out.pmtmp-Ab12Cd.msh": gmsh chooses its writer by extension), and renamed onto the
 * destination when complete. On any failure the temporary file is removed, so no half-written
 * file is ever left, neither at the destination nor beside it. Files are created with mode
 * 0666 less the process's umask, like any file a program creates (0644 under umask 022).
 *
 * A set of outputs (pm_outputs_*), the files and folders one command writes: each is reserved
 * before the work starts (a temporary file or folder beside it; an unwritable destination is
 * reported then, not after the work), written under its temporary name, and all are renamed into
 * place only once every one of them is complete. On any failure none of them exists: the
 * temporaries are removed, and so are the destinations already renamed when a later rename fails.
 *
 * Live temporaries (pm_tmp_*): every temporary file and folder made here is recorded while it
 * exists, and pm_tmp_remove_all() -- safe to call from a signal handler -- removes them all: the
 * packmesh command calls it on SIGINT and SIGTERM. Other code that makes temporary files (a
 * helper program's output) records them with pm_tmp_track.
 */
#ifndef PM_ATOMIC_FILE_H
#define PM_ATOMIC_FILE_H

#include <packmesh/packmesh.h>
#include <packmesh/packmesh_extended.h>

#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct pm_atomic_file {
  char *path;   /* destination, owned */
  char *tmp;    /* temporary file name, owned */
  FILE *f;      /* open stream on tmp when requested, else NULL */
  int slot;     /* its record among the live temporaries, -1 none */
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

/* ---- a set of outputs ---- */

/* pm_outputs (create, add, commit, destroy) and pm_path_same are part of the extended API
 * (packmesh_extended.h). */

/* ---- live temporaries ---- */

/* Record `path` (a file, or a folder when `folder` is set: its files are removed with it) as a
 * temporary to remove on a signal. Returns its record, or -1 when the table is full or the path
 * too long (it then goes unrecorded). */
int pm_tmp_track(const char *path, int folder);

/* Forget record `id` (the temporary was renamed or removed). Accepts -1. */
void pm_tmp_untrack(int id);

/* pm_tmp_remove_all (packmesh_extended.h) removes every recorded temporary. */

#ifdef __cplusplus
}
#endif

#endif /* PM_ATOMIC_FILE_H */
