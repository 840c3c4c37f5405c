/* Small helpers shared by the compare_*.c files: growing strings, shell quoting, whole-file
 * reads, folder creation and running a helper program (gnuplot, dpkg-query, Slurm's sbatch,
 * squeue, sacct) with a time limit, its output into a file or captured. */
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "common/base/clock.h"
#include "compare/src/study.h"

int pm_cmp_strcat(char **buf, size_t *len, size_t *cap, const char *text) {
  size_t n = strlen(text);
  if (*len + n + 1 > *cap) {
    size_t c = *cap ? *cap : 256;
    while (c < *len + n + 1) c *= 2;
    char *b = realloc(*buf, c);
    if (!b) return -1;
    *buf = b;
    *cap = c;
  }
  memcpy(*buf + *len, text, n + 1);
  *len += n;
  return 0;
}

int pm_cmp_appendf(char **buf, size_t *len, size_t *cap, const char *fmt, ...) {
  char small[1024];
  va_list ap;
  va_start(ap, fmt);
  int n = vsnprintf(small, sizeof small, fmt, ap);
  va_end(ap);
  if (n < 0) return -1;
  if ((size_t)n < sizeof small) return pm_cmp_strcat(buf, len, cap, small);
  char *big = malloc((size_t)n + 1);
  if (!big) return -1;
  va_start(ap, fmt);
  vsnprintf(big, (size_t)n + 1, fmt, ap);
  va_end(ap);
  int r = pm_cmp_strcat(buf, len, cap, big);
  free(big);
  return r;
}

void pm_cmp_shell_quote(const char *w, char *out, size_t len) {
  int plain = *w != '\0';
  for (const char *c = w; *c; ++c)
    if (!((*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') || (*c >= '0' && *c <= '9') ||
          strchr("_./:=,+-@%", *c)))
      plain = 0;
  if (plain) {
    snprintf(out, len, "%s", w);
    return;
  }
  /* 'text' with every ' written as '\'' (close, escaped quote, reopen). */
  size_t k = 0;
  if (len < 3) {
    if (len) out[0] = '\0';
    return;
  }
  out[k++] = '\'';
  for (const char *c = w; *c && k + 5 < len; ++c) {
    if (*c == '\'') {
      memcpy(out + k, "'\\''", 4);
      k += 4;
    } else {
      out[k++] = *c;
    }
  }
  out[k++] = '\'';
  out[k] = '\0';
}

char *pm_cmp_read_file(const char *path, size_t *len) {
  FILE *f = fopen(path, "rb");
  if (!f) return NULL;
  char *buf = NULL;
  size_t n = 0, cap = 0;
  for (;;) {
    if (n + 4096 + 1 > cap) {
      size_t c = cap ? 2 * cap : 8192;
      char *b = realloc(buf, c);
      if (!b) {
        free(buf);
        fclose(f);
        return NULL;
      }
      buf = b;
      cap = c;
    }
    size_t got = fread(buf + n, 1, 4096, f);
    n += got;
    if (got < 4096) break;
  }
  int bad = ferror(f);
  fclose(f);
  if (bad) {
    free(buf);
    return NULL;
  }
  buf[n] = '\0';
  if (len) *len = n;
  return buf;
}

pm_status pm_cmp_mkdirs(const char *path, pm_error *err) {
  char buf[4096];
  if (snprintf(buf, sizeof buf, "%s", path) >= (int)sizeof buf)
    return pm_error_setf(err, PM_ERR_ARG, "path too long: %s", path);
  for (char *p = buf + 1;; ++p) {
    if (*p == '/' || *p == '\0') {
      char c = *p;
      *p = '\0';
      if (mkdir(buf, 0777) != 0 && errno != EEXIST)
        return pm_error_setf(err, PM_ERR_IO, "cannot create folder '%s': %s", buf,
                             strerror(errno));
      *p = c;
      if (c == '\0') break;
    }
  }
  struct stat sb;
  if (stat(path, &sb) != 0 || !S_ISDIR(sb.st_mode))
    return pm_error_setf(err, PM_ERR_IO, "'%s' is not a folder", path);
  return PM_OK;
}

int pm_cmp_run_program(char *const argv[], const char *cwd, const char *out_path,
                       const char *err_path, double timeout_s, int *wstatus, int *timed_out) {
  *timed_out = 0;
  *wstatus = 0;
  fflush(NULL);
  pid_t pid = fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    setpgid(0, 0);
    if (cwd && chdir(cwd) != 0) _exit(127);
    int fo = open(out_path ? out_path : "/dev/null", O_WRONLY | O_CREAT | O_TRUNC, 0666);
    int fe = open(err_path ? err_path : "/dev/null", O_WRONLY | O_CREAT | O_TRUNC, 0666);
    int fi = open("/dev/null", O_RDONLY);
    if (fo < 0 || fe < 0 || fi < 0) _exit(127);
    dup2(fi, 0);
    dup2(fo, 1);
    dup2(fe, 2);
    execvp(argv[0], argv);
    _exit(127);
  }
  setpgid(pid, pid);
  /* A signal ending packmesh ends the helper too. */
  int group = pm_cmp_children_add(pid);
  double t0 = pm_seconds();
  for (;;) {
    pid_t w = waitpid(pid, wstatus, WNOHANG);
    if (w == pid) break;
    if (w < 0 && errno != EINTR) {
      pm_cmp_children_forget(group);
      return -1;
    }
    if (!*timed_out && pm_seconds() - t0 > timeout_s) {
      kill(-pid, SIGKILL);
      kill(pid, SIGKILL);
      *timed_out = 1;
    }
    struct timespec ts = {0, 10 * 1000 * 1000};
    nanosleep(&ts, NULL);
  }
  pm_cmp_children_forget(group);
  /* exec failure is exit code 127 from the child. */
  if (WIFEXITED(*wstatus) && WEXITSTATUS(*wstatus) == 127) return -1;
  return 0;
}

