/* The progress line of packmesh mesh: under a pseudo-terminal (script(1)) one line rewritten in
 * place with the method, its phase, iteration and particle count; nothing on stderr into a file;
 * --progress shows lines there too; --quiet silences everything but errors. */
#include "test_support.h"

#include "cli/cli_run.h"

static char dir[256];

/* Runs `packmesh ARGS` under a pseudo-terminal; returns what the terminal showed (malloc'ed). */
static char *run_on_tty(const char *args) {
  char cmd[4096], path[400];
  snprintf(path, sizeof path, "%s/tty.out", dir);
  snprintf(cmd, sizeof cmd, "script -qec \"'%s' %s\" /dev/null > '%s' 2>&1 < /dev/null",
           pm_test_cli_path(), args, path);
  int st = system(cmd);
  if (!WIFEXITED(st) || WEXITSTATUS(st) != 0) fail_msg("script -qec 'packmesh %s': status %d", args, st);
  char *out = pm_test_slurp(path);
  assert_non_null(out);
  return out;
}

static void progress_on_a_terminal_only(void **state) {
  (void)state;
  if (system("command -v script > /dev/null 2>&1") != 0) {
    print_message("script(1) is missing (util-linux): the terminal half is not checked\n");
    skip();
  }
  char args[1024];
  /* A run of a second or more: bubble on qi3 at a fine size. */
  snprintf(args, sizeof args, "mesh case:qi3 --method bubble --size 0.05 -o '%s/p.msh'", dir);
  char *tty = run_on_tty(args);
  /* The line is rewritten in place (carriage return, erase line) and names the method, the
   * iteration and the bubbles; it is erased before the summary line. */
  const char *line = strstr(tty, "\r\033[Kbubble: placing nodes, phase ");
  if (!line) fail_msg("no progress line on the terminal: '%s'", tty);
  assert_non_null(strstr(line, ", iteration "));
  assert_non_null(strstr(line, " bubbles, 0:"));
  const char *summary = strstr(tty, "bubble case:qi3: ");
  assert_non_null(summary);
  assert_true(summary > line);
  assert_non_null(strstr(tty, "\r\033[Kbubble case:qi3: "));
  free(tty);
  char path[400];
  snprintf(path, sizeof path, "%s/p.msh", dir);
  char *on_tty = pm_test_slurp(path);
  assert_non_null(on_tty);

  /* Into files: nothing on stderr, the summary on stdout, and the same mesh to the byte (the
   * progress line only reads what the method records). */
  char *out = NULL, *err = NULL;
  assert_int_equal(pm_test_cli(dir, args, &out, &err), 0);
  assert_string_equal(err, "");
  assert_non_null(strstr(out, "bubble case:qi3: "));
  free(out), free(err);
  char *in_file = pm_test_slurp(path);
  assert_non_null(in_file);
  assert_string_equal(on_tty, in_file);
  free(on_tty), free(in_file);

  /* --progress: lines into the file too, each a whole line. */
  snprintf(args, sizeof args, "mesh case:qi3 --method bubble --size 0.05 --progress -o '%s/p.msh'", dir);
  assert_int_equal(pm_test_cli(dir, args, &out, &err), 0);
  assert_non_null(strstr(err, "packmesh: bubble: loading the input, 0:"));
  assert_non_null(strstr(err, "packmesh: bubble: meshing, 0:"));
  assert_null(strchr(err, '\r'));
  free(out), free(err);

  /* A node-target search: each line says which run it is of the most it may take. */
  snprintf(args, sizeof args,
           "mesh case:qi3 --method gmsh-frontal --target-nodes 300 --progress -o '%s/t.msh'", dir);
  assert_int_equal(pm_test_cli(dir, args, &out, &err), 0);
  assert_non_null(strstr(err, "packmesh: gmsh-frontal: meshing (run 1 of at most 8), 0:"));
  assert_non_null(strstr(err, "packmesh: gmsh-frontal: meshing (run 2 of at most 8), 0:"));
  free(out), free(err);

  /* --quiet: nothing at all on success, even on a terminal and with a warning to give. */
  snprintf(args, sizeof args, "mesh case:qi3 --method bubble --target-nodes 5 --quiet -o '%s/q.stl'", dir);
  tty = run_on_tty(args);
  assert_string_equal(tty, "");
  free(tty);
  assert_int_equal(pm_test_cli(dir, args, &out, &err), 0);
  assert_string_equal(out, "");
  assert_string_equal(err, "");
  free(out), free(err);
  /* ... and errors still one line. */
  snprintf(args, sizeof args, "mesh case:nosuch --quiet -o '%s/q.msh'", dir);
  pm_test_cli_error(dir, args, 1, "nosuch");
  pm_test_cli_error(dir, "mesh case:qi3 --quiet --progress -o x.msh", 2, "exclude each other");
}

int main(void) {
  snprintf(dir, sizeof dir, "/tmp/pm_test_cli_progress_%d", (int)getpid());
  char cmd[300];
  snprintf(cmd, sizeof cmd, "mkdir -p %s", dir);
  if (system(cmd) != 0) return 1;
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(progress_on_a_terminal_only),
  };
  int rc = cmocka_run_group_tests(tests, NULL, NULL);
  snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
  if (system(cmd) != 0) rc = 1;
  return rc;
}
