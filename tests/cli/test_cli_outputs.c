/* The command's outputs as one set, and interruptions: a later output that cannot be written
 * leaves no earlier one behind; two options naming one file (or an output naming the input) are
 * usage errors; files respect the umask; SIGINT and SIGTERM during `mesh` (running or putting
 * its outputs in place), `quality` and `compare` (running or drawing) end with one line, exit
 * 130 / 143, and no file left behind. Set PM_TEST_CLI to run this against another build. */
#include "test_support.h"
#include "test_dirs.h"

#include <dirent.h>
#include <errno.h>
#include <signal.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "cli_run.h"
#include "common/mesh/mesh.h"
#include "common/mesh/mesh_io.h"

/* Names under folder d (recursively), except the captured stdout / stderr; how many. When
 * `part` is given, only names containing it are counted. */
static int count_names(const char *d, const char *part) {
  DIR *h = opendir(d);
  if (!h) return 0;
  int n = 0;
  struct dirent *de;
  while ((de = readdir(h))) {
    if (!strcmp(de->d_name, ".") || !strcmp(de->d_name, "..") || !strncmp(de->d_name, "cli.", 4))
      continue;
    char p[1200];
    snprintf(p, sizeof p, "%s/%s", d, de->d_name);
    struct stat st;
    if (stat(p, &st) == 0 && S_ISDIR(st.st_mode)) n += count_names(p, part);
    if (!part || strstr(de->d_name, part)) ++n;
  }
  closedir(h);
  return n;
}

/* ---- a later output fails: nothing is left ------------------------------------------------ */

static void failed_outputs_leave_nothing(void **state) {
  (void)state;
  mkdir(pm_test_in_dir("adir"), 0777);
  FILE *f = fopen(pm_test_in_dir("afile"), "w");
  fclose(f);
  struct {
    const char *opts, *names;
  } cases[] = {
      {"--stats '%s/nodir/s.json'", "nodir/s.json"},
      {"--stats '%s/adir'", "adir"},
      {"--trace '%s/nodir/t.csv'", "nodir/t.csv"},
      {"--stats '%s/afile/s.json'", "afile/s.json"},
      {"--stats '%s/s.json' --frames '%s/afile'", "afile"},
  };
  for (size_t k = 0; k < sizeof cases / sizeof cases[0]; ++k) {
    char opts[1400], args[2000];
    snprintf(opts, sizeof opts, cases[k].opts, pm_test_dir, pm_test_dir);
    snprintf(args, sizeof args, "mesh case:qi3 --method bubble -o '%s/out.msh' %s", pm_test_dir, opts);
    pm_test_cli_error(pm_test_dir, args, 1, cases[k].names);
    if (count_names(pm_test_dir, NULL) != 2) /* adir and afile only */
      fail_msg("%s: %d files left in the folder", opts, count_names(pm_test_dir, NULL));
  }
  /* --stats in a folder where no file can be made: a read-only folder (which root may write
   * anyway: then /proc, where nobody can create a file). */
  char ro[700], args[2000];
  snprintf(ro, sizeof ro, "%s", pm_test_in_dir("ro"));
  mkdir(ro, 0777);
  chmod(ro, 0555);
  if (geteuid() == 0) snprintf(ro, sizeof ro, "/proc");
  snprintf(args, sizeof args, "mesh case:qi3 --method bubble -o '%s/out.msh' --stats '%s/s.json'",
           pm_test_dir, ro);
  pm_test_cli_error(pm_test_dir, args, 1, "s.json");
  if (count_names(pm_test_dir, NULL) != 3) /* adir, afile and ro only */
    fail_msg("--stats in a read-only folder: %d files left in the folder", count_names(pm_test_dir, NULL));
  chmod(pm_test_in_dir("ro"), 0755);
}

static void one_file_twice_is_a_usage_error(void **state) {
  (void)state;
  char args[2000];
  snprintf(args, sizeof args, "mesh case:qi3 --method bubble -o '%s/same.msh' --stats '%s/same.msh'", pm_test_dir, pm_test_dir);
  pm_test_cli_error(pm_test_dir, args, 2, "-o and --stats name the same file");
  snprintf(args, sizeof args, "mesh case:qi3 --method bubble -o '%s/x.msh' --trace '%s/./x.msh'", pm_test_dir, pm_test_dir);
  pm_test_cli_error(pm_test_dir, args, 2, "-o and --trace name the same file");
  FILE *f = fopen(pm_test_in_dir("plate.json"), "w");
  fputs("{\"domain\": {\"case\": \"qi1\"}, \"size\": 0.5}", f);
  fclose(f);
  snprintf(args, sizeof args, "mesh '%s/plate.json' -o '%s/p.msh' --stats '%s/plate.json'", pm_test_dir, pm_test_dir, pm_test_dir);
  pm_test_cli_error(pm_test_dir, args, 2, "--stats");
  assert_int_equal(count_names(pm_test_dir, NULL), 1); /* plate.json, untouched */
  char *text = pm_test_slurp(pm_test_in_dir("plate.json"));
  assert_non_null(strstr(text, "qi1"));
  free(text);
}

