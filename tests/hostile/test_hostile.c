/* Every file of the hostile-input corpus (tests/data/hostile: the seeds, the cases found by hand
 * and the generated damages) through `packmesh quality` and, when `mesh` takes it as an input,
 * `packmesh mesh`, and the hostile invocations of invocations.txt. For every run:
 *   - it ends by itself within the time limit (PM_HOSTILE_TIMEOUT seconds, default 60), with an
 *     exit code below 128 (no crash, no abort, no sanitizer report: sanitizers exit non-zero
 *     with many lines);
 *   - stderr is empty on success and exactly one line "packmesh: ..." otherwise;
 *   - nothing is left in its output folder but the outputs of a success;
 *   - where expect.tsv names the run, its exit code and a piece of its message are those given.
 * A mesh file goes through `quality FILE` (`mesh` refuses it by its extension before reading a
 * byte: invocations.txt runs that once); a case or CAD file, or one of another extension, through
 * `mesh FILE -o ... --stats ...` and `quality seeds/square.msh --geometry FILE`. Case files are
 * meshed with bubble (--max-nodes 20000), CAD files with gmsh-frontal (the CAD geometry itself is
 * OpenCASCADE's business; what is tested is packmesh's handling).
 * Inputs made at run time: a case file of 20001 pieces (one more than a case file may hold), two
 * meshes of 400000 elements all on one face or one edge, and, when the shared CAD models are
 * there, bearing.iges cut in half.
 * Runs go two at a time (PM_HOSTILE_JOBS). Set PM_TEST_CLI to run another build of packmesh. */
#include "test_support.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>

#include "../cli/cli_run.h"

#define CORPUS PM_SOURCE_DIR "/tests/data/hostile"
#define MAX_RUNS 4096

typedef struct run {
  char label[700];     /* corpus path and command, for messages */
  char *argv[40];
  int argc;
  char outdir[600];
  char errpath[600];
  const char *outputs[3]; /* names a success leaves in outdir */
  /* expectation (expect.tsv / invocations.txt), exit -1 when none */
  int want_exit;
  char want_text[300];
  /* state */
  pid_t pid;
  double t0;
  int timed_out;
} run;

static run *runs;
static int nrun;
static char base[256];
static char square[700];

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static char *dupf(const char *fmt, const char *a, const char *b) {
  char buf[1400];
  snprintf(buf, sizeof buf, fmt, a, b);
  return strdup(buf);
}

static run *new_run(const char *label) {
  assert_true(nrun < MAX_RUNS);
  run *r = &runs[nrun];
  memset(r, 0, sizeof *r);
  snprintf(r->label, sizeof r->label, "%s", label);
  snprintf(r->outdir, sizeof r->outdir, "%s/out%d", base, nrun);
  snprintf(r->errpath, sizeof r->errpath, "%s/err%d", base, nrun);
  r->want_exit = -1;
  ++nrun;
  return r;
}

static void arg(run *r, char *a) { r->argv[r->argc++] = a; }

static int has_ext(const char *p, const char *e) {
  size_t n = strlen(p), k = strlen(e);
  return n > k && !strcmp(p + n - k, e);
}

/* The two runs of one corpus file. */
static void add_file(const char *rel, const char *path) {
  int is_case = has_ext(path, ".json");
  int is_cad = has_ext(path, ".step") || has_ext(path, ".stp") || has_ext(path, ".igs") ||
               has_ext(path, ".iges") || has_ext(path, ".brep");
  int is_mesh = has_ext(path, ".msh") || has_ext(path, ".vtk") || has_ext(path, ".vtu") ||
                has_ext(path, ".stl") || has_ext(path, ".mesh");
  char label[700];
  run *m = NULL;
  if (is_mesh) goto quality; /* `mesh` refuses a mesh file by its extension alone */
  snprintf(label, sizeof label, "%s: mesh", rel);
  m = new_run(label);
  arg(m, "mesh");
  arg(m, strdup(path));
  arg(m, "--method");
  arg(m, is_cad ? "gmsh-frontal" : "bubble");
  arg(m, "--max-nodes");
  arg(m, "20000");
  arg(m, "-o");
  arg(m, dupf("%s/out.msh", m->outdir, NULL));
  arg(m, "--stats");
  arg(m, dupf("%s/stats.json", m->outdir, NULL));
  m->outputs[0] = "out.msh", m->outputs[1] = "stats.json";
quality:
  snprintf(label, sizeof label, "%s: quality", rel);
  run *q = new_run(label);
  arg(q, "quality");
  if (is_case || is_cad) {
    arg(q, square);
    arg(q, "--geometry");
  }
  arg(q, strdup(path));
  arg(q, "--json");
}