/* Appends what fd has to read to *buf (grown; NUL-terminated); returns 0 at end of file, 1 when
 * more may come, -1 out of memory. */
static int drain(int fd, char **buf, size_t *len, size_t *cap) {
  char chunk[4096];
  ssize_t n = read(fd, chunk, sizeof chunk);
  if (n < 0) return errno == EINTR || errno == EAGAIN ? 1 : 0;
  if (n == 0) return 0;
  if (*len + (size_t)n + 1 > *cap) {
    size_t c = *cap ? *cap : 4096;
    while (c < *len + (size_t)n + 1) c *= 2;
    char *b = realloc(*buf, c);
    if (!b) return -1;
    *buf = b;
    *cap = c;
  }
  memcpy(*buf + *len, chunk, (size_t)n);
  *len += (size_t)n;
  (*buf)[*len] = '\0';
  return 1;
}

int pm_cmp_capture(char *const argv[], char *const env[], double timeout_s, char **out,
                   char **errtext, int *wstatus, int *timed_out) {
  *timed_out = 0;
  *wstatus = 0;
  if (out) *out = NULL;
  if (errtext) *errtext = NULL;
  int po[2], pe[2];
  if (pipe(po) != 0) return -1;
  if (pipe(pe) != 0) {
    close(po[0]);
    close(po[1]);
    return -1;
  }
  fflush(NULL);
  pid_t pid = fork();
  if (pid < 0) {
    close(po[0]);
    close(po[1]);
    close(pe[0]);
    close(pe[1]);
    return -1;
  }
  if (pid == 0) {
    setpgid(0, 0);
    int fi = open("/dev/null", O_RDONLY);
    if (fi < 0) _exit(127);
    dup2(fi, 0);
    dup2(po[1], 1);
    dup2(pe[1], 2);
    close(po[0]);
    close(pe[0]);
    for (int k = 0; env && env[k]; ++k) putenv(env[k]);
    execvp(argv[0], argv);
    _exit(127);
  }
  setpgid(pid, pid);
  int group = pm_cmp_children_add(pid);
  close(po[1]);
  close(pe[1]);
  char *b[2] = {NULL, NULL};
  size_t n[2] = {0, 0}, c[2] = {0, 0};
  int open_fd[2] = {po[0], pe[0]}, bad = 0;
  double t0 = pm_seconds();
  while (open_fd[0] >= 0 || open_fd[1] >= 0) {
    struct pollfd p[2];
    int np = 0, which[2];
    for (int k = 0; k < 2; ++k)
      if (open_fd[k] >= 0) {
        p[np].fd = open_fd[k];
        p[np].events = POLLIN;
        p[np].revents = 0;
        which[np++] = k;
      }
    int r = poll(p, (nfds_t)np, 100);
    if (r < 0 && errno != EINTR) break;
    for (int i = 0; i < np && r > 0; ++i) {
      if (!p[i].revents) continue;
      int k = which[i];
      int d = drain(open_fd[k], &b[k], &n[k], &c[k]);
      if (d < 0) bad = 1;
      if (d <= 0) {
        close(open_fd[k]);
        open_fd[k] = -1;
      }
    }
    if (!*timed_out && pm_seconds() - t0 > timeout_s) {
      kill(-pid, SIGKILL);
      kill(pid, SIGKILL);
      *timed_out = 1;
    }
  }
  for (int k = 0; k < 2; ++k)
    if (open_fd[k] >= 0) close(open_fd[k]);
  while (waitpid(pid, wstatus, 0) < 0 && errno == EINTR) {
  }
  pm_cmp_children_forget(group);
  for (int k = 0; k < 2; ++k)
    if (!b[k] && !bad) {
      b[k] = calloc(1, 1);
      if (!b[k]) bad = 1;
    }
  /* exec failure is exit code 127 from the child. */
  if (bad || (WIFEXITED(*wstatus) && WEXITSTATUS(*wstatus) == 127)) {
    free(b[0]);
    free(b[1]);
    return -1;
  }
  if (out)
    *out = b[0];
  else
    free(b[0]);
  if (errtext)
    *errtext = b[1];
  else
    free(b[1]);
  return 0;
}