static void outputs_respect_the_umask(void **state) {
  (void)state;
  mode_t old = umask(022);
  char args[2000];
  snprintf(args, sizeof args, "mesh case:qi3 --method bubble -o '%s/m.vtu' --stats '%s/s.json' --frames '%s/fr'",
           pm_test_dir, pm_test_dir, pm_test_dir);
  assert_int_equal(pm_test_cli(pm_test_dir, args, NULL, NULL), 0);
  umask(old);
  const char *files[] = {"m.vtu", "s.json", "fr/frames.pvd", "fr/frame_000000.vtu"};
  for (int k = 0; k < 4; ++k) {
    struct stat st;
    assert_int_equal(stat(pm_test_in_dir(files[k]), &st), 0);
    if ((st.st_mode & 0777) != 0644) fail_msg("%s: mode %03o, want 644", files[k], (unsigned)(st.st_mode & 0777));
  }
  struct stat st;
  assert_int_equal(stat(pm_test_in_dir("fr"), &st), 0);
  assert_int_equal(st.st_mode & 0777, 0755);
  assert_int_equal(count_names(pm_test_dir, ".pmtmp-"), 0);
}

/* ---- interruptions -------------------------------------------------------------------------- */

/* Start packmesh with argv (NULL-terminated, without the program), stdout and stderr to files
 * in pm_test_dir. */
static pid_t start(char **argv) {
  char po[700], pe[700];
  snprintf(po, sizeof po, "%s/cli.stdout", pm_test_dir);
  snprintf(pe, sizeof pe, "%s/cli.stderr", pm_test_dir);
  pid_t pid = fork();
  if (pid == 0) {
    FILE *o = freopen(po, "w", stdout), *e = freopen(pe, "w", stderr);
    if (!o || !e) _exit(126);
    char *full[64];
    full[0] = (char *)pm_test_cli_path();
    int n = 0;
    while (argv[n] && n < 62) full[n + 1] = argv[n], ++n;
    full[n + 1] = NULL;
    execv(full[0], full);
    _exit(127);
  }
  return pid;
}

static void pause_ms(int ms) {
  struct timespec ts = {ms / 1000, (long)(ms % 1000) * 1000000L};
  nanosleep(&ts, NULL);
}

/* 1 once process pid catches sig (its handler is installed: /proc/PID/status, SigCgt). */
static int catches(pid_t pid, int sig) {
  char path[64], line[256];
  snprintf(path, sizeof path, "/proc/%d/status", (int)pid);
  FILE *f = fopen(path, "r");
  if (!f) return 0;
  int yes = 0;
  while (fgets(line, sizeof line, f))
    if (!strncmp(line, "SigCgt:", 7)) yes = (strtoull(line + 7, NULL, 16) >> (sig - 1)) & 1;
  fclose(f);
  return yes;
}

/* Wait (up to `limit_s`) for a name containing `part` under pm_test_dir, then send sig; return the
 * wait status. */
static int signal_when(pid_t pid, const char *part, int sig, double limit_s) {
  int ws = 0;
  for (int t = 0; t < limit_s * 500; ++t) {
    if (waitpid(pid, &ws, WNOHANG) == pid) return ws;
    if (count_names(pm_test_dir, part) > 0) break;
    pause_ms(2);
  }
  kill(pid, sig);
  while (waitpid(pid, &ws, 0) < 0 && errno == EINTR) {
  }
  return ws;
}

/* Exit 128 + sig, one line naming the signal, and `left` names in the folder afterwards (-1: any
 * number). */
