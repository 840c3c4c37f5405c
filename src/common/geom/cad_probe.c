/* A trial read of a CAD file in a child process (see cad_probe.h). */
#include "common/geom/cad_probe.h"

#include <gmshc.h>

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "common/backends/gmsh_session.h"

static double seconds(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The child: a fresh gmsh model, the import, and an exit code. Never returns. */
static void child(const char *path, const char *format) {
  /* A crash must end the child, not run a handler inherited from the caller. */
  const int fatal[] = {SIGSEGV, SIGABRT, SIGBUS, SIGFPE, SIGILL, SIGINT, SIGTERM};
  for (size_t i = 0; i < sizeof fatal / sizeof fatal[0]; ++i) signal(fatal[i], SIG_DFL);
  int null = open("/dev/null", O_WRONLY);
  if (null >= 0) dup2(null, 1), dup2(null, 2);
  if (pm_gmsh_begin(NULL)) _exit(2);
  int ierr = 0;
  gmshModelAdd("packmesh-probe", &ierr);
  int *dt = NULL;
  size_t ndt = 0;
  ierr = 0;
  gmshModelOccImportShapes(path, &dt, &ndt, 0, format, &ierr);
  _exit(ierr ? 1 : 0);
}

pm_status pm_cad_probe(const char *path, const char *format, pm_error *err) {
  struct stat st;
  double mb = stat(path, &st) == 0 ? (double)st.st_size / (1 << 20) : 0;
  double limit = PM_CAD_PROBE_BASE_S + PM_CAD_PROBE_PER_MB_S * mb;
  /* No gmsh call may be half done in another thread when the child is made. */
  pm_gmsh_lock();
  fflush(NULL);
  pid_t pid = fork();
  if (pid == 0) child(path, format);
  pm_gmsh_unlock();
  if (pid < 0)
    return pm_error_setf(err, PM_ERR_BACKEND, "%s: cannot start a process to read it: %s", path,
                         strerror(errno));
  double t0 = seconds();
  int ws = 0;
  for (;;) {
    pid_t w = waitpid(pid, &ws, WNOHANG);
    if (w == pid) break;
    if (w < 0 && errno != EINTR) return PM_OK; /* reaped elsewhere (SIGCHLD ignored): no verdict */
    if (seconds() - t0 > limit) {
      kill(pid, SIGKILL);
      while (waitpid(pid, &ws, 0) < 0 && errno == EINTR) {
      }
      return pm_error_setf(err, PM_ERR_PARSE,
                           "%s: OpenCASCADE did not finish reading it within %.0f s: the file is "
                           "damaged",
                           path, limit);
    }
    struct timespec ts = {0, 2 * 1000 * 1000};
    nanosleep(&ts, NULL);
  }
  if (WIFSIGNALED(ws))
    return pm_error_setf(err, PM_ERR_PARSE, "%s: OpenCASCADE crashed reading it (signal %d, %s)",
                         path, WTERMSIG(ws), strsignal(WTERMSIG(ws)));
  return PM_OK;
}
