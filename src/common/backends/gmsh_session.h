/* The one place that owns gmsh's global state.
 *
 * gmsh is a process-wide singleton: one initialization, a "current model" that every call acts
 * on, and no documented thread safety. Every packmesh module that calls gmshc.h (geom_cad,
 * mesh_io, the gmsh peers) goes through this file:
 *   - pm_gmsh_begin() initializes gmsh once, quietly, with errors reported through ierr;
 *   - pm_gmsh_lock()/unlock() serialize calls made from worker threads;
 *   - a scope makes a named model current and restores the previous one afterwards, so a
 *     writer that builds a temporary model does not break a loaded CAD model;
 *   - pm_gmsh_error() turns gmsh's last error into a pm_error;
 *   - pm_gmsh_mute_stdout() silences what OpenCASCADE prints on stdout (STEP/IGES transfer
 *     statistics appear even with General.Terminal = 0, and would corrupt JSON on stdout).
 */
#ifndef PM_GMSH_SESSION_H
#define PM_GMSH_SESSION_H

#include <packmesh/packmesh.h>

/* Initialize gmsh if needed (idempotent, thread-safe). */
pm_status pm_gmsh_begin(pm_error *err);

/* Finalize gmsh if it was initialized. Only a program's main() calls this, at the very end. */
void pm_gmsh_shutdown(void);

/* A recursive lock around gmsh calls made while other threads may call gmsh too. */
void pm_gmsh_lock(void);
void pm_gmsh_unlock(void);

/* Fill err with `what` and gmsh's last error message; returns code. */
pm_status pm_gmsh_error(pm_error *err, pm_status code, const char *what);

typedef struct pm_gmsh_scope {
  char previous[256]; /* name of the model that was current, "" if none */
  int had_previous;
  int omp_threads;    /* the calling thread's OpenMP thread count before the scope */
} pm_gmsh_scope;

/* Make model `name` current, creating it when `create` is set (an existing model of that name is
 * an error then). Remembers the previous current model in scope. The scope holds the gmsh lock
 * from a successful enter to its leave; a failed enter holds nothing. Inside a scope the calling
 * thread's OpenMP thread count is 1: gmsh's meshers open OpenMP regions that follow it, and with
 * more than one thread gmsh 4.8.4's meshes change from run to run. */
pm_status pm_gmsh_scope_enter(pm_gmsh_scope *scope, const char *name, int create, pm_error *err);

/* Restore the model that was current before pm_gmsh_scope_enter() and release the lock. When
 * `remove_current` is set, the scope's model is removed first. */
void pm_gmsh_scope_leave(pm_gmsh_scope *scope, int remove_current);

/* Redirect file descriptor 1 to /dev/null until pm_gmsh_unmute_stdout(); returns a token
 * (the saved descriptor, or -1 if nothing was redirected). */
int pm_gmsh_mute_stdout(void);
void pm_gmsh_unmute_stdout(int token);

#endif /* PM_GMSH_SESSION_H */
