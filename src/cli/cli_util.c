/* Helpers shared by the subcommands (see cli_util.h). */
#include "cli/cli_util.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* One line: whatever a message holds, line breaks become spaces. */
static void put_line(const char *head, const char *msg, const char *tail) {
  fputs("packmesh: ", stderr);
  if (head) fputs(head, stderr);
  for (const char *c = msg; *c; ++c) fputc((*c == '\n' || *c == '\r') ? ' ' : *c, stderr);
  if (tail) fputs(tail, stderr);
  fputc('\n', stderr);
  fflush(stderr);
}

int pm_cli_fail(const char *fmt, ...) {
  char msg[1024];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(msg, sizeof msg, fmt, ap);
  va_end(ap);
  put_line(NULL, msg, NULL);
  return PM_EXIT_FAIL;
}

int pm_cli_usage(const char *cmd, const char *fmt, ...) {
  char msg[1024], tail[128];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(msg, sizeof msg, fmt, ap);
  va_end(ap);
  if (cmd)
    snprintf(tail, sizeof tail, " (see 'packmesh %s --help')", cmd);
  else
    snprintf(tail, sizeof tail, " (see 'packmesh --help')");
  put_line(NULL, msg, tail);
  return PM_EXIT_USAGE;
}

int pm_cli_usage_see(const char *see, const char *fmt, ...) {
  char msg[1024], tail[256];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(msg, sizeof msg, fmt, ap);
  va_end(ap);
  snprintf(tail, sizeof tail, " (%s)", see);
  put_line(NULL, msg, tail);
  return PM_EXIT_USAGE;
}

int pm_cli_error(const pm_error *e) {
  put_line(NULL, e->msg[0] ? e->msg : pm_status_name(e->code), NULL);
  return PM_EXIT_FAIL;
}

int pm_cli_flag(const char *arg, const char *name) {
  return arg[0] == '-' && arg[1] == '-' && strcmp(arg + 2, name) == 0;
}

int pm_cli_option(int argc, char **argv, int *i, const char *name, const char **value) {
  const char *a = argv[*i];
  size_t n = strlen(name);
  if (a[0] != '-' || a[1] != '-' || strncmp(a + 2, name, n) != 0) return 0;
  if (a[2 + n] == '=') {
    *value = a + 3 + n;
    *i += 1;
    return 1;
  }
  if (a[2 + n] != '\0') return 0;
  if (*i + 1 >= argc) return -1;
  *value = argv[*i + 1];
  *i += 2;
  return 1;
}

int pm_cli_parse_double(const char *text, double *out) {
  if (!text || !*text) return 0;
  char *end;
  errno = 0;
  double v = strtod(text, &end);
  if (*end != '\0' || errno == ERANGE || !isfinite(v)) return 0;
  *out = v;
  return 1;
}

int pm_cli_parse_long(const char *text, long lo, long hi, long *out) {
  if (!text || !*text) return 0;
  char *end;
  errno = 0;
  long v = strtol(text, &end, 10);
  if (*end != '\0' || errno == ERANGE || v < lo || v > hi) return 0;
  *out = v;
  return 1;
}

int pm_cli_emit(const char *text, size_t len) {
  if (len && fwrite(text, 1, len, stdout) != len)
    return pm_cli_fail("cannot write to standard output: %s", strerror(errno));
  if (fflush(stdout) != 0)
    return pm_cli_fail("cannot write to standard output: %s", strerror(errno));
  return PM_EXIT_OK;
}

double pm_cli_now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int pm_cli_listing_args(int argc, char **argv, const char *cmd, void (*usage)(FILE *f), int *json) {
  *json = 0;
  for (int i = 1; i < argc; ++i) {
    if (pm_cli_flag(argv[i], "help") || strcmp(argv[i], "-h") == 0) {
      usage(stdout);
      return PM_EXIT_OK;
    }
    if (pm_cli_flag(argv[i], "json")) {
      *json = 1;
      continue;
    }
    return pm_cli_usage(cmd, "unknown option '%s'", argv[i]);
  }
  return -1;
}
