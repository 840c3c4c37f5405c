/* Output files that appear whole or not at all (see atomic_file.h). */
#include "common/atomic_file.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* The extension of the last path component, with its dot, or "" . */
static const char *ext_of(const char *path) {
  const char *slash = strrchr(path, '/');
  const char *base = slash ? slash + 1 : path;
  const char *dot = strrchr(base, '.');
  return (dot && dot != base) ? dot : path + strlen(path);
}

pm_status pm_atomic_begin(pm_atomic_file *a, const char *path, int stream, pm_error *err) {
  memset(a, 0, sizeof *a);
  if (!path || !path[0]) return pm_error_setf(err, PM_ERR_ARG, "no output file name given");
  const char *ext = ext_of(path);
  size_t n = strlen(path), stem = (size_t)(ext - path), suffix = n - stem;
  a->path = strdup(path);
  a->tmp = malloc(n + 16);
  if (!a->path || !a->tmp) {
    pm_atomic_abort(a);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  }
  memcpy(a->tmp, path, stem);
  memcpy(a->tmp + stem, ".pmtmp-XXXXXX", 13);
  memcpy(a->tmp + stem + 13, ext, suffix + 1);
  int fd = mkstemps(a->tmp, (int)suffix);
  if (fd < 0) {
    pm_status s = pm_error_setf(err, PM_ERR_IO, "cannot write %s: %s", path, strerror(errno));
    free(a->tmp);
    a->tmp = NULL; /* nothing was created */
    pm_atomic_abort(a);
    return s;
  }
  if (stream) {
    a->f = fdopen(fd, "w");
    if (!a->f) {
      pm_status s = pm_error_setf(err, PM_ERR_IO, "cannot write %s: %s", path, strerror(errno));
      close(fd);
      pm_atomic_abort(a);
      return s;
    }
  } else {
    close(fd);
  }
  return PM_OK;
}

pm_status pm_atomic_commit(pm_atomic_file *a, pm_error *err) {
  pm_status s = PM_OK;
  if (a->f) {
    int bad = ferror(a->f);
    int e = errno;
    if (fclose(a->f) != 0) {
      bad = 1;
      e = errno;
    }
    a->f = NULL;
    if (bad) s = pm_error_setf(err, PM_ERR_IO, "cannot write %s: %s", a->path, strerror(e));
  }
  if (!s && rename(a->tmp, a->path) != 0)
    s = pm_error_setf(err, PM_ERR_IO, "cannot write %s: %s", a->path, strerror(errno));
  if (s) {
    pm_atomic_abort(a);
    return s;
  }
  free(a->tmp);
  free(a->path);
  memset(a, 0, sizeof *a);
  return PM_OK;
}

void pm_atomic_abort(pm_atomic_file *a) {
  if (!a) return;
  if (a->f) fclose(a->f);
  if (a->tmp) unlink(a->tmp);
  free(a->tmp);
  free(a->path);
  memset(a, 0, sizeof *a);
}

pm_status pm_atomic_write(const char *path, const void *data, size_t len, pm_error *err) {
  pm_atomic_file a;
  pm_status s = pm_atomic_begin(&a, path, 1, err);
  if (s) return s;
  if (len && fwrite(data, 1, len, a.f) != len) {
    s = pm_error_setf(err, PM_ERR_IO, "cannot write %s: %s", path, strerror(errno));
    pm_atomic_abort(&a);
    return s;
  }
  return pm_atomic_commit(&a, err);
}
