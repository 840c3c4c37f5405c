/* gmsh's global state, in one place (see gmsh_session.h). */
#include "common/backends/gmsh_session.h"

#include <gmshc.h>

#include <fcntl.h>
#include <omp.h>
#include <pthread.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

static pthread_once_t init_once = PTHREAD_ONCE_INIT;
static pthread_mutex_t gmsh_mutex;
static int gmsh_ready = 0;
static char gmsh_init_error[256];

static void init_mutex_and_gmsh(void) {
  pthread_mutexattr_t attr;
  pthread_mutexattr_init(&attr);
  pthread_mutexattr_settype(&attr, PTHREAD_MUTEX_RECURSIVE);
  pthread_mutex_init(&gmsh_mutex, &attr);
  pthread_mutexattr_destroy(&attr);

  int ierr = 0;
  /* gmsh applies General.NumThreads through omp_set_num_threads() on the calling thread: without
   * restoring it, every OpenMP loop of the program would run on one thread after gmsh starts. */
  int omp_threads = omp_get_max_threads();
  gmshInitialize(0, NULL, 0, &ierr);
  if (ierr) {
    snprintf(gmsh_init_error, sizeof gmsh_init_error, "gmsh failed to initialize");
    return;
  }
  /* Quiet, and errors come back through ierr instead of aborting the process. */
  gmshOptionSetNumber("General.Terminal", 0, &ierr);
  gmshOptionSetNumber("General.Verbosity", 0, &ierr);
  gmshOptionSetNumber("General.AbortOnError", 0, &ierr);
  /* packmesh decides threading itself; gmsh's own threads would compete for the 2 cores. */
  gmshOptionSetNumber("General.NumThreads", 1, &ierr);
  gmshOptionSetNumber("Mesh.MaxNumThreads1D", 1, &ierr);
  gmshOptionSetNumber("Mesh.MaxNumThreads2D", 1, &ierr);
  gmshOptionSetNumber("Mesh.MaxNumThreads3D", 1, &ierr);
  omp_set_num_threads(omp_threads);
  gmsh_ready = 1;
}

pm_status pm_gmsh_begin(pm_error *err) {
  pthread_once(&init_once, init_mutex_and_gmsh);
  if (!gmsh_ready) return pm_error_setf(err, PM_ERR_BACKEND, "%s", gmsh_init_error);
  return PM_OK;
}

void pm_gmsh_shutdown(void) {
  if (!gmsh_ready) return;
  int ierr = 0;
  pm_gmsh_lock();
  gmshFinalize(&ierr);
  gmsh_ready = 0;
  pm_gmsh_unlock();
}

/* The lock guards calls of 0.1 to a few microseconds (GMSH_API.md), made back to back by every
 * thread of a parallel loop over points on gmsh faces. A waiter that goes straight to sleep costs
 * a futex wait and, at the release, a futex wake: several microseconds each, more than the call
 * it waits for, and the two threads then hand the lock to each other through the kernel at every
 * call. So a waiter first retries for a while (LOCK_SPIN tries, about 10 us), and sleeps only
 * when the holder is busy with something long (loading a file, a peer's meshing). */
#define LOCK_SPIN 400

static inline void cpu_relax(void) {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#endif
}

void pm_gmsh_lock(void) {
  pthread_once(&init_once, init_mutex_and_gmsh);
  for (int k = 0; k < LOCK_SPIN; ++k) {
    if (pthread_mutex_trylock(&gmsh_mutex) == 0) return;
    cpu_relax();
  }
  pthread_mutex_lock(&gmsh_mutex);
}

void pm_gmsh_unlock(void) { pthread_mutex_unlock(&gmsh_mutex); }

pm_status pm_gmsh_error(pm_error *err, pm_status code, const char *what) {
  char *msg = NULL;
  int ierr = 0;
  gmshLoggerGetLastError(&msg, &ierr);
  pm_status s;
  if (!ierr && msg && msg[0])
    s = pm_error_setf(err, code, "%s: %s", what, msg);
  else
    s = pm_error_setf(err, code, "%s (gmsh gave no reason)", what);
  if (msg) gmshFree(msg);
  return s;
}

pm_status pm_gmsh_scope_enter(pm_gmsh_scope *scope, const char *name, int create, pm_error *err) {
  pm_status s = pm_gmsh_begin(err);
  if (s) return s;
  /* The scope holds the (recursive) gmsh lock until it is left, so no other thread can switch
   * the current model under it; gmsh runs on one OpenMP thread inside it (see the header). */
  pm_gmsh_lock();
  scope->omp_threads = omp_get_max_threads();
  omp_set_num_threads(1);
  scope->previous[0] = '\0';
  scope->had_previous = 0;
  int ierr = 0;
  char **names = NULL;
  size_t n = 0;
  gmshModelList(&names, &n, &ierr);
  int exists = 0;
  for (size_t i = 0; i < n; ++i) {
    if (strcmp(names[i], name) == 0) exists = 1;
    gmshFree(names[i]);
  }
  if (names) gmshFree(names);
  if (n > 0) {
    char *cur = NULL;
    gmshModelGetCurrent(&cur, &ierr);
    if (!ierr && cur) {
      snprintf(scope->previous, sizeof scope->previous, "%s", cur);
      scope->had_previous = 1;
    }
    if (cur) gmshFree(cur);
  }
  if (create) {
    if (exists) s = pm_error_setf(err, PM_ERR_INTERNAL, "gmsh model '%s' exists already", name);
    if (!s) gmshModelAdd(name, &ierr);
    if (!s && ierr) s = pm_gmsh_error(err, PM_ERR_BACKEND, "creating a gmsh model");
  } else {
    if (!exists) s = pm_error_setf(err, PM_ERR_INTERNAL, "no gmsh model named '%s'", name);
    if (!s) gmshModelSetCurrent(name, &ierr);
    if (!s && ierr) s = pm_gmsh_error(err, PM_ERR_BACKEND, "selecting a gmsh model");
  }
  /* A failed enter leaves nothing to leave: restore and release here. */
  if (s) {
    if (scope->had_previous && scope->previous[0]) gmshModelSetCurrent(scope->previous, &ierr);
    omp_set_num_threads(scope->omp_threads);
    pm_gmsh_unlock();
  }
  return s;
}

void pm_gmsh_scope_leave(pm_gmsh_scope *scope, int remove_current) {
  int ierr = 0;
  if (remove_current) gmshModelRemove(&ierr);
  if (scope->had_previous && scope->previous[0]) gmshModelSetCurrent(scope->previous, &ierr);
  omp_set_num_threads(scope->omp_threads);
  pm_gmsh_unlock();
}

int pm_gmsh_mute_stdout(void) {
  fflush(stdout);
  int saved = dup(1);
  if (saved < 0) return -1;
  int devnull = open("/dev/null", O_WRONLY);
  if (devnull < 0) {
    close(saved);
    return -1;
  }
  dup2(devnull, 1);
  close(devnull);
  return saved;
}

void pm_gmsh_unmute_stdout(int token) {
  if (token < 0) return;
  fflush(stdout);
  dup2(token, 1);
  close(token);
}