static void interrupted_cleanly(int ws, int sig, int left, const char *what) {
  char pe[700];
  snprintf(pe, sizeof pe, "%s/cli.stderr", pm_test_dir);
  char *err = pm_test_slurp(pe);
  if (!WIFEXITED(ws) || WEXITSTATUS(ws) != 128 + sig || pm_test_count_lines(err) != 1 ||
      !strstr(err, sig == SIGINT ? "interrupted by SIGINT" : "interrupted by SIGTERM")) {
    char copy[600];
    snprintf(copy, sizeof copy, "%s", err);
    free(err);
    fail_msg("%s: %s %d, stderr '%s' (want exit %d and one line)", what,
             WIFEXITED(ws) ? "exit" : "killed by signal", WIFEXITED(ws) ? WEXITSTATUS(ws) : WTERMSIG(ws),
             copy, 128 + sig);
  }
  free(err);
  int n = count_names(pm_test_dir, NULL);
  if (left >= 0 && n != left) fail_msg("%s: %d names left in the folder, want %d", what, n, left);
}

static void mesh_interrupted(void **state) {
  (void)state;
  const int sigs[2] = {SIGINT, SIGTERM};
  for (int k = 0; k < 2; ++k) {
    char out[700], st[700], tr[700], fr[700];
    snprintf(out, sizeof out, "%s/x.msh", pm_test_dir);
    snprintf(st, sizeof st, "%s/x.json", pm_test_dir);
    snprintf(tr, sizeof tr, "%s/x.csv", pm_test_dir);
    snprintf(fr, sizeof fr, "%s/new/frames", pm_test_dir);
    /* A run of several seconds (bubble on qi1 at d = 0.03): its temporaries exist from the
     * start. */
    char *argv[] = {"mesh", "case:qi1", "--method", "bubble", "--size", "0.03", "-o", out,
                    "--stats", st, "--trace", tr, "--frames", fr, NULL};
    int ws = signal_when(start(argv), "frame_", sigs[k], 60);
    interrupted_cleanly(ws, sigs[k], 0, "mesh");
  }
}

/* The reproduction of a hostile test of 82556e3: a signal delivered as a rename returns, at
 * every rename of the run (the frames' files, then the outputs put in place), through strace's
 * fault injection. (Under
 * ASan, LeakSanitizer cannot work in a traced process: it is turned off there.) */
static void mesh_interrupted_at_each_rename(void **state) {
  (void)state;
  if (system("strace -o /dev/null true > /dev/null 2>&1") != 0) skip();
  char cmd[3000], out[700];
  snprintf(out, sizeof out, "%s/renames", pm_test_dir);
  snprintf(cmd, sizeof cmd,
           "cd '%s' && ASAN_OPTIONS=detect_leaks=0 strace -f -o '%s' -e trace=rename '%s' mesh case:qi3 --method bubble -o x.msh "
           "--stats x.json --frames fr > /dev/null 2>&1",
           pm_test_dir, out, pm_test_cli_path());
  assert_int_equal(system(cmd), 0);
  char *log = pm_test_slurp(out);
  int renames = 0;
  for (const char *c = log; (c = strstr(c, "rename(")); ++c) ++renames;
  free(log);
  unlink(out);
  snprintf(cmd, sizeof cmd, "rm -rf '%s/x.msh' '%s/x.json' '%s/fr'", pm_test_dir, pm_test_dir, pm_test_dir);
  assert_int_equal(system(cmd), 0);
  assert_true(renames >= 4);
  int whens[6] = {1, 2, renames / 2, renames - 2, renames - 1, renames};
  for (int k = 0; k < 6; ++k)
    for (int fail = 0; fail < 2; ++fail) {
      snprintf(cmd, sizeof cmd,
               "cd '%s' && ASAN_OPTIONS=detect_leaks=0 strace -f -o /dev/null -e inject=rename:%ssignal=SIGINT:when=%d '%s' "
               "mesh case:qi3 --method bubble -o x.msh --stats x.json --frames fr > cli.stdout 2> cli.stderr",
               pm_test_dir, fail ? "error=EINTR:" : "", whens[k], pm_test_cli_path());
      int ws = system(cmd);
      char what[64];
      snprintf(what, sizeof what, "rename %d of %d%s", whens[k], renames, fail ? " failing" : "");
      interrupted_cleanly(ws, SIGINT, 0, what);
    }
}

