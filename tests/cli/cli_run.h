/* Running the packmesh binary from a test: exit code, stdout and stderr. */
#ifndef PM_TEST_CLI_RUN_H
#define PM_TEST_CLI_RUN_H

#include "test_support.h"

#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

/* The packmesh binary under test: PM_CLI, or the environment's PM_TEST_CLI (to run these tests
 * against another build of the command, an earlier commit's for instance). */
static inline const char *pm_test_cli_path(void) {
  const char *p = getenv("PM_TEST_CLI");
  return p && p[0] ? p : PM_CLI;
}

/* Run `packmesh ARGS` (ARGS is shell text), with stdout and stderr captured through files in
 * `dir`; *out and *err receive malloc'ed copies (may be NULL when not wanted). Returns the exit
 * code; a crash fails the test. */
static inline int pm_test_cli(const char *dir, const char *args, char **out, char **err) {
  char cmd[8192], po[600], pe[600];
  snprintf(po, sizeof po, "%s/cli.stdout", dir);
  snprintf(pe, sizeof pe, "%s/cli.stderr", dir);
  snprintf(cmd, sizeof cmd, "'%s' %s > '%s' 2> '%s'", pm_test_cli_path(), args, po, pe);
  int st = system(cmd);
  if (!WIFEXITED(st)) fail_msg("packmesh %s: did not exit normally", args);
  const char *paths[2] = {po, pe};
  char **bufs[2] = {out, err};
  for (int k = 0; k < 2; ++k) {
    if (!bufs[k]) continue;
    FILE *f = fopen(paths[k], "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    *bufs[k] = malloc((size_t)n + 1);
    assert_int_equal(fread(*bufs[k], 1, (size_t)n, f), (size_t)n);
    (*bufs[k])[n] = '\0';
    fclose(f);
  }
  return WEXITSTATUS(st);
}

/* Expect exit code `code` and exactly one line on stderr containing `needle`, nothing on
 * stdout. */
static inline void pm_test_cli_error(const char *dir, const char *args, int code,
                                     const char *needle) {
  char *out = NULL, *err = NULL;
  int rc = pm_test_cli(dir, args, &out, &err);
  int lines = 0;
  for (const char *c = err; *c; ++c) lines += *c == '\n';
  if (rc != code || lines != 1 || !strstr(err, needle) || out[0])
    fail_msg("packmesh %s: exit %d (want %d), stderr '%s' (want one line with '%s'), stdout '%s'",
             args, rc, code, err, needle, out);
  free(out);
  free(err);
}

/* The whole content of a file (malloc'ed), or NULL. */
static inline char *pm_test_slurp(const char *path) {
  FILE *f = fopen(path, "rb");
  if (!f) return NULL;
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fseek(f, 0, SEEK_SET);
  char *s = malloc((size_t)n + 1);
  size_t got = fread(s, 1, (size_t)n, f);
  s[got] = '\0';
  fclose(f);
  return s;
}

#endif /* PM_TEST_CLI_RUN_H */
