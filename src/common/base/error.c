/* The error record of include/packmesh/packmesh.h. */
#include <packmesh/packmesh.h>

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

pm_status pm_error_setf(pm_error *err, pm_status code, const char *fmt, ...) {
  if (!err) return code;
  err->code = code;
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(err->msg, sizeof err->msg, fmt, ap);
  va_end(ap);
  /* One line: a message from a library (gmsh, TetGen) may carry newlines. */
  for (char *c = err->msg; *c; ++c)
    if (*c == '\n' || *c == '\r') *c = ' ';
  return code;
}

pm_status pm_error_prefix(pm_error *err, const char *fmt, ...) {
  if (!err) return PM_OK;
  char head[256];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(head, sizeof head, fmt, ap);
  va_end(ap);
  char old[sizeof err->msg];
  memcpy(old, err->msg, sizeof old);
  /* Truncation is acceptable: the message stays one line, cut at the record's size. */
  size_t h = strlen(head);
  if (h > sizeof err->msg - 3) h = sizeof err->msg - 3;
  memcpy(err->msg, head, h);
  err->msg[h] = ':';
  err->msg[h + 1] = ' ';
  size_t room = sizeof err->msg - h - 3;
  size_t o = strlen(old);
  if (o > room) o = room;
  memcpy(err->msg + h + 2, old, o);
  err->msg[h + 2 + o] = '\0';
  return err->code;
}

void pm_error_clear(pm_error *err) {
  if (!err) return;
  err->code = PM_OK;
  err->msg[0] = '\0';
}

const char *pm_status_name(pm_status s) {
  switch (s) {
    case PM_OK: return "ok";
    case PM_ERR_ARG: return "bad argument";
    case PM_ERR_IO: return "i/o error";
    case PM_ERR_PARSE: return "parse error";
    case PM_ERR_GEOM: return "geometry error";
    case PM_ERR_BACKEND: return "backend error";
    case PM_ERR_LIMIT: return "limit exceeded";
    case PM_ERR_NOMEM: return "out of memory";
    case PM_ERR_INTERNAL: return "internal error";
    case PM_ERR_CANCELLED: return "cancelled";
  }
  return "unknown error";
}

const char *pm_version(void) { return PM_VERSION_STRING; }