static int collect(const char *rel_dir) {
  char d[700];
  snprintf(d, sizeof d, "%s/%s", CORPUS, rel_dir);
  DIR *h = opendir(d);
  if (!h) return 0;
  char (*names)[256] = malloc(MAX_RUNS * sizeof *names);
  int n = 0;
  struct dirent *de;
  while ((de = readdir(h)) && n < MAX_RUNS)
    if (de->d_name[0] != '.') snprintf(names[n++], 256, "%s", de->d_name);
  closedir(h);
  qsort(names, (size_t)n, sizeof names[0], (int (*)(const void *, const void *))strcmp);
  for (int i = 0; i < n; ++i) {
    char rel[700], path[1000];
    snprintf(rel, sizeof rel, "%s/%s", rel_dir, names[i]);
    snprintf(path, sizeof path, "%s/%s", CORPUS, rel);
    add_file(rel, path);
  }
  free(names);
  return n;
}

/* expect.tsv: "path<TAB>mesh|quality<TAB>exit<TAB>text" lines. */
static void read_expectations(void) {
  char *text = pm_test_slurp(CORPUS "/expect.tsv");
  assert_non_null(text);
  int matched = 0, lines = 0;
  for (char *line = strtok(text, "\n"); line; line = strtok(NULL, "\n")) {
    if (line[0] == '#' || !line[0]) continue;
    char path[400], cmd[32], want[300];
    int code;
    if (sscanf(line, "%399[^\t]\t%31[^\t]\t%d\t%299[^\n]", path, cmd, &code, want) != 4)
      fail_msg("expect.tsv: cannot read line '%s'", line);
    ++lines;
    char label[700];
    snprintf(label, sizeof label, "%s: %s", path, cmd);
    int found = 0;
    for (int i = 0; i < nrun; ++i)
      if (!strcmp(runs[i].label, label)) {
        runs[i].want_exit = code;
        snprintf(runs[i].want_text, sizeof runs[i].want_text, "%s", want);
        found = 1;
      }
    if (!found) fail_msg("expect.tsv names '%s', which is not in the corpus", label);
    matched += found;
  }
  free(text);
  assert_int_equal(matched, lines);
}

/* invocations.txt: "exit<TAB>text<TAB>arguments" lines; {OUT} is the run's output folder,
 * {CORPUS} the corpus, {INPUT} a copy of seeds/plate.json that a run may damage (an older build
 * that ignores the check being tested would overwrite it). */
static int read_invocations(void) {
  char *text = pm_test_slurp(CORPUS "/invocations.txt");
  assert_non_null(text);
  int n = 0;
  char *save = NULL;
  for (char *line = strtok_r(text, "\n", &save); line; line = strtok_r(NULL, "\n", &save)) {
    if (line[0] == '#' || !line[0]) continue;
    int code;
    char want[300], args[1000];
    if (sscanf(line, "%d\t%299[^\t]\t%999[^\n]", &code, want, args) != 3)
      fail_msg("invocations.txt: cannot read line '%s'", line);
    char label[700];
    snprintf(label, sizeof label, "invocation: %.680s", args);
    run *r = new_run(label);
    r->want_exit = code;
    snprintf(r->want_text, sizeof r->want_text, "%s", want);
    char *save2 = NULL;
    for (char *w = strtok_r(args, " ", &save2); w; w = strtok_r(NULL, " ", &save2)) {
      char *o = strstr(w, "{OUT}");
      if (o) {
        char buf[1400];
        snprintf(buf, sizeof buf, "%.*s%s%s", (int)(o - w), w, r->outdir, o + 5);
        arg(r, strdup(buf));
      } else if (!strncmp(w, "{CORPUS}", 8)) {
        arg(r, dupf("%s%s", CORPUS, w + 8));
      } else if (!strcmp(w, "{INPUT}")) {
        arg(r, dupf("%s/input.json", base, NULL));
      } else {
        arg(r, strdup(w));
      }
    }
    ++n;
  }
  free(text);
  return n;
}