static void quality_interrupted(void **state) {
  (void)state;
  /* A mesh large enough to take a while to read and measure (about a second): 2 x 700^2
   * triangles. The signal comes once the command's handler is installed. */
  pm_mesh *m = pm_mesh_create();
  pm_error e = {0};
  const int n = 700;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      double x[3] = {(double)i / n, (double)j / n, 0};
      pm_mesh_add_node(m, x, -1, -1, NULL, NULL, &e);
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      int32_t a = j * (n + 1) + i;
      pm_mesh_add_tri(m, a, a + 1, a + n + 2, -1, &e);
      pm_mesh_add_tri(m, a, a + n + 2, a + n + 1, -1, &e);
    }
  char path[700];
  snprintf(path, sizeof path, "%s/grid.msh", pm_test_dir);
  PM_ASSERT_OK(pm_mesh_write(m, path, &e), e);
  pm_mesh_destroy(m);
  const int sigs[2] = {SIGINT, SIGTERM};
  for (int k = 0; k < 2; ++k) {
    char *argv[] = {"quality", path, "--json", NULL};
    pid_t pid = start(argv);
    /* Once its handler is installed (the libraries take a while to load, longer under ASan). */
    for (int t = 0; t < 30000 && !catches(pid, sigs[k]); ++t) pause_ms(1);
    pause_ms(50);
    int ws = signal_when(pid, "no such name", sigs[k], 0);
    interrupted_cleanly(ws, sigs[k], 1, "quality");
  }
}

/* A study of one case and two methods, in the test's folder: argv for `compare`. */
static char **tiny_study(void) {
  static char out[700], suite[700];
  static char *argv[] = {"compare", suite, "-o", out, "--quiet", NULL};
  FILE *f = fopen(pm_test_in_dir("s.json"), "w");
  fputs("{\"name\": \"tiny\", \"cases\": [{\"input\": \"case:qi3\"}], \"methods\": [\"bubble\", "
        "\"gmsh-frontal\"], \"seeds\": [1]}",
        f);
  fclose(f);
  snprintf(out, sizeof out, "%s/study", pm_test_dir);
  snprintf(suite, sizeof suite, "%s/s.json", pm_test_dir);
  return argv;
}

static void compare_interrupted_running(void **state) {
  (void)state;
  char **argv = tiny_study();
  /* While the runs go: a run's temporaries appear first. */
  int ws = signal_when(start(argv), ".pmtmp-", SIGTERM, 60);
  char pe[700];
  snprintf(pe, sizeof pe, "%s/cli.stderr", pm_test_dir);
  char *err = pm_test_slurp(pe);
  if (!WIFEXITED(ws) || WEXITSTATUS(ws) != 143 || pm_test_count_lines(err) != 1 ||
      !strstr(err, "SIGTERM"))
    fail_msg("compare during the runs: status %d, stderr '%s'", ws, err);
  free(err);
  assert_int_equal(count_names(pm_test_dir, ".pmtmp-"), 0);
  assert_int_equal(count_names(pm_test_dir, ".part"), 0);
}

static void compare_interrupted_drawing(void **state) {
  (void)state;
  if (system("gnuplot --version > /dev/null 2>&1") != 0) skip();
  char **argv = tiny_study();
  /* While drawing: gnuplot's drawings are temporaries ".tmp-NAME.svg" until renamed. */
  int ws = signal_when(start(argv), ".tmp-", SIGINT, 120);
  interrupted_cleanly(ws, SIGINT, -1, "compare while drawing");
  assert_int_equal(count_names(pm_test_dir, ".tmp-"), 0);
  assert_int_equal(count_names(pm_test_dir, ".pmtmp-"), 0);
  assert_int_equal(count_names(pm_test_dir, ".gnuplot-version"), 0);
}

int main(void) {
  if (pm_test_dirs_init("pm_test_cli_outputs")) return 1;
  const struct CMUnitTest tests[] = {
      cmocka_unit_test_setup(failed_outputs_leave_nothing, pm_test_fresh_dir),
      cmocka_unit_test_setup(one_file_twice_is_a_usage_error, pm_test_fresh_dir),
      cmocka_unit_test_setup(outputs_respect_the_umask, pm_test_fresh_dir),
      cmocka_unit_test_setup(mesh_interrupted, pm_test_fresh_dir),
      cmocka_unit_test_setup(mesh_interrupted_at_each_rename, pm_test_fresh_dir),
      cmocka_unit_test_setup(quality_interrupted, pm_test_fresh_dir),
      cmocka_unit_test_setup(compare_interrupted_running, pm_test_fresh_dir),
      cmocka_unit_test_setup(compare_interrupted_drawing, pm_test_fresh_dir),
  };
  int rc = cmocka_run_group_tests(tests, NULL, NULL);
  char cmd[300];
  snprintf(cmd, sizeof cmd, "rm -rf %s", pm_test_base);
  if (system(cmd) != 0) rc = 1;
  return rc;
}