static void start(run *r) {
  mkdir(r->outdir, 0777);
  r->t0 = now();
  r->pid = fork();
  if (r->pid == 0) {
    int e = open(r->errpath, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    int o = open("/dev/null", O_WRONLY);
    if (e < 0 || o < 0) _exit(126);
    dup2(o, 1);
    dup2(e, 2);
    setpgid(0, 0);
    char *argv[42];
    argv[0] = (char *)pm_test_cli_path();
    for (int k = 0; k < r->argc; ++k) argv[k + 1] = r->argv[k];
    argv[r->argc + 1] = NULL;
    execv(argv[0], argv);
    _exit(127);
  }
}

static int count_left(const run *r, int success) {
  DIR *h = opendir(r->outdir);
  if (!h) return 0;
  int n = 0;
  struct dirent *de;
  while ((de = readdir(h))) {
    if (!strcmp(de->d_name, ".") || !strcmp(de->d_name, "..")) continue;
    int expected = 0;
    for (int k = 0; k < 3 && success; ++k) expected |= r->outputs[k] && !strcmp(de->d_name, r->outputs[k]);
    if (!expected) ++n;
  }
  closedir(h);
  return n;
}

/* Check a finished run; returns 1 when it is as it should be, else prints why. */
static int judge(run *r, int ws) {
  char *err = pm_test_slurp(r->errpath);
  if (!err) err = strdup("");
  int lines = 0;
  for (const char *c = err; *c; ++c) lines += *c == '\n';
  char why[600] = "";
  int code = WIFEXITED(ws) ? WEXITSTATUS(ws) : -1;
  if (r->timed_out)
    snprintf(why, sizeof why, "no end within the time limit");
  else if (!WIFEXITED(ws))
    snprintf(why, sizeof why, "killed by signal %d (%s)", WTERMSIG(ws), strsignal(WTERMSIG(ws)));
  else if (code >= 128)
    snprintf(why, sizeof why, "exit code %d", code);
  else if (code == 0 && lines != 0)
    snprintf(why, sizeof why, "success with %d lines on stderr", lines);
  else if (code != 0 && (lines != 1 || strncmp(err, "packmesh: ", 10) != 0))
    snprintf(why, sizeof why, "exit %d with %d lines on stderr", code, lines);
  else if (count_left(r, code == 0) > 0)
    snprintf(why, sizeof why, "exit %d left %d files in its output folder", code, count_left(r, code == 0));
  else if (r->want_exit >= 0 && (code != r->want_exit || !strstr(err, r->want_text)))
    snprintf(why, sizeof why, "exit %d (want %d), message not holding '%s'", code, r->want_exit,
             r->want_text);
  if (why[0]) {
    char first[400];
    snprintf(first, sizeof first, "%s", err);
    first[strcspn(first, "\n")] = '\0';
    print_message("FAIL %s: %s | stderr: %s\n", r->label, why, first);
  }
  free(err);
  return why[0] == '\0';
}

static void corpus_through_the_command(void **state) {
  (void)state;
  runs = calloc(MAX_RUNS, sizeof *runs);
  snprintf(base, sizeof base, "/tmp/pm_test_hostile_XXXXXX");
  assert_non_null(mkdtemp(base));
  snprintf(square, sizeof square, "%s/seeds/square.msh", CORPUS);
  int files = 0;
  const char *folders[] = {"seeds", "reported", "hand", "generated"};
  for (int k = 0; k < 4; ++k) files += collect(folders[k]);
  read_expectations();
  char *plate = pm_test_slurp(CORPUS "/seeds/plate.json"), input[400];
  assert_non_null(plate);
  snprintf(input, sizeof input, "%s/input.json", base);
  FILE *in_copy = fopen(input, "w");
  fputs(plate, in_copy);
  fclose(in_copy);
  free(plate);
  int invocations = read_invocations();
  /* bearing.iges cut in half (the hostile test's IGES file), made from the shared model when it
   * is here. */
  if (pm_test_have_cad()) {
    FILE *in = fopen(PM_CAD_DIR "/bearing.iges", "rb");
    char half[400];
    snprintf(half, sizeof half, "%s/bearing_half.iges", base);
    FILE *out = fopen(half, "wb");
    if (in && out) {
      fseek(in, 0, SEEK_END);
      long n = ftell(in);
      fseek(in, 0, SEEK_SET);
      char *b = malloc((size_t)n);
      if (fread(b, 1, (size_t)n, in) == (size_t)n) fwrite(b, 1, (size_t)n / 2, out);
      free(b);
    }
    if (in) fclose(in);
    if (out) fclose(out);
    add_file("bearing.iges cut in half", half);
    runs[nrun - 2].want_exit = 1;
    snprintf(runs[nrun - 2].want_text, sizeof runs[0].want_text, "truncated");
  }
  /* A case file of more pieces than a case file may hold (400 kB: made here, not kept). */
  char many[400];
  snprintf(many, sizeof many, "%s/too_many_pieces.json", base);
  FILE *f = fopen(many, "w");
  assert_non_null(f);
  fputs("{\"domain\": {\"loops\": [[", f);
  for (int i = 0; i <= 20000; ++i) fprintf(f, "%s{\"line\": [%d, %d]}", i ? ", " : "", i % 2, i);
  fputs("]]}, \"size\": 1}\n", f);
  fclose(f);
  add_file("too_many_pieces.json", many);
  runs[nrun - 2].want_exit = 1;
  snprintf(runs[nrun - 2].want_text, sizeof runs[0].want_text, "more than 20000 pieces");
  /* Meshes whose elements all share one face or one edge (8 MB each: made here). A sound mesh
   * has one or two elements there; the checker compared them pairwise, 80 s for these. */
  char star[2][400];
  for (int k = 0; k < 2; ++k) {
    snprintf(star[k], sizeof star[k], "%s/%s.msh", base, k ? "edge_book" : "one_face");
    FILE *sf = fopen(star[k], "w");
    assert_non_null(sf);
    const int n = 200000;
    fprintf(sf, "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n%d\n", n + 3);
    fprintf(sf, "1 0 0 0\n2 1 0 0\n3 0 1 0\n");
    for (int i = 0; i < n; ++i) fprintf(sf, "%d 0.5 %.9g %.9g\n", i + 4, cos(i), 1 + sin(i));
    fprintf(sf, "$EndNodes\n$Elements\n%d\n", 2 * n);
    for (int i = 0; i < n; ++i) {
      if (k == 0) {
        fprintf(sf, "%d 2 2 0 1 1 2 3\n", 2 * i + 1);           /* the same triangle */
        fprintf(sf, "%d 4 2 0 1 1 2 3 %d\n", 2 * i + 2, i + 4); /* tets on one face */
      } else {
        fprintf(sf, "%d 2 2 0 1 1 2 %d\n", 2 * i + 1, i + 4);   /* a book on edge 1-2 */
        fprintf(sf, "%d 2 2 0 1 2 1 %d\n", 2 * i + 2, i + 4);
      }
    }
    fprintf(sf, "$EndElements\n");
    fclose(sf);
    add_file(k ? "edge_book.msh" : "one_face.msh", star[k]);
  }
  print_message("%d corpus files, %d invocations: %d runs\n", files, invocations, nrun);
  if (files < 200) fail_msg("only %d files in the corpus (200 wanted)", files);

  const char *lim = getenv("PM_HOSTILE_TIMEOUT"), *jb = getenv("PM_HOSTILE_JOBS");
  double limit = lim ? atof(lim) : 60;
  int jobs = jb ? atoi(jb) : 2;
  if (jobs < 1) jobs = 1;
  int next = 0, running = 0, bad = 0;
  int *slot = malloc((size_t)jobs * sizeof *slot);
  for (int k = 0; k < jobs; ++k) slot[k] = -1;
  double t0 = now(), slowest = 0;
  const char *slowest_label = "";
  while (next < nrun || running > 0) {
    for (int k = 0; k < jobs; ++k) {
      if (slot[k] < 0 && next < nrun) {
        slot[k] = next++;
        start(&runs[slot[k]]);
        ++running;
      }
      if (slot[k] < 0) continue;
      run *r = &runs[slot[k]];
      int ws = 0;
      pid_t w = waitpid(r->pid, &ws, WNOHANG);
      if (w == 0) {
        if (now() - r->t0 > limit && !r->timed_out) {
          r->timed_out = 1;
          kill(-r->pid, SIGKILL);
          kill(r->pid, SIGKILL);
        }
        continue;
      }
      if (w < 0 && errno == EINTR) continue;
      kill(-r->pid, SIGKILL); /* helpers of a timed-out run */
      double dt = now() - r->t0;
      if (dt > slowest) slowest = dt, slowest_label = r->label;
      if (!judge(r, ws)) ++bad;
      slot[k] = -1;
      --running;
    }
    struct timespec ts = {0, 2000000};
    nanosleep(&ts, NULL);
  }
  print_message("%d runs in %.1f s (slowest %.2f s: %s); %d not as they should be\n", nrun,
                now() - t0, slowest, slowest_label, bad);
  char cmd[400];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", base);
  if (system(cmd) != 0) bad++;
  free(slot);
  if (bad) fail_msg("%d of %d runs failed (see the FAIL lines above)", bad, nrun);
}

int main(void) {
  const struct CMUnitTest tests[] = {cmocka_unit_test(corpus_through_the_command)};
  return cmocka_run_group_tests(tests, NULL, NULL);
}
